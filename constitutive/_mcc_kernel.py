"""Compiled (numba) per-point return mapping of Modified Cam Clay: the equations and the integration scheme of
:mod:`constitutive.mcc` (module docstring, docs/reference.md section 4).

Compression positive, kPa. Voigt order (11, 22, 33, 12, 23, 31); stresses with tensor shear, strains with
engineering shear. Per point: elastic trial; if f > 0, Newton with backtracking on the two unknowns
(y = d eps_v^p, d lambda), residuals r1 = y - d lambda M^2 (2p' - p'_c), r2 = f/p'_cn^2 with
p' = p'_n exp(a(d eps_v - y)), a = v_n/kappa, p'_c = p'_cn exp(b y), b = v_n/(lambda - kappa),
q = q_tr/(1 + 6 G_bar d lambda); the consistent tangent from the implicit-function theorem on (r1, r2). A point that
fails is sub-stepped (depth-first bisection, ``max_depth`` levels, the void ratio frozen within each sub-step); where
it fails at the deepest level, the stability margin of its state there (:func:`stability_margin`) tells whether the
continuum problem has a solution.
"""
from __future__ import annotations

import math

import numpy as np

from ._step_loops import adapt_points, drive_points
from .jit import STRAIN_TO_TENSOR as _T
from .jit import VOIGT_IDENTITY as _I
from .jit import VOIGT_WEIGHTS as _W
from .jit import all_finite as _all_finite
from .jit import expm1_over_x as _expm1_over_x
from .jit import jit, next_substep

#: columns of the per-point parameter array ``prm``: M^2, lambda, kappa and G (constant_G) or nu
PARAMETER_COLUMNS = ("M2", "lambda_", "kappa", "G_or_nu")


@jit
def _evaluate(y, dl, p_n, s_n, Pde, deps_v, pcn, a, b, M2, shear, constant_G, s_tr, n_tr):
    """State and residuals at (y, d lambda). Fills s_tr (trial deviator with the secant G_bar) and n_tr = dq_tr/ds_tr;
    returns p', dp'/d(d eps_v^e), G_bar, dG_bar/d(d eps_v^e), 1 + 6 G_bar d lambda, q, p'_c, r1, r2."""
    z = a * (deps_v - y)
    p = p_n * math.exp(z)
    if constant_G:
        Gb, Gb_x = shear, 0.0
    else:
        c_nu = 3.0 * (1.0 - 2.0 * shear) / (2.0 * (1.0 + shear))
        phi, dphi = _expm1_over_x(z)
        Gb, Gb_x = c_nu * p_n * a * phi, c_nu * p_n * a * a * dphi
    q2 = 0.0
    for k in range(6):
        s_tr[k] = s_n[k] + Gb * Pde[k]
        q2 += _W[k] * s_tr[k] * s_tr[k]
    q_tr = math.sqrt(1.5 * q2)
    q_safe = q_tr if q_tr > 0.0 else 1.0
    for k in range(6):
        n_tr[k] = 1.5 * _W[k] * s_tr[k] / q_safe
    den = 1.0 + 6.0 * Gb * dl
    q = q_tr / den
    pc = pcn * math.exp(b * y)
    r1 = y - dl * M2 * (2.0 * p - pc)
    r2 = (q * q + M2 * p * (p - pc)) / (pcn * pcn)
    return p, a * p, Gb, Gb_x, den, q, pc, r1, r2


@jit
def _jacobian(dl, p, p_x, Gb, Gb_x, den, q, pc, Pde, n_tr, M2, b, pcn):
    """d(r1, r2)/d(y, d lambda) and the partial derivatives r1_x, r2_x with respect to d eps_v^e."""
    pc_ref2 = pcn * pcn
    dqtr_dG = 0.0
    for k in range(6):
        dqtr_dG += n_tr[k] * Pde[k]
    q_x = (dqtr_dG - 6.0 * dl * q) / den * Gb_x
    q_l = -6.0 * Gb * q / den
    pc_y = b * pc
    r1_x = -2.0 * dl * M2 * p_x
    r2_x = (2.0 * q * q_x + M2 * (2.0 * p - pc) * p_x) / pc_ref2
    J11 = 1.0 + dl * M2 * pc_y - r1_x
    J12 = -M2 * (2.0 * p - pc)
    J21 = -M2 * p * pc_y / pc_ref2 - r2_x
    J22 = 2.0 * q * q_l / pc_ref2
    return J11, J12, J21, J22, r1_x, r2_x


@jit
def stability_margin(sig, pc, v, prm, constant_G):
    """1 + H / (n : D : n) at the stress ``sig`` (6,) with yield-surface size ``pc`` and specific volume ``v``, for
    a plastic strain increment: n = (df/dp', df/dq) = (M^2 (2p' - p'_c), 2q), D the tangent elasticity (K = v p'/kappa,
    G), n : D : n = K (df/dp')^2 + 3 G (df/dq)^2 and H = M^2 p' b p'_c df/dp' the hardening term (b = v/(lambda -
    kappa)). Negative: softening (df/dp' < 0, the dry side of critical) faster than the elasticity, so that no
    plastic state follows the current one under any small strain increment (the material point is unstable even
    under strain control: no return mapping exists for small increments)."""
    M2, lam, kap, shear = prm[0], prm[1], prm[2], prm[3]
    p = (sig[0] + sig[1] + sig[2]) / 3.0
    q2 = 0.0
    for k in range(6):
        d = sig[k] - p * _I[k]
        q2 += _W[k] * d * d
    q = math.sqrt(1.5 * q2)
    K = v * p / kap
    G = shear if constant_G else 3.0 * K * (1.0 - 2.0 * shear) / (2.0 * (1.0 + shear))
    f_p = M2 * (2.0 * p - pc)
    ndn = K * f_p * f_p + 12.0 * G * q * q
    return 1.0 + M2 * p * v / (lam - kap) * pc * f_p / ndn if ndn > 0.0 else 1.0


@jit(inline="always")
def _local_solve(sig_n, pcn, v, deps, prm, constant_G, tol, max_it, sig_o, dep_o, tan_o, s_n, Pde, s_tr, n_tr,
                 q_eps):
    """Backward-Euler return mapping of one point over one (sub-)increment. Fills sig_o, dep_o (plastic strain
    increment), tan_o (6 x 6); returns (converged, p'_c)."""
    M2, lam, kap, shear = prm[0], prm[1], prm[2], prm[3]
    a = v / kap
    b = v / (lam - kap)
    p_n = (sig_n[0] + sig_n[1] + sig_n[2]) / 3.0
    deps_v = deps[0] + deps[1] + deps[2]
    for k in range(6):
        s_n[k] = sig_n[k] - p_n * _I[k]
        Pde[k] = _T[k] * (deps[k] - deps_v / 3.0 * _I[k])  # 2 x the strain-increment deviator (stress Voigt)
    y = dl = 0.0
    p, p_x, Gb, Gb_x, den, q, pc, r1, r2 = _evaluate(y, dl, p_n, s_n, Pde, deps_v, pcn, a, b, M2, shear,
                                                     constant_G, s_tr, n_tr)
    if r2 > tol:
        done = False
        for _ in range(max_it):
            J11, J12, J21, J22, _, _ = _jacobian(dl, p, p_x, Gb, Gb_x, den, q, pc, Pde, n_tr, M2, b, pcn)
            det = J11 * J22 - J12 * J21
            if det == 0.0:
                det = 2.2250738585072014e-308
            dy = -(J22 * r1 - J12 * r2) / det
            dd = -(-J21 * r1 + J11 * r2) / det
            m0 = (b * r1) ** 2 + r2 ** 2
            step = 1.0
            y_t = dl_t = 0.0
            for _ls in range(12):  # backtracking on the merit function, d lambda kept >= 0
                y_t = y + step * dy
                dl_t = dl + step * dd
                if dl_t < 0.0:
                    dl_t = 0.5 * dl
                p, p_x, Gb, Gb_x, den, q, pc, r1, r2 = _evaluate(y_t, dl_t, p_n, s_n, Pde, deps_v, pcn, a, b, M2,
                                                                 shear, constant_G, s_tr, n_tr)
                m_t = (b * r1) ** 2 + r2 ** 2
                if math.isfinite(m_t) and (m_t < m0 or m_t <= tol * tol):
                    break
                step *= 0.5
            y, dl = y_t, dl_t
            if abs(b * r1) <= tol and abs(r2) <= tol:
                done = True
                break
        if not (done and math.isfinite(p) and math.isfinite(q)):
            return False, pcn
    # stress and plastic strain increment
    for k in range(6):
        s = s_tr[k] / den
        sig_o[k] = s + p * _I[k]
        dep_o[k] = y / 3.0 * _I[k] + 3.0 * dl * _W[k] * s
    # consistent tangent: sigma' = p' I + s_tr/den; (y, d lambda) from the implicit-function theorem on (r1, r2)
    J11, J12, J21, J22, r1_x, r2_x = _jacobian(dl, p, p_x, Gb, Gb_x, den, q, pc, Pde, n_tr, M2, b, pcn)
    c_q = 2.0 * q / (pcn * pcn) * Gb / den
    for j in range(6):  # q_eps = d q/d(d eps) at fixed G_bar, d lambda: (G_bar/den) n_tr P
        q_eps[j] = c_q * _T[j] * (n_tr[j] - _I[j] * (n_tr[0] + n_tr[1] + n_tr[2]) / 3.0)
    plastic = y != 0.0 or dl != 0.0
    det = J11 * J22 - J12 * J21
    if not plastic or det == 0.0:
        det = 1.0
    g_den, g_s = Gb / den, 6.0 * Gb / den
    for j in range(6):  # column j: d(y, d lambda)/d(d eps_j) = (Y, L), d(d eps_v^e)/d(d eps_j) = I_j - Y
        R1 = r1_x * _I[j]
        R2 = r2_x * _I[j] + q_eps[j]
        Y = -(J22 * R1 - J12 * R2) / det if plastic else 0.0
        L = -(-J21 * R1 + J11 * R2) / det if plastic else 0.0
        dx = _I[j] - Y
        for i in range(6):
            s_i = s_tr[i] / den
            tan_o[i, j] = (_I[i] * p_x * dx + g_den * _T[i] * ((1.0 if i == j else 0.0) - _I[i] * _I[j] / 3.0)
                           + (Pde[i] - 6.0 * dl * s_i) / den * Gb_x * dx - g_s * s_i * L)
    return _all_finite(tan_o), pc


@jit(inline="always")
def _update_point(sig, pc, e, deps, prm, constant_G, tol, max_it, max_depth, stress_out, dep_out, tangent_out,
                  failure_out, work):
    """One increment ``deps`` (6,) of one point from stress ``sig`` (6,), p'_c ``pc`` and void ratio ``e``; fills
    ``stress_out``, ``dep_out`` (the plastic strain increment) and ``tangent_out``. A sub-step that fails is split
    into halves (depth-first bisection, ``max_depth`` levels; the void ratio is updated between sub-steps,
    e <- e - (1 + e) d eps_v). Returns (converged, p'_c at the end); where it fails at the deepest level
    ``failure_out`` (5,) gets p', q, p'_c at the start of the sub-step that failed, the fraction of the increment
    done before it and :func:`stability_margin` there. ``work`` (>= 8, 6): scratch rows."""
    sig_c, sub, dep_c, s_n = work[0], work[1], work[2], work[3]
    Pde, s_tr, n_tr, q_eps = work[4], work[5], work[6], work[7]
    sig_c[:] = sig
    pc_c = pc
    e_c = e
    dep_out[:] = 0.0
    units = 1 << max_depth
    pos = 0
    level = 0
    while pos < units:
        frac = 1.0 / (1 << level)
        for k in range(6):
            sub[k] = deps[k] * frac
        ok, pc_new = _local_solve(sig_c, pc_c, 1.0 + e_c, sub, prm, constant_G, tol, max_it, stress_out, dep_c,
                                  tangent_out, s_n, Pde, s_tr, n_tr, q_eps)
        if not ok:
            if level >= max_depth:
                p_c = (sig_c[0] + sig_c[1] + sig_c[2]) / 3.0
                q2 = 0.0
                for k in range(6):
                    q2 += _W[k] * (sig_c[k] - p_c * _I[k]) ** 2
                failure_out[0], failure_out[1], failure_out[2] = p_c, math.sqrt(1.5 * q2), pc_c
                failure_out[3] = pos / units
                failure_out[4] = stability_margin(sig_c, pc_c, 1.0 + e_c, prm, constant_G)
                return False, pc_c
            level += 1
            continue
        sig_c[:] = stress_out
        pc_c = pc_new
        e_c -= (1.0 + e_c) * (sub[0] + sub[1] + sub[2])
        for k in range(6):
            dep_out[k] += dep_c[k]
        pos, level = next_substep(pos, level, units)
    return True, pc_c


@jit
def update_points(stress, pc, void_ratio, deps, prm, constant_G, tol, max_it, max_depth,
                  stress_out, pc_out, dep_out, tangent_out, failure_out):
    """One increment at every point (stress, deps (n, 6); pc, void_ratio (n,); prm (n, 4) in the order
    PARAMETER_COLUMNS), each by :func:`_update_point`. Returns the index of the first point that failed, or -1;
    for that point ``failure_out`` (5,) as in :func:`_update_point`."""
    work = np.empty((8, 6))
    for i in range(stress.shape[0]):
        ok, pc_new = _update_point(stress[i], pc[i], void_ratio[i], deps[i], prm[i], constant_G, tol, max_it,
                                   max_depth, stress_out[i], dep_out[i], tangent_out[i], failure_out, work)
        pc_out[i] = pc_new
        if not ok:
            return i
    return -1


#: the columns of the state of :func:`point_update`: p'_c, the void ratio e and the plastic strain (6)
STATE_COLUMNS = (("pc", 1), ("void_ratio", 1), ("plastic_strain", 6))
#: scratch rows of :func:`point_update` (``work``)
WORK_ROWS = 9
#: codes of :func:`point_update`: the return mapping failed (info: ``_update_point``'s failure_out); the void
#: ratio would fall to zero or below (info: the new and the old void ratio)
RETURN_MAPPING_FAILED, VOID_RATIO_COLLAPSED = 1, 2


@jit
def point_update(stress, state, deps, dt, prm, settings, stress_out, state_out, tangent_out, info, work):
    """The model's update of one point in the form of the compiled step loop
    (``_step_loops.drive_points``): ``state`` (8,) in STATE_COLUMNS, ``settings`` (constant_G as 0/1,
    tol, max_it, max_depth); ``dt`` unused (rate independent). As ``ModifiedCamClay.update``: the return mapping,
    then e <- e - (1 + e) d eps_v over the whole increment and the plastic strain accumulated. Returns 0, or a
    failure code (``RETURN_MAPPING_FAILED``, ``VOID_RATIO_COLLAPSED``) with ``info`` filled."""
    ok, pc = _update_point(stress, state[0], state[1], deps, prm, settings[0] != 0.0, settings[1], int(settings[2]),
                           int(settings[3]), stress_out, work[8], tangent_out, info, work)
    if not ok:
        return RETURN_MAPPING_FAILED
    e = state[1]
    e_new = e - (1.0 + e) * (deps[0] + deps[1] + deps[2])
    if e_new <= 0.0:
        info[0], info[1] = e_new, e
        return VOID_RATIO_COLLAPSED
    state_out[0], state_out[1] = pc, e_new
    for k in range(6):
        state_out[2 + k] = state[2 + k] + work[8, k]
    return 0


@jit
def drive(prm, settings, stress0, state0, steps, stop, newton, history, ending):
    """``_step_loops.drive_points`` with :func:`point_update` (the arguments are its)."""
    return drive_points(point_update, prm, settings, np.empty((WORK_ROWS, 6)), 1, stress0, state0, steps, stop,
                        newton, history, ending)


@jit
def adapt(prm, settings, stress0, state0, control, undrained, path, segments, records, going, step_control, newton,
          history, ending):
    """``_step_loops.adapt_points`` with :func:`point_update` (the arguments are its)."""
    return adapt_points(point_update, prm, settings, np.empty((WORK_ROWS, 6)), 1, stress0, state0, control, undrained,
                        path, segments, records, going, step_control, newton, history, ending)
