"""SIMSAND's physics switches (constitutive/sand/simsand.py module docstring): ``lode_dependence`` and
``state_dependent_dilatancy``, against closed forms of docs/reference.md section 3. Compression positive, kPa."""
import numpy as np
import pytest

from constitutive import ParameterError, labtests
from constitutive.invariants import isotropic_stiffness, lode_sin3theta, mean_stress
from constitutive.sand.simsand import P_AT, SIMSAND

#: synthetic-study true values (docs/reference.md section 5)
TRUE = dict(nu=0.2, K_0=100.0, n=0.6, e_ref=0.75, lambda_c=0.03, xi=0.6, phi_mu=30.0, k_p=0.003, A_d=1.0, n_p=2.0,
            n_d=2.0)
#: the same sand without the interlocking exponents of (VII)
PLAIN = {k: v for k, v in TRUE.items() if k not in ("n_p", "n_d")}
SYNTHETIC_BOUNDS = dict(e_ref=(0.5, 1.5), lambda_c=(0.001, 0.1), xi=(0.01, 1.0), phi_mu=(20.0, 50.0),
                        k_p=(1e-4, 1e-2), A_d=(0.5, 2.0))
SIN_MU = np.sin(np.radians(30.0))
#: (VII) in compression and Sheng et al.'s extension factor, for phi_mu = 30 degrees
M_C = 6.0 * SIN_MU / (3.0 - SIN_MU)
C_LODE = (3.0 - SIN_MU) / (3.0 + SIN_MU)
LARGE = np.linspace(0.02, 1.0, 50)  # drained to 100 % axial strain: H = eps_d^p/(k_p + eps_d^p) ~ 0.997
CURVES = ("q", "p", "e", "axial_strain", "radial_strain")


def triaxial_stress(sa, sr):
    return np.array([[sa, sr, sr, 0.0, 0.0, 0.0]])


# ----------------------------------------------------------------------------------------------- Lode dependence
@pytest.mark.parametrize("e0, p0", [(0.6, 800.0), (0.8, 25.0), (0.7, 200.0)])
def test_drained_extension_reaches_M_c_without_and_c_M_c_with_lode_dependence(e0, p0):
    """Drained triaxial extension to 100 % axial strain tends to eta = q/p' = -M_c(phi_mu) on a circular deviatoric
    section and to -c M_c with the Sheng et al. rule (same tolerance as the compression test of
    tests/constitutive/test_simsand.py: H ~ 0.997 and the final state is within 2e-3 of e_c)."""
    for lode, expected in ((False, -M_C), (True, -C_LODE * M_C)):
        c = labtests.drained_triaxial(SIMSAND(**TRUE, lode_dependence=lode), e0, p0, -LARGE)
        assert c["q"][0, -1] / c["p"][0, -1] == pytest.approx(expected, abs=0.005), lode


def test_drained_extension_through_the_six_component_update_reaches_M_c_without_lode_dependence():
    """The generic driver (six-component numpy ``update``, Newton on the lateral strain) honours the switch too."""
    c = labtests.drained_triaxial(SIMSAND(**TRUE, lode_dependence=False), 0.7, 200.0, -np.linspace(0.02, 0.6, 30),
                                  route="generic")
    assert c["q"][0, -1] / c["p"][0, -1] == pytest.approx(-M_C, abs=0.005)


@pytest.mark.parametrize("drained", [True, False])
def test_compression_is_unchanged_without_lode_dependence(drained):
    """In triaxial compression sin 3theta = +1 and Sheng et al.'s M equals M_c: the curves are the same bits."""
    ea = np.linspace(0.0025, 0.25, 100)
    for e0, p0 in ((0.6, 800.0), (0.8, 25.0)):
        on = SIMSAND(**TRUE).triaxial_test(e0, p0, ea, drained=drained)
        off = SIMSAND(**TRUE, lode_dependence=False).triaxial_test(e0, p0, ea, drained=drained)
        for k in CURVES:
            np.testing.assert_array_equal(on[k], off[k])


def test_friction_ratios_and_initial_state_without_lode_dependence():
    """M_p = M_c(phi_p), M_pt = M_c(phi_pt) at every Lode angle, phi_p and phi_pt from (VI)-(VII) computed here; an
    extension stress with c M_p < eta < M_p is inside the circular surface (eps_d^p = k_p eta/(M_p - eta), (IV))
    and beyond the Sheng et al. one (initial_state refuses it)."""
    e, p = 0.62, 300.0
    ec = 0.75 * np.exp(-0.03 * (p / P_AT) ** 0.6)
    sin_p = np.sin(np.arctan((ec / e) ** 2.0 * np.tan(np.radians(30.0))))
    sin_pt = np.sin(np.arctan((ec / e) ** -2.0 * np.tan(np.radians(30.0))))
    Mp_c, Mpt_c = 6 * sin_p / (3 - sin_p), 6 * sin_pt / (3 - sin_pt)
    off = SIMSAND(**TRUE, lode_dependence=False)
    for s3 in (1.0, 0.3, -0.7, -1.0):
        Mp, Mpt = off.friction_ratios(p, e, s3)
        assert Mp == pytest.approx(Mp_c, rel=1e-12) and Mpt == pytest.approx(Mpt_c, rel=1e-12)
    q = 0.95 * Mp_c * p
    stress = triaxial_stress(p - 2 * q / 3, p + q / 3)
    assert lode_sin3theta(stress)[0] == pytest.approx(-1.0) and mean_stress(stress)[0] == pytest.approx(p)
    state = off.initial_state(stress, e)
    assert state["eps_dp"][0] == pytest.approx(0.003 * 0.95 * Mp_c / (0.05 * Mp_c), rel=1e-10)
    with pytest.raises(ValueError, match="not below the peak-strength ratio"):
        SIMSAND(**TRUE).initial_state(stress, e)


def test_six_component_yield_gradient_has_no_lode_part_without_lode_dependence():
    """At a general Lode angle on the yield surface, a deviatoric strain increment that only rotates the stress
    deviator at constant p' and q (the Lode-angle direction) is elastic on a circular section: the continuum tangent
    returns D d eps for it (the yield gradient has no component along d sin3theta/d sigma), but not with the Sheng et
    al. rule."""
    e, p = 0.65, 200.0
    s = np.array([60.0, -10.0, -50.0, 0.0, 0.0, 0.0])  # deviator, sin 3theta = 0.45
    stress = (p * np.array([1, 1, 1, 0, 0, 0]) + s)[None, :]
    for lode, elastic in ((False, True), (True, False)):
        model = SIMSAND(**TRUE, lode_dependence=lode)
        state = model.initial_state(stress, e)
        _, _, tangent = model.update(stress, state, np.zeros((1, 6)))
        d = np.array([0.0, 1.0, -1.0, 0.0, 0.0, 0.0])
        d = d - (d @ s) / (s @ s) * s  # deviatoric, orthogonal to s: no change of q to first order
        K = model.bulk_modulus(p, e)
        D = isotropic_stiffness(K, model.shear_modulus(p, e))[0]
        same = np.allclose(tangent[0] @ d, D @ d, rtol=1e-10, atol=1e-10 * np.abs(D @ d).max())
        assert same == elastic, lode


# ----------------------------------------------------------------------------------------------- dilatancy
def test_dense_sample_has_no_peak_above_M_mu_without_state_dependent_dilatancy():
    """Dense sample (e0 0.6, p'0 800 kPa, denser than critical): with (VII) it peaks above M_mu (measured 1.282,
    tests/constitutive/test_simsand.py); without interlocking eta = M_mu H stays below M_mu = 1.2 along the whole path,
    rising monotonically, and the sample never dilates (A_d (M_mu - eta) > 0 and p' rises)."""
    ea = np.linspace(0.0025, 0.25, 100)
    assert np.max(SIMSAND(**TRUE).triaxial_test(0.6, 800.0, ea)["q"] / 800.0) > M_C  # eta > M_C since p' >= 800
    c = SIMSAND(**PLAIN, state_dependent_dilatancy=False).triaxial_test(0.6, 800.0, ea)
    eta = c["q"][0] / c["p"][0]
    assert eta.max() <= M_C + 1e-8 and np.all(np.diff(eta) > 0.0)
    assert np.all(np.diff(c["volumetric_strain"][0]) > 0.0)
    large = SIMSAND(**PLAIN, state_dependent_dilatancy=False).triaxial_test(0.6, 800.0, LARGE)
    assert large["q"][0, -1] / large["p"][0, -1] == pytest.approx(M_C, abs=0.005)


@pytest.mark.parametrize("ratio", [0.6, 0.999])
def test_stress_dilatancy_uses_M_mu_without_state_dependent_dilatancy(ratio):
    """On the yield surface of a dense state (e 0.6, p' 400 kPa, where (VII) would give M_pt < M_mu) the plastic flow
    direction m, read from the continuum tangent C (D^-1 (D - C) d is parallel to m for a loading d), has
    d eps_v^p/d eps_d^p = A_d (M_mu - eta), M_mu = 6 sin phi_mu/(3 - sin phi_mu) of (V): zero dilatancy at eta = M_mu
    (here eta = 0.999 M_mu)."""
    model = SIMSAND(**PLAIN, state_dependent_dilatancy=False)
    e, p = 0.6, 400.0
    Mp, Mpt = (float(x) for x in model.friction_ratios(p, e, 1.0))
    assert Mp == pytest.approx(M_C, rel=1e-12) and Mpt == pytest.approx(M_C, rel=1e-12)
    assert float(SIMSAND(**TRUE).friction_ratios(p, e, 1.0)[1]) < 0.95 * M_C
    eta = ratio * M_C
    stress = triaxial_stress(p + 2 * eta * p / 3, p - eta * p / 3)
    state = model.initial_state(stress, e)
    _, _, tangent = model.update(stress, state, np.zeros((1, 6)))
    D = isotropic_stiffness(model.bulk_modulus(p, e), model.shear_modulus(p, e))[0]
    m = np.linalg.solve(D, (D - tangent[0]) @ np.array([1.0, -0.2, -0.2, 0.0, 0.0, 0.0]))
    assert m[1] == pytest.approx(m[2], rel=1e-12) and np.allclose(m[3:], 0.0, atol=1e-12 * abs(m[0]))
    assert m[:3].sum() / (2.0 / 3.0 * (m[0] - m[1])) == pytest.approx(1.0 * (M_C - eta), abs=1e-10)


# ----------------------------------------------------------------------------------------------- identities
def test_switches_on_are_the_default_model_and_off_equals_zero_interlocking():
    """Default = both switches given True, bit for bit; state_dependent_dilatancy=False = the model with explicit
    n_p = n_d = 0, bit for bit (drained and undrained, compression and extension)."""
    ea = np.linspace(0.0025, 0.25, 50)
    for drained in (True, False):
        for sign in (1.0, -1.0):
            default = SIMSAND(**TRUE).triaxial_test(0.7, 200.0, sign * ea, drained=drained)
            on = SIMSAND(**TRUE, lode_dependence=True, state_dependent_dilatancy=True).triaxial_test(
                0.7, 200.0, sign * ea, drained=drained)
            off = SIMSAND(**PLAIN, state_dependent_dilatancy=False).triaxial_test(0.7, 200.0, sign * ea,
                                                                                  drained=drained)
            zero = SIMSAND(**PLAIN, n_p=0.0, n_d=0.0).triaxial_test(0.7, 200.0, sign * ea, drained=drained)
            for k in CURVES:
                np.testing.assert_array_equal(default[k], on[k])
                np.testing.assert_array_equal(off[k], zero[k])
            assert not np.array_equal(default["q"], off["q"])


@pytest.mark.parametrize("drained, sign", [(True, 1.0), (True, -1.0), (False, 1.0), (False, -1.0)])
def test_compiled_kernel_equals_the_numpy_reference_with_the_switches_off(drained, sign):
    """Both switches off, 10 prior samples: the compiled kernel and the numpy reference (triaxial_integrator="numpy")
    give the same failures, curves within 1e-6 of the curve scale in a batch (the numpy crossing iteration is
    batch-wide), and the same curves to rtol 1e-9 for single points (round-off of two implementations amplified by
    the local error estimate that sizes the substeps: test_simsand.IMPLEMENTATIONS_RTOL)."""
    rng = np.random.default_rng(5)
    params = dict(PLAIN, **{k: rng.uniform(lo, hi, 10) for k, (lo, hi) in SYNTHETIC_BOUNDS.items()})
    ea = sign * np.linspace(0.005, 0.25, 50)
    kw = dict(lode_dependence=False, state_dependent_dilatancy=False)
    c = SIMSAND(**params, **kw).triaxial_test(0.7, 200.0, ea, drained=drained, on_failure="nan")
    r = SIMSAND(**params, **kw, triaxial_integrator="numpy").triaxial_test(0.7, 200.0, ea, drained=drained,
                                                                           on_failure="nan")
    np.testing.assert_array_equal(c["failed"], r["failed"])
    ok = ~c["failed"]
    assert ok.sum() >= 5
    for k in CURVES:
        scale = np.abs(r[k][ok]).max(axis=1, keepdims=True) + 1e-12
        assert np.abs(c[k][ok] - r[k][ok]).max() / (1.0 if k == "e" else scale.min()) < 1e-6, k
    for i in np.flatnonzero(ok)[:2]:
        one = SIMSAND(**{k: (v[i] if np.ndim(v) else v) for k, v in params.items()}, **kw,
                      triaxial_integrator="numpy").triaxial_test(0.7, 200.0, ea, drained=drained)
        np.testing.assert_allclose(c["q"][i], one["q"][0], rtol=1e-9, atol=1e-9 * np.abs(one["q"]).max())
        np.testing.assert_allclose(c["e"][i], one["e"][0], rtol=1e-9)


# ----------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("kwargs, message", [
    (dict(PLAIN, n_p=2.0, state_dependent_dilatancy=False), "n_p = 2.0 given but state_dependent_dilatancy=False"),
    (dict(PLAIN, n_d=np.array([0.0, 1.0]), state_dependent_dilatancy=False), "n_d = .* given but"),
    (dict(PLAIN, n_d=2.0), "parameter n_p is required with state_dependent_dilatancy=True"),
    (dict(TRUE, lode_dependence="no"), "lode_dependence must be True or False, got 'no'"),
    (dict(PLAIN, state_dependent_dilatancy=0), "state_dependent_dilatancy must be True or False, got 0"),
])
def test_bad_switch_input_raises(kwargs, message):
    with pytest.raises(ParameterError, match=message):
        SIMSAND(**kwargs)


# ----------------------------------------------------------------------------------------------- catalog and studies
def test_catalog_enrichments_are_the_simsand_switches():
    from constitutive import physics_catalog as catalog

    base = {"lode_dependence": False, "state_dependent_dilatancy": False, "viscous": False, "anisotropy": False}
    bounds = {"e_ref": (0.5, 1.5), "phi_mu": (20.0, 50.0)}
    switches, b, log_uniform = catalog.enriched_settings("Lode dependence", base, bounds, "SIMSAND")
    assert switches == dict(base, lode_dependence=True) and b == bounds and log_uniform == ()
    switches, b, _ = catalog.enriched_settings("state-dependent dilatancy", base, bounds, "SIMSAND")
    assert switches == dict(base, state_dependent_dilatancy=True)
    assert b == dict(bounds, n_p=(0.1, 10.0), n_d=(0.1, 10.0))
    full = {d["name"]: d for d in catalog.signatures(dict(base, lode_dependence=True,
                                                          state_dependent_dilatancy=True), "SIMSAND")}
    assert full["Lode dependence"]["in_base"] and full["state-dependent dilatancy"]["in_base"]
    assert full["anisotropy"]["enrichment"] is None and "SIMSAND has no switch" in full["anisotropy"]["unavailable"]
    for name in ("Lode dependence", "state-dependent dilatancy"):
        with pytest.raises(ValueError, match="already has it"):
            catalog.enriched_settings(name, dict(base, lode_dependence=True, state_dependent_dilatancy=True), {},
                                      "SIMSAND")


OFF = "lode_dependence = false\nstate_dependent_dilatancy = false\n"


def _drained_study(tmp_path, switches=OFF, interlocking="", free=""):
    """The shipped drained example (cases/examples/triaxial_drained.toml, SYNTHETIC data) with the [model] switches
    ``switches``, the fixed n_p, n_d lines replaced by ``interlocking`` and ``free`` added to [model.free]."""
    from pathlib import Path

    examples = Path(__file__).resolve().parents[2] / "cases" / "examples"
    text = (examples / "triaxial_drained.toml").read_text()
    for old, new in (('file = "data/', f'file = "{examples}/data/'),
                     ('name = "SIMSAND"\n', f'name = "SIMSAND"\n{switches}'),
                     ("n_p = 2.0\nn_d = 2.0\n", interlocking), ("[model.free]\n", f"[model.free]\n{free}")):
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "study.toml"
    path.write_text(text)
    return path


def test_study_switches_off_without_n_p_n_d_and_the_initial_state_parameter_covariate(tmp_path):
    """A study can state the base model without the physics (no n_p, n_d); its forward model runs the switched
    model (phi_mu = 30: no peak above M_mu) and reports each test's initial state parameter psi_0 = e_0 - e_c(p'_0)
    (Been & Jefferies 1985), computed here from (VI) and the test conditions, as a between-test covariate."""
    import inference
    from cases.study.loop.study_problem import StudyProblem
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study

    study = load_study(_drained_study(tmp_path))
    assert study.switches == {"lode_dependence": False, "state_dependent_dilatancy": False}
    obs, times = load_observations(study.tests)
    problem = StudyProblem(study, obs, times, quick=True)
    assert problem.catalog_switches(study.switches)["state_dependent_dilatancy"] is False
    curves = problem.map_curves({"e_ref": 0.75, "phi_mu": 30.0, "k_p": 0.003}, study.switches)
    like = inference.Likelihood(obs, problem.forward(study.switches), batch=True)
    cov = problem.curve_covariates(like, curves)["initial state parameter"]
    assert set(cov) == {(t.name, c) for t in study.tests for c in ("q", "void_ratio")}
    for t in study.tests:  # (e0, p'0) = (0.7, 200 kPa) and (0.6, 800 kPa)
        assert np.all(curves[t.name]["stress_ratio"] <= M_C + 1e-8)
        psi0 = t.e0 - 0.75 * np.exp(-0.03 * (t.p0 / P_AT) ** 0.6)
        assert curves[t.name]["initial_state_parameter"].shape == curves[t.name]["q"].shape
        np.testing.assert_allclose(curves[t.name]["initial_state_parameter"], psi0, rtol=1e-12)
        assert cov[(t.name, "q")] == pytest.approx(psi0, rel=1e-12)


@pytest.mark.parametrize("interlocking, free, message", [
    ("n_p = 2.0\n", "", "n_p = 2.0 given but state_dependent_dilatancy=False"),
    ("", "n_d = [0.1, 10.0]\n", "model.free.n_d.*not used when state_dependent_dilatancy = false"),
])
def test_study_refuses_interlocking_parameters_with_the_switch_off(tmp_path, interlocking, free, message):
    from cases.study.checks import StudyError
    from cases.study.reading.schema import load_study

    with pytest.raises(StudyError, match=message):
        load_study(_drained_study(tmp_path, interlocking=interlocking, free=free))


def test_study_needs_n_p_n_d_with_state_dependent_dilatancy(tmp_path):
    from cases.study.checks import StudyError
    from cases.study.reading.schema import load_study

    with pytest.raises(StudyError, match="state_dependent_dilatancy = true needs n_d"):
        load_study(_drained_study(tmp_path, switches="", interlocking="n_p = 2.0\n"))


def test_sand_examples_are_synthetic_do_not_name_the_effect_and_equal_their_generator(tmp_path):
    """cases/examples/sand_lab*.toml and sand_density*.toml: the shipped records are labelled SYNTHETIC, neither their
    names nor their text name the generating model's Lode rule or interlocking (n_p, n_d where the base lacks them),
    and they equal a fresh run of cases/examples/sand_lab_data.py."""
    import importlib.util
    from pathlib import Path

    from cases.study.reading.schema import load_study

    examples = Path(__file__).resolve().parents[2] / "cases" / "examples"
    spec = importlib.util.spec_from_file_location("sand_lab_data", examples / "sand_lab_data.py")
    generator = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generator)
    assert set(generator.DATASETS) == {"sand_lab", "sand_lab_control", "sand_density", "sand_density_control"}
    for study in generator.DATASETS:
        base = load_study(examples / f"{study}.toml")
        shipped = {t.name: t.file for t in base.tests}
        assert len(shipped) == (12 if study.startswith("sand_lab") else 8)
        fresh = {f.stem: f for f in generator.write(study, tmp_path / study)}
        assert set(fresh) == set(shipped)
        words = ("lode", "sheng", "theta", "circular", "interlocking", "dilatancy", "state_dependent")
        words += () if base.switches["state_dependent_dilatancy"] else ('"n_p"', '"n_d"')
        for name, f in shipped.items():
            text = f.read_text()
            assert text.startswith("# synthetic: NOT MEASURED DATA")
            for word in words:
                assert word not in text.lower() and word not in str(f.relative_to(examples)).lower(), (f, word)
            assert text == fresh[name].read_text(), name
