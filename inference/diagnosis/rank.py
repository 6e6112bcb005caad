"""Explain a located mismatch with candidate physics, and conclude on the omitted physics by the Bayes factor.

Generic: candidate physics reach this module as plain data (dicts; for soils the cases' physics catalog writes them),
each with a residual signature: items {covariate, role, weight, direction, curves, meaning}.

Signature score of a candidate (`rank_candidates`). For each signature item i with weight w_i:
  evidence_i = R^2_i  when the covariate was reported, its attribution (`attribution.attribute`) is significant
                      (Holm-adjusted p <= alpha) and, when the item states a direction d_i = +-1, the Spearman rank
                      correlation rho_i between the covariate and the relative residual (pooled over the points of
                      the curves the item names) has the sign of d_i;
  evidence_i = 0      otherwise (status: "not reported", "not significant" or "opposite direction").
  score = sum_i w_i evidence_i / sum_i w_i (0 <= score <= 1; items whose covariate is not reported count as 0).
Items on a covariate tested by a few-test contrast (`attribution`, fewer than 5 tests) are judged on the contrasts
of the item's own curves instead: p = (Bonferroni over those curves of the one-sided p in the item's direction, or
two-sided for direction 0) x the covariate's Holm factor p_adjusted/p_value; "supports" when p <= alpha, "opposite
direction" when the two-sided p is <= alpha with the other sign. Each item also carries its effect size: the
|mean difference| of the contrast, else the root mean square of the residual the covariate explains.
A candidate is *named* when the screening verdict is "structured mismatch", the base model does not already have the
physics, and at least one of its primary items supports it; *plausible* when it is named, or the verdict is
structured, it is not in the base, its score is > 0 and no primary item is in the opposite direction. Candidates
are ranked named first, then by score.

Confirmation (`conclude`): by evidence together with the signature. When the screening finds structure, the loop
calibrates the enriched class of every candidate with an enrichment (`loop`), named or not, so the evidence itself
can point at physics whose signature the records test weakly (two or three tests). With ln B = ln Z_enriched -
ln Z_base (the classes' log-evidences; the soil studies' loop refines them at the posterior mode,
``inference.mode_evidence``):
1. the contenders are the enriched classes within ``margin`` of the best ln B; the chosen one is the only contender,
   or among several the best-ranked one named by its signature (none when no contender is named: the evidence does
   not separate them);
2. the chosen candidate is confirmed when its ln B >= ``threshold``, no primary item of its signature points the
   other way ("opposite direction" on the base class), and its enriched class explains its own predicted pattern:
   every primary item that supports it on the base class no longer supports it on the enriched class's screening,
   or its effect size fell to at most ``pattern_reduction`` (default PATTERN_REDUCTION = 0.5) of the base's
   (`pattern_explained`), and the misfit the base's screening located (its mismatch regions) falls to at most
   ``misfit_reduction`` (default MISFIT_REDUCTION = 0.6) of the base's in the median region (`misfit_explained`).
The threshold, margin and the two reductions are the fields of one `records.DecisionRule`.
A candidate is *named by its signature* (`rank_candidates`) or *named by the evidence*: a contender with ln B >=
``threshold`` whose signature does not point the other way. The omitted physics is the confirmed candidate, or
"none"; every other candidate's decision gives the reason (below the threshold, its signature contradicted, beaten
by the leader by the margin, its pattern left, not separated from another). A named candidate without an
implemented enrichment is "candidate named, enrichment not available".

Threshold and margin. Default 3 for both (``DecisionRule()``, STRONG_LOG_BAYES: 2 ln B > 6, "strong" on the Kass &
Raftery 1995 scale). Under a misspecified error model (independent errors where the residuals are autocorrelated, one
sigma for curves of different scatter) Bayes factors are over-confident (Brynjarsdottir & O'Hagan 2014;
docs/reference.md section 9), so the threshold must be calibrated on negative controls: run the loop on control
programmes of each kind (the same tests, logging and noise, no hidden effect, >= 3 noise seeds each), record the largest
ln B of any enriched class over the base on each control, and set ``threshold`` (and ``margin``) above the largest
control value with room for the seed-to-seed scatter (e.g. max + 2 standard deviations, never below 3); state the
controls and the value used in the study's notes.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import stats

from . import contrast
from .attribution import per_curve
from .records import (
    MISFIT_REDUCTION,
    PATTERN_REDUCTION,
    STRONG_LOG_BAYES,
    CandidateDecision,
    CandidateScore,
    Conclusion,
    DecisionRule,
    SignatureItem,
)
from .screening import ScreenReport
from .trust import confirmation_blocks, highest_estimate, importance_checked, out_of_reach, sampler_disagrees

__all__ = ["STRONG_LOG_BAYES", "PATTERN_REDUCTION", "MISFIT_REDUCTION", "rank_candidates", "pattern_explained",
           "misfit_explained", "conclude", "unseen"]

ROLES = ("primary", "supporting")


def _check_candidate(c):
    for key in ("name", "signature"):
        if key not in c:
            raise ValueError(f"candidate {c.get('name', '?')!r}: missing field {key!r}")
    for item in c["signature"]:
        missing = {"covariate", "role", "weight", "direction"} - set(item)
        if missing:
            raise ValueError(f"candidate {c['name']!r}: signature item {item} lacks {sorted(missing)}")
        if item["role"] not in ROLES:
            raise ValueError(f"candidate {c['name']!r}: role {item['role']!r} must be one of {ROLES}")
        if item["direction"] not in (-1, 0, 1):
            raise ValueError(f"candidate {c['name']!r}: direction {item['direction']!r} must be -1, 0 or +1")
        if not item["weight"] > 0:
            raise ValueError(f"candidate {c['name']!r}: weight {item['weight']!r} must be > 0")


def names_curve(curves, curve) -> bool:
    """Whether a signature item's ``curves`` (None: every curve) name ``curve``. A curve named "quantity@part" (one
    part of a recorded quantity, e.g. one stage of a staged test) is named by its quantity."""
    return curves is None or curve in curves or curve.partition("@")[0] in curves


def _rank_correlation(residuals, covariate, curves):
    """Spearman rho between a numeric covariate and the residual, pooled over the points of ``curves`` (None: all);
    None when not computable (categorical, no points, constant)."""
    xs, rs = [], []
    for (t, c), r in residuals.items():
        if not names_curve(curves, c) or (t, c) not in covariate:
            continue
        v = np.asarray(covariate[t, c])
        if v.dtype.kind not in "biuf":
            return None
        ok = np.isfinite(r) & np.isfinite(v)
        xs.append(v[ok])
        rs.append(r[ok])
    if not xs:
        return None
    x, r = np.concatenate(xs), np.concatenate(rs)
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(r) == 0:
        return None
    return float(stats.spearmanr(x, r)[0])


def _contrast_p(a, item, want):
    """(one-sided or two-sided p of the item on its curves' few-test contrasts, two-sided p, sign of the strongest
    z, effect |mean b|), or None when the covariate has no contrast on the item's curves. Bonferroni over those
    curves, then the covariate's Holm factor p_adjusted / p_value."""
    details = {c: d for c, d in (a.contrast or {}).items() if names_curve(item.get("curves"), c)}
    if not details:
        return None
    m = len(details)
    holm_factor = a.p_adjusted / a.p_value if a.p_value > 0 else 1.0
    two = min(1.0, m * min(d["p"] for d in details.values()) * holm_factor)
    strongest = min(details.values(), key=lambda d: d["p"])
    if want == 0:
        one = two
    else:
        one = min(1.0, m * min(contrast.one_sided(d, want) for d in details.values()) * holm_factor)
    return one, two, int(np.sign(strongest["z"])), max(abs(d["mean"]) for d in details.values())


def _item(item, a, rho, alpha):
    """(status, item p, effect size) of one signature item against one covariate attribution ``a`` (Attribution or
    None): the module docstring's rules."""
    want = int(item["direction"])
    if a is None:
        return "not reported", None, None
    effect = a.explained_rms
    few = _contrast_p(a, item, want)
    if few is not None:
        one, two, sign, effect = few
        if one <= alpha:
            return "supports", one, effect
        return ("opposite direction" if two <= alpha and want != 0 and sign != want else "not significant"), one, \
            effect
    if a.p_adjusted > alpha:
        return "not significant", a.p_adjusted, effect
    if want != 0 and (rho is None or np.sign(rho) != want):
        return ("opposite direction" if rho is not None else "direction not measurable"), a.p_adjusted, effect
    return "supports", a.p_adjusted, effect


def rank_candidates(report, residuals: dict, covariates: dict, candidates: list, alpha=None) -> list:
    """Score and rank candidate physics against a screening (module docstring: the score, when a candidate is named
    and when it is plausible). report: ScreenReport or its dict; residuals: {(test, curve): r} of the screened class;
    covariates: the per-point covariates given to ``screen``; candidates: plain-data catalog entries (each with
    ``signature``, optional ``in_base``, ``enrichment``, ``unavailable``). Returns [CandidateScore] by decreasing
    score, named first."""
    rep = ScreenReport.from_dict(report) if isinstance(report, dict) else report
    alpha = rep.alpha if alpha is None else float(alpha)
    structured = rep.verdict == "structured mismatch"
    attribution = {a.name: a for a in rep.attribution}
    expanded = {name: per_curve(name, spec, residuals) for name, spec in covariates.items()}
    ranked = []
    for c in candidates:
        _check_candidate(c)
        items, num, den, primary, against = [], 0.0, 0.0, False, False
        for item in c["signature"]:
            name = item["covariate"]
            a = attribution.get(name)
            rho = _rank_correlation(residuals, expanded[name], item.get("curves")) if name in expanded else None
            status, p_item, effect = _item(item, a, rho, alpha)
            evidence = a.r2 if status == "supports" else 0.0
            num += item["weight"] * evidence
            den += item["weight"]
            primary |= status == "supports" and item["role"] == "primary"
            against |= status == "opposite direction" and item["role"] == "primary"
            items.append(SignatureItem(item["covariate"], item["role"], item["weight"], item["direction"],
                                       item.get("meaning"), item.get("curves"), None if a is None else a.r2,
                                       None if a is None else a.p_adjusted, p_item, effect, rho, status, evidence))
        in_base = bool(c.get("in_base", False))
        score = num / den if den else 0.0
        named = structured and primary and not in_base
        plausible = named or (structured and not in_base and score > 0 and not against)
        ranked.append(CandidateScore(c["name"], c.get("physics", ""), score, named, plausible, in_base,
                                     c.get("enrichment"), c.get("unavailable", ""), tuple(items)))
    return sorted(ranked, key=lambda d: (-d.named, -d.score))


def pattern_explained(base_entry: CandidateScore, enriched_entry: CandidateScore | None,
                      reduction=PATTERN_REDUCTION) -> tuple:
    """(explained, reasons): does the enriched class explain the candidate's own residual pattern?

    base_entry: the candidate ranked on the base class's screening; enriched_entry: the same candidate ranked on the
    enriched class's screening (None: not screened, counted as explained). Explained when every primary item that
    supports the candidate on the base class either no longer supports it on the enriched class or its effect size
    (few-test contrast: |mean difference|; else the root mean square of the residual the covariate explains) fell
    to at most ``reduction`` times the base's. reasons: the items left, in words."""
    if enriched_entry is None:
        return True, []
    after = {(i.covariate, tuple(i.curves or ()), i.direction): i for i in enriched_entry.items}
    left = []
    for i in base_entry.items:
        if i.role != "primary" or i.status != "supports":
            continue
        j = after.get((i.covariate, tuple(i.curves or ()), i.direction))
        if j is None or j.status != "supports":
            continue
        if i.effect is not None and j.effect is not None and j.effect <= reduction * i.effect:
            continue
        size = "" if i.effect is None or j.effect is None else \
            f" (size {100 * i.effect:.2g} % -> {100 * j.effect:.2g} %)"
        left.append(f"{i.covariate}: {i.meaning}{size}")
    return not left, left


class CurveSpan(NamedTuple):
    """A whole structured curve standing for a mismatch region where the screening located none: points
    ``i_start:i_stop`` of curve ``curve`` of test ``test``."""

    test: str
    curve: str
    i_start: int
    i_stop: int


def located_misfit(report: ScreenReport, residuals: dict) -> list:
    """What the misfit check compares: the screening's mismatch regions, or, where it located none but found
    structured curves, each structured curve whole (`CurveSpan`); ``residuals``: {(test, curve): r} of the class
    screened."""
    if report.regions:
        return list(report.regions)
    return [CurveSpan(c.test, c.curve, 0, len(residuals[c.test, c.curve])) for c in report.curves if c.structured]


def _abs_mean(r) -> float:
    return abs(float(np.nanmean(r)))


def _rms(r) -> float:
    return float(np.sqrt(np.nanmean(np.square(r))))


def misfit_explained(regions, base_residuals: dict, enriched_residuals: dict, reduction=MISFIT_REDUCTION) -> tuple:
    """(explained, reasons): does an enriched class remove the misfit the base class's screening located?

    regions: the base class's mismatch regions (``structure.Region``: test, curve, i_start, i_stop);
    base_residuals, enriched_residuals: {(test, curve): r} relative residuals of the two classes at the records.
    For each region the ratio |mean r_enriched| / |mean r_base| over its points; explained when the median ratio over
    the regions is at most ``reduction`` (no region: not explained, a check with nothing to check; `located_misfit`
    gives the structured curves whole when the screening located no region, and for them the ratio is of the RMS
    residual: a misfit of shape, as a relaxation curve's early and late errors of opposite sign, has a mean near zero).
    The median, not a
    weighted mean: a region where the simulated value passes near zero (a deviator stress turning from compression to
    extension) has relative residuals of any size and must not decide alone. reasons: the regions left, in words."""
    if not regions:
        return False, ["the base's screening located no misfit, so none can be shown to be explained"]
    ratios = []
    for g in regions:
        key, sl = (g.test, g.curve), slice(g.i_start, g.i_stop)
        size = _rms if isinstance(g, CurveSpan) else _abs_mean
        before, after = size(base_residuals[key][sl]), size(enriched_residuals[key][sl])
        ratios.append(after / before if before > 0 else 1.0)
    median = float(np.median(ratios))
    if median <= reduction:
        return True, []
    return False, [f"the located misfit ({len(regions)} region(s)) falls only to {100 * median:.0f} % of the "
                   f"base's (median over the regions; needs <= {100 * reduction:.0f} %)"]


def conclude(ranked: list, classes: list, rule=DecisionRule(), explained=None, numerics="") -> Conclusion:
    """The omitted physics from ranked candidates [CandidateScore] and model classes [ModelClass] (module docstring:
    confirmation) under ``rule`` (its threshold and margin; the reductions are applied by `pattern_explained` and
    `misfit_explained`, whose verdicts come in ``explained``: {candidate: (explained, reasons)}, missing: explained; the
    checks of `trust` block a class that cannot confirm). With a class of role "model form" (the base with a model-form
    discrepancy), the chosen enrichment must also beat it by ``rule.model_form_lead``; when nothing is confirmed and it
    beats the base by the threshold, the misfit is of model form (``Conclusion.model_form["prevails"]``). ``numerics``:
    why the located misfit may be the forward model's own discretisation error (`trust`), which then blocks every
    candidate.
    """
    threshold, margin, form_lead = float(rule.threshold), rule.lead, rule.model_form_lead
    explained = explained or {}
    base = [c for c in classes if c.role == "base"]
    if len(base) != 1:
        raise ValueError(f"classes need exactly one with role 'base', got {[c.name for c in base]}")
    base = base[0]
    model_form = next((c for c in classes if c.role == "model form"), None)
    lnz0 = base.log_evidence
    enriched = {c.candidate: c for c in classes if c.role == "enriched"}
    log_bayes = {c.name: c.log_evidence - lnz0 for c in classes if c.role == "enriched"}
    by_candidate = {cand: log_bayes[c.name] for cand, c in enriched.items()}
    over_form = ({} if model_form is None else
                 {cand: c.log_evidence - model_form.log_evidence for cand, c in enriched.items()})
    entry = {r.name: r for r in ranked}
    order = sorted(by_candidate, key=lambda k: -by_candidate[k])
    leader = order[0] if order else None
    against = {name: _against(entry.get(name)) for name in by_candidate}
    # the ln Z an enriched class must reach to confirm: the base's plus the threshold, the model-form class's plus
    # its margin (`trust`: a lower bound of the class's ln Z that clears it is a check of its evidence)
    over_base = highest_estimate(base, rule) + threshold
    floor = max(over_base, -np.inf if model_form is None else highest_estimate(model_form, rule) + form_lead)

    def blocking(name, cl, must_reach):
        """Why the class ``cl`` of candidate ``name`` cannot confirm, its evidence checked against ``must_reach``."""
        reasons = confirmation_blocks(cl, getattr(entry.get(name), "enrichment", None), rule, must_reach)
        if numerics:
            reasons.append(numerics)
        if not rule.signature_unseen_confirms and unseen(entry.get(name)):
            reasons.append("its signature cannot show in these records (no record reports "
                           f"{' or '.join(sorted({i.covariate for i in entry[name].items if i.role == 'primary'}))}),"
                           " and on top of a confirmed effect the evidence alone does not name it")
        # against the base only, and not when the class's refined estimate passed an importance check and the
        # base's did too or cannot reach it: a sampler's estimate with few particles lags the more the more
        # parameters a class has (`trust`, check 4)
        if rule.sampler_agrees and not (importance_checked(cl, rule, must_reach) and (
                importance_checked(base, rule) or out_of_reach(cl, base, threshold))):
            disagree = sampler_disagrees(cl, base)
            if disagree:
                reasons.append(disagree)
        return reasons

    blocks = {name: blocking(name, cl, floor) for name, cl in enriched.items()}
    # the candidates within the margin of the best ln B; among several, the best-ranked one named by its signature
    contenders = [k for k in order if by_candidate[k] >= by_candidate[leader] - margin] if order else []
    chosen = contenders[0] if len(contenders) == 1 else next(
        (r.name for r in ranked if r.named and r.name in contenders), None)
    omitted, tentative = "none", None
    if chosen is not None and by_candidate[chosen] >= threshold and not against[chosen]:
        beats_form = over_form.get(chosen, form_lead) >= form_lead
        if beats_form and not blocks[chosen]:
            if explained.get(chosen, (True, []))[0]:
                omitted = chosen
            else:   # all but its pattern or misfit explained: a second effect may hold the rest (`loop`, step 6)
                tentative = chosen
        elif not beats_form and rule.joint_below_model_form and not unseen(entry.get(chosen)) \
                and not blocking(chosen, enriched[chosen], over_base):
            # beyond the base by trusted evidence, below the model-form class, named by its signature or by the
            # evidence with a signature the records can show: a second effect may hold what the discrepancy takes
            # up (`loop`, step 6)
            tentative = chosen
    decisions = []
    for r in ranked:
        name, lnb = r.name, by_candidate.get(r.name)
        named = bool(r.named)
        by_evidence = lnb is not None and lnb >= threshold and not against[name] and name in contenders
        confirmed = name == omitted
        ok, left = explained.get(name, (True, []))
        prefix = "named, not confirmed" if named else "not confirmed"
        if r.in_base:
            decision = "already in the base model"
        elif r.enrichment is None:
            decision = (f"candidate named, enrichment not available ({r.unavailable})" if named else "not named")
        elif lnb is None:
            decision = "candidate named, enriched class not calibrated" if named else "not named"
        elif confirmed:
            decision = f"confirmed: ln B = {lnb:.2f} >= {threshold:g}" + (
                "" if model_form is None else f", {over_form[name]:.2f} over the model-form class") + (
                "" if named else " (named by the evidence; its signature is not contradicted)")
        elif lnb < threshold:
            decision = f"{prefix}: ln B = {lnb:.2f} < {threshold:g}"
        elif against[name]:
            decision = f"{prefix}: ln B = {lnb:.2f} but its signature points the other way: {against[name]}"
        elif blocks[name]:
            decision = f"{prefix}: ln B = {lnb:.2f} but {'; '.join(blocks[name])}"
        elif over_form.get(name, form_lead) < form_lead:
            decision = (f"{prefix}: ln B = {lnb:.2f} over the base but {over_form[name]:.2f} < {form_lead:g} over the "
                        "model-form class (a smooth discrepancy without physics explains the misfit as well)")
        elif omitted != "none":
            decision = f"also raises the evidence: ln B = {lnb:.2f} (the omitted physics is {omitted})"
        elif name not in contenders:
            decision = (f"{prefix}: ln B = {lnb:.2f}, beaten by the enriched class of {leader} "
                        f"(ln B = {by_candidate[leader]:.2f}, margin {margin:g})")
        elif not ok:
            decision = (f"{prefix}: ln B = {lnb:.2f} but its enriched class leaves its own residual pattern: "
                        f"{'; '.join(left)}")
        else:  # a contender that is not the chosen one
            others = ", ".join(f"{k} (ln B = {by_candidate[k]:.2f})" for k in contenders if k != name)
            decision = (f"{prefix}: ln B = {lnb:.2f} is not separated by the margin {margin:g} from the enriched "
                        f"class of {others}" + ("" if chosen is None else f", and {chosen} ranks above it"))
        decisions.append(CandidateDecision(name, decision, confirmed, by_evidence and not named))
    form = None
    if model_form is not None:
        lnb_form = model_form.log_evidence - lnz0
        form = {"class": model_form.name, "log_bayes": lnb_form,
                "log_bayes_enriched": {enriched[k].name: v for k, v in over_form.items()},
                "prevails": omitted == "none" and lnb_form >= threshold}
    return Conclusion(omitted, log_bayes, tuple(decisions), rule, form, tentative)


def unseen(entry) -> bool:
    """The candidate (a `records.CandidateScore`) is named by the evidence alone and every primary item of its
    signature is "not reported": no record defines its covariate, so the programme cannot show the effect's own
    signature (`records.DecisionRule.signature_unseen_confirms`)."""
    primary = [i for i in getattr(entry, "items", ()) if i.role == "primary"]
    return bool(primary) and not entry.named and all(i.status == "not reported" for i in primary)


def _against(entry) -> str:
    """The meanings of the candidate's primary signature items that point the other way ("" when none)."""
    if not entry:
        return ""
    return "; ".join(f"{i.covariate}: {i.meaning}" for i in entry.items
                     if i.role == "primary" and i.status == "opposite direction")
