"""The signs of the catalog's rate and swelling signatures in relaxation after loading and after unloading, checked
against the enrichments themselves: the residual a rate-independent Modified Cam Clay fit would leave on records of
a viscous soil, or of a soil with delayed swelling, must follow the hold time in the direction the catalog states
(constitutive.physics_catalog: viscosity's "hold time after loading" item -1 on effective stresses, time-dependent
swelling's "hold time after unloading" item +1). The programme is the oedometer relaxation study of the independent
data set (loading, relaxation, unloading, relaxation; its study file only, not its records)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from constitutive import physics_catalog

STUDY = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent" / "relaxation_A_s1" / "study.toml"
MCC = {"M": 1.2, "lambda_": 0.25, "kappa": 0.05, "pc0": 60.0}


def _item(candidate, covariate):
    c = physics_catalog.candidate(candidate)
    return next(i for i in c.signature if i["covariate"] == covariate and "axial_stress" in (i["curves"] or ()))


@pytest.fixture(scope="module")
def curves():
    study = load_study(STUDY)
    obs, times = load_observations(study.tests)
    problem = StudyProblem(study, obs, times, quick=True)

    def run(candidate, extra):
        switches = problem.base_switches if candidate is None else physics_catalog.enriched_settings(
            candidate, problem.base_switches, problem.base_bounds, problem.model)[0]
        return problem.map_curves({**MCC, **extra}, switches)["OED_relax"]

    return {"mcc": run(None, {}), "viscosity": run("viscosity", {"C_alpha_e": 0.01}),
            "swelling": run("time-dependent swelling", {"kappa_s": 0.02, "tau_s": 1.0e4}),
            "x": {c: curve.x for c, curve in obs["OED_relax"].curves.items()}}


def _trend(curves, model, stage):
    """Spearman rho of the hold time (the stage's recorded abscissa, s) against r = U_model/U_mcc - 1 on the axial
    stress of one relaxation stage, and the largest change of r over the hold, |r - r(first record)| (the
    history before the hold sets r's level, the hold its trend)."""
    key = f"axial_stress@{stage}"
    x = curves["x"][key]
    r = np.asarray(curves[model][key]) / np.asarray(curves["mcc"][key]) - 1.0
    return stats.spearmanr(x, r)[0], np.abs(r - r[0]).max()


def test_relaxation_after_loading_carries_the_viscosity_sign(curves):
    rho, size = _trend(curves, "viscosity", "relaxation2")
    assert _item("viscosity", "hold time after loading")["direction"] == -1
    assert rho < -0.9 and size > 0.02   # the viscous stress relaxes below the rate-independent one, more with time


def test_relaxation_after_unloading_carries_the_swelling_sign(curves):
    rho, size = _trend(curves, "swelling", "relaxation10")
    assert _item("time-dependent swelling", "hold time after unloading")["direction"] == +1
    assert rho > 0.9 and size > 0.02    # delayed swelling against the held strain raises the stress
    # after loading (first loading, p' at its maximum) the swelling element does nothing
    key = "axial_stress@relaxation2"
    assert np.abs(np.asarray(curves["swelling"][key]) / np.asarray(curves["mcc"][key]) - 1.0).max() < 1e-6


def test_a_viscous_soil_relaxes_little_after_unloading(curves):
    """Inside its yield surface after unloading an overstress model relaxes far less than after loading (the
    catalog's "loading phase" item: holds after unloading carry little of the viscosity signature)."""
    after_loading = _trend(curves, "viscosity", "relaxation2")[1]
    after_unloading = _trend(curves, "viscosity", "relaxation10")[1]
    assert after_unloading < 0.2 * after_loading
