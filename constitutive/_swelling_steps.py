"""Delayed swelling's update of one point in the form of the compiled step loops (:mod:`constitutive._step_loops`),
around a base model's compiled update of one point, and the loops with it (``drive``: ``mixed_control``,
``adapt``: ``adaptive_control``) for each base that has one (:data:`LOOPS`, keyed by the base's own ``drive``).

The arithmetic is that of :class:`constitutive.swelling.DelayedSwelling` for one point: the strain split (S1), the
equilibrium swelling (S2), backward Euler of the Kelvin rate (S3) solved for x = eps_s,n+1 by Newton safeguarded by
its bracket (false position with the Illinois modification, bisection while an end is not evaluated), the void
ratio (S4) and the consistent tangent. Compression positive, kPa, s, strains dimensionless.

Layout: ``state`` is the base's state then (swelling_strain, p_max); ``prm`` the base's parameter row then
(kappa_s, tau_s); ``settings`` the base's then (tolerance, max_iterations, the base's state width, its parameter
width, the column of its void ratio). The base is called with contiguous copies of its state (``work[1]``,
``work[2]``) and the work array of its own loops (``work[0]``), i.e. with the argument types its own loops use, so
its compiled code is shared with them.
"""
from __future__ import annotations

import math

import numpy as np

from . import _anicreep_kernel, _anicreep_points, _anicreep_steps, _mcc_kernel
from ._step_loops import adapt_points, drive_points
from ._swelling_kernel import _np_max, _np_min
from .jit import jit

#: the columns the wrapper adds to the base's state
OWN_STATE_COLUMNS = (("swelling_strain", 1), ("p_max", 1))
#: failure codes of the swelling iteration (a base's own codes are below 100): p' <= 0 where (S2) acts (info: p',
#: p'_max); the swelling strain did not converge (info: |R|, bracket lo, hi, dt/tau_s)
NEGATIVE_MEAN_STRESS, NOT_CONVERGED = 101, 102
#: the length of ``info`` the swelling failures fill
INFO_SIZE = 4


@jit(inline="always")
def _swelling_point(base_update, stress, state, deps, dt, prm, settings, stress_out, state_out, tangent_out, info,
                    work):
    """One increment of one point of the base ``base_update`` with delayed swelling in series (module docstring).
    Returns 0, a base failure code (its ``info``) or NEGATIVE_MEAN_STRESS / NOT_CONVERGED (``info`` as
    documented there); ``tangent_out`` the consistent tangent."""
    base_work, base_state, base_state_out, base_strain = work
    n_set = settings.size
    tol, max_iterations = settings[n_set - 5], int(settings[n_set - 4])
    n_state, n_prm, void_column = int(settings[n_set - 3]), int(settings[n_set - 2]), int(settings[n_set - 1])
    for k in range(n_state):
        base_state[k] = state[k]
    e, eps_n, p_max = state[void_column], state[n_state], state[n_state + 1]
    a = dt / prm[n_prm + 1]
    slope = prm[n_prm] / (1.0 + e)
    x_hi = eps_n / (1.0 + a)                                        # the least swelling possible
    p_n = (stress[0] + stress[1] + stress[2]) / 3.0
    lagged = slope * math.log(max(p_n, 1e-300) / p_max) if p_n < p_max else 0.0
    x = _np_min(x_hi, (eps_n + a * lagged) / (1.0 + a))              # x_0, the lagged estimate
    lo, hi, r_lo, r_hi, side, residual_before = x, x_hi, np.nan, np.nan, 0.0, np.inf
    p, c = 0.0, 0.0
    converged = False
    for iteration in range(max_iterations):
        third = (x - eps_n) / 3.0                                  # (S1)
        for k in range(6):
            base_strain[k] = deps[k] - (third if k < 3 else 0.0)
        code = base_update(stress, base_state, base_strain, dt, prm, settings, stress_out, base_state_out,
                           tangent_out, info, base_work)
        if code != 0:
            return code
        p = (stress_out[0] + stress_out[1] + stress_out[2]) / 3.0
        below = p < p_max
        law = below and a > 0.0 and slope > 0.0
        if law and p <= 0.0:
            info[0], info[1] = p, p_max
            return NEGATIVE_MEAN_STRESS
        ratio = (p if law and p > 0.0 else p_max) / p_max
        eq = slope * math.log(ratio) if below else 0.0              # (S2)
        r = x - (eps_n + a * eq) / (1.0 + a)                       # R(x) of (S3)
        c = a / (1.0 + a) * slope / p if law else 0.0
        if abs(r) <= tol:
            converged = True
            break
        if iteration == 0:                                         # the bracket of the root
            lo = x - _np_max(r, 0.0)
            hi = _np_min(hi, x - _np_min(r, 0.0))
        if r > 0.0:
            if side > 0.0:
                r_lo = 0.5 * r_lo                                  # Illinois: the end kept twice
            hi, r_hi, side = x, r, 1.0
        elif r < 0.0:
            if side < 0.0:
                r_hi = 0.5 * r_hi
            lo, r_lo, side = x, r, -1.0
        progress = abs(r) <= 0.5 * residual_before
        residual_before = abs(r)
        volumetric = 0.0
        for i in range(3):
            for k in range(3):
                volumetric += tangent_out[i, k]
        slope_r = 1.0 + c * volumetric / 9.0
        newton = x - r / (slope_r if slope_r > 0.0 else 1.0)
        both = math.isfinite(r_lo) and math.isfinite(r_hi)
        secant = lo - (r_lo if both else 0.0) * (hi - lo) / ((r_hi - r_lo) if both else 1.0)
        fallback = secant if both and secant > lo and secant < hi else 0.5 * (lo + hi)
        x = newton if slope_r > 0.0 and newton >= lo and newton <= hi and progress else fallback
    if not converged:
        info[0], info[1], info[2], info[3] = residual_before, lo, hi, a
        return NOT_CONVERGED
    for k in range(n_state):
        state_out[k] = base_state_out[k]
    state_out[void_column] = base_state_out[void_column] - (1.0 + e) * (x - eps_n)      # (S4)
    state_out[n_state] = x
    state_out[n_state + 1] = _np_max(p_max, p)
    _consistent_tangent(tangent_out, c)
    return 0


@jit(inline="always")
def _consistent_tangent(D, c):
    """C = D^b - c/(9 (1 + c K_t)) (D^b m)(m^T D^b), K_t = m.D^b.m/9, in place of the base tangent D (6, 6)."""
    Dm, mD = np.empty(6), np.empty(6)
    for k in range(6):
        Dm[k] = D[k, 0] + D[k, 1] + D[k, 2]
        mD[k] = D[0, k] + D[1, k] + D[2, k]
    f = c / (9.0 * (1.0 + c * (Dm[0] + Dm[1] + Dm[2]) / 9.0))
    for r in range(6):
        for k in range(6):
            D[r, k] -= f * Dm[r] * mD[k]


def _width(columns):
    """The width of a flat state of STATE_COLUMNS ``columns``."""
    return sum(width for _, width in columns)


_MCC_STATE, _ANICREEP_STATE = _width(_mcc_kernel.STATE_COLUMNS), _width(_anicreep_steps.STATE_COLUMNS)


@jit(inline="always")
def _work(base_work, n_state):
    """``work`` of :func:`_swelling_point`: the base's own work, its state in and out, the base strain."""
    return base_work, np.empty(n_state), np.empty(n_state), np.empty(6)


@jit
def mcc_point_update(stress, state, deps, dt, prm, settings, stress_out, state_out, tangent_out, info, work):
    """:func:`_swelling_point` on Modified Cam Clay (``_mcc_kernel.point_update``)."""
    return _swelling_point(_mcc_kernel.point_update, stress, state, deps, dt, prm, settings, stress_out, state_out,
                           tangent_out, info, work)


@jit
def mcc_drive(prm, settings, stress0, state0, steps, stop, newton, history, ending):
    """``_step_loops.drive_points`` with :func:`mcc_point_update`."""
    work = _work(np.empty((_mcc_kernel.WORK_ROWS, 6)), _MCC_STATE)
    return drive_points(mcc_point_update, prm, settings, work, 1, stress0, state0, steps, stop, newton, history,
                        ending)


@jit
def mcc_adapt(prm, settings, stress0, state0, control, undrained, path, segments, records, going, step_control,
              newton, history, ending):
    """``_step_loops.adapt_points`` with :func:`mcc_point_update`."""
    work = _work(np.empty((_mcc_kernel.WORK_ROWS, 6)), _MCC_STATE)
    return adapt_points(mcc_point_update, prm, settings, work, 1, stress0, state0, control, undrained, path,
                        segments, records, going, step_control, newton, history, ending)


@jit(inline="always")
def _anicreep_work():
    """The work of ANICREEP's own loops (``_anicreep_steps.drive``)."""
    return (*_anicreep_points._scratch(), np.zeros(len(_anicreep_kernel.PARAMETER_COLUMNS)))


@jit
def anicreep_point_update(stress, state, deps, dt, prm, settings, stress_out, state_out, tangent_out, info, work):
    """:func:`_swelling_point` on ANICREEP (``_anicreep_steps.point_update``)."""
    return _swelling_point(_anicreep_steps.point_update, stress, state, deps, dt, prm, settings, stress_out,
                           state_out, tangent_out, info, work)


@jit
def anicreep_drive(prm, settings, stress0, state0, steps, stop, newton, history, ending):
    """``_step_loops.drive_points`` with :func:`anicreep_point_update`."""
    work = _work(_anicreep_work(), _ANICREEP_STATE)
    return drive_points(anicreep_point_update, prm, settings, work, 7, stress0, state0, steps, stop, newton, history,
                        ending)


@jit
def anicreep_adapt(prm, settings, stress0, state0, control, undrained, path, segments, records, going, step_control,
                   newton, history, ending):
    """``_step_loops.adapt_points`` with :func:`anicreep_point_update`."""
    work = _work(_anicreep_work(), _ANICREEP_STATE)
    return adapt_points(anicreep_point_update, prm, settings, work, 7, stress0, state0, control, undrained, path,
                        segments, records, going, step_control, newton, history, ending)


#: the swelling loops (drive, adapt) over each base's own compiled ``drive``
LOOPS = {_mcc_kernel.drive: (mcc_drive, mcc_adapt), _anicreep_steps.drive: (anicreep_drive, anicreep_adapt)}
