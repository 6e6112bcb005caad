"""A study file's [enrichment.<candidate>] priors reach the loop (cases.study.loop.problem): the enriched class is
calibrated under them, the diagnosis' record of the candidates carries them, and the prior-bound warnings of the
enriched class are measured against them. The calibration itself is intercepted (no solve)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from corpus_inputs import LAB_CSV, LAB_TOML

import inference
from cases.study.loop import problem as problem_module
from cases.study.loop.study_problem import StudyProblem
from cases.study.outputs.calibration_warnings import bound_warnings
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study

PRIORS = """
[enrichment.viscosity]
C_alpha_e = [0.0005, 0.05]
[enrichment.destructuration]
xi = { bounds = [2.0, 20.0], prior = "uniform" }
"""


def _problem(tmp_path):
    (tmp_path / "t1.csv").write_text(LAB_CSV)
    (tmp_path / "study.toml").write_text(LAB_TOML + PRIORS)
    study = load_study(tmp_path / "study.toml")
    obs, times = load_observations(study.tests)
    problem = StudyProblem(study, obs, times, quick=True)
    problem.start(obs, None, tmp_path, 1, study.settings(True), "test")
    return problem


def _prior_of(problem, candidate, monkeypatch) -> inference.Prior:
    """The prior the enriched class of ``candidate`` would be calibrated under."""
    seen = []

    def stop(like, prior, *args, **kw):
        seen.append(prior)
        raise RuntimeError("intercepted")

    monkeypatch.setattr(problem_module.runner, "calibrate", stop)
    with pytest.raises(RuntimeError, match="intercepted"):
        problem.calibrate(candidate)
    return seen[0]


def test_the_study_prior_reaches_the_enriched_class(tmp_path, monkeypatch):
    problem = _problem(tmp_path)
    viscosity = {b.name: (b.lower, b.upper, b.kind) for b in _prior_of(problem, "viscosity", monkeypatch).bounds}
    assert viscosity["C_alpha_e"] == (0.0005, 0.05, "log-uniform")
    assert viscosity["M"] == (0.8, 1.8, "uniform") and viscosity["ocr"] == (1.0, 4.0, "log-uniform")
    # the table's own prior form; the parameter it leaves out keeps the catalog's prior
    destructuration = {b.name: (b.lower, b.upper, b.kind)
                       for b in _prior_of(problem, "destructuration", monkeypatch).bounds}
    assert destructuration["xi"] == (2.0, 20.0, "uniform")
    assert destructuration["chi0"] == (0.1, 50.0, "log-uniform")
    # a candidate the study gives no prior: the catalog's
    swelling = {b.name: (b.lower, b.upper, b.kind)
                for b in _prior_of(problem, "time-dependent swelling", monkeypatch).bounds}
    assert swelling["kappa_s"] == (0.001, 0.05, "log-uniform")
    records = {c["name"]: c["enrichment"] for c in problem.candidates()}
    assert records["viscosity"]["parameters"] == {"C_alpha_e": [0.0005, 0.05]}
    assert records["destructuration"]["log_uniform"] == ["chi0"]


def test_an_enriched_class_is_warned_at_the_study_bound(tmp_path, monkeypatch):
    prior = _prior_of(_problem(tmp_path), "viscosity", monkeypatch)
    # a posterior of the enriched class with C_alpha_e at the study's lower bound, everything else mid-prior
    middle = {b.name: np.sqrt(b.lower * b.upper) if b.kind == "log-uniform" else 0.5 * (b.lower + b.upper)
              for b in prior.bounds}
    theta = np.array([0.0005 if n == "C_alpha_e" else middle[n] for n in prior.names])
    samples = theta * np.linspace(1.0, 1.01, 30)[:, None]
    post = inference.Posterior(
        names=prior.names, samples=samples, log_like=np.zeros(30), log_evidence=0.0, map_theta=theta,
        map_log_posterior=0.0, stages=[], stage_samples=[samples], stage_log_like=[np.zeros(30)], failures=[],
        n_forward_solves=0, wall_s=0.0, ranks=1, executor="serial", prior=prior.describe())
    assert bound_warnings(post, lower_only=("sigma_eps",)) == [
        "C_alpha_e MAP 0.0005, 2.5 % quantile 0.0005001, 97.5 % quantile 0.0005049 at the lower bound 0.0005 of its "
        "prior: widen the bound or fix it"]


def test_each_class_names_the_kernels_it_compiles(tmp_path):
    """What the loop announces when a cache is cold (``runner.announce_compilation``): the base's kernels, the
    enrichment family's for a class the base model cannot take, and delayed swelling's on top."""
    problem = _problem(tmp_path)

    def names(switches):
        return [f.name for f in problem.kernels(switches)]

    assert names({}) == ["_mcc_kernel.py"]
    assert names({"viscous": True}) == ["_anicreep_kernel.py", "_anicreep_steps.py"]
    assert names({"swelling": True}) == ["_anicreep_kernel.py", "_anicreep_steps.py", "_swelling_kernel.py",
                                         "_swelling_steps.py"]


INDEPENDENT = Path(__file__).resolve().parents[4] / "validation" / "data" / "independent"


@pytest.mark.parametrize("case, shears", [("il_B_s1", False), ("crs_B_s1", False), ("relaxation_A_s1", False),
                                          ("ck0u_C_s1", True), ("ciu_A_s1", True)])
def test_the_fabric_is_free_only_on_a_programme_that_shears(tmp_path, monkeypatch, case, shears):
    """The anisotropic class frees the initial fabric and its rotation (alpha0, omega_ratio) where a specimen is
    sheared (CK0U, CIU); on an incremental-loading, CRS or relaxation programme it keeps S-CLAY1's from M."""
    study = load_study(INDEPENDENT / case / "study.toml")
    obs, times = load_observations(study.tests)
    problem = StudyProblem(study, obs, times, quick=True)
    problem.start(obs, None, tmp_path, 1, study.settings(True), "test")
    assert problem.shears is shears
    names = set(_prior_of(problem, "anisotropy", monkeypatch).names)
    assert names >= {"M", "lambda_", "kappa", "pc0", "sigma_eps"}
    assert names & {"alpha0", "omega_ratio"} == ({"alpha0", "omega_ratio"} if shears else set())
