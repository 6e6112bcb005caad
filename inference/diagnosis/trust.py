"""Whether a calibrated enriched class may confirm its candidate at all: checks of its posterior, its mode and its
evidence that come before any Bayes factor (docs/reference.md section 9, "trusted evidence").

A class cannot confirm when
1. its posterior collapsed: every free parameter's posterior standard deviation is below ``collapse_fraction`` of
   its prior range (the sampler lost its population; its ln Z and mode say nothing of the evidence), or one of its
   candidate's added parameters did, below ``lost_dimension_fraction`` of its prior range (in log for a log-uniform
   prior): the sampler lost that dimension, its population stuck at one value of it, and neither its estimate nor
   a refined one climbed from it can be checked against the other (measured: a swelling class's tau_s at 5.3e5 s,
   standard deviation 73 s, refined mode 1.0e3 s, importance ESS 2 of 1024);
2. an added parameter of its candidate sits at the end of its prior where the physics vanishes (the catalog's
   ``inert_at``: within ``inert_fraction`` of the prior range from that end, measured in log for a log-uniform
   prior): the enrichment then fits as the base class does, or as something other than the named physics (a
   swelling time constant at its floor is an instantaneous compliance, not a time effect);
3. its refined evidence is not checked (`evidence_check`): it is checked when its importance-sampling estimate has
   an effective sample size of at least ``ess_fraction`` of its draws, or when the Laplace and importance-sampling
   estimates, made independently (one from the curvature at the mode, one from draws), agree within three standard
   errors of the latter and 1 nat, or when its lower bound (``inference.mode_evidence``'s ``log_lower``: ln Z is
   above it with probability 0.95 whatever the importance proposal's fit, by Markov's inequality) already clears
   what the class must reach to confirm (the base's ln Z plus the threshold, the model-form class's plus its
   margin; for a class whose own estimate had no importance check, the highest of its estimates:
   `highest_estimate`), or when it agrees within three standard errors and 1 nat with the sampler's own ln Z; a
   class whose ln Z was to be refined and could not be (``records.NOT_REFINED``: no stencil around its mode inside
   what the forward model solves) has only the sampler's estimate, which nothing checks: it cannot confirm, nor be
   a tentative leader;
4. the sampler's own ln Z favours the base class, while the refined estimates favour the enriched one: two
   estimates that disagree in sign are a warning, not a licence to take the larger one (`sampler_disagrees`). It
   does not apply when both refined estimates passed an importance check (the first three ways of check 3): the
   sampler's estimate is then the unchecked one, and it lags the further behind the more parameters and tempering
   stages a class has (a destructuration class of a CRS programme: sampler 174.3 against 270.1 by importance
   sampling and 270.4 by Laplace). Nor does it apply when the class's refined estimate passed an importance check
   and lies the threshold above the base's log-likelihood at the base's refined mode (`out_of_reach`): Z = int L pi
   <= max L, so no estimate of the base, checked or not, could reach it unless the base fits far better somewhere
   its sampler and its climb never went (a swelling class on a viscous base: importance sampling 302.4, ESS 140 of
   512, its sampler stuck at 159.6 in a poorer mode; the base's ln L at its mode 250.0). Nor is it applied against
   the model-form class, whose several extra parameters make the few-particle sampler's estimate lag further: on a
   CRS programme with hidden viscosity the sampler put the model-form class 9.1 above the viscous one, the refined
   estimates 14.8 below.
And no class confirms anything when the base's misfit is of the size of its forward model's own discretisation
error (`numerics_comparable`: the refined-minus-calibrated difference at the base's mode reaches
``numerical_fraction`` of the located misfit): the misfit is then not shown to be physics at all.
Each check gives its reason in words; a check with nothing to check (no refinement asked for, no added parameter with
an inert end) passes.
"""
from __future__ import annotations

import math

import numpy as np

from .records import NOT_REFINED, DecisionRule, ModelClass

__all__ = [
    "IMPORTANCE_CHECKS", "confirmation_blocks", "evidence_check", "evidence_trusted", "highest_estimate",
    "importance_checked", "out_of_reach", "sampler_disagrees", "numerics_comparable",
]


def _position(value: float, lower: float, upper: float, kind: str) -> float:
    """Where ``value`` lies in its prior range, 0 at the lower end and 1 at the upper (log scale when log-uniform)."""
    if kind == "log-uniform" and lower > 0 and value > 0:
        return (math.log(value) - math.log(lower)) / (math.log(upper) - math.log(lower))
    return (value - lower) / (upper - lower)


def _spread(parameter: dict, lower: float, upper: float, kind: str) -> float:
    """A parameter's posterior standard deviation as a fraction of its prior range: of ln theta (std/mean, to first
    order) over ln(upper/lower) for a log-uniform prior, of theta over upper - lower otherwise."""
    if kind == "log-uniform" and lower > 0 and parameter["mean"] > 0:
        return parameter["std"] / parameter["mean"] / math.log(upper / lower)
    return parameter["std"] / (upper - lower)


def _agree(value: float, other, std_error) -> bool:
    """Two estimates of ln Z agree: within three standard errors and 1 nat."""
    return other is not None and abs(value - other) <= max(3.0 * float(std_error or 0.0), 1.0)


#: the checks of a refined ln Z that rest on importance sampling (check 3 of the module docstring)
IMPORTANCE_CHECKS = ("importance sampling", "Laplace and importance sampling agree",
                     "its 95 % lower bound clears what it must reach")


def evidence_check(cls: ModelClass, rule: DecisionRule, floor: float | None = None) -> str:
    """Which check of the class's refined ln Z passed (check 3 of the module docstring): one of
    IMPORTANCE_CHECKS, "the sampler agrees", or "" when none did (or there is no refined estimate: "no refined
    estimate"). ``floor``: the ln Z the class must reach to confirm (None: the lower bound is not asked)."""
    ev = cls.evidence
    if not ev:
        return "no refined estimate"
    if ev.get("method") == NOT_REFINED:
        return ""
    if ev.get("method") == "importance sampling" and ev.get("n_draws") and \
            ev.get("ess", 0.0) >= rule.ess_fraction * ev["n_draws"]:
        return IMPORTANCE_CHECKS[0]
    if ev.get("method") == "Laplace" and _agree(ev["log_evidence"], ev.get("log_is"), ev.get("std_error")):
        return IMPORTANCE_CHECKS[1]
    if floor is not None and ev.get("log_lower") is not None and ev["log_lower"] >= floor:
        return IMPORTANCE_CHECKS[2]
    if _agree(ev["log_evidence"], cls.sampler_log_evidence, ev.get("std_error")):
        return "the sampler agrees"
    return ""


def evidence_trusted(cls: ModelClass, rule: DecisionRule, floor: float | None = None) -> str:
    """"" when the class's ln Z may be used to confirm, else why not (check 3 of the module docstring; ``floor`` as
    in `evidence_check`)."""
    if evidence_check(cls, rule, floor):
        return ""
    ev, sampler = cls.evidence, cls.sampler_log_evidence
    if ev.get("method") == NOT_REFINED:
        return ("evidence not trusted: its ln Z could not be refined at its mode (the forward model fails around its "
                "best-fitting parameters, so no curvature could be taken there), and the sampler's own estimate is not "
                "checked")
    if ev.get("method") in ("importance sampling", "lower bound") and ev.get("n_draws"):
        why = (f"its importance-sampling estimate has an effective sample size of {ev.get('ess', 0.0):.0f} of "
               f"{ev['n_draws']} draws (needs {100 * rule.ess_fraction:.0f} %)")
    else:
        why = f"its refined ln Z is a {ev.get('method', 'mode')} estimate without an importance-sampling check"
        if ev.get("log_is") is not None:
            why += f" (importance sampling differs by {ev['log_is'] - ev['log_evidence']:+.1f})"
    if floor is not None and ev.get("log_lower") is not None:
        why += f"; its 95 % lower bound {ev['log_lower']:.1f} falls short of {floor:.1f}"
    gap = "" if sampler is None else f", and the sampler's estimate differs by {ev['log_evidence'] - sampler:+.1f}"
    return f"evidence not trusted: {why}{gap}"


def highest_estimate(cls: ModelClass, rule: DecisionRule) -> float:
    """The class's ln Z when its refined estimate passed an importance check, else the highest of its refined
    estimates (Laplace, importance sampling): what a class compared with must be taken to reach when its own value is
    not checked (the floor of check 3's lower bound)."""
    ev = cls.evidence or {}
    if importance_checked(cls, rule):
        return cls.log_evidence
    return max(v for v in (cls.log_evidence, ev.get("log_laplace"), ev.get("log_is")) if v is not None)


def importance_checked(cls: ModelClass, rule: DecisionRule, floor: float | None = None) -> bool:
    """The class's refined ln Z passed an importance check (IMPORTANCE_CHECKS; ``floor`` as in `evidence_check`)."""
    return evidence_check(cls, rule, floor) in IMPORTANCE_CHECKS


def out_of_reach(cls: ModelClass, other: ModelClass, margin: float) -> bool:
    """The class's ln Z lies ``margin`` or more above the ``other`` class's log-likelihood at its refined mode, which
    bounds every estimate of the other's ln Z from above (Z = int L pi <= max L; check 4 of the module docstring).
    False when the other class has no such record."""
    top = (other.evidence or {}).get("log_likelihood_mode")
    return top is not None and cls.log_evidence >= top + margin


def sampler_disagrees(cls: ModelClass, other: ModelClass) -> str:
    """"" unless the sampler's own ln Z favours ``other`` while the class's ln Z (refined) favours the class (check 4);
    then the reason in words."""
    if cls.sampler_log_evidence is None or other.sampler_log_evidence is None:
        return ""
    sampler = cls.sampler_log_evidence - other.sampler_log_evidence
    if sampler < 0 <= cls.log_evidence - other.log_evidence:
        return (f"the sampler's own estimate favours the {other.role} class (ln B = {sampler:+.1f} by the sampler, "
                f"{cls.log_evidence - other.log_evidence:+.1f} refined)")
    return ""


def confirmation_blocks(cls: ModelClass, enrichment: dict | None, rule: DecisionRule,
                        floor: float | None = None) -> list:
    """Why the enriched class ``cls`` cannot confirm its candidate (checks 1-3 of the module docstring), in words;
    [] when nothing blocks it. ``enrichment``: the candidate's plain-data enrichment (its ``inert_at``); ``floor``:
    the ln Z it must reach to confirm (`evidence_check`)."""
    blocks = []
    free = [n for n in cls.parameters if n in cls.priors]
    if free and all(cls.parameters[n]["std"] < rule.collapse_fraction * (cls.priors[n][1] - cls.priors[n][0])
                    for n in free):
        blocks.append(f"its posterior collapsed (every standard deviation below {rule.collapse_fraction:g} of its "
                      "prior range)")
    for name in (enrichment or {}).get("parameters") or {}:
        if name in cls.parameters and name in cls.priors:
            spread = _spread(cls.parameters[name], *cls.priors[name])
            if spread < rule.lost_dimension_fraction:
                blocks.append(f"the sampler lost its added parameter {name}: posterior standard deviation "
                              f"{spread:.2g} of its prior range (below {rule.lost_dimension_fraction:g}), MAP "
                              f"{cls.parameters[name]['map']:.4g}")
    for name, end in ((enrichment or {}).get("inert_at") or {}).items():
        if name not in cls.parameters or name not in cls.priors:
            continue
        lower, upper, kind = cls.priors[name]
        value = cls.parameters[name]["map"]
        at = _position(value, lower, upper, kind)
        if (end == "lower" and at <= rule.inert_fraction) or (end == "upper" and at >= 1.0 - rule.inert_fraction):
            bound = lower if end == "lower" else upper
            blocks.append(f"its added parameter {name} = {value:.4g} sits at the {end} end of its prior ({bound:g}), "
                          "where the effect vanishes")
    reason = evidence_trusted(cls, rule, floor)
    if reason:
        blocks.append(reason)
    return blocks


def numerics_comparable(base: ModelClass, regions, rule: DecisionRule) -> str:
    """"" unless the base class's discretisation error (``base.numerical_error``: RMS relative difference per curve
    between the calibrated and a refined discretisation at its mode) reaches ``rule.numerical_fraction`` of the
    located misfit (|mean r| of each region; the median ratio over the regions); then the reason in words. No region
    or no measurement: ""."""
    error = {(e["test"], e["curve"]): e["rms"] for e in base.numerical_error}
    ratios = [error[(r.test, r.curve)] / abs(r.mean_relative) for r in regions
              if (r.test, r.curve) in error and r.mean_relative != 0]
    if not ratios:
        return ""
    median = float(np.median(ratios))
    if median < rule.numerical_fraction:
        return ""
    worst = max(base.numerical_error, key=lambda e: e["rms"])
    return (f"the forward model's discretisation error at the base's mode is {100 * median:.0f} % of the located "
            f"misfit (median over the regions; largest on {worst['test']} {worst['curve']}: RMS "
            f"{100 * worst['rms']:.2g} %): the misfit may be numerical; confirm with a finer discretisation")
