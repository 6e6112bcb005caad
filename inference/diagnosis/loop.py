"""The calibrate -> diagnose loop as a library function: calibrate the base class, locate and explain the mismatch,
calibrate the enriched classes of the candidates, compare log-evidences together with the signatures.

The loop knows nothing of the physics: a problem (`LoopProblem`) calibrates a model class on request and returns its
record (`ModelClass`), gives the base class's per-point covariates and the candidate physics as plain data
(`rank.rank_candidates`). Everything stays in memory; the problem writes whatever files it wants (for a run
directory, `files.write_input` and `files.write_diagnosis`).

Steps of `run_loop`:
1. base = problem.calibrate(None); candidates = problem.candidates(); covariates = problem.covariates(base);
2. first diagnosis (`report.diagnose`) of the base class alone; when its screening finds structure and the problem
   writes its base in other conventions (``problem.compare_conventions(base)``, optional: the same model written
   another way, e.g. specific volume 1 + e or 1 + e0), those compete first, and a convention the data prefer becomes
   the base, whose first diagnosis replaces the own convention's (a convention is never asked for when the base's
   residual is noise: it could only feed a line of the report); when the base's residual is consistent with noise
   the step ends there (nothing is calibrated beside the base); else the model-form class (the base with a discrepancy,
   ``problem.calibrate_model_form()``, optional) is calibrated with the enriched classes (step 4) and the first
   diagnosis made again with it beside the base;
3. the candidates to enrich, by the problem's ``enrich`` (optional attribute, or `run_loop`'s argument):
   "named": the first candidate in ranked order that is named and has an enrichment (named candidates before it
   without an enrichment are listed as "named without enrichment"); "all" (default): that one, then, when the
   screening finds structure, every other candidate with an enrichment that the base model lacks, named or not, in
   ranked order (`rank.conclude` then decides by the evidence together with the signatures); then the problem's
   ``also_enrich(first)`` names, in their order, not chosen already;
4. each chosen candidate's enriched class is calibrated (``problem.calibrate(name)``), together with the model-form
   class: side by side where the problem can (``problem.calibrate_side_by_side``, optional: the classes do not
   depend on each other, and the candidates to enrich follow from the base's screening alone); under "all" a candidate
   beyond the first named one whose calibration the problem refuses (ValueError: no enrichment for this forward
   model) is listed in ``LoopResult.not_calibrated`` with the reason, and so is every enriched class whose
   calibration stopped (``SamplerError``: too many failed solves), which the verdict then cannot confirm;
5. when an enriched class was calibrated, the final diagnosis compares every class (`report.diagnose`: a candidate
   is confirmed by its ln B, the margin over the other enriched classes and its own residual pattern explained,
   under the loop's `records.DecisionRule`, `rank.conclude`); else the first is final.
6. stepwise discovery (a problem with ``adopt``): when an enrichment is confirmed, ``problem.adopt(class)`` makes
   that enriched class the base of the next step, and steps 2-5 run again on it: the remaining candidates are
   enriched on top of it (combined classes), beside a model-form class of the new base, and confirmed by the same
   rule, except that a candidate named by the evidence alone whose signature cannot show in the records (every
   primary item "not reported") does not confirm (``DecisionRule.signature_unseen_confirms`` off): on top of a
   confirmed effect a flexible class takes up what that class leaves. The discovery stops when a step confirms
   nothing, when the new base's screening finds no structure (step 2: nothing is calibrated), or after
   ``max_steps`` steps. Each later step is a `LoopResult` in
   ``LoopResult.steps`` (the first step is the result itself); ``LoopResult.chain`` lists the confirmed candidates.
   Two effects at once can hide each other: the leading candidate may pass every check but leave part of the
   located misfit, which belongs to the other effect, or, with a signature the records can show, pass every check
   but the lead over the model-form class, whose smooth discrepancy absorbs what the other effect leaves
   (`records.Conclusion.tentative`). Such a candidate is adopted tentatively (once in a chain): when the next step
   confirms a second effect on top of it, the combined class removes the misfit located on the tentative step's
   base (`rank.misfit_explained`, the rule's reduction), beats that step's model-form class by the rule's margin
   and the second effect's class alone (calibrated at that step) by the threshold, both are confirmed
   (``LoopResult.joint`` of that step); otherwise neither is, and the discovery stops. A tentative candidate below
   the model-form class must still beat the base by the threshold with trusted evidence.
The loop's settings (alpha, level, n_shifts and the rule) stay with its result (``LoopResult.settings``), so that
``files.write_input(..., **result.settings)`` records them for the re-diagnosis of the run directory (of each step).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Protocol

from ..tmcmc import SamplerError
from .rank import located_misfit, misfit_explained
from .records import DecisionRule, Diagnosis, ModelClass
from .report import diagnose
from .screening import relative_residuals
from .trust import highest_estimate

__all__ = ["LoopProblem", "LoopResult", "run_loop", "ENRICH", "MAX_STEPS", "MODEL_FORM"]

#: which candidates the loop enriches (module docstring, step 3)
ENRICH = ("all", "named")
#: the most steps of the stepwise discovery (module docstring, step 6): the catalog's clay effects are four
MAX_STEPS = 3
#: the request for the model-form class among the classes of one step (``LoopProblem.calibrate_side_by_side``)
MODEL_FORM = "model form"


class LoopProblem(Protocol):
    """What `run_loop` needs from a study.

    likelihood: an inference.Likelihood of the recorded curves (the screening reads its observations and near-zero
    floor); description: one line for the diagnosis report, read after the base class is calibrated.
    ``compare_conventions``, ``also_enrich``, ``calibrate_model_form``, ``calibrate_side_by_side``, ``adopt`` and
    ``enrich`` ("all" or "named", module docstring step 3) are optional.
    """

    likelihood: object
    description: str

    def candidates(self) -> list:
        """Candidate physics as plain data (``rank.rank_candidates``), judged against the base class."""

    def calibrate(self, candidate: str | None) -> ModelClass:
        """Calibrate the base class (candidate None) or the base class enriched with ``candidate``."""

    def covariates(self, base: ModelClass) -> dict:
        """Per-point covariates of the calibrated base class, in the form of ``screen``."""

    def compare_conventions(self, base: ModelClass) -> ModelClass | None:
        """Calibrate the base class in its other conventions (the same model written another way); return the
        record of the one the data prefer when it replaces ``base`` (the problem's likelihood, description and
        covariates then follow it), else None."""

    def calibrate_model_form(self) -> ModelClass:
        """Calibrate the base class with a model-form discrepancy (``inference.Discrepancy``): the physics-free
        alternative every enrichment must beat (`rank.conclude`)."""

    def calibrate_side_by_side(self, requests: list) -> list:
        """The classes ``requests`` of one step (:data:`MODEL_FORM`, or a candidate's name for its enriched class)
        as ``calibrate_model_form()`` and ``calibrate(name)`` give them, but side by side where the problem can
        (``inference.side_by_side``): [(ModelClass, None) or (None, the error)] in their order."""

    def also_enrich(self, first_diagnosis: Diagnosis) -> list:
        """Further candidates (names, in this order) to enrich after the best-ranked named one, from the first
        diagnosis."""

    def adopt(self, confirmed: ModelClass) -> ModelClass:
        """Make the confirmed enriched class the base of the next step (module docstring, step 6): later
        ``calibrate(name)`` enrich it, ``calibrate_model_form()`` adds the discrepancy to it, ``candidates()`` list
        its physics as in the base; returns it as the new base class's record."""


@dataclass
class LoopResult:
    """The records of one loop.

    first: the `records.Diagnosis` of the base class alone; final: that of every calibrated class (the first when no
    enriched class was calibrated); classes: [ModelClass], the base class first; covariates: the base class's;
    named: candidates named in the final diagnosis; named_without_enrichment: named candidates ranked above the chosen
    one that have no enrichment for this base class; not_calibrated: {candidate: reason} of the candidates chosen
    under enrich "all" whose enriched class the problem refused; timing: {screen_and_rank_s (the first diagnosis),
    diagnose_final_s (the second; 0 when none), calibration_s {class: s}, conventions_s (the other conventions of the
    base, when compared), loop_s} in seconds (the first step's
    loop_s: the whole loop's); settings: the diagnosis settings {alpha, level, n_shifts, rule} (the keywords of
    `files.write_input`); steps: the later steps of the stepwise discovery (module docstring, step 6), each a
    LoopResult; candidates: the candidates as the step's diagnosis read them (plain data); joint: for a step whose
    tentative candidate was adopted, {tentative, with (the next step's confirmed candidate or None), explained (the
    combined class removes this step's located misfit and beats its model-form class), alone (the tentative
    candidate's decision on its own), left (what the combined class leaves, in words)}, else None.
    """

    first: Diagnosis
    final: Diagnosis
    classes: list
    covariates: dict
    named: list
    named_without_enrichment: list
    timing: dict
    not_calibrated: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    steps: list = field(default_factory=list)
    candidates: list = field(default_factory=list)
    joint: dict | None = None

    @property
    def chain(self) -> list:
        """The candidates confirmed step by step (module docstring, step 6), in order: a tentative one when the
        next step's effect explained the rest with it; nothing from a tentative step on when it did not."""
        out = []
        for s in [self, *self.steps]:
            if s.joint is not None:
                if not s.joint["explained"]:
                    break
                out.append(s.joint["tentative"])
            elif s.final.omitted_physics != "none":
                out.append(s.final.omitted_physics)
        return out


def _chosen(first: Diagnosis, enrich: str) -> tuple:
    """(named candidates without an enrichment ranked above the first enrichable named one, the candidates to
    enrich in order, how many of them the "named" rule chose) from the first diagnosis (module docstring, step 3)."""
    skipped, chosen = [], []
    for cand in first.candidates:
        if not cand.named:
            continue
        if cand.enrichment is None:
            skipped.append(cand.name)
            continue
        chosen.append(cand.name)
        break
    n_named_rule = len(chosen)
    if enrich == "all" and first.verdict == "structured mismatch":
        chosen += [c.name for c in first.candidates if c.enrichment is not None and not c.in_base
                   and c.name not in chosen]
    return skipped, chosen, n_named_rule


def run_loop(problem: LoopProblem, alpha=0.05, level=0.95, rule=DecisionRule(), n_shifts=1000,
             enrich=None, max_steps=MAX_STEPS) -> LoopResult:
    """Calibrate, locate, explain, enrich, recalibrate, compare, and step on from a confirmed enrichment (module
    docstring); writes no files.

    alpha: family-wise false-alarm level of each screening; level: predictive band level; rule: the
    `records.DecisionRule` that confirms an enrichment (`rank.conclude`; calibrate its threshold on negative
    controls, `rank` module docstring); n_shifts: null draws of the attribution; enrich: "all" or "named"
    (default: the problem's ``enrich``, else "all"); max_steps: the most steps of the stepwise discovery (1: the
    single-step loop).
    """
    enrich = enrich or getattr(problem, "enrich", "all")
    if enrich not in ENRICH:
        raise ValueError(f"enrich = {enrich!r} must be one of {ENRICH}")
    t_loop = time.perf_counter()
    settings = {"alpha": alpha, "level": level, "rule": rule, "n_shifts": n_shifts}
    base = replace(problem.calibrate(None), role="base", candidate=None)
    result = _step(problem, base, settings, enrich, getattr(problem, "compare_conventions", None))
    adopt = getattr(problem, "adopt", None)
    last, tried_tentative = result, False
    later = {**settings, "rule": replace(rule, signature_unseen_confirms=False)}   # the rule of the later steps
    while adopt is not None and 1 + len(result.steps) < max_steps:
        name, tentative = last.final.omitted_physics, False
        if name == "none":
            if last.final.tentative is None or tried_tentative:
                break
            name, tentative, tried_tentative = last.final.tentative, True, True
        confirmed = next(c for c in last.classes if c.role == "enriched" and c.candidate == name)
        step = _step(problem, replace(adopt(confirmed), role="base", candidate=None), later, enrich)
        result.steps.append(step)
        if tentative:
            _joint(problem.likelihood, last, step, name, rule)
            if not last.joint["explained"]:
                break
        last = step
    result.timing["loop_s"] = time.perf_counter() - t_loop
    return result


def _joint(likelihood, step: LoopResult, after: LoopResult, tentative: str, rule: DecisionRule):
    """``step.joint``: whether the class the next step (``after``) confirmed on top of ``step``'s tentative candidate
    removes the misfit located on ``step``'s base (module docstring, step 6)."""
    second = after.final.omitted_physics
    alone = next((c.decision for c in step.final.candidates if c.name == tentative), "")
    if second == "none":
        step.joint = {"tentative": tentative, "with": None, "explained": False, "alone": alone,
                      "left": ["no second effect was confirmed on top of it"]}
        return
    combined = next(c for c in after.classes if c.role == "enriched" and c.candidate == second)
    base = step.classes[0]
    base_r = relative_residuals(likelihood, base.map_simulated)
    explained, left = misfit_explained(located_misfit(step.final.screens[base.name], base_r), base_r,
                                       relative_residuals(likelihood, combined.map_simulated), rule.misfit_reduction)
    # each effect pays its own way: the combined class beats the tentative step's model-form class by its margin
    # and the second effect's class alone (calibrated at the tentative step) by the threshold
    for role, candidate, need, what in (("model form", None, rule.model_form_lead, "model-form class"),
                                        ("enriched", second, float(rule.threshold), f"class of {second} alone")):
        other = next((c for c in step.classes if c.role == role and c.candidate == candidate), None)
        if other is None:
            continue
        lead = combined.log_evidence - highest_estimate(other, rule)
        if lead < need:
            explained = False
            left = [*left, f"the combined class {combined.name} is {lead:.2f} < {need:g} over the {what} at the "
                           f"tentative step ({other.name})"]
    step.joint = {"tentative": tentative, "with": second, "explained": explained, "alone": alone, "left": left}


def _calibrated(problem: LoopProblem, requests: list) -> list:
    """[(ModelClass, None) or (None, the error)] of the classes ``requests`` (:data:`MODEL_FORM` or a candidate's
    name), in their order: ``problem.calibrate_side_by_side(requests)`` where the problem has it, else one after the
    other here, a ValueError or SamplerError kept as the class's outcome (any other error stops the loop)."""
    side_by_side = getattr(problem, "calibrate_side_by_side", None)
    if side_by_side is not None:
        return side_by_side(requests)
    out = []
    for name in requests:
        try:
            out.append((problem.calibrate_model_form() if name == MODEL_FORM else problem.calibrate(name), None))
        except (ValueError, SamplerError) as err:
            out.append((None, err))
    return out


def _step(problem: LoopProblem, base: ModelClass, settings: dict, enrich: str, conventions=None) -> LoopResult:
    """One step of the loop from the calibrated ``base`` class (module docstring, steps 1-5); ``conventions``: the
    problem's ``compare_conventions`` (the first step only)."""
    t_step = time.perf_counter()
    candidates = problem.candidates()
    covariates = problem.covariates(base)
    classes = [base]
    t0 = time.perf_counter()
    first = diagnose(problem.likelihood, classes, covariates, candidates, problem.description, **settings)
    screen_s, conventions_s = time.perf_counter() - t0, {}
    if first.verdict == "structured mismatch" and conventions is not None:
        t0 = time.perf_counter()
        other = conventions(base)
        conventions_s = {"conventions_s": time.perf_counter() - t0}
        if other is None:  # the own convention stays: only the description (which the data prefer) changes
            first = replace(first, description=problem.description)
        else:  # the data prefer another convention: it is the base, screened afresh
            base = replace(other, role="base", candidate=None)
            candidates, covariates, classes = problem.candidates(), problem.covariates(base), [base]
            t0 = time.perf_counter()
            first = diagnose(problem.likelihood, classes, covariates, candidates, problem.description, **settings)
            screen_s += time.perf_counter() - t0
    if first.verdict != "structured mismatch":   # the residual is noise: no class is calibrated beside the base
        return LoopResult(first, first, classes, covariates, first.named, [], {
            "screen_and_rank_s": screen_s, "diagnose_final_s": 0.0, "calibration_s": {base.name: base.wall_s},
            **conventions_s, "loop_s": time.perf_counter() - t_step}, {}, settings, [], candidates)
    # the candidates to enrich follow from the base's screening alone (a model-form class names nothing), so the
    # model-form class and the enriched classes are calibrated together (side by side where the problem can)
    skipped, chosen, n_named_rule = _chosen(first, enrich)
    also = getattr(problem, "also_enrich", None)
    extra = [name for name in (also(first) if also else []) if name not in chosen]
    model_form = getattr(problem, "calibrate_model_form", None) is not None
    requests = ([MODEL_FORM] if model_form else []) + chosen + extra
    outcomes = _calibrated(problem, requests)
    if model_form:
        cls, err = outcomes.pop(0)
        if err is not None:
            raise err
        classes.append(replace(cls, role="model form", candidate=None))
        t0 = time.perf_counter()
        first = diagnose(problem.likelihood, classes, covariates, candidates, problem.description, **settings)
        screen_s += time.perf_counter() - t0
    refused = {}
    for k, (name, (cls, err)) in enumerate(zip(chosen + extra, outcomes)):
        if err is None:
            classes.append(replace(cls, role="enriched", candidate=name))
        elif isinstance(err, SamplerError):  # the enriched class's calibration stopped (e.g. too many failed solves)
            refused[name] = f"calibration stopped: {err}"
        elif isinstance(err, ValueError) and k >= n_named_rule and name not in extra:
            refused[name] = str(err)
        else:
            raise err
    final, final_s = first, 0.0
    if len(classes) > 1:
        t0 = time.perf_counter()
        final = diagnose(problem.likelihood, classes, covariates, candidates, problem.description, **settings)
        final_s = time.perf_counter() - t0
    timing = {"screen_and_rank_s": screen_s, "diagnose_final_s": final_s,
              "calibration_s": {c.name: c.wall_s for c in classes}, **conventions_s,
              "loop_s": time.perf_counter() - t_step}
    return LoopResult(first, final, classes, covariates, final.named, skipped, timing, refused, settings, [],
                      candidates)
