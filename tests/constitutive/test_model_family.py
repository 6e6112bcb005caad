"""Modified Cam Clay as the ANICREEP family with every switch off and MCC's current specific volume
(constitutive.registry.enrichment_family, mcc_as_anicreep; ANICREEP specific_volume="current"): the same curves in
undrained and drained triaxial shear from isotropic and K0 states and in the CRS oedometer, to the local Newton
tolerances (both integrate backward Euler with v = 1 + e_n frozen over an increment, exact exponential pressure and
hardening laws, the secant shear modulus). Oracles: MCC's own integration and the closed form of the strain measures
(d eps = -de/(1 + e_n): e = (1 + e0) prod(1 - d eps) - 1 under strain control; with specific_volume="initial",
d eps = -de/(1 + e0)). Staged programmes through the study path: tests/cases/test_family_staged.py."""
import numpy as np
import pytest

from constitutive import labtests
from constitutive.registry import build_model, enrichment_family, k0_surface_ratio

MCC = dict(M=1.2, lambda_=0.2, kappa=0.04, nu=0.3, ocr=1.5)
E0 = 1.0
EPS = np.linspace(0.002, 0.15, 40)


def _start(p0, k0):
    sa = 3.0 * p0 / (1.0 + 2.0 * k0)
    return np.array([sa, k0 * sa, k0 * sa, 0.0, 0.0, 0.0])


def _pair(stress0, values=MCC):
    fam = enrichment_family("ModifiedCamClay")
    return (build_model("ModifiedCamClay", values, {}),
            build_model(fam.model, fam.translate(values, stress0, E0), fam.switches))


def test_family_of_each_model():
    fam = enrichment_family("ModifiedCamClay")
    assert fam.model == "ANICREEP" and fam.switches == {"anisotropy": False, "viscous": False,
                                                        "destructuration": False, "specific_volume": "current"}
    assert _pair(_start(100.0, 1.0))[1].specific_volume == "current"
    assert enrichment_family("ANICREEP").model == "ANICREEP" and enrichment_family("SIMSAND").switches == {}


@pytest.mark.parametrize("k0,p0", [(1.0, 100.0), (0.6, 110.0)])
def test_initial_surface_is_mcc_surface(k0, p0):
    s0 = _start(p0, k0)
    mcc, ani = _pair(s0)
    pc = mcc.initial_state(s0[None], E0)["pc"]
    assert ani.initial_state(s0[None])["pm_ref"] == pytest.approx(pc, rel=1e-12)
    # the closed form of the K0_nc ellipse ratio at M = 1.2: K0_nc = 0.5, (1 + 1)/3 + 3 0.25/(1.44 2)
    assert k0_surface_ratio(1.2) == pytest.approx(2.0 / 3.0 + 0.75 / 2.88, rel=1e-12)


@pytest.mark.parametrize("k0,p0", [(1.0, 100.0), (0.6, 110.0)])
@pytest.mark.parametrize("sign", [1, -1])
def test_undrained_triaxial_identical(k0, p0, sign):
    mcc, ani = _pair(_start(p0, k0))
    cm = labtests.undrained_triaxial(mcc, E0, p0, sign * EPS, k0=k0, substeps=20, route="generic")
    ca = labtests.undrained_triaxial(ani, E0, p0, sign * EPS, k0=k0, substeps=20, route="generic")
    for name in ("q", "p", "excess_pore_pressure"):
        assert np.allclose(ca[name], cm[name], rtol=1e-9, atol=1e-9 * p0), name


@pytest.mark.parametrize("k0,p0", [(1.0, 100.0), (0.6, 110.0)])
@pytest.mark.parametrize("sign", [1, -1])
def test_drained_triaxial_identical(k0, p0, sign):
    """Drained: the volume changes, so this checks the current specific volume (with specific_volume="initial" q
    differed by up to 1.1 % of its largest value here). Agreement to 1e-8 of the largest value: measured at most
    4e-10, the local Newton tolerances (1e-10 and 1e-11 on scaled residuals) accumulated over the 800 steps."""
    mcc, ani = _pair(_start(p0, k0))
    cm = labtests.drained_triaxial(mcc, E0, p0, sign * EPS, k0=k0, substeps=20, route="generic")
    ca = labtests.drained_triaxial(ani, E0, p0, sign * EPS, k0=k0, substeps=20, route="generic")
    for name in ("q", "p", "e", "volumetric_strain"):
        assert np.max(np.abs(ca[name] - cm[name])) < 1e-8 * np.max(np.abs(cm[name])), name


def test_crs_oedometer_identical_and_the_strain_measure_closed_form():
    """CRS (strain control): the void ratio follows the closed form of the current specific volume frozen over each
    of the n steps, e = (1 + e0) prod(1 - d eps) - 1, in both models, and sigma'_v agrees (1e-8); the family class
    with specific_volume="initial" has e = e0 - (1 + e0) eps instead, the measure the option replaces."""
    s0 = np.array([50.0, 30.0, 30.0, 0.0, 0.0, 0.0])
    mcc, ani = _pair(s0)
    eps = np.linspace(0.002, 0.2, 60)
    cm = labtests.oedometer_crs(mcc, E0, 50.0, eps, 1e-6, k0=0.6, substeps=20)
    ca = labtests.oedometer_crs(ani, E0, 50.0, eps, 1e-6, k0=0.6, substeps=20)
    d = np.diff(np.concatenate([[0.0], eps])) / 20.0
    current = (1.0 + E0) * np.cumprod(np.repeat(1.0 - d, 20))[19::20] - 1.0
    assert np.allclose(cm["e"][0], current, atol=1e-10) and np.allclose(ca["e"][0], current, atol=1e-10)
    assert np.max(np.abs(ca["axial_stress"][0] / cm["axial_stress"][0] - 1.0)) < 1e-8
    fam = enrichment_family("ModifiedCamClay")
    initial = build_model(fam.model, fam.translate(MCC, s0, E0), {**fam.switches, "specific_volume": "initial"})
    ci = labtests.oedometer_crs(initial, E0, 50.0, eps, 1e-6, k0=0.6, substeps=20)
    assert np.allclose(ci["e"][0], E0 - (1.0 + E0) * eps, atol=1e-12)


def test_study_family_forward_reproduces_the_mcc_study():
    """An MCC study (cases/examples/triaxial_undrained.toml: CK0UC and CIUE, ocr free) through its family's forward
    model with every ANICREEP switch off gives the MCC study's curves (1e-8 relative), and an enriched class runs."""
    from pathlib import Path

    from cases.study.forward.family import FamilyForward
    from cases.study.forward.study import StudyForward
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study
    study = load_study(Path(__file__).resolve().parents[2] / "cases/examples/triaxial_undrained.toml")
    obs, _ = load_observations(study.tests)
    batch = [{"M": 1.2, "ocr": 1.5}, {"M": 1.0, "ocr": 2.5}]
    base = StudyForward(study, obs, {})(batch)
    family = FamilyForward(study, obs, enrichment_family(study.model).switches)(batch)
    for a, b in zip(base, family):
        for t in a:
            for c in obs[t].curves:
                x, y = np.asarray(a[t][c]), np.asarray(b[t][c])
                assert np.max(np.abs(x - y)) < 1e-8 * np.max(np.abs(x)), (t, c)
    viscous = FamilyForward(study, obs, {"anisotropy": False, "viscous": True, "destructuration": False})(
        [{**p, "C_alpha_e": 0.01} for p in batch])
    assert all(np.all(np.isfinite(viscous[i][t][c])) for i in range(2) for t in viscous[i] for c in obs[t].curves)


def test_constant_shear_modulus_maps_to_the_initial_poisson_ratio():
    """MCC with a constant G: ANICREEP's nu gives the same G at the initial state, so the first elastic undrained
    increment (inside the surface, OCR 2) has the same stiffness, q = 3 G eps_a (1e-6)."""
    values = dict(M=1.2, lambda_=0.2, kappa=0.04, G=4000.0, ocr=2.0)
    mcc, ani = _pair(_start(100.0, 1.0), values)
    eps = np.array([1e-6])
    for model in (mcc, ani):
        c = labtests.undrained_triaxial(model, E0, 100.0, eps, substeps=1, route="generic")
        assert c["q"][0, 0] == pytest.approx(3.0 * 4000.0 * 1e-6, rel=1e-5)
