"""Compiled (numba) integration of ANICREEP's points over one increment: the update of one point (sub-stepping by
depth-first bisection around :mod:`constitutive._anicreep_kernel`'s local solve of one increment) and the FE's loop
over points (``update_points``). Compression positive, kPa, s; Voigt order and conventions of that module.

Compilation: every helper of the local solve is inlined (``jit(inline="always")``) into ``_update_point``, itself
inlined into ``update_points``, and into ``_update_point_lab``, inlined into ``_anicreep_steps.point_update``, so the
loop over points is one compiled body, without calls and without numba's reference counting (atomic operations) of
every array view passed to a function: about 210 per point update when the helpers were separate functions.
Inlining does not reorder floating-point operations (the same results to the bit); it doubles the cold compile
(once, then cached).

Specialization: ``_update_point`` (the FE's) inlines ``_local_solve`` twice, with the literal nc = 4 of the
axisymmetric FE's points and with nc at run time (3 or 6). With a constant nc every loop over the components and the
local unknowns, the LU included, has constant bounds and is unrolled: the same operations in the same order, about
a fifth less time per FE point update. ``_update_point_lab`` (the laboratory loops') inlines the copy for the
literal nc = 3 of triaxial and oedometer points (a quarter less time per laboratory forward solve) and calls
``_local_solve_called`` for any other point: a second inlined copy would double the cold compile (numba's inlining
costs grow faster than the code inlined).
"""
from __future__ import annotations

import math

import numpy as np

from ._anicreep_kernel import MAX_NX, _local_solve, components_in_play
from .jit import VOIGT_IDENTITY as _I
from .jit import VOIGT_WEIGHTS as _W
from .jit import jit, next_substep


def _point_integrator(literal_nc, inline_others):
    """The update of one point (inlined where it is called) with the local solve for the constant nc =
    ``literal_nc`` and, for other points, for nc at run time: inlined when ``inline_others``, else a call of
    :func:`_local_solve_called` (module docstring, Specialization). The arguments are constants of the closure, which
    numba's dead-branch pruning resolves before compiling: a variant compiles only what it uses."""

    @jit(inline="always")
    def update_point(sig, alp, pm, chi, deps, dt, prm, viscous, tol, max_it, max_dz, max_depth, reduce, want_tangent,
                     stress_out, alpha_out, dvp_out, tan_out, work):
        """Integrate one increment ``deps`` (6,) over ``dt`` of one point (stress ``sig``, fabric ``alp`` (6,), p'_m^r
        ``pm``, bonding ``chi``; ``prm`` its PARAMETER_COLUMNS row). With ``reduce`` in the components in play
        (``components_in_play``), otherwise in all 6; ``tan_out`` (6, 6) filled only with ``want_tangent`` (the
        consistent tangent of the last sub-step). A sub-step that fails is split into halves (depth-first bisection,
        ``max_depth`` levels). Fills stress_out, alpha_out and dvp_out (the viscoplastic strain increment); returns
        (converged, p'_m^r, chi, p'_m^d/p'_m^r at the end, eps_d^vp = sqrt(2/3 e^vp:e^vp) of the increment).
        ``work``: the scratch arrays (ws (38, MAX_NX), X, Xn, dX, R, rhs (MAX_NX,), J, LU (MAX_NX, MAX_NX), piv
        (MAX_NX,) int, and four (6,))."""
        ws, X, Xn, dX, R, rhs, J, LU, piv, sig_c, alp_c, dvp_c, sub_deps = work
        nc = components_in_play(sig, alp, deps) if reduce else 6
        for k in range(6):
            sig_c[k] = sig[k]
            alp_c[k] = alp[k]
            dvp_out[k] = 0.0
        pm_c = pm
        chi_c = chi
        ratio = 0.0
        units = 1 << max_depth
        pos = 0
        level = 0
        while pos < units:
            frac = 1.0 / (1 << level)
            for k in range(6):
                sub_deps[k] = deps[k] * frac
            if nc == literal_nc:
                ok, pm_new, ratio_new, chi_new = _local_solve(
                    sig_c, alp_c, pm_c, chi_c, sub_deps, dt * frac, prm, viscous, tol, max_it, max_dz, literal_nc,
                    want_tangent, stress_out, alpha_out, dvp_c, tan_out, ws, X, Xn, dX, R, J, LU, piv, rhs)
            elif inline_others:
                ok, pm_new, ratio_new, chi_new = _local_solve(
                    sig_c, alp_c, pm_c, chi_c, sub_deps, dt * frac, prm, viscous, tol, max_it, max_dz, nc,
                    want_tangent, stress_out, alpha_out, dvp_c, tan_out, ws, X, Xn, dX, R, J, LU, piv, rhs)
            else:
                ok, pm_new, ratio_new, chi_new = _local_solve_called(
                    sig_c, alp_c, pm_c, chi_c, sub_deps, dt * frac, prm, viscous, tol, max_it, max_dz, nc,
                    want_tangent, stress_out, alpha_out, dvp_c, tan_out, ws, X, Xn, dX, R, J, LU, piv, rhs)
            if not ok:
                if level >= max_depth:
                    return False, pm_c, chi_c, ratio, 0.0
                level += 1
                continue
            for k in range(6):
                sig_c[k] = stress_out[k]
                alp_c[k] = alpha_out[k]
            pm_c = pm_new
            chi_c = chi_new
            ratio = ratio_new
            for k in range(6):
                dvp_out[k] += dvp_c[k]
            pos, level = next_substep(pos, level, units)
        dv = (dvp_out[0] + dvp_out[1] + dvp_out[2]) / 3.0
        e2 = 0.0
        for k in range(6):  # eps_d^vp increment sqrt(2/3 e:e) of the whole increment (engineering shear: weight 1/2)
            e = dvp_out[k] - dv * _I[k]
            e2 += e * e / _W[k]
        return True, pm_c, chi_c, ratio, math.sqrt(2.0 / 3.0 * e2)

    return update_point


@jit
def _local_solve_called(sig_n, alp_n, pm_n, chi_n, deps, dt, prm, viscous, tol, max_it, max_dz, nc, want_tangent,
                        sig_o, alp_o, dvp_o, tan_o, ws, X, Xn, dX, R, J, LU, piv, rhs):
    """:func:`_local_solve` (the same arguments and results) as a function of its own: called, not inlined, by the
    laboratory loops for their rare points with shear."""
    return _local_solve(sig_n, alp_n, pm_n, chi_n, deps, dt, prm, viscous, tol, max_it, max_dz, nc, want_tangent,
                        sig_o, alp_o, dvp_o, tan_o, ws, X, Xn, dX, R, J, LU, piv, rhs)


#: the FE's update of one point (``update_points``: its points carry the shear stress sigma_rz, nc = 4) and the
#: laboratory step loops' (``_anicreep_steps``: triaxial and oedometer points carry no shear, nc = 3)
_update_point = _point_integrator(4, True)
_update_point_lab = _point_integrator(3, False)


@jit(inline="always")
def _scratch():
    """The scratch arrays of :func:`_update_point`."""
    return (np.zeros((38, MAX_NX)), np.zeros(MAX_NX), np.zeros(MAX_NX), np.zeros(MAX_NX), np.zeros(MAX_NX),
            np.zeros(MAX_NX), np.zeros((MAX_NX, MAX_NX)), np.zeros((MAX_NX, MAX_NX)), np.zeros(MAX_NX, dtype=np.int64),
            np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6))


@jit
def update_points(stress, alpha, pm_ref, chi, deps, dt, prm, viscous, tol, max_it, max_dz, max_depth, reduce,
                  want_tangent, stress_out, alpha_out, pm_out, chi_out, dvp_out, vp_shear_out, ratio_out, tangent_out):
    """Integrate one increment at every point (arrays over n points: stress, alpha (n, 6), pm_ref (n,), chi (n,) the
    bonding (0 without destructuration), deps (n, 6), dt (n,), prm (n, 10) in the order PARAMETER_COLUMNS), each by
    :func:`_update_point`; tangent_out (n, 6, 6) is filled only with ``want_tangent`` (without it any (1, 6, 6)
    array, never written). Fills the *_out arrays (dvp_out the viscoplastic strain increment, vp_shear_out its
    eps_d^vp = sqrt(2/3 e^vp:e^vp)); returns the index of the first point that failed at the deepest level, or -1."""
    work = _scratch()
    for i in range(stress.shape[0]):
        ok, pm_new, chi_new, ratio, vp_shear = _update_point(
            stress[i], alpha[i], pm_ref[i], chi[i], deps[i], dt[i], prm[i], viscous, tol, max_it, max_dz, max_depth,
            reduce, want_tangent, stress_out[i], alpha_out[i], dvp_out[i], tangent_out[i if want_tangent else 0],
            work)
        if not ok:
            return i
        pm_out[i], chi_out[i], ratio_out[i], vp_shear_out[i] = pm_new, chi_new, ratio, vp_shear
    return -1
