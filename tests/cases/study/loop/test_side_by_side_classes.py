"""LoopProblem.calibrate_side_by_side: the classes of one step calibrated side by side, each in a child of the loop's
process, are the classes one after the other gives, to the bit; what the next step needs comes back (the figures and
files the children kept, the likelihood of each class for ``adopt``). SYNTHETIC records of the independent
generator (a CRS programme of a viscous clay)."""
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import inference
from cases.study.cli import arguments, run_settings
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from inference.diagnosis import MODEL_FORM
from inference.executors.side_by_side import can_fork

STUDY = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent" / "crs_C_s1" / "study.toml"
REQUESTS = [MODEL_FORM, "viscosity", "time-dependent swelling", "no such effect"]


def _step(out, processes):
    """The base class, then REQUESTS side by side (one process: one after the other), with a tiny sampler."""
    study = load_study(STUDY)
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True, processes=processes)
    settings = replace(study.settings(True, None), n_samples=16, max_steps=2, predictive_draws=4)
    problem.start(observations, run_settings(arguments("", ["--quick"])), out, 1, settings, "test")
    try:
        base = problem.calibrate(None)
        return problem, base, problem.calibrate_side_by_side(REQUESTS)
    except BaseException:   # no background drawer left to hold the interpreter's exit
        problem.figures.close()
        raise


def _compare(one, two, base1, base2, both, children_left):
    """The same classes to the bit, the same error for an effect the catalog lacks, no child left."""
    assert base1.log_evidence == base2.log_evidence
    for (a, err_a), (b, err_b) in zip(one[:3], two[:3]):
        assert err_a is None and err_b is None
        assert a.name == b.name and a.log_evidence == b.log_evidence and a.extra["map_theta"] == b.extra["map_theta"]
        assert a.J_g == b.J_g and a.sampler_log_evidence == b.sampler_log_evidence
        for key, values in a.map_simulated.items():
            np.testing.assert_array_equal(values, b.map_simulated[key])
    assert one[3][0] is None and two[3][0] is None and type(one[3][1]) is type(two[3][1])
    assert str(one[3][1]) == str(two[3][1])
    assert "model-form discrepancy" in two[0][0].name and "viscous=True" in two[1][0].name
    # the only process left is the loop's background drawer of the figures
    assert children_left() == [both.figures.drawer[0]]


@pytest.mark.skipif(not can_fork(), reason="side by side needs fork")
def test_side_by_side_gives_the_classes_one_after_the_other_gives(tmp_path, monkeypatch, children_left):
    alone, base1, one = _step(tmp_path / "one", 1)
    children = tmp_path / "children"
    plain = inference.side_by_side

    def recorded(tasks, processes, in_child, back, **options):   # each child writes its process id there
        def marked(task):
            with children.open("a") as f:
                f.write(f"{os.getpid()}\n")
            return in_child(task)
        return plain(tasks, processes, marked, back, **options)

    monkeypatch.setattr(inference, "side_by_side", recorded)
    both, base2, two = _step(tmp_path / "two", 2)
    pids = children.read_text().split()
    assert len(pids) == len(REQUESTS) == len(set(pids)) and str(os.getpid()) not in pids
    try:
        _compare(one, two, base1, base2, both, children_left)
        # what the children kept comes back: each class's figures and posterior.nc are drawn and written here
        with inference.PoolExecutor(2) as pool:
            both.figures.draw_all(pool)
    finally:
        alone.figures.close()
        both.figures.close()
    assert not children_left()
    for folder in ("model_form", "enriched_viscosity", "enriched_time-dependent_swelling"):
        for name in ("curves.png", "pairs.png", "posterior.nc", "summary.json"):
            assert (tmp_path / "two" / folder / name).is_file(), (folder, name)
    # and the next step can be built on a class calibrated in a child: its likelihood came back, bound
    viscous1, viscous2 = one[1][0], two[1][0]
    adopted1 = alone.adopt(replace(viscous1, role="enriched", candidate="viscosity"))
    adopted2 = both.adopt(replace(viscous2, role="enriched", candidate="viscosity"))
    assert adopted2.numerical_error == adopted1.numerical_error and adopted2.numerical_error
