"""A class of the soil loop whose ln Z cannot be refined at its mode (LoopProblem.refined_evidence gives None) keeps
the sampler's ln Z and is marked inference.diagnosis.NOT_REFINED, so that it cannot confirm; a refined class keeps
its estimate. The sampler and the record are replaced by stand-ins: what is tested is the wiring of calibrate_class."""
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from cases.study.loop import problem as loop_problem
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from inference.diagnosis import NOT_REFINED, ModelClass

STUDY = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent" / "relaxation_A_s1" / "study.toml"


@pytest.mark.parametrize("refined", [None, {"log_evidence": 250.0, "method": "importance sampling"}])
def test_a_class_that_cannot_be_refined_is_marked_and_a_refined_one_is_not(tmp_path, monkeypatch, refined):
    study = load_study(STUDY)
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True)
    problem.start(observations, None, tmp_path, 1, study.settings(True, None), "test")
    monkeypatch.setattr(loop_problem.runner, "announce_compilation", lambda kernels, evaluate: None)
    monkeypatch.setattr(loop_problem.runner, "calibrate", lambda *a, **k: SimpleNamespace(log_evidence=240.0))
    monkeypatch.setattr(problem, "refined_evidence", lambda like, prior, post, seed: refined)

    def finish_class(post, like, name, switches, run, out, seed, draws, wall_s, evidence=None, prior=None):
        lnz = post.log_evidence if evidence is None else evidence["log_evidence"]
        return ModelClass(name, "base", None, lnz, {}, {}, 0.02, {}, {}, np.empty(0), evidence=evidence), {}

    monkeypatch.setattr(problem, "finish_class", finish_class)
    cls, _, _ = problem.calibrate_class(observations, "MCC", dict(problem.base_switches), problem.base_bounds,
                                        tuple(problem.base_log_uniform), None, tmp_path / "base", 1, problem.settings)
    if refined is None:
        assert cls.log_evidence == 240.0 and cls.evidence == {"method": NOT_REFINED}
    else:
        assert cls.log_evidence == 250.0 and cls.evidence == refined
    assert set(cls.extra["phases_s"]) == {"sampler", "evidence", "record_and_outputs"}
