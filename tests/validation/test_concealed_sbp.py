"""validation.proofs.sbp: SYNTHETIC two-rate SBP data with a hidden effect, the partial-drainage enrichment (coupled FE
with the permeability free) and the loop (slow)."""
import os
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from tolerances import FE_RTOL

from constitutive import physics_catalog  # noqa: E402
from validation.proofs import sbp as cs  # noqa: E402

FORBIDDEN = ("visc", "creep", "c_alpha", "secondary", "rate-dep", "rate dep", "drain", "permeab", "consolid",
             "set_1", "k_true")


def test_shipped_data_equal_the_generator():
    for effect, e in cs.EFFECTS.items():
        gen = cs.synthetic_curves(effect, seed=1)
        for pp in (True, False):
            obs = cs.load_data(effect, pore_pressure=pp)
            for t in obs:
                for c, curve in t.curves.items():
                    np.testing.assert_allclose(curve.x, gen[t.name]["cavity_strain_pct"], rtol=1e-9)
                    np.testing.assert_allclose(curve.y, gen[t.name][f"{c}_kPa"], rtol=FE_RTOL, err_msg=(effect, c))


def test_data_files_are_labelled_synthetic_and_do_not_name_the_effect():
    files = sorted(cs.DATA.glob("*/*.csv"))
    assert len(files) == 2 * len(cs.EFFECTS)
    for f in files:
        text = f.read_text()
        assert text.startswith("# synthetic: NOT MEASURED DATA"), f
        low = (f.name + text).lower()
        for word in FORBIDDEN:
            assert word not in low, (f, word)
    for e in cs.EFFECTS.values():  # blind directory names
        assert all(w not in e["dataset"] for w in ("visc", "drain", "none", "control"))
    source = (cs.DATA / "SOURCE.md").read_text()
    assert "SYNTHETIC" in source and "seed 1" in source and "0.02" in source


def test_partial_drainage_enrichment_from_the_catalog():
    switches, bounds, log_uniform = physics_catalog.enriched_settings(
        "partial drainage", cs.SBPProblem(1e-9, True).catalog_switches(cs.BASE_SWITCHES), cs.BASE_BOUNDS)
    assert switches["coupled"] is True and log_uniform == ("permeability",)
    lo, hi = bounds["permeability"]
    assert lo <= 1e-10 and hi >= 1e-7 and np.log10(hi / lo) >= 4  # several decades, both data sets' k inside
    sig = {d["name"]: d for d in physics_catalog.signatures({"coupled": False})}["partial drainage"]
    primary = next(i for i in sig["signature"] if i["role"] == "primary")
    assert primary["covariate"] == "drainage time factor" and primary["direction"] == -1
    assert "pore_pressure" in primary["curves"]


def test_enriched_forward_reproduces_the_data_noise_free_at_the_generating_values():
    """The partial-drainage class (k free) at the generating k equals the generator without noise; the base class
    with the assumed k differs from it (the hidden effect) mostly in the wall pore pressure of the slow test."""
    effect = "partial drainage"
    clean = cs.synthetic_curves(effect, seed=1, noise=0.0)
    switches, _, _ = physics_catalog.enriched_settings(effect, {"coupled": False, **cs.BASE_SWITCHES}, cs.BASE_BOUNDS)
    problem = cs.SBPProblem(cs.EFFECTS[effect]["k_assumed"], True)
    params = {**cs.GENERATING, "permeability": cs.EFFECTS[effect]["k_true"]}
    like_x = cs.strains()
    sim = problem.forward(switches)(params)
    base = problem.forward(cs.BASE_SWITCHES)(cs.GENERATING)
    for t in cs.RATES:
        for c in cs.CURVES:
            x, y = sim[t][c]
            np.testing.assert_allclose(np.interp(like_x, x, y), clean[t][f"{c}_kPa"], rtol=1e-9)
    xb, ub = base["slow"]["pore_pressure"]
    gap = 1.0 - clean["slow"]["pore_pressure_kPa"][-1] / np.interp(10.0, xb, ub)
    assert gap > 0.2  # drainage: lower wall pore pressure than the assumed (100x smaller) k gives


def test_covariates_report_the_drainage_time_factor():
    obs = cs.load_data("none")
    problem = cs.SBPProblem(cs.EFFECTS["none"]["k_assumed"], True)
    cov = problem.curve_covariates(type("L", (), {"observations": obs})(), None)
    assert set(cov) <= set(physics_catalog.COVARIATES)
    T = cov["drainage time factor"]
    assert T["slow", "pore_pressure"][-1] / T["fast", "pore_pressure"][-1] == pytest.approx(
        cs.RATES["fast"] / cs.RATES["slow"])
    assert cov["strain rate"]["fast", "cavity_pressure"] == cs.RATES["fast"]


# ---------------------------------------------------------------------------------------------- signatures at SBP scale
def _planted_sbp(cavity, pore, seed=0):
    """Two SBP tests (fast, slow) with smooth simulated curves; recorded = simulated x (1 + pattern + 2 % noise), the
    pattern rising linearly along the curve to ``cavity[t]`` / ``pore[t]`` at 10 % (relative). Returns
    (Likelihood, simulated, covariates) for pore pressure recorded and for the cavity pressure only."""
    from inference import Likelihood

    rng = np.random.default_rng(seed)
    x = cs.strains()
    sim = {"cavity_pressure": 150.0 + 120.0 * (1.0 - np.exp(-x / 2.0)), "pore_pressure": 40.0 + 60.0 * np.sqrt(x / 10)}
    recorded = {t: {"cavity_strain_pct": x, **{f"{c}_kPa": y * (1.0 + {"cavity_pressure": cavity,
                                                                       "pore_pressure": pore}[c][t] * x / 10.0
                                                               + cs.NOISE * rng.standard_normal(x.size))
                                               for c, y in sim.items()}} for t in cs.RATES}
    out = []
    for pp in (True, False):
        like = Likelihood(cs.observations_from(recorded, pp, "yes"), lambda p: {}, sigma=cs.NOISE)
        cov = cs.SBPProblem(cs.EFFECTS["none"]["k_assumed"], pp).curve_covariates(like, None)
        out.append((like, {(t.name, c): sim[c] for t in like.observations for c in t.curves}, cov, pp))
    return out


def _diagnosed(like, simulated, cov):
    from inference import diagnosis
    from inference.diagnosis import relative_residuals, screen

    report = screen(like, simulated, cs.NOISE, covariates=cov, n_shifts=300)
    switches = cs.SBPProblem(1e-9, True).catalog_switches(cs.BASE_SWITCHES)
    ranked = diagnosis.rank_candidates(report, relative_residuals(like, simulated), cov,
                                      physics_catalog.signatures(switches))
    return diagnosis.Diagnosis("", 0.05, report.verdict, "none", "-", (), tuple(report.attribution),
                               tuple(diagnosis.DiagnosedCandidate(**vars(r)) for r in ranked), (), {},
                               diagnosis.DecisionRule(), {}, (), {})


@pytest.mark.parametrize("effect, cavity, pore", [
    ("viscosity", {"fast": 0.03, "slow": -0.03}, {"fast": -0.05, "slow": 0.05}),
    ("partial drainage", {"fast": 0.03, "slow": -0.03}, {"fast": 0.05, "slow": -0.05}),
    ("none", {"fast": 0.0, "slow": 0.0}, {"fast": 0.0, "slow": 0.0})])
def test_two_rate_signatures_name_the_effect_only_with_the_pore_pressure(effect, cavity, pore):
    """The patterns of data sets 1-3 (viscosity: faster test's cavity pressure higher, its pore pressure lower than
    simulated; partial drainage: both higher in the faster test; none: noise), two tests: with the wall pore pressure
    the catalog names exactly the hidden effect (the few-test contrast of inference.diagnosis makes the two-test
    rate trend significant; the pore-pressure items tell the two apart); with the cavity pressure only nothing is
    named and the case says it cannot tell viscosity from partial drainage apart and needs the pore pressure."""
    for like, sim, cov, pp in _planted_sbp(cavity, pore):
        diag = _diagnosed(like, sim, cov)
        named = diag.named
        limits, answer = cs.design_limits(diag, pp)
        rate = next(a for a in diag.attribution if a.name == "strain rate")
        if effect == "none":
            assert diag.verdict == "consistent with noise" and named == []
            assert "cannot tell" not in answer
            continue
        assert rate.contrast and rate.p_adjusted <= 0.05
        assert rate.contrast["cavity_pressure"]["z"] > 0
        if pp:
            assert diag.verdict == "structured mismatch" and named == [effect], (named, limits)
        else:
            assert named == []
            assert answer.startswith("cannot tell viscosity from partial drainage apart") and "pore pressure" in answer


@pytest.mark.slow
def test_tiny_loop_end_to_end(tmp_path):
    """The loop on the control data with tiny settings runs and writes the diagnosis; every class has ln Z."""
    row = cs.run_case("none", 1, tmp_path, pore_pressure=True, settings=cs.Settings(12, 1, 4), processes=1)
    assert (tmp_path / "diagnosis.json").exists() and (tmp_path / "case.json").exists()
    assert row["verdict"] in ("structured mismatch", "consistent with noise")
    assert all(np.isfinite(v) for v in row["log_evidence"].values())


@pytest.mark.parametrize("visc, drain, favours", [(20.0, 5.4, True), (3.3, 1.9, False), (1.0, -2.0, False)])
def test_answer_without_pore_pressure_mentions_the_evidence_only_when_it_separates(visc, drain, favours):
    """Without the wall pore pressure the answer is 'cannot tell ... apart'; it adds which class the Bayes factors
    favour only when the best has ln B >= 3 and beats the other by >= 3 (data sets 1 and 2 without pore pressure,
    noise seeds 1 and 2: ln B 20.0 / 5.4 and 3.3 / 1.9)."""
    like, sim, cov, pp = _planted_sbp({"fast": 0.03, "slow": -0.03}, {"fast": -0.05, "slow": 0.05})[1]
    diag = _diagnosed(like, sim, cov)
    diag = replace(diag, classes=(
        SimpleNamespace(role="enriched", candidate="viscosity", log_bayes_vs_base=visc),
        SimpleNamespace(role="enriched", candidate="partial drainage", log_bayes_vs_base=drain)))
    limits, answer = cs.design_limits(diag, pp)
    assert not pp and answer.startswith("cannot tell viscosity from partial drainage apart")
    assert ("favours viscosity" in answer) == favours
