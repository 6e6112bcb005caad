"""The discretisation error the diagnosis measures at the base's mode (StudyForward(refinement=...),
LoopProblem.numerical_error): a finer discretisation converges (the error halves or better with the step), and the
measured error is the difference from the finest solution the test can afford, named per curve."""
from pathlib import Path

import numpy as np

from cases.study.forward.study import StudyForward
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from inference import Likelihood

EXAMPLES = Path(__file__).resolve().parents[4] / "cases" / "examples"
PARAMS = {"M": 1.2, "lambda_": 0.2, "kappa": 0.03, "ocr": 1.5}


def _curves(study, observations, refinement):
    like = Likelihood(observations, StudyForward(study, observations, {}, refinement=refinement), batch=True)
    result = like.forward.simulate_batch(tuple(PARAMS), np.array([list(PARAMS.values())]))[0][0]
    return like.simulated_at_observations(result)


def test_the_lab_drivers_converge_with_the_refined_strain_step():
    study = load_study(EXAMPLES / "triaxial_undrained.toml")
    observations, _ = load_observations(study.tests)
    curves = {r: _curves(study, observations, r) for r in (1, 2, 8)}
    for key in curves[1]:
        coarse = np.max(np.abs(curves[1][key] - curves[8][key]))
        half = np.max(np.abs(curves[2][key] - curves[8][key]))
        assert coarse > 0.0
        assert half < 0.6 * coarse, (key, coarse, half)  # at least first order in the strain step


def test_the_problem_reports_the_error_per_curve():
    study = load_study(EXAMPLES / "triaxial_undrained.toml")
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True)
    like = problem.make_likelihood(observations, {}).bind(list(PARAMS) + ["sigma_eps"])
    theta = list(PARAMS.values()) + [0.02]
    simulated = like.simulated_at_observations(problem.map_curves(PARAMS, {}))

    class Mode:
        extra = {"map_theta": theta}
        map_simulated = simulated

    error = problem.numerical_error(like, Mode, {})
    assert {(e["test"], e["curve"]) for e in error} == set(like.curve_keys)
    fine = like.simulated_at_observations(problem.refined_curves(PARAMS, {}))
    for e in error:
        key = (e["test"], e["curve"])
        used = like.masks[key]
        d = np.abs(fine[key] - simulated[key])[used] / np.abs(observations[key[0]].curves[key[1]].y[used])
        assert e["max"] == d.max() and 0.0 < e["rms"] <= e["max"]
