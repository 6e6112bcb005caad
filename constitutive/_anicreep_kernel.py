"""Compiled (numba) per-point integrator of ANICREEP: the equations are those of :mod:`constitutive.anicreep`
(module docstring, docs/reference.md section 4), numbered (E), (F), (V), (H), (R) as there.

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

Components in play. Every rate in (E), (F), (V), (R), (H) is a linear combination of s, alpha_d and d eps, so shear
components that are zero in sigma', alpha_d and d eps at the start of an increment stay zero, and the residuals in
them decouple (p', M^2 - alpha^2, xi:xi, xi:alpha_d and d eps_d^vp depend on them only quadratically). Each point is
therefore integrated in the fewest leading Voigt components that carry everything: nc = 3 (no shear: triaxial and
oedometer tests), 4 (gamma_23 = gamma_31 = 0: the axisymmetric FE) or 6, with 2 nc + 1 unknowns X = (sigma'[:nc],
alpha_d[:nc], z) instead of 13. Same arithmetic on the components kept (the dropped ones only ever added exact
zeros). The tangent's rows and columns of a dropped shear component k are zero off the diagonal; its diagonal
follows from the decoupled 2 x 2 linearization of R_sigma,k and R_alpha,k (g_k = 3 xi_k/(p' Ma), xi_k = sigma'_k -
p' alpha_k):

    D_kk = G_bar / (1 + 6 G_bar d lambda (1 - p' a)/(p' Ma)),
    a = omega (3 <d eps_v^vp>/4 + omega_d d eps_d^vp/3) / (p' (1 + omega (<d eps_v^vp> + omega_d d eps_d^vp)))

(the dalpha_k/dsigma'_k of R_alpha). ``reduce=False`` in ``_anicreep_points.update_points`` integrates all 6 (the
tests' oracle).

Compilation: every helper is inlined (``jit(inline="always")``) into ``_local_solve``, itself inlined into the
integration of points (:mod:`constitutive._anicreep_points`: the FE's and the laboratory loops' update of one point).
"""
from __future__ import annotations

import math

import numpy as np

from .jit import STRAIN_TO_TENSOR as _T
from .jit import VOIGT_IDENTITY as _I
from .jit import VOIGT_WEIGHTS as _W
from .jit import all_finite as _all_finite
from .jit import expm1_over_x as _expm1_over_x
from .jit import jit

MAX_NX = 13                                     # unknowns per point with all 6 components (2 nc + 1)
#: columns of the per-point parameter array ``prm``
PARAMETER_COLUMNS = ("M2", "c_e", "c_p", "r_G", "omega", "omega_d", "inv_beta", "mu", "xi", "xi_d")
#: the failure codes of a point's update (``_anicreep_steps.point_update``): the local Newton failed (info: dt, then
#: the stress at the increment's start); the void ratio would fall to zero or below (info: the new and the old one)
LOCAL_NEWTON_FAILED, VOID_RATIO_COLLAPSED = 1, 2


@jit(inline="always")
def _dot(a, b, nc):
    """a:b of two stress-like Voigt vectors (the first nc components)."""
    shear = 0.0
    for k in range(3, nc):
        shear += a[k] * b[k]
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * shear


@jit(inline="always")
def components_in_play(stress, alpha, deps):
    """3, 4 or 6: the leading Voigt components that carry every non-zero shear of one point (module docstring)."""
    if stress[4] != 0.0 or stress[5] != 0.0 or alpha[4] != 0.0 or alpha[5] != 0.0 or deps[4] != 0.0 \
            or deps[5] != 0.0:
        return 6
    if stress[3] != 0.0 or alpha[3] != 0.0 or deps[3] != 0.0:
        return 4
    return 3


@jit(inline="always")
def _surface(sig, alp, M2, s, xi, g, nc):
    """(F) through sig with fabric alp: fills s (deviator), xi = s - p' alp, g = df/dsigma'/(p'(M^2 - alpha^2)) (V);
    returns p', M^2 - alpha^2, p'_m^d and E = xi:alp + (M^2 - alpha^2)(p'_m^d - 2p')/3 (g = (3 xi - E I)/(p' Ma))."""
    p = (sig[0] + sig[1] + sig[2]) / 3.0
    for k in range(nc):
        s[k] = sig[k] - p * _I[k]
        xi[k] = s[k] - p * alp[k]
    Ma = M2 - 1.5 * _dot(alp, alp, nc)
    pmd = p + 1.5 * _dot(xi, xi, nc) / (Ma * p)
    E = _dot(xi, alp, nc) + Ma * (pmd - 2.0 * p) / 3.0
    for k in range(nc):
        g[k] = (3.0 * xi[k] - E * _I[k]) / (p * Ma)
    return p, Ma, pmd, E


@jit(inline="always")
def _elastic_stress(s_n, p_n, c_e, r_G, deps_e, sig_e, c, nc):
    """(E) integrated exactly along the elastic strain increment deps_e (engineering Voigt): p' = p'_n exp(x),
    x = c_e d eps_v^e; s = s_n + 2 G_bar de^e, G_bar = r_G K_bar, K_bar = p'_n c_e phi(x). Fills sig_e and the
    vector c; returns G_bar. The stiffness d sig_e/d deps_e is S_e v = G_bar T o (v - I tr(v)/3) + c tr(v)
    (``_stiffness_entry``)."""
    dve = deps_e[0] + deps_e[1] + deps_e[2]
    x = c_e * dve
    p_e = p_n * math.exp(x)
    phi, dphi = _expm1_over_x(x)
    gk = r_G * p_n * c_e * phi
    gk_x = r_G * p_n * c_e * c_e * dphi  # d(r_G K_bar)/d(d eps_v^e)
    for k in range(nc):
        dev = (deps_e[k] - dve / 3.0 * _I[k]) * _T[k]
        sig_e[k] = s_n[k] + gk * dev + p_e * _I[k]
        c[k] = gk_x * dev + p_e * c_e * _I[k]
    return gk


@jit(inline="always")
def _stiffness_entry(gk, c, k, j):
    """(S_e)_kj = d sigma'_E,k/d(d eps^e_j) (``_elastic_stress``)."""
    return gk * _T[k] * ((1.0 if k == j else 0.0) - _I[k] * _I[j] / 3.0) + c[k] * _I[j]


@jit(inline="always")
def _evaluate(X, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, chi_n, prm, dlam_ref, active, want_jac, skip_tol, nc, R, J,
              ws):
    """Residuals R (2 nc + 1) at X = (sigma'[:nc], alpha_d[:nc], z) and, when ``want_jac`` and some |R_i| exceeds
    ``skip_tol`` (a converged point needs no Jacobian unless for its tangent), the analytic Jacobian
    J = dR/dX. ``ws`` is scratch (rows 0-31 used here, 32 x 13 at least); on return ws[2, :nc] holds g and, with
    ``want_jac``, ws[6, :nc] the vector c of the elastic stiffness (``_elastic_stress``). Returns (ln(p'_m^d/p'_m^r),
    d lambda, G_bar, chi at the end of the increment)."""
    M2, c_e, c_p, r_G, omega, omega_d, inv_beta = prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6]
    nx = 2 * nc + 1
    iz = 2 * nc                                      # index of z
    sig = X[0:nc]
    alp = X[nc:iz]
    z = X[iz]
    s, xi, g, gdev, deps_e, sig_e, c = ws[0, :6], ws[1, :6], ws[2, :6], ws[3, :6], ws[4, :6], ws[5, :6], ws[6, :6]
    p, Ma, pmd, E = _surface(sig, alp, M2, s, xi, g, nc)
    dlam = dlam_ref * math.exp(z)
    trg = g[0] + g[1] + g[2]
    for k in range(nc):
        gdev[k] = g[k] - trg / 3.0 * _I[k]
    sq = math.sqrt(2.0 / 3.0 * _dot(gdev, gdev, nc) + 1e-30)
    dv = dlam * trg                                  # d eps_v^vp
    dd = dlam * sq                                   # d eps_d^vp (magnitude)
    for k in range(nc):
        deps_e[k] = deps[k] - dlam * _W[k] * g[k]
    gk = _elastic_stress(s_n, p_n, c_e, r_G, deps_e, sig_e, c, nc)
    for k in range(nc):
        R[k] = (sig[k] - sig_e[k]) / pm_n
    dv_plus = dv if dv > 0.0 else 0.0
    for k in range(nc):
        a1 = 0.75 * s[k] / p - alp[k]
        a2 = s[k] / (3.0 * p) - alp[k]
        R[nc + k] = alp[k] - alp_n[k] - omega * (a1 * dv_plus + omega_d * a2 * dd)
    ln_ratio = math.log(pmd) - ln_pm_n - c_p * dv
    chi = chi_n
    if chi_n > 0.0:         # (D): p'_m^r = (1 + chi) p'_mi^r
        chi = chi_n * math.exp(-prm[8] * (abs(dv) + prm[9] * dd))
        ln_ratio -= math.log1p(chi) - math.log1p(chi_n)
    R[iz] = ln_ratio - inv_beta * z if active else z
    rmax = 0.0
    for k in range(nx):
        rmax = max(rmax, abs(R[k]))
    if not want_jac or rmax <= skip_tol:
        return ln_ratio, dlam, gk, chi

    # ---- analytic Jacobian: chain rule through (F), (V), (E), (R), (H). Per column j (nx unknowns) the
    # derivatives of p', M^2 - alpha^2, xi:xi and xi:alpha_d (dxi_k/dsigma'_j = delta_kj - (I_k + alpha_k) I_j/3,
    # dxi_k/dalpha_j = -p' delta_kj), then nc x nx blocks for g, d eps^e and the residual rows.
    third = 1.0 / 3.0
    ip, iMa, ipMa, ipm = 1.0 / p, 1.0 / Ma, 1.0 / (p * Ma), 1.0 / pm_n
    dp, dMa, dB, dD1 = ws[20], ws[21], ws[22], ws[23]
    dpmd, dE, dpM, dtrg = ws[24], ws[25], ws[26], ws[27]
    ddv, ddd, dl, tr_dde = ws[28], ws[29], ws[30], ws[31]
    dg, dde = ws[8:14], ws[14:20]
    tr_xi = xi[0] + xi[1] + xi[2]
    tr_alp = alp[0] + alp[1] + alp[2]
    D1 = _dot(xi, alp, nc)
    A2 = _dot(alp, alp, nc)
    for j in range(nc):     # sigma'_j columns and alpha_j columns
        dp[j] = _I[j] * third
        dMa[j] = 0.0
        dB[j] = 2.0 * (_W[j] * xi[j] - dp[j] * (tr_xi + D1))
        dD1[j] = _W[j] * alp[j] - dp[j] * (tr_alp + A2)
        dp[nc + j] = 0.0
        dMa[nc + j] = -3.0 * _W[j] * alp[j]
        dB[nc + j] = -2.0 * p * _W[j] * xi[j]
        dD1[nc + j] = _W[j] * (xi[j] - p * alp[j])
    dp[iz] = dMa[iz] = dB[iz] = dD1[iz] = 0.0  # z column
    C = pmd - p
    for j in range(nx):
        dpmd[j] = dp[j] + 1.5 * dB[j] * ipMa - C * (dMa[j] * iMa + dp[j] * ip)
        dE[j] = dD1[j] + (dMa[j] * (pmd - 2.0 * p) + Ma * (dpmd[j] - 2.0 * dp[j])) * third
        dpM[j] = dp[j] * Ma + p * dMa[j]
        dl[j] = 0.0
    dl[iz] = dlam
    for k in range(nc):     # g = (3 xi - E I)/(p' Ma)
        for j in range(nx):
            dg[k, j] = -(dE[j] * _I[k] + g[k] * dpM[j]) * ipMa
        for j in range(3):
            dg[k, j] -= (_I[k] + alp[k]) * ipMa
        dg[k, k] += 3.0 * ipMa
        dg[k, nc + k] -= 3.0 * p * ipMa
    tr_gdev = gdev[0] + gdev[1] + gdev[2]
    for j in range(nx):
        dtrg[j] = dg[0, j] + dg[1, j] + dg[2, j]
        ddv[j] = dlam * dtrg[j] + trg * dl[j]                 # d(d eps_v^vp)
        ddd[j] = sq * dl[j] - dlam * (2.0 / 3.0) * tr_gdev * dtrg[j] * third / sq
    for k in range(nc):
        f = dlam * (2.0 / 3.0) * _W[k] * gdev[k] / sq
        for j in range(nx):
            ddd[j] += f * dg[k, j]                           # d(d eps_d^vp)
            dde[k, j] = -_W[k] * (dlam * dg[k, j] + g[k] * dl[j])  # d(d eps^e)
    for j in range(nx):
        tr_dde[j] = dde[0, j] + dde[1, j] + dde[2, j]
    for k in range(nc):     # R_sigma = (sigma' - sigma'_E)/p'_m,n^r, d sigma'_E = S_e d eps^e (_stiffness_entry)
        gT, gTI, ck = gk * _T[k], gk * _T[k] * _I[k] * third, c[k]
        for j in range(nx):
            J[k, j] = -(gT * dde[k, j] - gTI * tr_dde[j] + ck * tr_dde[j]) * ipm
        J[k, k] += ipm
    dv_plus = dv if dv > 0.0 else 0.0
    h_pos = 1.0 if dv > 0.0 else 0.0
    f_s = -omega * (0.75 * dv_plus + omega_d * dd * third) * ip  # coefficient of d(s_k)/p' - s_k dp'/p'^2 terms
    diag = 1.0 + omega * (dv_plus + omega_d * dd)
    for k in range(nc):     # R_alpha
        sp = s[k] * ip
        a1 = -omega * (0.75 * sp - alp[k]) * h_pos
        a2 = -omega * omega_d * (sp * third - alp[k])
        for j in range(nx):
            J[nc + k, j] = a1 * ddv[j] + a2 * ddd[j] - f_s * sp * dp[j]
        for j in range(3):
            J[nc + k, j] -= f_s * _I[k] * third
        J[nc + k, k] += f_s
        J[nc + k, nc + k] += diag
    if active:              # R_z
        for j in range(nx):
            J[iz, j] = dpmd[j] / pmd - c_p * ddv[j]
        if chi_n > 0.0:     # -d ln(1 + chi) = xi chi/(1 + chi) (sign(dv) d(d eps_v^vp) + xi_d d(d eps_d^vp))
            f_chi = prm[8] * chi / (1.0 + chi)
            sgn = 1.0 if dv > 0.0 else (-1.0 if dv < 0.0 else 0.0)
            for j in range(nx):
                J[iz, j] += f_chi * (sgn * ddv[j] + prm[9] * ddd[j])
        J[iz, iz] -= inv_beta
    else:
        for j in range(nx):
            J[iz, j] = 0.0
        J[iz, iz] = 1.0
    return ln_ratio, dlam, gk, chi


@jit(inline="always")
def _copy_square(A, B, n):
    """B[:n, :n] = A[:n, :n], element by element (no array views)."""
    for i in range(n):
        for j in range(n):
            B[i, j] = A[i, j]


@jit(inline="always")
def _lu_factor(A, piv, n):
    """In-place LU with partial pivoting of A[:n, :n]; False if a pivot is zero or not finite."""
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


@jit(inline="always")
def _lu_solve(A, piv, b, n):
    """Solve in place A[:n, :n] x = b[:n] with the factors of ``_lu_factor``."""
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


@jit(inline="always")
def _local_solve(sig_n, alp_n, pm_n, chi_n, deps, dt, prm, viscous, tol, max_it, max_dz, nc, want_tangent,
                 sig_o, alp_o, dvp_o, tan_o, ws, X, Xn, dX, R, J, LU, piv, rhs):
    """One backward-Euler increment of one point in its first nc Voigt components (the others zero: module
    docstring). Fills sig_o, alp_o (deviatoric), dvp_o and, with ``want_tangent``, tan_o (6 x 6); returns
    (converged, p'_m^r at the end, p'_m^d/p'_m^r at the end, chi at the end). Without the tangent the Newton
    iterates are the same; a full step that converges is then accepted without its Jacobian."""
    M2, c_e, c_p, r_G, inv_beta, mu = prm[0], prm[1], prm[2], prm[3], prm[6], prm[7]
    nx = 2 * nc + 1
    iz = 2 * nc
    p_n = (sig_n[0] + sig_n[1] + sig_n[2]) / 3.0
    s_n = ws[7, :6]
    for k in range(nc):
        s_n[k] = sig_n[k] - p_n * _I[k]
    ln_pm_n = math.log(pm_n)

    # elastic trial sigma'_E(d eps) and the surface through it with the old fabric
    sig_t, s_t, xi_t, g_t, c_t = ws[32, :6], ws[33, :6], ws[34, :6], ws[35, :6], ws[36, :6]
    _elastic_stress(s_n, p_n, c_e, r_G, deps, sig_t, c_t, nc)
    p_t, _, pmd_t, _ = _surface(sig_t, alp_n, M2, s_t, xi_t, g_t, nc)
    L_t = math.log(pmd_t) - ln_pm_n
    trg = g_t[0] + g_t[1] + g_t[2]
    G2 = 0.0
    for k in range(nc):
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
                    dz = (L_t - A * dl - inv_beta * z0) / (A * dl + inv_beta)
                    z0 += dz
                    if dz == 0.0:  # converged: the remaining iterations would change nothing
                        break
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
    for k in range(nc):
        X[k] = sig_t[k] - dl0 * K_t * (trg * _I[k] + 2.0 * r_G * (g_t[k] - trg / 3.0 * _I[k]))
        p_pred += X[k] * _I[k] / 3.0
    finite = True
    for k in range(nc):
        finite = finite and math.isfinite(X[k])
    if not (valid_trial and p_pred > 0.0 and finite):
        for k in range(nc):
            X[k] = sig_t[k]
    for k in range(nc):
        X[nc + k] = alp_n[k]
    X[iz] = z0

    # Newton with backtracking on |R|^2. One evaluation site (keeps the compiled code small): an iterate and a full
    # Newton step (usually accepted: it becomes the next iterate) are evaluated with the Jacobian, which is skipped
    # where the residual has converged and no tangent is wanted; shorter line-search trials without it (an accepted
    # one that has not converged, or converged when the tangent is wanted, is then re-evaluated with it).
    skip_tol = -1.0 if want_tangent else tol
    converged = False
    at_iterate = True  # Xn is the accepted iterate X
    n_jac = n_ls = 0
    step = 1.0
    m0 = 0.0
    ln_ratio, dlam, gk, chi = 0.0, 0.0, 0.0, chi_n
    for i in range(nx):
        Xn[i] = X[i]
    while True:
        with_jac = at_iterate or step == 1.0
        ln_ratio, dlam, gk, chi = _evaluate(Xn, deps, s_n, p_n, alp_n, pm_n, ln_pm_n, chi_n, prm, dlam_ref, active,
                                            with_jac, skip_tol, nc, R, J, ws)
        m = 0.0
        rmax = 0.0
        for i in range(nx):
            m += R[i] * R[i]
            rmax = max(rmax, abs(R[i]))
        if not at_iterate:  # line-search trial: accept on sufficient decrease, or after 10 halvings
            n_ls += 1
            if not ((np.isfinite(m) and (m <= (1.0 - 1e-4 * step) * m0 or m <= tol * tol)) or n_ls == 10):
                step *= 0.5
                for i in range(nx):
                    Xn[i] = X[i] + step * dX[i]
                continue
            for i in range(nx):
                X[i] = Xn[i]
            at_iterate = True
            if not with_jac:
                if rmax <= tol and not want_tangent:
                    converged = True
                    break
                continue
        # at the accepted iterate X = Xn, with R and J
        if not np.isfinite(m):
            break
        if rmax <= tol:
            converged = True
            break
        n_jac += 1
        _copy_square(J, LU, nx)
        if n_jac >= max_it or not _lu_factor(LU, piv, nx):
            break
        for i in range(nx):
            dX[i] = -R[i]
        _lu_solve(LU, piv, dX, nx)
        if dX[iz] > max_dz:
            f = max_dz / dX[iz]
            for i in range(nx):
                dX[i] *= f
        m0, step, n_ls, at_iterate = m, 1.0, 0, False
        for i in range(nx):
            Xn[i] = X[i] + dX[i]
    if not converged:
        return False, pm_n, 0.0, chi_n

    g = ws[2, :6]  # converged: R, g (ws[2]) and, with the tangent, J and c (ws[6]) belong to X
    tr_alp = (X[nc] + X[nc + 1] + X[nc + 2]) / 3.0
    dvp_v = 0.0
    for k in range(6):
        sig_o[k] = X[k] if k < nc else 0.0
        alp_o[k] = X[nc + k] - tr_alp * _I[k] if k < nc else 0.0
        dvp_o[k] = dlam * _W[k] * g[k] if k < nc else 0.0
        dvp_v += dvp_o[k] * _I[k]
    if want_tangent and not _tangent(gk, ws[6, :6], g, X, dlam, prm, pm_n, nc, J, LU, piv, rhs, tan_o):
        return False, pm_n, 0.0, chi_n
    pm_new = pm_n * math.exp(c_p * dvp_v)  # (H)
    if chi_n > 0.0:
        pm_new *= (1.0 + chi) / (1.0 + chi_n)  # (D), chi from the converged residual
    ok = (X[0] + X[1] + X[2]) > 0.0
    return ok, pm_new, math.exp(ln_ratio), chi


@jit(inline="always")
def _tangent(gk, c, g, X, dlam, prm, pm_n, nc, J, LU, piv, rhs, tan_o):
    """Consistent tangent tan_o = d sigma'/d(d eps) (6 x 6) at the converged X with Jacobian J: dX/d(d eps) =
    J^-1 [S_e/p'_m,n^r; 0] in the nc components, the closed-form diagonal of the dropped shear components (module
    docstring). False when J is singular or the tangent not finite."""
    nx = 2 * nc + 1
    iz = 2 * nc
    _copy_square(J, LU, nx)
    if not _lu_factor(LU, piv, nx):
        return False
    for i in range(6):
        for j in range(6):
            tan_o[i, j] = 0.0
    for j in range(nc):
        for i in range(nx):
            rhs[i] = _stiffness_entry(gk, c, i, j) / pm_n if i < nc else 0.0
        _lu_solve(LU, piv, rhs, nx)
        for i in range(nc):
            tan_o[i, j] = rhs[i]
    if nc < 6:  # diagonal of the dropped shear components (module docstring)
        p = (X[0] + X[1] + X[2]) / 3.0
        Ma = prm[0] - 1.5 * _dot(X[nc:iz], X[nc:iz], nc)
        trg = g[0] + g[1] + g[2]
        G2 = 0.0
        for k in range(nc):
            v = g[k] - trg / 3.0 * _I[k]
            G2 += _W[k] * v * v
        dv_plus = max(dlam * trg, 0.0)
        dd = dlam * math.sqrt(2.0 / 3.0 * G2 + 1e-30)
        omega, omega_d = prm[4], prm[5]
        a = omega * (0.75 * dv_plus + omega_d * dd / 3.0) / (p * (1.0 + omega * (dv_plus + omega_d * dd)))
        d_shear = gk / (1.0 + 6.0 * gk * dlam * (1.0 - p * a) / (p * Ma))
        for k in range(nc, 6):
            tan_o[k, k] = d_shear
    return _all_finite(tan_o)


@jit
def surface_size_points(stress, alpha, M2):
    """p'_m^d (kPa) of the surface (F) through each stress (n, 6) with fabric alpha (n, 6); M2 (n,)."""
    n = stress.shape[0]
    out = np.empty(n)
    s, xi, g = np.zeros(6), np.zeros(6), np.zeros(6)
    for i in range(n):
        _, _, pmd, _ = _surface(stress[i], alpha[i], M2[i], s, xi, g, 6)
        out[i] = pmd
    return out
