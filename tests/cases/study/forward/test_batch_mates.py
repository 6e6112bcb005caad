"""A parameter set's curves do not depend on the other sets solved beside it (the executors' chunks, the loop's
classes side by side and MPI ranks then give the same answer): the points of a stage are stepped side by side on
aligned steps, each taking the steps its own ramp asks for and resting through the others, and a point that failed
before the stage does not shape them.

The cases found (the independent generator's programmes, SYNTHETIC): on an IL programme of a bonded clay (Modified
Cam Clay with destructuration through the ANICREEP family, specific volume 1 + e0) one parameter set (xi 24.9)
fails in a load stage, and the next load ramp of its batch-mates was split by its stress at the failure (their axial
strain moved by up to 7e-3); on a CRS programme with unloading and reloading every set's reloading ramp was split
as finely as the set that needed the most steps asked."""
from pathlib import Path

import numpy as np

import inference
from cases.study.forward.lab_stage_steps import _linear_knots
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study

INDEPENDENT = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent"
STUDY = INDEPENDENT / "il_B_s1" / "study.toml"
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
    _same_curves(alone, beside)


def _same_curves(a, b):
    assert set(a) == set(b)
    for test in a:
        for key, values in a[test].items():
            x = values[1] if isinstance(values, tuple) else values
            y = b[test][key][1] if isinstance(b[test][key], tuple) else b[test][key]
            np.testing.assert_array_equal(np.asarray(y), np.asarray(x), err_msg=f"{test} {key}")


def test_live_points_needing_other_steps_keep_the_curves_they_have_alone():
    study = load_study(INDEPENDENT / "crs_ur_E_s2" / "study.toml")
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True)
    forward = problem.forward(dict(problem.base_switches))
    prior = problem.prior(problem.base_bounds, problem.base_log_uniform)
    sets = [{k: v for k, v in zip(prior.names, x) if not k.startswith("sigma")}
            for x in prior.sample(np.random.default_rng(7), 8)]
    together = forward(sets)
    for alone, beside in zip((forward([s])[0] for s in sets), together):
        assert not isinstance(beside, Exception)
        _same_curves(alone, beside)


def test_aligned_knots_rest_where_a_particle_needs_fewer_steps():
    """Two particles over [0, 1]: 2 and 4 equal parts; the first rests at its end for two steps and its knots are
    those it has alone."""
    points = np.array([[0.0, 0.0], [1.0, 1.0]])
    knots, last, taken = _linear_knots(points, lambda a, b: np.array([[2.0, 4.0]]))
    np.testing.assert_array_equal(taken, [[True, True], [True, True], [False, True], [False, True]])
    np.testing.assert_array_equal(knots[:, 1], [0.25, 0.5, 0.75, 1.0])
    alone, last_alone, taken_alone = _linear_knots(points[:, :1], lambda a, b: np.array([[2.0]]))
    np.testing.assert_array_equal(knots[:2, 0], alone[:, 0])
    assert np.all(knots[2:, 0] == alone[-1, 0]) and taken_alone.all() and list(last) == [3] and list(last_alone) == [1]
