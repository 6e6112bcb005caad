"""The soil side of the conventions step (LoopProblem.compare_conventions): a Modified Cam Clay study is calibrated
in its own convention first (specific volume 1 + e); the other (1 + e0, through the ANICREEP family) is calibrated
only when asked, replaces the base only when it wins by CONVENTION_LOG_BAYES, and then every later class is written
in it. The calibrations are replaced by records of chosen ln Z: what is tested is the decision and its words."""
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from cases.study.loop.problem import CONVENTION_LOG_BAYES
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from inference.diagnosis import ModelClass

STUDY = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent" / "relaxation_A_s1" / "study.toml"


def _problem(tmp_path, monkeypatch, log_evidence):
    """A started StudyProblem whose calibrations return a record with ln Z = log_evidence(class name)."""
    study = load_study(STUDY)
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True)
    problem.start(observations, None, tmp_path, 1, study.settings(True, None), "test")
    calls = []

    def calibrate_class(observations, name, switches, bounds, log_uniform, run, out, seed, settings, **kw):
        calls.append((name, dict(switches), out))
        cls = ModelClass(name, "base", None, log_evidence(name), {}, {"M": {"map": 1.2}}, 0.02, {}, {},
                         np.empty(0), extra={"map_theta": [1.2, 0.02]}, wall_s=1.0)
        return cls, SimpleNamespace(names=["M", "sigma_eps"]), SimpleNamespace(name=name)

    monkeypatch.setattr(problem, "calibrate_class", calibrate_class)
    monkeypatch.setattr(problem, "numerical_error", lambda like, cls, switches: [])
    return problem, calls


@pytest.mark.parametrize("gain, adopted", [(CONVENTION_LOG_BAYES + 2.0, True), (CONVENTION_LOG_BAYES - 1.0, False)])
def test_the_other_convention_is_calibrated_on_request_and_replaces_the_base_only_when_clearly_preferred(
        tmp_path, monkeypatch, gain, adopted):
    problem, calls = _problem(tmp_path, monkeypatch, lambda name: 250.0 + (gain if "initial" in name else 0.0))
    base = problem.calibrate(None)
    assert [c[0] for c in calls] == [base.name] and "specific_volume" not in calls[0][1]
    assert "compared only when the base's residual is structured" in problem.description
    record = problem.compare_conventions(base)
    assert len(calls) == 2 and calls[1][1]["specific_volume"] == "initial"
    assert calls[1][2] == tmp_path / "convention_specific_volume_initial"
    assert [c["log_evidence"] for c in problem.conventions_compared] == [250.0, 250.0 + gain]
    assert "compared only when" not in problem.description
    if adopted:
        assert record is not None and record.name == calls[1][0] and record.log_evidence == 250.0 + gain
        assert problem.convention == {"specific_volume": "initial"} and problem.likelihood.name == record.name
        assert problem.description.endswith("the base is written with specific volume 1 + e0 (held at its "
                                             "initial value).")
        assert problem.enriched_class("viscosity")[1]["specific_volume"] == "initial"
    else:
        assert record is None and problem.convention == {} and problem.likelihood.name == base.name
        assert problem.description.endswith("the base is written with specific volume 1 + e (current).")
        assert problem.enriched_class("viscosity")[1]["specific_volume"] == "current"
