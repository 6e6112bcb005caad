"""The per-point arithmetic of the delayed-swelling iteration (:mod:`constitutive.swelling`, (S1)-(S3)), compiled.

The wrapper's root iteration on the swelling strain x = eps_s,n+1 calls the base model's update (Python) and
numpy's logarithm between these steps; everything else of an iteration is elementwise per point and done here, in
the operations and order of the module docstring of :mod:`constitutive.swelling` (the results are the same bits as
the equivalent numpy expressions: only IEEE arithmetic and comparisons, no reductions, no transcendental
functions). Arrays over n points; compression positive, strains dimensionless, stresses kPa.
"""
from __future__ import annotations

import math

import numpy as np

from .jit import jit

_IDENTITY = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])


@jit
def base_strains(dstrain, x, eps_n, out):
    """(S1): the base model's strain increment d eps - ((x - eps_s,n)/3) m, in ``out`` (n, 6)."""
    for i in range(dstrain.shape[0]):
        third = (x[i] - eps_n[i]) / 3.0
        for k in range(6):
            out[i, k] = dstrain[i, k] - third * _IDENTITY[k]


@jit
def law_ratios(s_b, p_max, a, slope, active, p, ratio):
    """The mean stress p' of the base stresses ``s_b`` (n, 6) in ``p`` (the normal components summed in index
    order) and the argument p'/p'_max of the logarithm of (S2) per point in ``ratio`` (1 where (S2) does not act:
    p' >= p'_max, a = 0 or kappa_s = 0, or p' <= 0); returns the first ``active`` point where (S2) acts at p' <= 0,
    or -1."""
    bad = -1
    for i in range(p.size):
        p[i] = (s_b[i, 0] + s_b[i, 1] + s_b[i, 2]) / 3.0
        law = p[i] < p_max[i] and a[i] > 0.0 and slope[i] > 0.0
        if bad < 0 and active[i] and law and p[i] <= 0.0:
            bad = i
        ratio[i] = (p[i] if law and p[i] > 0.0 else p_max[i]) / p_max[i]
    return bad


@jit
def residuals(x, p, p_max, log_ratio, a, slope, eps_n, tol, active, residual, c, done):
    """R(x) = x - (eps_s,n + a eps_s^eq)/(1 + a) and c = a/(1 + a) kappa_s/((1 + e_n) p') where (S2) acts (else 0)
    per point (``log_ratio`` ln(p'/p'_max) of :func:`law_ratios`); ``done`` the ``active`` points with |R| <= tol,
    which leave ``active`` (in place). Returns (points done, points still active)."""
    n_done, n_active = 0, 0
    for i in range(x.size):
        below = p[i] < p_max[i]
        law = below and a[i] > 0.0 and slope[i] > 0.0
        eq = slope[i] * log_ratio[i] if below else 0.0
        residual[i] = x[i] - (eps_n[i] + a[i] * eq) / (1.0 + a[i])
        c[i] = a[i] / (1.0 + a[i]) * slope[i] / p[i] if law else 0.0
        done[i] = active[i] and abs(residual[i]) <= tol
        if done[i]:
            active[i] = False
            n_done += 1
        elif active[i]:
            n_active += 1
    return n_done, n_active


@jit(inline="always")
def _np_max(u, v):
    """numpy's maximum of two floats (a nan propagates)."""
    return u if u >= v or u != u else v


@jit(inline="always")
def _np_min(u, v):
    """numpy's minimum of two floats (a nan propagates)."""
    return u if u <= v or u != u else v


@jit
def next_iterates(first, x, residual, c, volumetric, active, bracket, x_next):
    """The bracket update and the next trial x of the ``active`` points (others keep x), in place.

    ``bracket`` = (lo, hi, r_lo, r_hi, side, residual_before) (n,) each (:class:`constitutive.swelling`): on the
    ``first`` evaluation the bracket [x - max(R, 0), min(hi, x - min(R, 0))]; then the end on R's side becomes x
    (the R of an end kept twice halved: Illinois). Next x: Newton (R' = 1 + c K_t, K_t = ``volumetric``/9 with
    ``volumetric`` the sum of the base tangent's normal block) where it stays within the bracket and |R| halved
    since the previous iterate, else false position between the bracket's ends (both evaluated), else bisection.
    ``residual_before`` becomes |R|."""
    lo, hi, r_lo, r_hi, side, residual_before = bracket
    for i in range(x.size):
        r = residual[i]
        if first:
            lo[i] = x[i] - _np_max(r, 0.0)
            hi[i] = _np_min(hi[i], x[i] - _np_min(r, 0.0))
        up = active[i] and r > 0.0
        down = active[i] and r < 0.0
        if up and side[i] > 0.0:
            r_lo[i] = 0.5 * r_lo[i]
        if down and side[i] < 0.0:
            r_hi[i] = 0.5 * r_hi[i]
        if up:
            hi[i], r_hi[i], side[i] = x[i], r, 1.0
        elif down:
            lo[i], r_lo[i], side[i] = x[i], r, -1.0
        progress = abs(r) <= 0.5 * residual_before[i]
        residual_before[i] = abs(r)
        if not active[i]:
            x_next[i] = x[i]
            continue
        slope_r = 1.0 + c[i] * volumetric[i] / 9.0
        newton = x[i] - r / (slope_r if slope_r > 0.0 else 1.0)
        both = math.isfinite(r_lo[i]) and math.isfinite(r_hi[i])
        secant = lo[i] - (r_lo[i] if both else 0.0) * (hi[i] - lo[i]) / ((r_hi[i] - r_lo[i]) if both else 1.0)
        fallback = secant if both and secant > lo[i] and secant < hi[i] else 0.5 * (lo[i] + hi[i])
        x_next[i] = newton if slope_r > 0.0 and newton >= lo[i] and newton <= hi[i] and progress else fallback


@jit
def tangent(D_b, c, out):
    """The consistent tangent C = D^b - c/(9 (1 + c K_t)) (D^b m)(m^T D^b), K_t = m.D^b.m/9, in ``out`` (n, 6, 6)
    from the base tangent D_b (n, 6, 6) and c (n,); the sums over the normal components in index order."""
    Dm, mD = np.empty(6), np.empty(6)
    for i in range(D_b.shape[0]):
        for k in range(6):
            Dm[k] = D_b[i, k, 0] + D_b[i, k, 1] + D_b[i, k, 2]
            mD[k] = D_b[i, 0, k] + D_b[i, 1, k] + D_b[i, 2, k]
        K_t = (Dm[0] + Dm[1] + Dm[2]) / 9.0
        f = c[i] / (9.0 * (1.0 + c[i] * K_t))
        for r in range(6):
            for k in range(6):
                out[i, r, k] = D_b[i, r, k] - f * Dm[r] * mD[k]
