"""cases.concealed_sbp: SYNTHETIC two-rate SBP data with a hidden effect, the partial-drainage enrichment (coupled FE
with the permeability free) and the loop (slow)."""
import os

import numpy as np
import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from cases import concealed_sbp as cs  # noqa: E402
from constitutive import physics_catalog  # noqa: E402

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
                    np.testing.assert_allclose(curve.y, gen[t.name][f"{c}_kPa"], rtol=1e-8, err_msg=(effect, c))


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
    sim = problem.forward(switches)([params])[0]
    base = problem.forward(cs.BASE_SWITCHES)([cs.GENERATING])[0]
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
    cov = problem.covariates(type("L", (), {"observations": obs})(), None)
    assert set(cov) <= set(physics_catalog.COVARIATES)
    T = cov["drainage time factor"]
    assert T["slow", "pore_pressure"][-1] / T["fast", "pore_pressure"][-1] == pytest.approx(
        cs.RATES["fast"] / cs.RATES["slow"])
    assert cov["strain rate"]["fast", "cavity_pressure"] == cs.RATES["fast"]


@pytest.mark.slow
def test_tiny_loop_end_to_end(tmp_path):
    """The loop on the control data with tiny settings runs and writes the diagnosis; every class has ln Z."""
    row = cs.run_case("none", 1, tmp_path, pore_pressure=True, settings=cs.Settings(12, 1, 4), processes=1)
    assert (tmp_path / "diagnosis.json").exists() and (tmp_path / "case.json").exists()
    assert row["verdict"] in ("structured mismatch", "consistent with noise")
    assert all(np.isfinite(v) for v in row["log_evidence"].values())
