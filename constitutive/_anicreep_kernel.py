"""Compiled (numba) per-point integrator of ANICREEP: the equations are those of :mod:`constitutive.anicreep`
(module docstring, REFERENCE.md section 4), numbered (E), (F), (V), (H), (R) as there.

Compression positive, kPa, s. Voigt order (11, 22, 33, 12, 23, 31); stress-like vectors (sigma', s, alpha_d, g)
carry tensor shear components, strain vectors engineering shear. Per point, one increment is integrated by
backward Euler in the unknowns X = (sigma' (6), alpha_d (6), z), d lambda = d lambda_ref exp(z), with residuals

    R_sigma = (sigma' - sigma'_E(d eps - d lambda W g))/p'_m,n^r     (E), W = (1, 1, 1, 2, 2, 2)
    R_alpha = alpha_d - alpha_d,n - omega[(3s/(4p') - alpha_d)<d eps_v^vp> + omega_d (s/(3p') - alpha_d) d eps_d^vp] (R)
    R_z     = ln(p'_m^d/p'_m,n^r) - c_p d eps_v^vp - ln((1 + chi)/(1 + chi_n)) - z/beta   (F), (H), (D), (V)
              in log form (rate independent: 1/beta = 0; R_z = z where the elastic trial lies inside the reference
              surface), chi = chi_n exp(-xi(|d eps_v^vp| + xi_d d eps_d^vp)) (D).

Destructuration (D) adds no unknown: the bonding chi at the end of the increment is an explicit function of the
viscoplastic strain increments (exact integration of d chi = -xi chi (|d eps_v^vp| + xi_d d eps_d^vp) at the
increment's constant rates, the same exponential integration as (H)), so it enters R_z and the last Jacobian row
only. Every destructuration operation is guarded by chi_n > 0: with chi_n = 0 (switch off, chi0 = 0, or bonding
destroyed to underflow) the arithmetic is exactly that of the model without (D).

The Jacobian dR/dX is ANALYTIC (forward-mode chain rule written out in ``_evaluate``; the test suite checks it
against complex-step differentiation of an independent numpy residual). Newton with the z-step limited to
``max_dz`` and backtracking on |R|^2; a point that fails is sub-stepped (halves, recursively up to ``max_depth``
levels, in the order of a depth-first bisection). The consistent tangent is dsigma'/d(d eps) = [J^-1 dR/d(d eps)]
from the converged LU factors (implicit-function theorem); for a sub-stepped point it is the last sub-step's.
"""
from __future__ import annotations

import math

import numpy as np

from ._jit import STRAIN_TO_TENSOR as _T
from ._jit import VOIGT_IDENTITY as _I
from ._jit import VOIGT_WEIGHTS as _W
from ._jit import all_finite as _all_finite
from ._jit import expm1_over_x as _expm1_over_x
from ._jit import jit, next_substep

_NX = 13                                        # unknowns per point
#: columns of the per-point parameter array ``prm``
PARAMETER_COLUMNS = ("M2", "c_e", "c_p", "r_G", "omega", "omega_d", "inv_beta", "mu", "xi", "xi_d")


@jit
def _dot(a, b):
    """a:b of two stress-like Voigt vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5])


@jit
def _surface(sig, alp, M2, s, xi, g):
    """(F) through sig with fabric alp: fills s (deviator), xi = s - p' alp, g = df/dsigma'/(p'(M^2 - alpha^2)) (V);
    returns p', M^2 - alpha^2, p'_m^d and E = xi:alp + (M^2 - alpha^2)(p'_m^d - 2p')/3 (g = (3 xi - E I)/(p' Ma))."""
    p = (sig[0] + sig[1] + sig[2]) / 3.0
    for k in range(6):
        s[k] = sig[k] - p * _I[k]
        xi[k] = s[k] - p * alp[k]
    Ma = M2 - 1.5 * _dot(alp, alp)
    pmd = p + 1.5 * _dot(xi, xi) / (Ma * p)
    E = _dot(xi, alp) + Ma * (pmd - 2.0 * p) / 3.0
    for k in range(6):
        g[k] = (3.0 * xi[k] - E * _I[k]) / (p * Ma)
    return p, Ma, pmd, E


@jit
def _elastic_stress(s_n, p_n, c_e, r_G, deps_e, sig_e, c):
    """(E) integrated exactly along the elastic strain increment deps_e (engineering Voigt): p' = p'_n exp(x),
    x = c_e d eps_v^e; s = s_n + 2 G_bar de^e, G_bar = r_G K_bar, K_bar = p'_n c_e phi(x). Fills sig_e and the
    vector c; returns G_bar. The stiffness d sig_e/d deps_e is S_e v = G_bar T o (v - I tr(v)/3) + c tr(v)
    (``_apply_stiffness``)."""
    dve = deps_e[0] + deps_e[1] + deps_e[2]
    x = c_e * dve
    p_e = p_n * math.exp(x)
    phi, dphi = _expm1_over_x(x)
    gk = r_G * p_n * c_e * phi
    gk_x = r_G * p_n * c_e * c_e * dphi  # d(r_G K_bar)/d(d eps_v^e)
    for k in range(6):
        dev = (deps_e[k] - dve / 3.0 * _I[k]) * _T[k]
        sig_e[k] = s_n[k] + gk * dev + p_e * _I[k]
        c[k] = gk_x * dev + p_e * c_e * _I[k]
    return gk


@jit
def _apply_stiffness(gk, c, v, k):
    """Component k of S_e v (``_elastic_stress``)."""
    tr = v[0] + v[1] + v[2]
    return gk * _T[k] * (v[k] - _I[k] * tr / 3.0) + c[k] * tr


@jit
def _evaluate(X, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, chi_n, prm, dlam_ref, active, want_jac, R, J, ws):
    """Residuals R (13) at X and, when ``want_jac``, the analytic Jacobian J = dR/dX (13 x 13). ``ws`` is scratch
    (rows 0-31 used here, 32 x 13 at least); on return ws[2, :6] holds g and, with ``want_jac``, ws[6, :6] the vector c of the elastic
    stiffness (``_elastic_stress``). Returns (ln(p'_m^d/p'_m^r), d lambda, G_bar, chi at the end of the increment)."""
    M2, c_e, c_p, r_G, omega, omega_d, inv_beta = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6]
    sig = X[0:6]
    alp = X[6:12]
    z = X[12]
    s, xi, g, gdev, deps_e, sig_e, c = ws[0, :6], ws[1, :6], ws[2, :6], ws[3, :6], ws[4, :6], ws[5, :6], ws[6, :6]
    p, Ma, pmd, E = _surface(sig, alp, M2, s, xi, g)
    dlam = dlam_ref * math.exp(z)
    trg = g[0] + g[1] + g[2]
    for k in range(6):
        gdev[k] = g[k] - trg / 3.0 * _I[k]
    sq = math.sqrt(2.0 / 3.0 * _dot(gdev, gdev) + 1e-30)
    dv = dlam * trg                                  # d eps_v^vp
    dd = dlam * sq                                   # d eps_d^vp (magnitude)
    for k in range(6):
        deps_e[k] = deps[k] - dlam * _W[k] * g[k]
    gk = _elastic_stress(s_n, p_n, c_e, r_G, deps_e, sig_e, c)
    for k in range(6):
        R[k] = (sig[k] - sig_e[k]) / pm_n
    dv_plus = dv if dv > 0.0 else 0.0
    for k in range(6):
        a1 = 0.75 * s[k] / p - alp[k]
        a2 = s[k] / (3.0 * p) - alp[k]
        R[6 + k] = alp[k] - alp_n[k] - omega * (a1 * dv_plus + omega_d * a2 * dd)
    ln_ratio = math.log(pmd) - ln_pm_n - c_p * dv
    chi = chi_n
    if chi_n > 0.0:         # (D): p'_m^r = (1 + chi) p'_mi^r
        chi = chi_n * math.exp(-prm[8] * (abs(dv) + prm[9] * dd))
        ln_ratio -= math.log1p(chi) - math.log1p(chi_n)
    R[12] = ln_ratio - inv_beta * z if active else z
    if not want_jac:
        return ln_ratio, dlam, gk, chi

    # ---- analytic Jacobian: chain rule through (F), (V), (E), (R), (H). Per column j (13 unknowns) the
    # derivatives of p', M^2 - alpha^2, xi:xi and xi:alpha_d (dxi_k/dsigma'_j = delta_kj - (I_k + alpha_k) I_j/3,
    # dxi_k/dalpha_j = -p' delta_kj), then 6 x 13 blocks for g, d eps^e and the residual rows.
    third = 1.0 / 3.0
    ip, iMa, ipMa, ipm = 1.0 / p, 1.0 / Ma, 1.0 / (p * Ma), 1.0 / pm_n
    dp, dMa, dB, dD1 = ws[20], ws[21], ws[22], ws[23]
    dpmd, dE, dpM, dtrg = ws[24], ws[25], ws[26], ws[27]
    ddv, ddd, dl, tr_dde = ws[28], ws[29], ws[30], ws[31]
    dg, dde = ws[8:14], ws[14:20]
    tr_xi = xi[0] + xi[1] + xi[2]
    tr_alp = alp[0] + alp[1] + alp[2]
    D1 = _dot(xi, alp)
    A2 = _dot(alp, alp)
    for j in range(6):      # sigma'_j columns and alpha_j columns
        dp[j] = _I[j] * third
        dMa[j] = 0.0
        dB[j] = 2.0 * (_W[j] * xi[j] - dp[j] * (tr_xi + D1))
        dD1[j] = _W[j] * alp[j] - dp[j] * (tr_alp + A2)
        dp[6 + j] = 0.0
        dMa[6 + j] = -3.0 * _W[j] * alp[j]
        dB[6 + j] = -2.0 * p * _W[j] * xi[j]
        dD1[6 + j] = _W[j] * (xi[j] - p * alp[j])
    dp[12] = dMa[12] = dB[12] = dD1[12] = 0.0  # z column
    C = pmd - p
    for j in range(_NX):
        dpmd[j] = dp[j] + 1.5 * dB[j] * ipMa - C * (dMa[j] * iMa + dp[j] * ip)
        dE[j] = dD1[j] + (dMa[j] * (pmd - 2.0 * p) + Ma * (dpmd[j] - 2.0 * dp[j])) * third
        dpM[j] = dp[j] * Ma + p * dMa[j]
        dl[j] = 0.0
    dl[12] = dlam
    for k in range(6):      # g = (3 xi - E I)/(p' Ma)
        for j in range(_NX):
            dg[k, j] = -(dE[j] * _I[k] + g[k] * dpM[j]) * ipMa
        for j in range(3):
            dg[k, j] -= (_I[k] + alp[k]) * ipMa
        dg[k, k] += 3.0 * ipMa
        dg[k, 6 + k] -= 3.0 * p * ipMa
    tr_gdev = gdev[0] + gdev[1] + gdev[2]
    for j in range(_NX):
        dtrg[j] = dg[0, j] + dg[1, j] + dg[2, j]
        ddv[j] = dlam * dtrg[j] + trg * dl[j]                 # d(d eps_v^vp)
        ddd[j] = sq * dl[j] - dlam * (2.0 / 3.0) * tr_gdev * dtrg[j] * third / sq
    for k in range(6):
        f = dlam * (2.0 / 3.0) * _W[k] * gdev[k] / sq
        for j in range(_NX):
            ddd[j] += f * dg[k, j]                           # d(d eps_d^vp)
            dde[k, j] = -_W[k] * (dlam * dg[k, j] + g[k] * dl[j])  # d(d eps^e)
    for j in range(_NX):
        tr_dde[j] = dde[0, j] + dde[1, j] + dde[2, j]
    for k in range(6):      # R_sigma = (sigma' - sigma'_E)/p'_m,n^r, d sigma'_E = S_e d eps^e (_apply_stiffness)
        gT, gTI, ck = gk * _T[k], gk * _T[k] * _I[k] * third, c[k]
        for j in range(_NX):
            J[k, j] = -(gT * dde[k, j] - gTI * tr_dde[j] + ck * tr_dde[j]) * ipm
        J[k, k] += ipm
    dv_plus = dv if dv > 0.0 else 0.0
    h_pos = 1.0 if dv > 0.0 else 0.0
    f_s = -omega * (0.75 * dv_plus + omega_d * dd * third) * ip  # coefficient of d(s_k)/p' - s_k dp'/p'^2 terms
    diag = 1.0 + omega * (dv_plus + omega_d * dd)
    for k in range(6):      # R_alpha
        sp = s[k] * ip
        a1 = -omega * (0.75 * sp - alp[k]) * h_pos
        a2 = -omega * omega_d * (sp * third - alp[k])
        for j in range(_NX):
            J[6 + k, j] = a1 * ddv[j] + a2 * ddd[j] - f_s * sp * dp[j]
        for j in range(3):
            J[6 + k, j] -= f_s * _I[k] * third
        J[6 + k, k] += f_s
        J[6 + k, 6 + k] += diag
    if active:              # R_z
        for j in range(_NX):
            J[12, j] = dpmd[j] / pmd - c_p * ddv[j]
        if chi_n > 0.0:     # -d ln(1 + chi) = xi chi/(1 + chi) (sign(dv) d(d eps_v^vp) + xi_d d(d eps_d^vp))
            f_chi = prm[8] * chi / (1.0 + chi)
            sgn = 1.0 if dv > 0.0 else (-1.0 if dv < 0.0 else 0.0)
            for j in range(_NX):
                J[12, j] += f_chi * (sgn * ddv[j] + prm[9] * ddd[j])
        J[12, 12] -= inv_beta
    else:
        for j in range(_NX):
            J[12, j] = 0.0
        J[12, 12] = 1.0
    return ln_ratio, dlam, gk, chi


@jit
def _lu_factor(A, piv):
    """In-place LU with partial pivoting of A (13 x 13); False if a pivot is zero or not finite."""
    n = _NX
    for k in range(n):
        imax = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                imax, amax = i, abs(A[i, k])
        if not (amax > 0.0 and amax < np.inf):
            return False
        piv[k] = imax
        if imax != k:
            for j in range(n):
                A[k, j], A[imax, j] = A[imax, j], A[k, j]
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            A[i, k] = f
            for j in range(k + 1, n):
                A[i, j] -= f * A[k, j]
    return True


@jit
def _lu_solve(A, piv, b):
    """Solve in place A x = b with the factors of ``_lu_factor``."""
    n = _NX
    for k in range(n):
        if piv[k] != k:
            b[k], b[piv[k]] = b[piv[k]], b[k]
    for i in range(n):
        for j in range(i):
            b[i] -= A[i, j] * b[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            b[i] -= A[i, j] * b[j]
        b[i] /= A[i, i]


@jit(inline="always")  # one call site (update_points): compiled once, inside it
def _local_solve(sig_n, alp_n, pm_n, chi_n, deps, dt, prm, viscous, tol, max_it, max_dz,
                 sig_o, alp_o, dvp_o, tan_o, ws, X, Xn, dX, R, J, LU, piv, rhs):
    """One backward-Euler increment of one point. Fills sig_o, alp_o (deviatoric), dvp_o, tan_o (6 x 6); returns
    (converged, p'_m^r at the end, p'_m^d/p'_m^r at the end, chi at the end)."""
    M2, c_e, c_p, r_G, inv_beta, mu = prm[0], prm[1], prm[2], prm[3], prm[6], prm[7]
    p_n = (sig_n[0] + sig_n[1] + sig_n[2]) / 3.0
    s_n = ws[7, :6]
    for k in range(6):
        s_n[k] = sig_n[k] - p_n * _I[k]
    ln_pm_n = math.log(pm_n)

    # elastic trial sigma'_E(d eps) and the surface through it with the old fabric
    sig_t, s_t, xi_t, g_t, c_t = ws[32, :6], ws[33, :6], ws[34, :6], ws[35, :6], ws[36, :6]
    _elastic_stress(s_n, p_n, c_e, r_G, deps, sig_t, c_t)
    p_t, _, pmd_t, _ = _surface(sig_t, alp_n, M2, s_t, xi_t, g_t)
    L_t = math.log(pmd_t) - ln_pm_n
    trg = g_t[0] + g_t[1] + g_t[2]
    G2 = 0.0
    for k in range(6):
        v = g_t[k] - trg / 3.0 * _I[k]
        G2 += _W[k] * v * v
    K_t = p_t * c_e
    A_el = (K_t * trg * trg + 2.0 * r_G * K_t * G2) / pmd_t
    A = A_el + c_p * trg
    if chi_n > 0.0:  # (D) softens the linearized hardening: d ln(1 + chi)/d lambda at chi_n
        A -= prm[8] * chi_n / (1.0 + chi_n) * (abs(trg) + prm[9] * math.sqrt(2.0 / 3.0 * G2))
    dlam_c = L_t / (A if A > 0.0 else A_el)  # linearized return to the reference surface
    if viscous:
        dlam_ref = mu * dt
        active = True
        z0 = L_t / inv_beta
        use_c = L_t > 0.0 and dlam_c > 0.0 and dlam_ref > 0.0
        if use_c:
            z0 = min(z0, math.log(dlam_c / dlam_ref))
            if A > 0.0:
                # scalar Newton on the linearized (V): L_t - A dlam_ref e^z - z/beta = 0 (concave, decreasing in z,
                # started right of its root): a cheap predictor of z for the full local Newton
                for _ in range(8):
                    dl = dlam_ref * math.exp(z0)
                    z0 += (L_t - A * dl - inv_beta * z0) / (A * dl + inv_beta)
    else:
        active = L_t > 1e-12
        dlam_ref = 1.0 if active else 0.0
        z0 = math.log(dlam_c if dlam_c > 0.0 else 1e-300) if active else 0.0
    valid_trial = np.isfinite(L_t) and p_t > 0.0
    if not (valid_trial and np.isfinite(z0)):
        z0 = 0.0
    # stress predictor: linearized return sigma'_E - d lambda D W g (elastic D at the trial state)
    dl0 = dlam_ref * math.exp(z0) if (valid_trial and active) else 0.0
    p_pred = 0.0
    for k in range(6):
        X[k] = sig_t[k] - dl0 * K_t * (trg * _I[k] + 2.0 * r_G * (g_t[k] - trg / 3.0 * _I[k]))
        p_pred += X[k] * _I[k] / 3.0
    if not (valid_trial and p_pred > 0.0 and _all_finite(X[:6])):
        for k in range(6):
            X[k] = sig_t[k]
    for k in range(6):
        X[6 + k] = alp_n[k]
    X[12] = z0

    # Newton with backtracking on |R|^2. One evaluation site (keeps the compiled code small): the full Newton step
    # is evaluated with the Jacobian (usually accepted: it becomes the next iterate), shorter line-search trials
    # without it (the accepted one is then re-evaluated with it).
    converged = False
    at_iterate = True  # Xn is the accepted iterate X
    n_jac = n_ls = 0
    step = 1.0
    m0 = 0.0
    ln_ratio, dlam, gk, chi = 0.0, 0.0, 0.0, chi_n
    Xn[:] = X
    while True:
        with_jac = at_iterate or step == 1.0
        ln_ratio, dlam, gk, chi = _evaluate(Xn, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, chi_n, prm, dlam_ref, active,
                                            with_jac, R, J, ws)
        m = 0.0
        rmax = 0.0
        for i in range(_NX):
            m += R[i] * R[i]
            rmax = max(rmax, abs(R[i]))
        if not at_iterate:  # line-search trial: accept on sufficient decrease, or after 10 halvings
            n_ls += 1
            if not ((np.isfinite(m) and (m <= (1.0 - 1e-4 * step) * m0 or m <= tol * tol)) or n_ls == 10):
                step *= 0.5
                for i in range(_NX):
                    Xn[i] = X[i] + step * dX[i]
                continue
            X[:] = Xn
            at_iterate = True
            if not with_jac:
                continue
        # at the accepted iterate X = Xn, with R and J
        if not np.isfinite(m):
            break
        if rmax <= tol:
            converged = True
            break
        n_jac += 1
        LU[:, :] = J
        if n_jac >= max_it or not _lu_factor(LU, piv):
            break
        for i in range(_NX):
            dX[i] = -R[i]
        _lu_solve(LU, piv, dX)
        if dX[12] > max_dz:
            f = max_dz / dX[12]
            for i in range(_NX):
                dX[i] *= f
        m0, step, n_ls, at_iterate = m, 1.0, 0, False
        for i in range(_NX):
            Xn[i] = X[i] + dX[i]
    if not converged:
        return False, pm_n, 0.0, chi_n

    # converged: R, J, g (ws[2]) and c (ws[6]) belong to X; consistent tangent dX/d(d eps) = J^-1 [S_e/p'_m,n^r; 0]
    LU[:, :] = J
    if not _lu_factor(LU, piv):
        return False, pm_n, 0.0, chi_n
    unit = ws[37, :6]
    for j in range(6):
        unit[:] = 0.0
        unit[j] = 1.0
        for i in range(_NX):
            rhs[i] = _apply_stiffness(gk, ws[6, :6], unit, i) / pm_n if i < 6 else 0.0
        _lu_solve(LU, piv, rhs)
        for i in range(6):
            tan_o[i, j] = rhs[i]
    g = ws[2, :6]
    tr_alp = (X[6] + X[7] + X[8]) / 3.0
    dvp_v = 0.0
    for k in range(6):
        sig_o[k] = X[k]
        alp_o[k] = X[6 + k] - tr_alp * _I[k]
        dvp_o[k] = dlam * _W[k] * g[k]
        dvp_v += dvp_o[k] * _I[k]
    pm_new = pm_n * math.exp(c_p * dvp_v)  # (H)
    if chi_n > 0.0:
        pm_new *= (1.0 + chi) / (1.0 + chi_n)  # (D), chi from the converged residual
    ok = _all_finite(tan_o) and (X[0] + X[1] + X[2]) > 0.0
    return ok, pm_new, math.exp(ln_ratio), chi


@jit
def update_points(stress, alpha, pm_ref, chi, deps, dt, prm, viscous, tol, max_it, max_dz, max_depth,
                  stress_out, alpha_out, pm_out, chi_out, dvp_out, vp_shear_out, ratio_out, tangent_out):
    """Integrate one increment at every point (arrays over n points: stress, alpha (n, 6), pm_ref (n,), chi (n,) the
    bonding (0 without destructuration), deps (n, 6), dt (n,), prm (n, 10) in the order PARAMETER_COLUMNS). A point
    that fails is split into halves (depth-first bisection, ``max_depth`` levels). Fills the *_out arrays (dvp_out
    the viscoplastic strain increment, vp_shear_out its eps_d^vp = sqrt(2/3 e^vp:e^vp)); returns the index of the
    first point that failed at the deepest level, or -1."""
    n = stress.shape[0]
    ws = np.zeros((38, _NX))  # scratch rows: 0-31 _evaluate, 7 and 32-37 _local_solve
    X, Xn, dX, R, rhs = np.zeros(_NX), np.zeros(_NX), np.zeros(_NX), np.zeros(_NX), np.zeros(_NX)
    J, LU = np.zeros((_NX, _NX)), np.zeros((_NX, _NX))
    piv = np.zeros(_NX, dtype=np.int64)
    sig_c, alp_c, dvp_c, sub_deps = np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6)
    units = 1 << max_depth
    for i in range(n):
        sig_c[:] = stress[i]
        alp_c[:] = alpha[i]
        pm_c = pm_ref[i]
        chi_c = chi[i]
        dvp_out[i, :] = 0.0
        pos = 0
        level = 0
        while pos < units:
            frac = 1.0 / (1 << level)
            for k in range(6):
                sub_deps[k] = deps[i, k] * frac
            ok, pm_new, ratio, chi_new = _local_solve(sig_c, alp_c, pm_c, chi_c, sub_deps, dt[i] * frac, prm[i],
                                                      viscous, tol, max_it, max_dz, stress_out[i], alpha_out[i],
                                                      dvp_c, tangent_out[i], ws, X, Xn, dX, R, J, LU, piv, rhs)
            if not ok:
                if level >= max_depth:
                    return i
                level += 1
                continue
            sig_c[:] = stress_out[i]
            alp_c[:] = alpha_out[i]
            pm_c = pm_new
            chi_c = chi_new
            ratio_out[i] = ratio
            for k in range(6):
                dvp_out[i, k] += dvp_c[k]
            pos, level = next_substep(pos, level, units)
        pm_out[i] = pm_c
        chi_out[i] = chi_c
        dv = (dvp_out[i, 0] + dvp_out[i, 1] + dvp_out[i, 2]) / 3.0
        e2 = 0.0
        for k in range(6):  # eps_d^vp increment sqrt(2/3 e:e) of the whole increment (engineering shear: weight 1/2)
            e = dvp_out[i, k] - dv * _I[k]
            e2 += e * e / _W[k]
        vp_shear_out[i] = math.sqrt(2.0 / 3.0 * e2)
    return -1


@jit
def surface_size_points(stress, alpha, M2):
    """p'_m^d (kPa) of the surface (F) through each stress (n, 6) with fabric alpha (n, 6); M2 (n,)."""
    n = stress.shape[0]
    out = np.empty(n)
    s, xi, g = np.zeros(6), np.zeros(6), np.zeros(6)
    for i in range(n):
        _, _, pmd, _ = _surface(stress[i], alpha[i], M2[i], s, xi, g)
        out[i] = pmd
    return out
