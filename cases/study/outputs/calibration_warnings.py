"""Warnings of a finished calibration, one line each (report.md and stdout, prefixed ``warning:`` there):

- a parameter on a prior bound: its MAP, 2.5 % or 97.5 % quantile within ``BOUND_TOLERANCE`` (1 %) of the prior box
  width from a bound (the width of ln x for a log-uniform prior): the data push the parameter out of the box, so
  the bound, not the data, decides its value (an error parameter's upper bound has its own warning, next). A lower
  bound of 0 is a bound on a scale: a value counts as on it only when it is also within ``ZERO_BOUND_FRACTION``
  (a tenth) of the 97.5 % quantile, i.e. the posterior reaches down to 0 on its own scale (a sigma_eps of 0.0018
  +- 0.0001 in a box [0, 1] is not on its bound);
- an error parameter (sigma_eps or sigma_eps_<group>) whose MAP is within ``SIGMA_TOLERANCE`` (2 %) of the box width
  from its upper bound: the model cannot fit the curves within the noise the prior allows;
- failed solves: draws on which the model could not follow the programme (a stress path the model cannot reach, an
  integration that failed) count as zero likelihood; the line gives how many of the run's evaluations failed, how
  many of them at the final stage (the posterior: only those concern the calibrated parameters) and the most
  frequent reason (every failed solve with its parameters is in failed_solves.jsonl);
- a poor fit: a curve whose RMS relative residual (U_obs - U_num)/U_obs at the MAP, over the points Eq. (5) uses,
  exceeds ``POOR_FIT_RATIO`` (3) times the median over the curves of their error parameter at the MAP (under the
  error model of Eq. (1), docs/reference.md section 1, the RMS is about sigma_eps); the line names the test, the
  curve and the abscissa range of ``WINDOW`` (a fifth of the points, at least 3) consecutive points with the largest
  mean squared residual. For a model-form class (the base plus a smooth discrepancy, ``inference.Discrepancy``) the
  residual is taken net of the discrepancy's posterior mean at the same point: its sigma_eps is the noise left after the
  discrepancy, and the physics' own misfit is what the discrepancy is there to carry;
- one error parameter for quantities of unequal scatter: with one sigma_eps for every curve (Eq. (4)), the RMS
  relative residual at the MAP of one recorded quantity (q, the void ratio, a pore pressure, ...) is ``SHARE_RATIO``
  (3) or more times that of another: sigma_eps follows the larger, and the curves of the smaller weigh (ratio)^2 times
  less in the likelihood than under an error parameter of their own, so the calibration hardly sees them (the
  volume change of a drained test beside its q); the line gives each quantity's RMS and the ``[sigma_eps] groups``
  by quantity that Eq. (6g) offers. It is said only where no curve is a poor fit and no error parameter is at its
  ceiling: a curve missed by several times sigma_eps is the model's misfit, which an error group would not mend.
"""
from __future__ import annotations

import re
from collections import Counter

import numpy as np

from cases.study.programme import split_key
from inference.priors import Bound

__all__ = ["BOUND_TOLERANCE", "SIGMA_TOLERANCE", "POOR_FIT_RATIO", "SHARE_RATIO", "ZERO_BOUND_FRACTION", "WINDOW",
           "prior_bounds", "bound_warnings", "sigma_warnings", "failure_warnings", "fit_warnings",
           "shared_sigma_warnings", "calibration_warnings", "warnings_section"]

BOUND_TOLERANCE = 0.01
SIGMA_TOLERANCE = 0.02
POOR_FIT_RATIO = 3.0
SHARE_RATIO = 3.0
ZERO_BOUND_FRACTION = 0.1
WINDOW = 0.2
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _position(bound, value):
    """(value - lower) / (upper - lower), in ln x for a log-uniform prior."""
    if bound.kind == "log-uniform":
        return (np.log(value) - np.log(bound.lower)) / (np.log(bound.upper) - np.log(bound.lower))
    return (value - bound.lower) / (bound.upper - bound.lower)


def prior_bounds(post) -> dict:
    """{name: inference.priors.Bound} of the posterior's prior (``post.prior``, the prior's ``describe()``)."""
    return {d["name"]: Bound(d["name"], d["lower"], d["upper"], d["kind"]) for d in post.prior if "name" in d}


def bound_warnings(post, lower_only=(), tolerance=BOUND_TOLERANCE, skip=()) -> list:
    """Parameters whose MAP or 2.5 / 97.5 % quantile lies within ``tolerance`` of the prior box width from a bound
    (the lower bound only for those in ``lower_only``; none for those in ``skip``)."""
    q = post.quantiles((0.025, 0.975))
    out = []
    for b in prior_bounds(post).values():
        if b.name in skip:
            continue
        stats = {"MAP": post.map[b.name], "2.5 % quantile": q[b.name][0], "97.5 % quantile": q[b.name][1]}
        at_zero = b.lower == 0.0 and b.kind != "log-uniform"   # a bound on a scale (module docstring)
        sides = [("lower", b.lower, lambda x: _position(b, x) <= tolerance
                  and (not at_zero or x <= ZERO_BOUND_FRACTION * q[b.name][1]))]
        if b.name not in lower_only:
            sides.append(("upper", b.upper, lambda x: _position(b, x) >= 1.0 - tolerance))
        for side, value, near in sides:
            hits = [f"{label} {v:.4g}" for label, v in stats.items() if near(v)]
            if hits:
                out.append(f"{b.name} {', '.join(hits)} at the {side} bound {value:g} of its prior: widen the "
                           "bound or fix it")
    return out


def sigma_warnings(post, sigma_names, tolerance=SIGMA_TOLERANCE) -> list:
    """Error parameters whose MAP lies within ``tolerance`` of the box width from the upper bound."""
    out, bounds = [], prior_bounds(post)
    for name in sigma_names:
        b = bounds[name]
        value = post.map[name]
        if _position(b, value) >= 1.0 - tolerance:
            out.append(f"{name} MAP {value:.4g} at the upper bound {b.upper:g} of its prior: the model cannot fit "
                       "these curves within the noise the prior allows")
    return out


def failure_warnings(post) -> list:
    """One line when some of the run's evaluations failed (zero likelihood): how many, of how many, and the most
    frequent reason (reasons that differ only in their numbers count as one; the line quotes the first of them)."""
    if not post.failures:
        return []
    groups = Counter(_NUMBER.sub("#", str(f["reason"])) for f in post.failures)
    shape, count = groups.most_common(1)[0]
    example = " ".join(next(str(f["reason"]) for f in post.failures
                            if _NUMBER.sub("#", str(f["reason"])) == shape).split())
    last = len(post.stages) - 1
    final = sum(f.get("stage") == last for f in post.failures)
    where = (f"{final} of them at the final stage: the posterior reaches parameters the programme cannot follow"
             if final else "none at the final stage: regions of the prior the programme cannot follow")
    return [f"{len(post.failures)} of {post.n_forward_solves} forward solves failed and count as zero likelihood, "
            f"{where} (failed_solves.jsonl); most frequent reason ({count}): {example}"]


def _worst_window(x, r2):
    """(x_start, x_end, index slice) of the WINDOW-long run of consecutive points with the largest mean r^2."""
    n = r2.size
    w = min(n, max(3, int(round(WINDOW * n))))
    means = np.convolve(r2, np.ones(w) / w, mode="valid")
    i = int(np.argmax(means))
    return x[i], x[i + w - 1], slice(i, i + w)


def fit_warnings(like, map_simulated: dict, curve_sigma: dict, ratio=POOR_FIT_RATIO, discrepancy=None) -> list:
    """Curves whose RMS relative residual at the MAP exceeds ``ratio`` times the median of ``curve_sigma`` (each
    curve's error parameter at the MAP, {(test, curve): sigma}), worst first. ``map_simulated``: {(test, curve):
    simulated values at the recorded abscissae}; ``discrepancy``: {(test, curve): the discrepancy's posterior mean at
    the recorded points (``Likelihood.discrepancy_mean``)}, subtracted from the residuals when given."""
    reference = float(np.median(list(curve_sigma.values())))
    net = " net of the discrepancy" if discrepancy else ""
    found = []
    residuals = like.residuals(None, map_simulated)
    for t in like.observations:
        for c, curve in t.curves.items():
            used = like.masks[t.name, c]
            r = residuals[t.name, c][used]
            if discrepancy:
                r = r - discrepancy[t.name, c][used]
            x = curve.x[used]
            if not np.isfinite(r).all():
                found.append((np.inf, f"poor fit: test {t.name}, curve {c}: the MAP simulation is not finite"))
                continue
            rms = float(np.sqrt(np.mean(r * r)))
            if rms > ratio * reference:
                lo, hi, window = _worst_window(x, r * r)
                found.append((rms, f"poor fit: test {t.name}, curve {c}: RMS relative residual{net} {100 * rms:.3g} % "
                                   f"({rms / reference:.1f} x the median sigma_eps {100 * reference:.3g} %), worst "
                                   f"for {curve.x_name} {lo:.4g} to {hi:.4g} (mean residual "
                                   f"{100 * float(np.mean(r[window])):+.3g} %)"))
    return [text for _, text in sorted(found, key=lambda f: -f[0])]


def shared_sigma_warnings(like, map_simulated: dict, ratio=SHARE_RATIO) -> list:
    """One line when a single error parameter serves recorded quantities whose RMS relative residual at the MAP
    (over the points Eq. (5) uses, every curve of the quantity pooled) differs by ``ratio`` or more (module
    docstring); none with error groups or a discrepancy (a model-form class: its discrepancy is per quantity)."""
    if len(like.sigma_names) != 1 or like.discrepancy_names:
        return []
    squares = {}
    for (test, c), r in like.residuals(None, map_simulated).items():
        r = r[like.masks[test, c]]
        if r.size and np.isfinite(r).all():
            total = squares.setdefault(split_key(c)[0], [0.0, 0])
            total[0] += float(r @ r)
            total[1] += r.size
    rms = {q: np.sqrt(s / n) for q, (s, n) in squares.items() if n}
    if len(rms) < 2 or min(rms.values()) <= 0.0:
        return []
    high, low = max(rms, key=rms.get), min(rms, key=rms.get)
    if rms[high] < ratio * rms[low]:
        return []
    each = ", ".join(f"{q} {100 * v:.3g} %" for q, v in sorted(rms.items(), key=lambda kv: -kv[1]))
    groups = ", ".join(f'{q} = ["{q}"]' for q in rms)
    return [f"one {like.sigma_names[0]} serves quantities whose RMS relative residual at the MAP differs "
            f"{rms[high] / rms[low]:.1f} times ({each}): the {low} curves weigh about "
            f"{(rms[high] / rms[low]) ** 2:.0f} times less than under an error parameter of their own; give each "
            f"quantity its own (Eq. (6g)): [sigma_eps] groups = {{ {groups} }}"]


def calibration_warnings(post, like, map_simulated: dict, theta=None) -> list:
    """Every warning of a finished calibration (module docstring): bounds, error parameters at their ceiling, failed
    solves, poor fits, one error parameter for quantities of unequal scatter. ``like``: the calibration's
    ``inference.Likelihood`` (bound to the prior's order); ``map_simulated`` the curves at ``theta`` (default the
    posterior's MAP; a refined mode where the class is recorded at it), whose error parameters the poor fits are
    judged against. A model-form discrepancy's parameters get no bound warning: its amplitude at the floor is the base
    class's fit, and its prior bounds are a choice of the diagnosis, not of the study; the poor fits of a model-form
    class are judged net of its discrepancy's posterior mean at ``theta``."""
    theta = post.map_theta if theta is None else theta
    sigma = like.curve_sigmas(theta)[0]
    sigma = np.broadcast_to(sigma, (len(like.curve_keys),))
    discrepancy = like.discrepancy_mean(theta, map_simulated) if like.discrepancy_names else None
    ceiling = sigma_warnings(post, like.sigma_names)
    poor = fit_warnings(like, map_simulated, dict(zip(like.curve_keys, sigma.tolist())), discrepancy=discrepancy)
    return (bound_warnings(post, lower_only=like.sigma_names, skip=like.discrepancy_names) + ceiling
            + failure_warnings(post) + poor + ([] if ceiling or poor else shared_sigma_warnings(like, map_simulated)))


def warnings_section(warnings: list) -> list:
    """Each warning printed on stdout (``warning: ...``); returns the lines of report.md's Warnings section."""
    for text in warnings:
        print(f"warning: {text}", flush=True)
    return ["## Warnings", ""] + ([f"- {text}" for text in warnings] or ["none"]) + [""]
