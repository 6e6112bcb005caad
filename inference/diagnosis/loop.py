"""The calibrate -> diagnose loop as a library function: calibrate the base class, locate and explain the mismatch,
calibrate the enriched classes of the candidates, compare log-evidences together with the signatures.

The loop knows nothing of the physics: a problem (`LoopProblem`) calibrates a model class on request and returns its
record (`ModelClass`), gives the base class's per-point covariates and the candidate physics as plain data
(`rank.rank_candidates`). Everything stays in memory; the problem writes whatever files it wants (for a run
directory, `files.write_input` and `files.write_diagnosis`).

Steps of `run_loop`:
1. candidates = problem.candidates(); base = problem.calibrate(None); covariates = problem.covariates(base);
2. first diagnosis (`report.diagnose`) of the base class alone;
3. the candidates to enrich, by the problem's ``enrich`` (optional attribute, or `run_loop`'s argument):
   "named": the first candidate in ranked order that is named and has an enrichment (named candidates before it
   without an enrichment are listed as "named without enrichment"); "all" (default): that one, then, when the
   screening finds structure, every other candidate with an enrichment that the base model lacks, named or not, in
   ranked order (`rank.conclude` then decides by the evidence together with the signatures); then the problem's
   ``also_enrich(first)`` names, in their order, not chosen already;
4. each chosen candidate's enriched class is calibrated (``problem.calibrate(name)``); under "all" a candidate
   beyond the first named one whose calibration the problem refuses (ValueError: no enrichment for this forward
   model) is listed in ``LoopResult.not_calibrated`` with the reason, and so is every enriched class whose
   calibration stopped (``SamplerError``: too many failed solves), which the verdict then cannot confirm;
5. when an enriched class was calibrated, the final diagnosis compares every class (`report.diagnose`: a candidate
   is confirmed by its ln B, the margin over the other enriched classes and its own residual pattern explained,
   `rank.conclude`); else the first is final.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from ..tmcmc import SamplerError
from .rank import STRONG_LOG_BAYES
from .report import diagnose

__all__ = ["ModelClass", "LoopProblem", "LoopResult", "run_loop", "ENRICH"]

ROLES = ("base", "enriched")
#: which candidates the loop enriches (module docstring, step 3)
ENRICH = ("all", "named")


@dataclass
class ModelClass:
    """One calibrated model class, as the diagnosis reads it.

    name: the class's name (e.g. its model and switches); role: "base" or "enriched"; candidate: the candidate
    physics an enriched class adds (None for the base class); log_evidence: ln Z of the calibration; J_g: goodness
    of fit at the MAP per test, Eq. (6) (docs/reference.md section 1); parameters: {name: {map, mean, std, q2.5,
    q97.5}} of the posterior; sigma_eps: the error parameter at the MAP (with error groups, Eq. (6g), each curve's
    sigma, a list in the likelihood's curve order); map_simulated: {(test, curve): simulated values at the recorded
    abscissae} at the MAP; sample_simulated: {(test, curve): (n_s, n)} the same for n_s posterior samples,
    sample_sigma (n_s,) their sigma_eps, or (n_s, n_curves) with error groups (for the predictive bands); wall_s:
    calibration wall time (s); n_forward_solves: forward solves of the calibration; extra: the problem's own data
    (e.g. the MAP's raw curves for its covariates and figures), never read by the diagnosis; warnings: the
    calibration's own findings of a poor fit, in words (e.g. "sigma_eps at its prior's upper bound 0.3", "M on its
    prior's lower bound"), named in the diagnosis' verdict.
    """

    name: str
    role: str
    candidate: str | None
    log_evidence: float
    J_g: dict
    parameters: dict
    sigma_eps: float | list
    map_simulated: dict
    sample_simulated: dict
    sample_sigma: np.ndarray
    wall_s: float = 0.0
    n_forward_solves: int = 0
    extra: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"model class {self.name!r}: role {self.role!r} must be one of {ROLES}")

    def to_dict(self) -> dict:
        """The class dict of `report.diagnose` and `files.write_input` (``extra`` left out)."""
        return {"name": self.name, "role": self.role, "candidate": self.candidate,
                "log_evidence": self.log_evidence, "J_g": self.J_g, "parameters": self.parameters,
                "sigma_eps": self.sigma_eps, "wall_s": self.wall_s, "n_forward_solves": self.n_forward_solves,
                "map_simulated": self.map_simulated, "sample_simulated": self.sample_simulated,
                "sample_sigma": self.sample_sigma, "warnings": list(self.warnings)}


class LoopProblem(Protocol):
    """What `run_loop` needs from a study.

    likelihood: an inference.Likelihood of the recorded curves (the screening reads its observations and near-zero
    floor); description: one line for the diagnosis report, read after the base class is calibrated.
    ``also_enrich`` and ``enrich`` ("all" or "named", module docstring step 3) are optional.
    """

    likelihood: object
    description: str

    def candidates(self) -> list:
        """Candidate physics as plain data (``rank.rank_candidates``), judged against the base class."""

    def calibrate(self, candidate: str | None) -> ModelClass:
        """Calibrate the base class (candidate None) or the base class enriched with ``candidate``."""

    def covariates(self, base: ModelClass) -> dict:
        """Per-point covariates of the calibrated base class, in the form of ``screen``."""

    def also_enrich(self, first_diagnosis: dict) -> list:
        """Further candidates (names, in this order) to enrich after the best-ranked named one, from the first
        diagnosis."""


@dataclass
class LoopResult:
    """The records of one loop.

    first: the diagnosis of the base class alone; final: the diagnosis of every calibrated class (the first when no
    enriched class was calibrated); classes: [ModelClass], the base class first; covariates: the base class's;
    named: candidates named in the final diagnosis; named_without_enrichment: named candidates ranked above the chosen
    one that have no enrichment for this base class; not_calibrated: {candidate: reason} of the candidates chosen
    under enrich "all" whose enriched class the problem refused; timing: {screen_and_rank_s (the first diagnosis),
    diagnose_final_s (the second; 0 when none), calibration_s {class: s}, loop_s} in seconds.
    """

    first: dict
    final: dict
    classes: list
    covariates: dict
    named: list
    named_without_enrichment: list
    timing: dict
    not_calibrated: dict = field(default_factory=dict)


def _chosen(first: dict, enrich: str) -> tuple:
    """(named candidates without an enrichment ranked above the first enrichable named one, the candidates to
    enrich in order, how many of them the "named" rule chose) from the first diagnosis (module docstring, step 3)."""
    skipped, chosen = [], []
    for cand in first["candidates"]:
        if not cand["named"]:
            continue
        if cand["enrichment"] is None:
            skipped.append(cand["name"])
            continue
        chosen.append(cand["name"])
        break
    n_named_rule = len(chosen)
    if enrich == "all" and first["verdict"] == "structured mismatch":
        chosen += [c["name"] for c in first["candidates"] if c["enrichment"] is not None and not c["in_base"]
                   and c["name"] not in chosen]
    return skipped, chosen, n_named_rule


def run_loop(problem: LoopProblem, alpha=0.05, level=0.95, threshold=STRONG_LOG_BAYES, n_shifts=1000, enrich=None,
             margin=None) -> LoopResult:
    """Calibrate, locate, explain, enrich, recalibrate, compare (module docstring); writes no files.

    alpha: family-wise false-alarm level of each screening; level: predictive band level; threshold: ln B that
    confirms an enrichment (`rank.conclude`; calibrate it on negative controls, `report` module docstring);
    n_shifts: null draws of the covariate attribution; enrich: "all" or "named" (default: the problem's ``enrich``,
    else "all"); margin: ln B by which a candidate must beat the other enriched classes (default: threshold).
    """
    enrich = enrich or getattr(problem, "enrich", "all")
    if enrich not in ENRICH:
        raise ValueError(f"enrich = {enrich!r} must be one of {ENRICH}")
    t_loop = time.perf_counter()
    settings = {"alpha": alpha, "level": level, "threshold": threshold, "n_shifts": n_shifts, "margin": margin}
    candidates = problem.candidates()
    base = replace(problem.calibrate(None), role="base", candidate=None)
    covariates = problem.covariates(base)
    classes = [base]
    t0 = time.perf_counter()
    first = diagnose(problem.likelihood, classes, covariates, candidates, problem.description, **settings)
    screen_s = time.perf_counter() - t0
    skipped, chosen, n_named_rule = _chosen(first, enrich)
    also = getattr(problem, "also_enrich", None)
    extra = [name for name in (also(first) if also else []) if name not in chosen]
    refused = {}
    for k, name in enumerate(chosen + extra):
        try:
            classes.append(replace(problem.calibrate(name), role="enriched", candidate=name))
        except ValueError as err:
            if k < n_named_rule or name in extra:
                raise
            refused[name] = str(err)
        except SamplerError as err:  # the enriched class's calibration stopped (e.g. too many failed solves)
            refused[name] = f"calibration stopped: {err}"
    final, final_s = first, 0.0
    if len(classes) > 1:
        t0 = time.perf_counter()
        final = diagnose(problem.likelihood, classes, covariates, candidates, problem.description, **settings)
        final_s = time.perf_counter() - t0
    timing = {"screen_and_rank_s": screen_s, "diagnose_final_s": final_s,
              "calibration_s": {c.name: c.wall_s for c in classes}, "loop_s": time.perf_counter() - t_loop}
    return LoopResult(first, final, classes, covariates, [c["name"] for c in final["candidates"] if c["named"]],
                      skipped, timing, refused)
