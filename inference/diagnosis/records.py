"""The records of a missing-physics diagnosis: the model classes it reads, the rule that confirms an enrichment, and
what it finds (mismatch regions, scored candidates, the conclusion), with the one serialisation of a diagnosis to
DIR/diagnosis.json (`Diagnosis.to_json`, `Diagnosis.from_json`).

Signs and units: a relative residual is r = U_obs/U_sim - 1 (dimensionless, Eq. (1) of docs/reference.md section 1);
a region's sign is "+" where the records lie above the simulation; log-evidences ln Z and log Bayes factors
ln B = ln Z_enriched - ln Z_base are natural logarithms; abscissae are in the recorded curve's x unit.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from .attribution import Attribution
from .screening import ScreenReport
from .structure import Region

__all__ = ["STRONG_LOG_BAYES", "PATTERN_REDUCTION", "MISFIT_REDUCTION", "DecisionRule", "ModelClass", "MismatchRegion",
           "SignatureItem", "CandidateScore", "CandidateDecision", "Conclusion", "DiagnosedCandidate", "ClassSummary",
           "NextTest", "Diagnosis"]

#: ln B at and above which the evidence for the enriched class is "strong" (B >= 20, Kass & Raftery 1995)
STRONG_LOG_BAYES = 3.0
#: an enriched class explains a primary item when its effect size falls to at most this fraction of the base's
PATTERN_REDUCTION = 0.5
#: an enriched class explains the misfit the screening located when it falls to at most this fraction of the base's
#: (median region). Set between the two groups of the independent generator's programmes: the hidden effects'
#: classes left 0.00-0.51 of it (ck0u destructuration 0.51, anisotropy 0.35-0.47); classes past the ln B threshold on
#: the controls left 0.79-0.89 (swelling +26.7 on ciu_D_s3; swelling and destructuration on the CIU control with 0.4 %
#: noise; notes/independent-diagnosis.md)
MISFIT_REDUCTION = 0.6
#: the roles of a model class: the base, a base enriched with a candidate physics, and the base with a model-form
#: discrepancy (``inference.Discrepancy``), the physics-free alternative every enrichment must beat
ROLES = ("base", "enriched", "model form")
#: an added parameter within this fraction of its prior range (in log for a log-uniform prior) of the end where its
#: physics vanishes sits at that end (`trust.confirmation_blocks`)
INERT_FRACTION = 0.02
#: an importance-sampling estimate of ln Z is trusted when its effective sample size is at least this fraction of
#: its draws (docs/reference.md section 9: below about 10 % not trusted)
ESS_FRACTION = 0.1
#: a posterior has collapsed when every free parameter's standard deviation is below this fraction of its prior range
COLLAPSE_FRACTION = 1e-6
#: the sampler has lost an added parameter's dimension when its posterior standard deviation is below this fraction of
#: its prior range (in log for a log-uniform prior); measured on 181 enriched classes of the independent programmes'
#: loops (seeds 1-3, the multi-effect set) and the measured A7: two below it, both swelling classes on CIU programmes
#: (a step-2 class whose tau_s stood at 5.3e5 s with a standard deviation of 73 s while its refined mode sat at 1.0e3 s:
#: 1.2e-5; a control's: 6.9e-12), every other at 5.3e-4 or more, the confirmed true effects at 3.5e-3 or more
#: (notes/precision.md)
LOST_DIMENSION_FRACTION = 1e-4
#: the forward model's discretisation error is comparable with the located misfit when it reaches this fraction of it
#: (median over the regions; `trust.numerics_comparable`)
NUMERICAL_FRACTION = 0.5
#: the ``evidence`` of a class whose ln Z was to be refined at its mode and could not be (``inference.mode_evidence``
#: returned None: no finite-difference stencil around a climb's end inside what the forward model solves): its ln Z
#: is the sampler's own, unchecked, and cannot confirm (`trust`, check 3)
NOT_REFINED = "not refined"


@dataclass(frozen=True)
class DecisionRule:
    """The settings that decide whether an enrichment is confirmed (`rank.conclude`).

    threshold: ln B (natural log, >= 0) the chosen enriched class must reach over the base class; margin: ln B by
    which it must lead the other enriched classes (None: the threshold); pattern_reduction: the fraction of the
    base's effect size to which each supporting primary item must fall on the enriched class; misfit_reduction: the
    fraction of the base's located misfit (median region of |mean r|) to which it must fall; inert_fraction,
    ess_fraction, collapse_fraction, lost_dimension_fraction: the checks of an enriched class's evidence and mode
    (`trust`);
    model_form_margin: ln B by which the chosen enrichment must beat the model-form class when there is one (None:
    the threshold); numerical_fraction: the base's discretisation error, as a fraction of the located misfit, at which
    the misfit counts as numerical (no enrichment is confirmed on it; `trust.numerics_comparable`); sampler_agrees:
    the sampler's own ln Z must not favour the base class (the refined estimates decide the size of ln B, not its
    sign alone); joint_below_model_form: a leader that passes every check but the lead over the model-form class
    (named by its signature, or by the evidence with a signature the records can show) is tentative
    (`rank.conclude`): two effects at once can leave a smooth discrepancy as good as either alone, and the stepwise
    loop confirms both only when their combined class beats the model-form class too (`loop`, step 6);
    signature_unseen_confirms: a candidate named by the evidence alone may confirm
    although every primary item of its signature is "not reported" (no record where its covariate is defined: the
    programme cannot show the effect's own signature); the stepwise loop sets it False from the second step on, where
    a flexible class takes up what the confirmed class leaves (`rank.conclude`). A study calibrates the threshold and
    margin on negative controls (`rank` module docstring) and passes its rule to the loop, which records it in
    DIR/diagnosis_input.json (`to_dict`, `from_dict`) for the re-diagnosis of the directory. With a model-form class
    among the classes, the chosen enrichment must beat it, too, by the threshold.
    """

    threshold: float = STRONG_LOG_BAYES
    margin: float | None = None
    pattern_reduction: float = PATTERN_REDUCTION
    misfit_reduction: float = MISFIT_REDUCTION
    model_form_margin: float | None = None
    inert_fraction: float = INERT_FRACTION
    ess_fraction: float = ESS_FRACTION
    collapse_fraction: float = COLLAPSE_FRACTION
    lost_dimension_fraction: float = LOST_DIMENSION_FRACTION
    numerical_fraction: float = NUMERICAL_FRACTION
    sampler_agrees: bool = True
    joint_below_model_form: bool = True
    signature_unseen_confirms: bool = True

    def __post_init__(self):
        if not self.threshold >= 0 or any(m is not None and not m >= 0 for m in (self.margin, self.model_form_margin)):
            raise ValueError(f"decision rule: threshold {self.threshold} and margin {self.margin} must be >= 0")
        if not (0 < self.pattern_reduction <= 1 and 0 < self.misfit_reduction <= 1):
            raise ValueError(f"decision rule: reductions {self.pattern_reduction}, {self.misfit_reduction} must be in "
                             "(0, 1]")
        for name in ("inert_fraction", "ess_fraction", "collapse_fraction", "lost_dimension_fraction"):
            if not 0 <= getattr(self, name) < 1:
                raise ValueError(f"decision rule: {name} = {getattr(self, name)} must be in [0, 1)")

    @property
    def lead(self) -> float:
        """The margin in force (ln B): the margin, or the threshold when none is set."""
        return float(self.threshold if self.margin is None else self.margin)

    @property
    def model_form_lead(self) -> float:
        """The ln B an enrichment needs over the model-form class: ``model_form_margin``, or the threshold."""
        return float(self.threshold if self.model_form_margin is None else self.model_form_margin)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "DecisionRule":
        return cls(**{f.name: d[f.name] for f in fields(cls) if f.name in d})


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
    calibration wall time (s); n_forward_solves: log-likelihood evaluations of the calibration (the sampler's and
    the refined evidence's, whose sets sharing their soil parameters share one solve); extra: the problem's own data
    (e.g. the MAP's raw curves for its covariates and figures), never read by the diagnosis; warnings: the
    calibration's own findings of a poor fit, in words (e.g. "sigma_eps at its prior's upper bound 0.3", "M on its
    prior's lower bound"), named in the diagnosis' verdict; sampler_log_evidence: the sampler's own ln Z when
    ``log_evidence`` is a refined estimate (``inference.mode_evidence``), whose record is ``evidence`` (the
    `EvidenceEstimate` as a dict); priors: {parameter: [lower, upper, kind]} of the class's free parameters (the
    mode's checks, `trust`); discrepancy: for a model-form class, where its discrepancy lies at its mode
    (``inference.discrepancy.where_it_lies``: [{test, curve, x_name, x_start, x_end, rms, max}], largest first);
    numerical_error: the forward model's discretisation error at the class's mode, [{test, curve, rms, max}] of the
    relative difference between the calibrated and a refined discretisation (the problem's, e.g. half the strain
    steps, twice the FE cells and increments), empty when not measured.
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
    sampler_log_evidence: float | None = None
    evidence: dict | None = None
    priors: dict = field(default_factory=dict)
    discrepancy: list = field(default_factory=list)
    numerical_error: list = field(default_factory=list)

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"model class {self.name!r}: role {self.role!r} must be one of {ROLES}")

    def to_dict(self) -> dict:
        """The class as plain data for `files.write_input` (``extra`` left out)."""
        return {"name": self.name, "role": self.role, "candidate": self.candidate,
                "log_evidence": self.log_evidence, "J_g": self.J_g, "parameters": self.parameters,
                "sigma_eps": self.sigma_eps, "wall_s": self.wall_s, "n_forward_solves": self.n_forward_solves,
                "map_simulated": self.map_simulated, "sample_simulated": self.sample_simulated,
                "sample_sigma": self.sample_sigma, "warnings": list(self.warnings),
                "sampler_log_evidence": self.sampler_log_evidence, "evidence": self.evidence,
                "priors": self.priors, "discrepancy": self.discrepancy,
                "numerical_error": self.numerical_error}

    @classmethod
    def of(cls, model_class) -> "ModelClass":
        """A ``ModelClass`` itself, or one from its dict (the fields of `to_dict`; others ignored; missing
        ``wall_s``, ``n_forward_solves`` and ``warnings`` take their defaults)."""
        if isinstance(model_class, cls):
            return model_class
        names = {f.name for f in fields(cls)} - {"extra"}
        return cls(**{k: v for k, v in model_class.items() if k in names})


@dataclass
class MismatchRegion(Region):
    """A mismatch region of the base class (`structure.Region`) with its abscissa unit.

    x_start, x_end: abscissa range in ``x_unit``; i_start, i_stop: point indices (stop exclusive); sign: "+" when the
    records lie above the simulation (r > 0); mean_relative: mean r over the region; n_points: its points;
    statistic, p_value: its scan statistic and p-value; p_adjusted: Bonferroni over the screening's family.
    """

    x_unit: str


@dataclass(frozen=True)
class SignatureItem:
    """One signature item of a candidate judged against a screening (`rank.rank_candidates`).

    covariate, role ("primary" | "supporting"), weight (> 0), direction (-1, 0, +1: the sign of the residual's trend
    with the covariate), meaning, curves (None: every curve): the catalog's item; r2, p_adjusted: the covariate's
    attribution (None when not reported); p_item: the item's own p (few-test contrast or the attribution's); effect:
    its effect size as a fraction of U_sim (|mean difference| of the contrast, else the rms residual the covariate
    explains); rank_correlation: Spearman rho between the covariate and r; status: "supports", "not reported", "not
    significant", "opposite direction" or "direction not measurable"; evidence: R^2 when it supports, else 0.
    """

    covariate: str
    role: str
    weight: float
    direction: int
    meaning: str | None
    curves: list | None
    r2: float | None
    p_adjusted: float | None
    p_item: float | None
    effect: float | None
    rank_correlation: float | None
    status: str
    evidence: float


@dataclass(frozen=True)
class CandidateScore:
    """A candidate physics scored on one class's screening (`rank.rank_candidates`).

    name, physics: the catalog's; score: sum of weight x evidence over the items / sum of the weights (0 to 1);
    named: the screening is structured, the base lacks the physics and a primary item supports it; plausible: named,
    or structured, not in the base, score > 0 and no primary item the other way; in_base: the base model has it;
    enrichment: the catalog's enrichment (None: none implemented); unavailable: why not, in words; items: the
    signature items judged.
    """

    name: str
    physics: str
    score: float
    named: bool
    plausible: bool
    in_base: bool
    enrichment: dict | None
    unavailable: str
    items: tuple = ()


@dataclass(frozen=True)
class CandidateDecision:
    """The conclusion on one candidate (`rank.conclude`): its decision in words, whether it is the confirmed one, and
    whether the evidence names it (a contender with ln B >= the threshold that its signature did not name)."""

    name: str
    decision: str
    confirmed: bool
    named_by_evidence: bool


@dataclass(frozen=True)
class Conclusion:
    """The result of `rank.conclude`: the omitted physics ("none" when nothing is confirmed), ln B of every
    enriched class over the base {class: ln Z - ln Z_base}, the decisions in ranked order and the rule applied;
    model_form: None without a model-form class, else {class, log_bayes (over the base), log_bayes_enriched
    {enriched class: ln Z - ln Z_model_form}, prevails (no enrichment is confirmed and the model-form class beats the
    base by the threshold: a misfit of model form)}; tentative: when nothing is confirmed, the candidate that passes
    every check but leaves part of the located misfit or of its own pattern, or (under
    ``rule.joint_below_model_form``, with a signature the records can show) every check but the lead over the
    model-form class (a second effect may hold the rest: the stepwise loop tries it as the next step's base), else
    None."""

    omitted_physics: str
    log_bayes: dict
    candidates: tuple
    rule: DecisionRule
    model_form: dict | None = None
    tentative: str | None = None


@dataclass(frozen=True)
class DiagnosedCandidate(CandidateScore):
    """A candidate as the diagnosis reports it: its score on the base class, named (by the signature or the evidence),
    named_by ("signature", "evidence" or None), the decision and confirmation of `rank.conclude`, and whether its
    enriched class explains its own pattern (pattern_explained None when not calibrated; pattern_left: what is
    left, in words)."""

    named_by: str | None = None
    decision: str = ""
    confirmed: bool = False
    pattern_explained: bool | None = None
    pattern_left: tuple = ()


@dataclass(frozen=True)
class ClassSummary:
    """A model class as the diagnosis reports it: name, role, candidate, log_evidence (ln Z), J_g per test,
    parameters, sigma_eps, wall_s (s), warnings (from `ModelClass`), log_bayes_vs_base (ln B; 0 for the base, None
    for an enriched class not compared), structure (`report` residual-structure statistics of its screening) and
    evidence_method (how its refined ln Z was estimated, ``inference.mode_evidence``'s method; None without one)."""

    name: str
    role: str
    candidate: str | None
    log_evidence: float
    J_g: dict | None
    parameters: dict | None
    sigma_eps: float | list
    wall_s: float | None
    warnings: list | None
    log_bayes_vs_base: float | None
    structure: dict
    evidence_method: str | None = None


@dataclass(frozen=True)
class NextTest:
    """What the records lack to test one candidate: the tests or curves it needs, in words."""

    candidate: str
    needs: tuple


@dataclass(frozen=True)
class Diagnosis:
    """The diagnosis of a calibrate -> diagnose loop (`report.diagnose`).

    description: one line; alpha: family-wise false-alarm level of each screening; verdict: the base class's
    screening verdict ("structured mismatch" | "consistent with noise"); omitted_physics: the confirmed candidate or
    "none"; recommendation: in one line; mismatch_regions, attribution: the base class's; candidates: ranked on the
    base class, with their decisions; classes: every class; log_bayes: {enriched class: ln B}; rule: the decision
    rule applied; warnings: {class: poor-fit warnings}; next_tests: per candidate not named, what the records lack;
    screens: {class: ScreenReport}; wall_s: the diagnosis' wall time (s); model_form: the model-form verdict of
    `Conclusion` with, when it prevails, where the discrepancy lies ({test, curve, x range, size}, largest first);
    tentative: `Conclusion.tentative`.
    """

    description: str
    alpha: float
    verdict: str
    omitted_physics: str
    recommendation: str
    mismatch_regions: tuple
    attribution: tuple
    candidates: tuple
    classes: tuple
    log_bayes: dict
    rule: DecisionRule
    warnings: dict
    next_tests: tuple
    screens: dict
    wall_s: float = 0.0
    model_form: dict | None = None
    tentative: str | None = None

    @property
    def named(self) -> list:
        """The names of the candidates named (by their signature or by the evidence), in ranked order."""
        return [c.name for c in self.candidates if c.named]

    def to_dict(self) -> dict:
        """The diagnosis as plain data, the keys of DIR/diagnosis.json (the rule as threshold_log_bayes and
        margin_log_bayes)."""
        return {"description": self.description, "alpha": self.alpha, "verdict": self.verdict,
                "omitted_physics": self.omitted_physics, "recommendation": self.recommendation,
                "mismatch_regions": [asdict(r) for r in self.mismatch_regions],
                "attribution": [a.to_dict() for a in self.attribution],
                "candidates": [_candidate_dict(c) for c in self.candidates],
                "classes": [asdict(c) for c in self.classes], "log_bayes": self.log_bayes,
                "threshold_log_bayes": float(self.rule.threshold), "margin_log_bayes": self.rule.lead,
                "warnings": self.warnings, "next_tests": [{"candidate": n.candidate, "needs": list(n.needs)}
                                                          for n in self.next_tests],
                "screens": {name: rep.to_dict() for name, rep in self.screens.items()}, "wall_s": self.wall_s,
                "model_form": self.model_form, "tentative": self.tentative}

    def to_json(self) -> str:
        """DIR/diagnosis.json's text (numpy scalars and arrays as plain numbers and lists)."""
        return json.dumps(self.to_dict(), indent=1, default=_json_default)

    @classmethod
    def from_json(cls, text: str) -> "Diagnosis":
        """A diagnosis back from DIR/diagnosis.json's text (the rule's reductions take their defaults: the run's
        diagnosis_input.json records the whole rule)."""
        d = json.loads(text)
        return cls(d["description"], d["alpha"], d["verdict"], d["omitted_physics"], d["recommendation"],
                   tuple(MismatchRegion(**r) for r in d["mismatch_regions"]),
                   tuple(Attribution(**a) for a in d["attribution"]),
                   tuple(_candidate(c) for c in d["candidates"]), tuple(ClassSummary(**c) for c in d["classes"]),
                   d["log_bayes"], DecisionRule(d["threshold_log_bayes"], d["margin_log_bayes"]), d["warnings"],
                   tuple(NextTest(n["candidate"], tuple(n["needs"])) for n in d["next_tests"]),
                   {name: ScreenReport.from_dict(rep) for name, rep in d["screens"].items()}, d["wall_s"],
                   d.get("model_form"), d.get("tentative"))


def _candidate_dict(c: DiagnosedCandidate) -> dict:
    d = asdict(c)
    d["pattern_left"] = list(c.pattern_left)
    return d


def _candidate(d: dict) -> DiagnosedCandidate:
    return DiagnosedCandidate(**{**d, "items": tuple(SignatureItem(**i) for i in d["items"]),
                                 "pattern_left": tuple(d["pattern_left"])})


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON-serializable: {type(obj).__name__}")
