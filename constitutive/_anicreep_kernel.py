"""Compiled (numba) per-point integrator of ANICREEP: the equations are those of :mod:`constitutive.anicreep`
(module docstring, REFERENCE.md section 4), numbered (E), (F), (V), (H), (R) as there.

Compression positive, kPa, s. Voigt order (11, 22, 33, 12, 23, 31); stress-like vectors (sigma', s, alpha_d, g)
carry tensor shear components, strain vectors engineering shear. Per point, one increment is integrated by
backward Euler in the unknowns X = (sigma' (6), alpha_d (6), z), d lambda = d lambda_ref exp(z), with residuals

    R_sigma = (sigma' - sigma'_E(d eps - d lambda W g))/p'_m,n^r     (E), W = (1, 1, 1, 2, 2, 2)
    R_alpha = alpha_d - alpha_d,n - omega[(3s/(4p') - alpha_d)<d eps_v^vp> + omega_d (s/(3p') - alpha_d) d eps_d^vp] (R)
    R_z     = ln(p'_m^d/p'_m,n^r) - c_p d eps_v^vp - z/beta              (F), (H), (V) in log form
              (rate independent: 1/beta = 0; R_z = z where the elastic trial lies inside the reference surface).

The Jacobian dR/dX is ANALYTIC (forward-mode chain rule written out in ``_evaluate``; the test suite checks it
against complex-step differentiation of an independent numpy residual). Newton with the z-step limited to
``max_dz`` and backtracking on |R|^2; a point that fails is sub-stepped (halves, recursively up to ``max_depth``
levels, in the order of a depth-first bisection). The consistent tangent is dsigma'/d(d eps) = [J^-1 dR/d(d eps)]
from the converged LU factors (implicit-function theorem); for a sub-stepped point it is the last sub-step's.
"""
from __future__ import annotations

import math

import numpy as np

from ._jit import jit

_I = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])   # identity, Voigt
_W = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])   # a:b = sum W a b for stress-like Voigt vectors
_T = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])   # engineering-strain deviator -> 2 x tensor deviator
_NX = 13                                        # unknowns per point
#: columns of the per-point parameter array ``prm``
PARAMETER_COLUMNS = ("M2", "c_e", "c_p", "r_G", "omega", "omega_d", "inv_beta", "mu")


@jit
def _dot(a, b):
    """a:b of two stress-like Voigt vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5])


@jit
def _expm1_over_x(x):
    """phi(x) = (exp(x) - 1)/x and phi'(x); series sum_k x^k/(k+1)! (k <= 6) for |x| < 1e-2 (error < 4e-16)."""
    if abs(x) < 1e-2:
        phi = 1.0 + x * (1 / 2 + x * (1 / 6 + x * (1 / 24 + x * (1 / 120 + x * (1 / 720 + x / 5040)))))
        dphi = 1 / 2 + x * (2 / 6 + x * (3 / 24 + x * (4 / 120 + x * (5 / 720 + x * 6 / 5040))))
        return phi, dphi
    return math.expm1(x) / x, (math.exp(x) * (x - 1.0) + 1.0) / (x * x)


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
def _elastic_stress(s_n, p_n, c_e, r_G, deps_e, sig_e, S_e, want_tangent):
    """(E) integrated exactly along the elastic strain increment deps_e (engineering Voigt): fills sig_e and, when
    ``want_tangent``, S_e = d sig_e/d deps_e (6 x 6). p' = p'_n exp(x), x = c_e d eps_v^e; s = s_n + 2 G_bar de^e,
    G_bar = r_G K_bar, K_bar = p'_n c_e phi(x)."""
    dve = deps_e[0] + deps_e[1] + deps_e[2]
    x = c_e * dve
    p_e = p_n * math.exp(x)
    phi, dphi = _expm1_over_x(x)
    gk = r_G * p_n * c_e * phi
    gk_x = r_G * p_n * c_e * c_e * dphi  # d(G_bar-like factor)/d(d eps_v^e)
    for k in range(6):
        dev = (deps_e[k] - dve / 3.0 * _I[k]) * _T[k]
        sig_e[k] = s_n[k] + gk * dev + p_e * _I[k]
        if want_tangent:
            for m in range(6):
                v = gk * _T[k] * ((1.0 if k == m else 0.0) - _I[k] * _I[m] / 3.0)
                if m < 3:
                    v += gk_x * dev + p_e * c_e * _I[k]
                S_e[k, m] = v


@jit
def _evaluate(X, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, prm, dlam_ref, active, want_jac, R, J, S_e, ws):
    """Residuals R (13) at X and, when ``want_jac``, the analytic Jacobian J = dR/dX (13 x 13) and S_e = d sig_E/d
    deps_e. ``ws`` is scratch (>= 35 x 13); on return ws[2, :6] holds g. Returns (ln(p'_m^d/p'_m^r), d lambda)."""
    M2, c_e, c_p, r_G, omega, omega_d, inv_beta = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6]
    sig = X[0:6]
    alp = X[6:12]
    z = X[12]
    s, xi, g, gdev, deps_e, sig_e = ws[0, :6], ws[1, :6], ws[2, :6], ws[3, :6], ws[4, :6], ws[5, :6]
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
    _elastic_stress(s_n, p_n, c_e, r_G, deps_e, sig_e, S_e, want_jac)
    for k in range(6):
        R[k] = (sig[k] - sig_e[k]) / pm_n
    dv_plus = dv if dv > 0.0 else 0.0
    for k in range(6):
        a1 = 0.75 * s[k] / p - alp[k]
        a2 = s[k] / (3.0 * p) - alp[k]
        R[6 + k] = alp[k] - alp_n[k] - omega * (a1 * dv_plus + omega_d * a2 * dd)
    ln_ratio = math.log(pmd) - ln_pm_n - c_p * dv
    R[12] = ln_ratio - inv_beta * z if active else z
    if not want_jac:
        return ln_ratio, dlam

    # ---- analytic Jacobian: derivatives of every intermediate with respect to the 13 unknowns (columns j)
    dxi, dg, dde = ws[8:14], ws[14:20], ws[20:26]
    dp, dMa, dpmd, ddv, ddd = ws[26], ws[27], ws[28], ws[29], ws[30]
    C = pmd - p
    pMa = p * Ma
    for k in range(6):
        for j in range(_NX):
            dxi[k, j] = 0.0
        for j in range(3):      # dxi_k/dsigma_j = delta_kj - (I_k + alp_k) I_j/3
            dxi[k, j] = -(_I[k] + alp[k]) / 3.0
        dxi[k, k] += 1.0
        dxi[k, 6 + k] = -p      # dxi_k/dalp_j = -p' delta_kj
    for j in range(_NX):
        dp[j] = 1.0 / 3.0 if j < 3 else 0.0
        dMa[j] = -3.0 * _W[j - 6] * alp[j - 6] if 6 <= j < 12 else 0.0
        dB = 0.0   # d(xi:xi)
        dD1 = 0.0  # d(xi:alp)
        for k in range(6):
            dB += _W[k] * xi[k] * dxi[k, j]
            dD1 += _W[k] * alp[k] * dxi[k, j]
        dB *= 2.0
        if 6 <= j < 12:
            dD1 += _W[j - 6] * xi[j - 6]
        dpmd[j] = dp[j] + 1.5 * dB / pMa - C * (dMa[j] / Ma + dp[j] / p)
        dE = dD1 + dMa[j] * (pmd - 2.0 * p) / 3.0 + Ma * (dpmd[j] - 2.0 * dp[j]) / 3.0
        dpM = dp[j] * Ma + p * dMa[j]
        dtrg = 0.0
        for k in range(6):
            dg[k, j] = (3.0 * dxi[k, j] - dE * _I[k] - g[k] * dpM) / pMa
            if k < 3:
                dtrg += dg[k, j]
        dl = dlam if j == 12 else 0.0
        dG = 0.0
        for k in range(6):
            dG += _W[k] * gdev[k] * (dg[k, j] - dtrg / 3.0 * _I[k])
        ddv[j] = dlam * dtrg + trg * dl
        ddd[j] = dlam * (2.0 / 3.0) * dG / sq + sq * dl
        for k in range(6):
            dde[k, j] = -_W[k] * (dlam * dg[k, j] + g[k] * dl)
    for k in range(6):          # R_sigma
        for j in range(_NX):
            acc = 0.0
            for m in range(6):
                acc += S_e[k, m] * dde[m, j]
            J[k, j] = ((1.0 if j == k else 0.0) - acc) / pm_n
    for k in range(6):          # R_alpha
        sp = s[k] / p
        a1 = 0.75 * sp - alp[k]
        a2 = sp / 3.0 - alp[k]
        for j in range(_NX):
            ds = ((1.0 if j == k else 0.0) - _I[k] * _I[j] / 3.0) if j < 6 else 0.0
            dsp = (ds - sp * dp[j]) / p
            e_j = 1.0 if j == 6 + k else 0.0
            ddv_plus = ddv[j] if dv > 0.0 else 0.0
            J[6 + k, j] = e_j - omega * ((0.75 * dsp - e_j) * dv_plus + a1 * ddv_plus
                                         + omega_d * ((dsp / 3.0 - e_j) * dd + a2 * ddd[j]))
    for j in range(_NX):        # R_z
        if active:
            J[12, j] = dpmd[j] / pmd - c_p * ddv[j] - (inv_beta if j == 12 else 0.0)
        else:
            J[12, j] = 1.0 if j == 12 else 0.0
    return ln_ratio, dlam


@jit
def _lu_factor(A, piv):
    """In-place LU with partial pivoting of the square A; False if a pivot is zero or not finite."""
    n = A.shape[0]
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
        for i in range(k + 1, n):
            f = A[i, k] / A[k, k]
            A[i, k] = f
            for j in range(k + 1, n):
                A[i, j] -= f * A[k, j]
    return True


@jit
def _lu_solve(A, piv, b):
    """Solve in place A x = b with the factors of ``_lu_factor``."""
    n = A.shape[0]
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


@jit
def _all_finite(a):
    for v in a.flat:
        if not np.isfinite(v):
            return False
    return True


@jit
def _local_solve(sig_n, alp_n, pm_n, deps, dt, prm, viscous, tol, max_it, max_dz,
                 sig_o, alp_o, dvp_o, tan_o, ws, X, Xn, dX, R, J, LU, piv, S_e, rhs):
    """One backward-Euler increment of one point. Fills sig_o, alp_o (deviatoric), dvp_o, tan_o (6 x 6); returns
    (converged, p'_m^r at the end, p'_m^d/p'_m^r at the end)."""
    M2, c_e, c_p, r_G, inv_beta, mu = prm[0], prm[1], prm[2], prm[3], prm[6], prm[7]
    p_n = (sig_n[0] + sig_n[1] + sig_n[2]) / 3.0
    s_n = ws[6, :6]
    for k in range(6):
        s_n[k] = sig_n[k] - p_n * _I[k]
    ln_pm_n = math.log(pm_n)

    # elastic trial sigma'_E(d eps) and the surface through it with the old fabric
    sig_t, s_t, xi_t, g_t = ws[31, :6], ws[32, :6], ws[33, :6], ws[34, :6]
    _elastic_stress(s_n, p_n, c_e, r_G, deps, sig_t, S_e, False)
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

    converged = False
    ln_ratio, dlam = 0.0, 0.0
    for _ in range(max_it):
        ln_ratio, dlam = _evaluate(X, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, prm, dlam_ref, active, True, R, J,
                                   S_e, ws)
        if not (_all_finite(R) and _all_finite(J)):
            break
        rmax = 0.0
        m0 = 0.0
        for i in range(_NX):
            rmax = max(rmax, abs(R[i]))
            m0 += R[i] * R[i]
        if rmax <= tol:
            converged = True
            break
        LU[:, :] = J
        if not _lu_factor(LU, piv):
            break
        for i in range(_NX):
            dX[i] = -R[i]
        _lu_solve(LU, piv, dX)
        if dX[12] > max_dz:
            f = max_dz / dX[12]
            for i in range(_NX):
                dX[i] *= f
        step = 1.0
        for _ls in range(10):  # backtracking on |R|^2
            for i in range(_NX):
                Xn[i] = X[i] + step * dX[i]
            _evaluate(Xn, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, prm, dlam_ref, active, False, R, J, S_e, ws)
            mn = 0.0
            for i in range(_NX):
                mn += R[i] * R[i]
            if np.isfinite(mn) and (mn <= (1.0 - 1e-4 * step) * m0 or mn <= tol * tol):
                break
            step *= 0.5
        X[:] = Xn
    if not converged:
        return False, pm_n, 0.0

    # converged: R, J, S_e and g (ws[2]) belong to X; consistent tangent dX/d(d eps) = J^-1 [S_e/p'_m,n^r; 0]
    LU[:, :] = J
    if not _lu_factor(LU, piv):
        return False, pm_n, 0.0
    for j in range(6):
        for i in range(_NX):
            rhs[i] = S_e[i, j] / pm_n if i < 6 else 0.0
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
    ok = _all_finite(tan_o) and (X[0] + X[1] + X[2]) > 0.0
    return ok, pm_new, math.exp(ln_ratio)


@jit
def update_points(stress, alpha, pm_ref, deps, dt, prm, viscous, tol, max_it, max_dz, max_depth,
                  stress_out, alpha_out, pm_out, dvp_out, ratio_out, tangent_out):
    """Integrate one increment at every point (arrays over n points: stress, alpha (n, 6), pm_ref (n,), deps
    (n, 6), dt (n,), prm (n, 8) in the order PARAMETER_COLUMNS). A point that fails is split into halves
    (depth-first bisection, ``max_depth`` levels). Fills the *_out arrays; returns the index of the first point that
    failed at the deepest level, or -1."""
    n = stress.shape[0]
    ws = np.zeros((36, _NX))
    X, Xn, dX, R, rhs = np.zeros(_NX), np.zeros(_NX), np.zeros(_NX), np.zeros(_NX), np.zeros(_NX)
    J, LU = np.zeros((_NX, _NX)), np.zeros((_NX, _NX))
    piv = np.zeros(_NX, dtype=np.int64)
    S_e = np.zeros((6, 6))
    sig_c, alp_c, dvp_c, sub_deps = np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6)
    units = 1 << max_depth
    for i in range(n):
        sig_c[:] = stress[i]
        alp_c[:] = alpha[i]
        pm_c = pm_ref[i]
        dvp_out[i, :] = 0.0
        pos = 0
        level = 0
        while pos < units:
            frac = 1.0 / (1 << level)
            for k in range(6):
                sub_deps[k] = deps[i, k] * frac
            ok, pm_new, ratio = _local_solve(sig_c, alp_c, pm_c, sub_deps, dt[i] * frac, prm[i], viscous, tol,
                                             max_it, max_dz, stress_out[i], alpha_out[i], dvp_c, tangent_out[i],
                                             ws, X, Xn, dX, R, J, LU, piv, S_e, rhs)
            if not ok:
                if level >= max_depth:
                    return i
                level += 1
                continue
            sig_c[:] = stress_out[i]
            alp_c[:] = alpha_out[i]
            pm_c = pm_new
            ratio_out[i] = ratio
            for k in range(6):
                dvp_out[i, k] += dvp_c[k]
            pos += units >> level
            while level > 0 and pos % (units >> (level - 1)) == 0:  # both halves of this level done: go up
                level -= 1
        pm_out[i] = pm_c
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
