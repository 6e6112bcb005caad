"""A parameter set's curves do not depend on the other sets solved beside it (the executors' chunks, the loop's
classes side by side and MPI ranks then give the same answer): the points of a stage share its steps (a ramp split
as finely as its most demanding point asks), and a point that failed before the stage must not shape them.

The case found: the independent generator's IL programme of a bonded clay (SYNTHETIC), Modified Cam Clay with
destructuration through the ANICREEP family, specific volume 1 + e0; one parameter set (xi 24.9) fails in a load
stage, and the next load ramp of its batch-mates was split by its stress at the failure (their axial strain moved
by up to 7e-3)."""
from pathlib import Path

import numpy as np

import inference
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study

STUDY = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent" / "il_B_s1" / "study.toml"
LIVE = {"M": 1.2036386071663627, "lambda_": 0.32139894082979703, "kappa": 0.08964002267475141,
        "pc0": 150.32623173507773, "chi0": 46.684614190718456, "xi": 2.0798741367157643}
FAILS = {"M": 1.337412130089028, "lambda_": 0.22016803259162812, "kappa": 0.07992616209196035,
         "pc0": 42.18722743465819, "chi0": 19.091068832133956, "xi": 24.877287671383076}


def test_a_failed_batch_mate_leaves_the_others_curves_bit_for_bit():
    study = load_study(STUDY)
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True)
    problem.adopted_switches, problem.convention, problem.class_root = {}, {"specific_volume": "initial"}, Path(".")
    _, switches, _, _, _ = problem.enriched_class("destructuration")
    forward = problem.forward(switches)
    alone = forward([LIVE])[0]
    failed, beside = forward([FAILS, LIVE])
    assert isinstance(failed, inference.ForwardModelError) and not isinstance(beside, Exception)
    assert set(beside["IL"]) == set(alone["IL"])
    for key, values in alone["IL"].items():
        a = values[1] if isinstance(values, tuple) else values
        b = beside["IL"][key][1] if isinstance(beside["IL"][key], tuple) else beside["IL"][key]
        np.testing.assert_array_equal(np.asarray(b), np.asarray(a), err_msg=key)
