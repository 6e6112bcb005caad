"""Constraints between a study's parameters: the model's own (``constitutive.registry.ModelSpec.constraints``, e.g.
ModifiedCamClay and ANICREEP: ``kappa < lambda_``) and those of ``[model] constraints = ["..."]`` in the study file.

A constraint restricts the prior of the free parameters (``inference.Prior(bounds, constraints)``: zero density where
it is violated). Fixed parameters are replaced by their values. A constraint that every corner of the prior box
satisfies holds everywhere in the box (each side is linear in one parameter) and is left out, so a study whose box
already respects it samples exactly as without it; one that no corner satisfies leaves nothing to sample and is
refused.
"""
from __future__ import annotations

import itertools

import numpy as np

from inference.constraints import parse_constraint
from inference.priors import Bound, Prior, PriorError

__all__ = ["read_constraints", "feasible_point"]


def read_constraints(ck, table, spec, model, fixed: dict, free: dict, log_uniform=()) -> tuple:
    """The constraints (``inference.Constraint``) that restrict the free parameters' prior box: the model's and
    ``table`` (the ``[model]`` table's ``constraints`` list), fixed values substituted, those always satisfied in the
    box left out; ``log_uniform`` names the free parameters with a log-uniform prior. Errors (StudyError) name the
    file, ``model.constraints`` and the expression, also when the constraints leave less of the box than
    ``inference.priors.MIN_ACCEPTED_FRACTION``."""
    given = table.get("constraints", [])
    if not isinstance(given, list) or not all(isinstance(c, str) and c.strip() for c in given):
        ck.fail("model.constraints", given, "expected a list of expressions such as \"kappa < lambda_\"")
    known = {**spec.defaults, **fixed}
    names = tuple(free) + tuple(known)
    out = []
    for text, own in [(c, True) for c in given] + [(c, False) for c in spec.constraints]:
        try:
            c = parse_constraint(text, names)
        except ValueError as exc:
            if not own:  # the model's constraint names a parameter this study does not use
                continue
            ck.fail("model.constraints", text, f"{exc} (free and fixed parameters)")
        values = {n: known[n] for n in c.names if n not in free}
        c = c.with_values(values)
        if c.constant() is not None:  # fixed values only: the model's own is checked by constructing it
            if own and not c.constant():
                ck.fail("model.constraints", text, f"does not hold for the fixed values {values}")
            continue
        why = "" if own else f" ({model} needs it)"
        corners = _corners(c, free)
        if corners.all():
            continue
        if not corners.any():
            fixed_text = "".join(f", {n} = {v:g} fixed" for n, v in values.items())
            why = f"no point of the prior box satisfies {c.text}{fixed_text}{why}"
            if own:
                ck.fail("model.constraints", text, why)
            ck.fail(f"model.free.{c.names[0]}", list(free[c.names[0]]), why)
        if all(c.text != o.text for o in out):
            out.append(c)
    if out:
        try:
            Prior([Bound(n, lo, hi, "log-uniform" if n in log_uniform else "uniform") for n, (lo, hi) in free.items()],
                  out)
        except PriorError as exc:
            ck.fail("model.constraints", [c.text for c in out], str(exc))
    return tuple(out)


def _corners(constraint, free) -> np.ndarray:
    """Whether the constraint holds at each corner of the box of its free parameters (bool array)."""
    names = constraint.names
    corners = np.array(list(itertools.product(*[free[n] for n in names])), dtype=float)
    return constraint.holds(corners, names)


def feasible_point(free: dict, constraints, point: dict, keep=None, draws=4096):
    """``point`` when it satisfies the constraints, else the nearest (in box-width units) of ``draws`` box draws
    (fixed stream, seed 0) that does, with ``keep``'s value held at ``point[keep]``; None when none does."""
    names = tuple(free)
    theta = np.array([[point[n] for n in names]])
    if all(c.holds(theta, names)[0] for c in constraints):
        return point
    lo, hi = (np.array([free[n][i] for n in names]) for i in (0, 1))
    box = lo + np.random.default_rng(0).random((draws, len(names))) * (hi - lo)
    if keep is not None:
        box[:, names.index(keep)] = point[keep]
    ok = np.ones(draws, dtype=bool)
    for c in constraints:
        ok &= c.holds(box, names)
    if not ok.any():
        return None
    distance = (((box[ok] - theta) / (hi - lo)) ** 2).sum(axis=1)
    best = box[ok][int(np.argmin(distance))]
    return {n: float(v) for n, v in zip(names, best)}
