"""Covariates of the generic study path (cases.study.loop.covariates.programme_covariates with within_test=True) for the
catalog's signatures, against the programmes' own definitions (stage targets, stage times, the recorded peak), and the
signs of the catalog's hold items against the viscous model's own relaxation after loading and after unloading."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import inference
from cases.study.forward.lab_staged import simulate_programme
from cases.study.loop.covariates import programme_covariates, stage_phases
from cases.study.programme import InitialState, Stage, TestSpec, programme_of
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from constitutive import physics_catalog
from constitutive.anicreep import ANICREEP
from inference.diagnosis.attribution import KINDS, SCOPES

EXAMPLES = Path(__file__).resolve().parents[4] / "cases" / "examples"


def _programme(initial, *stages):
    return TestSpec(name="t", type="programme", apparatus="triaxial", initial=initial, stages=tuple(stages))


def _study_covariates(name):
    study = load_study(EXAMPLES / name)
    obs, times = load_observations(study.tests)
    map_curves = {t.name: {k: c.y for k, c in obs[t.name].curves.items()} for t in study.tests}
    return study, obs, programme_covariates(study.tests, obs, map_curves, times=times, within_test=True)


def test_stage_phases_follow_the_stress_history():
    """Consolidation to 200 kPa (loading), swelling to 50 (unloading), creep (a hold after unloading), shear: OCR
    200/50 = 4 from the shear stage on, consolidation isotropic."""
    spec = _programme(InitialState(e0=1.0, p0=20.0),
                      Stage("consolidation", "c1", p=200.0), Stage("consolidation", "c2", p=50.0),
                      Stage("creep", "h3", duration=1e4), Stage("shear", "s4", strain_rate=1e-5,
                                                                direction="compression"))
    ph = stage_phases(spec)
    assert [p.phase for p in ph] == ["loading", "unloading", "hold", "loading"]
    assert ph[2].after == "unloading" and ph[3].after == "unloading"
    assert [p.ocr for p in ph] == pytest.approx([1.0, 1.0, 4.0, 4.0])
    assert ph[3].consolidation == "isotropic"
    k0 = _programme(InitialState(e0=1.0, sigma_v0=50.0, K0=0.6, ocr=3.0), Stage("shear", "s1", strain_rate=1e-5))
    assert stage_phases(k0)[0].ocr == pytest.approx(3.0) and stage_phases(k0)[0].consolidation == "K0"


def test_relaxation_study_hold_time_and_phase():
    """relaxation.toml: CRS then relaxation (oedometer), undrained shear then relaxation (triaxial): the hold time after
    loading is the relaxation stage's own time abscissa, undefined elsewhere; the phase is loading / hold; every
    declared spec has a kind and scope that inference.diagnosis.attribution accepts."""
    study, obs, cov = _study_covariates("relaxation.toml")
    hold = cov["hold time after loading"]
    assert hold["kind"] == "numeric" and hold["scope"] == "within"
    for (test, key), values in hold["values"].items():
        assert key.endswith("@relaxation")
        assert np.array_equal(values, obs[test].curves[key].x)
    assert "hold time after unloading" not in cov
    phase = cov["loading phase"]["values"]
    assert all(set(v) == ({"hold"} if k[1].endswith("@relaxation") else {"loading"}) for k, v in phase.items())
    for spec in cov.values():
        if isinstance(spec, dict) and "values" in spec:
            assert spec.get("kind", "numeric") in KINDS and spec.get("scope", "within") in SCOPES
    rates = cov["strain rate"]
    assert rates["OED_relax", "axial_stress@crs"] == pytest.approx(2.0e-6)


def test_ciu_ocr_overconsolidation_from_the_stage_targets():
    """ciu_ocr.toml: consolidation to p'_c then swelling to p'_c/OCR: the shear stages' overconsolidation is the
    programme's ratio of its two consolidation targets; per stage, so it is not declared a between-test condition
    (the consolidation stage of the same test is normally consolidated)."""
    study, obs, cov = _study_covariates("ciu_ocr.toml")
    ocr = cov["overconsolidation"]
    assert "scope" not in ocr and ocr["kind"] == "numeric"
    for spec in study.tests:
        targets = [s.p for s in spec.stages if s.kind == "consolidation"]
        expected = max(targets) / targets[-1]
        for (test, key), value in ocr["values"].items():
            if test == spec.name and key.startswith("q@"):
                assert value == pytest.approx(expected)


def test_crs_unloading_stage_is_unloading():
    study, obs, cov = _study_covariates("crs_unload_reload.toml")
    phase = cov["loading phase"]["values"]
    for spec in study.tests:
        for (test, key), v in phase.items():
            if test == spec.name:
                stage = spec.stage(key.split("@")[1])
                assert set(v) == {"unloading" if stage.strain_rate < 0 else "loading"}


def test_post_peak_strain_of_a_flat_triaxial_test():
    """A recorded q that peaks at 3 % and softens: the post-peak strain is NaN up to the peak, strain - 3 % after it,
    on every curve of the test."""
    eps = np.linspace(0.5, 10.0, 20)
    q = np.where(eps <= 3.0, 100.0 * eps / 3.0, 100.0 - 4.0 * (eps - 3.0))
    spec = programme_of(TestSpec("T", "triaxial", drainage="undrained", direction="compression",
                                 consolidation="isotropic", p0=100.0, e0=1.0, strain_rate=1e-5))
    curves = {"q": inference.Curve(eps, q, "axial_strain", "q"),
              "p": inference.Curve(eps, 100.0 - eps, "axial_strain", "p")}
    obs = inference.Observations([inference.Test("T", curves, {})])
    cov = programme_covariates([spec], obs, {"T": {}}, within_test=True)
    pp = cov["post-peak strain"]
    k = int(np.argmax(q))
    for c in ("q", "p"):
        v = pp["values"]["T", c]
        assert np.all(np.isnan(v[:k + 1]))
        assert np.allclose(v[k + 1:], (eps[k + 1:] - eps[k]) / 100.0)


def test_viscous_relaxation_signs_after_loading_and_unloading():
    """Viscous ANICREEP in the oedometer: with the strain held after CRS loading the vertical stress relaxes
    (falls); after CRS unloading it hardly moves (below 1/10 of the fall after loading): the catalog's viscosity
    item on the hold after loading has direction -1 on effective stresses and viscosity states nothing on holds after
    unloading, where time-dependent swelling (a rise of stress) has its own items with the opposite sign."""
    model = ANICREEP(M=1.2, lambda_=0.2, kappa=0.03, nu=0.25, e0=1.5, sigma_p0=60.0, C_alpha_e=0.01,
                     anisotropy=False)
    t = np.geomspace(10.0, 86400.0, 12)
    initial = InitialState(e0=1.5, sigma_v0=40.0, K0=0.6)
    after_load = TestSpec("a", "programme", apparatus="oedometer", initial=initial, stages=(
        Stage("crs", "crs1", strain_rate=1e-5, to_strain=0.08, abscissa="axial_strain"),
        Stage("relaxation", "relax2", duration=86400.0)))
    after_unload = TestSpec("b", "programme", apparatus="oedometer", initial=initial, stages=(
        Stage("crs", "crs1", strain_rate=1e-5, to_strain=0.08, abscissa="axial_strain"),
        Stage("crs", "crs2", strain_rate=-1e-5, to_strain=0.07, abscissa="axial_strain"),
        Stage("relaxation", "relax3", duration=86400.0)))
    a, fa = simulate_programme(model, after_load, {"axial_stress@relax2": t}, 1)
    b, fb = simulate_programme(model, after_unload, {"axial_stress@relax3": t}, 1)
    assert not fa[0] and not fb[0]
    drop_load = a["axial_stress@relax2"][0, -1] - a["axial_stress@relax2"][0, 0]
    drop_unload = b["axial_stress@relax3"][0, -1] - b["axial_stress@relax3"][0, 0]
    assert drop_load < 0 and abs(drop_unload) < 0.1 * abs(drop_load)
    catalog = {c.name: c for c in physics_catalog.CATALOG}
    visc = [i for i in catalog["viscosity"].signature if i["covariate"] == "hold time after loading"]
    stress = [i for i in visc if set(i["curves"]) <= set(physics_catalog.EFFECTIVE_STRESS_CURVES)]
    strain = [i for i in visc if set(i["curves"]) <= set(physics_catalog.STRAIN_CURVES)]
    assert [i["direction"] for i in stress] == [-1] and [i["direction"] for i in strain] == [+1]
    assert not any(i["covariate"] == "hold time after unloading" for i in catalog["viscosity"].signature)
    swelling = catalog["time-dependent swelling"]
    assert swelling.enrichment.switches == {"swelling": True} and set(swelling.enrichment.parameters) == {
        "kappa_s", "tau_s"}
    items = {(i["covariate"], tuple(i["curves"])): i["direction"] for i in swelling.signature if i["curves"]}
    assert items["hold time after unloading", physics_catalog.EFFECTIVE_STRESS_CURVES] == +1
    assert items["hold time after unloading", physics_catalog.STRAIN_CURVES] == -1
    assert all(i["covariate"] in physics_catalog.COVARIATES for c in physics_catalog.CATALOG for i in c.signature)


def test_a_staged_record_without_times_takes_the_time_of_its_strain_rate():
    """real_kaolin_ciu_ratestep.toml: MEASURED rate-step shears whose file gives no times (empty time columns) and a
    consolidation stage recorded by stress: a shear stage's time is its strain over its rate (the stage's own
    definition), the consolidation stage, with neither times nor a rate, has no time; no covariate is undefined on
    every point (the screening refuses such a covariate)."""
    study, obs, cov = _study_covariates("real_kaolin_ciu_ratestep.toml")
    spec = study.tests[0]
    shears = {s.name: s for s in spec.stages if s.procedure.shearing}
    assert len(shears) == 20
    for (test, key), t in cov["time"].items():
        stage = key.split("@")[1]
        assert stage in shears
        x = obs[test].curves[key].x
        np.testing.assert_allclose(t, np.abs(x) / 100.0 / shears[stage].strain_rate, rtol=1e-12)
    assert {key.split("@")[1] for _, key in cov["time"]} == set(shears)
    for name, spec_ in cov.items():
        values = spec_["values"] if "values" in spec_ else spec_
        arrays = [np.atleast_1d(np.asarray(v)) for v in values.values()]
        numeric = [a for a in arrays if a.dtype.kind == "f"]
        assert not numeric or any(np.isfinite(a).any() for a in numeric), name
