"""Compiled (numba) SIMSAND: the local equations (III)-(VII), shared with the numpy integrator of
:mod:`constitutive.sand.simsand`, and the per-point integrator of the triaxial space.

Shared equations (``friction_terms``, ``peak_terms``, ``yield_value``, ``material_terms``): elementwise arithmetic that
numba compiles for floats (the kernel below) and for 1-D arrays (the numpy integrator of ``SIMSAND.update`` calls them
on arrays of points; ``prm`` is then the (len(PARAMETER_COLUMNS), n) parameter array, so ``prm[k]`` is a row of n
values, while the kernel passes one point's row of the (n, len(PARAMETER_COLUMNS)) array, so ``prm[k]`` is a float).
One source for the constitutive equations, whichever integrator runs them.

Triaxial integrator (``update_points``: one increment; ``triaxial_points``: a whole triaxial test, the fast path of
``SIMSAND.triaxial_test``): the scheme of ``SIMSAND._substeps`` (module docstring of simsand) written for one
axisymmetric point (sigma'_a, sigma'_r), (eps_a, eps_r): modified Euler with the local error control of Sloan et al.
(2001) and the same tolerances, stage-wise mixed control (a stress-controlled component keeps its prescribed stress
increment in every stage), the elastic-plastic crossing by the Pegasus method, one consistent drift correction per
plastic substep (normal correction where it is not possible), the tension cutoff at p_min, and the same failure rules
(codes below; messages in ``simsand.FAILURE_REASONS``). Points are independent and the loop over points runs inside the
kernel, so a batch gives the bits of separate calls. The numpy integrator of the triaxial space is kept in simsand as
the test oracle of this kernel (``SIMSAND(..., triaxial_integrator="numpy")``). Per point, where the numpy one works on
a batch: the Pegasus iteration stops when this point's crossing has converged (the numpy one iterates until every
crossing point of the batch has). A failed point returns its last accepted state; its substep hint is not meaningful.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit
from .constants import E_MAX_STIFFNESS

#: rows (numpy integrator) or columns (kernel) of the parameter array ``prm`` (``_lode``: 1.0 with the Lode dependence
#: of M_p and M_pt, 0.0 without it, see ``lode_argument``)
PARAMETER_COLUMNS = ("K_0", "n", "lambda_c", "xi", "k_p", "A_d", "n_p", "n_d", "_log_e_ref", "_log_tan_mu",
                     "_shear_ratio", "_lode")
K0, N, LAM, XI, KP, AD, NP, ND, LOG_EREF, LOG_TANMU, SHEAR_RATIO, LODE = range(len(PARAMETER_COLUMNS))
#: failure codes of the integrators (0: none): index into simsand.FAILURE_REASONS
NO_UNIQUE_RESPONSE, CONTROL_LOST, CONTROL_LOST_WITHIN, DRIFT_FAILED, STATE_INVALID, ERROR_CONTROL = range(1, 7)
_NAN = math.nan


# ------------------------------------------------------------------------------------------------ shared equations
@jit
def friction_terms(tan_phi, sin3theta):
    """M(theta) (VII, Sheng, Sloan & Yu 2000) for the friction angle with tangent ``tan_phi``, and dM/dtan phi,
    dM/dsin3theta. M_c = 6 sin phi/(3 - sin phi) at sin 3theta = +1, c M_c at -1, c = (3 - sin phi)/(3 + sin phi)."""
    sec2 = 1.0 + tan_phi * tan_phi
    root = np.sqrt(sec2)
    sin_phi = tan_phi / root
    Mc = 6.0 * sin_phi / (3.0 - sin_phi)
    c = (3.0 - sin_phi) / (3.0 + sin_phi)
    c2 = c * c
    c4 = c2 * c2
    den = 1.0 + c4 - (1.0 - c4) * sin3theta
    M = Mc * np.sqrt(np.sqrt(2.0 * c4 / den))
    dlnM_dc = 1.0 / c - c2 * c * (1.0 + sin3theta) / den
    dlnM_dsin = 3.0 / (sin_phi * (3.0 - sin_phi)) - 6.0 / (3.0 + sin_phi) ** 2 * dlnM_dc
    return M, M * dlnM_dsin / (sec2 * root), M * 0.25 * (1.0 - c4) / den


@jit
def lode_argument(sin3theta, lode):
    """The sin 3theta at which the friction ratios M_p and M_pt are evaluated: sin 3theta itself with the Lode
    dependence (``lode`` = 1.0, the column ``_lode``), +1 without it (``lode`` = 0.0: M(theta) = M_c for every Lode
    angle, a circular deviatoric section). Its derivative with respect to sin 3theta is ``lode``."""
    return lode * sin3theta + (1.0 - lode)


@jit
def peak_terms(pe, e, eps_dp, sin3theta, prm, p_at):
    """(VI) CSL and (VII) peak angle at p' = pe (floored at p_min by the caller), void ratio e: ln(p'/p_at),
    x = (p'/p_at)^xi, ln(e_c/e), H = eps_d^p/(k_p + eps_d^p) of (IV), tan phi_p, and (M_p, dM_p/dtan phi_p,
    dM_p/dsin3theta) (the last zero without Lode dependence)."""
    log_pr = np.log(pe / p_at)
    x = np.exp(prm[XI] * log_pr)
    log_r = prm[LOG_EREF] - prm[LAM] * x - np.log(e)
    tan_p = np.exp(prm[NP] * log_r + prm[LOG_TANMU])
    H = eps_dp / (prm[KP] + eps_dp)
    Mp, dMp_dtan, dMp_dsin3 = friction_terms(tan_p, lode_argument(sin3theta, prm[LODE]))
    return log_pr, x, log_r, H, tan_p, Mp, dMp_dtan, dMp_dsin3 * prm[LODE]


@jit
def yield_value(eta, pe, e, eps_dp, sin3theta, prm, p_at):
    """(f, M_p): the yield function (IV) f = eta - M_p H."""
    _, _, _, H, _, Mp, _, _ = peak_terms(pe, e, eps_dp, sin3theta, prm, p_at)
    return eta - H * Mp, Mp


@jit
def material_terms(eta, pe, e, eps_dp, sin3theta, prm, p_at):
    """Everything a local evaluation needs besides directions: f (IV); K of (III) and G = (G/K) K; df/dp' and df/de
    through M_p(e_c(p'), e) (d ln e_c/dp' = -lambda xi x/p'); the dilatancy A_d (M_pt - eta) of (V);
    K_p = -df/d eps_d^p; H dM_p/dsin3theta (the Lode part of the yield gradient)."""
    log_pr, x, log_r, H, tan_p, Mp, dMp_dtan, dMp_dsin3 = peak_terms(pe, e, eps_dp, sin3theta, prm, p_at)
    Mpt = friction_terms(np.exp(prm[LOG_TANMU] - prm[ND] * log_r), lode_argument(sin3theta, prm[LODE]))[0]
    K = prm[K0] * p_at * (E_MAX_STIFFNESS - e) ** 2 / (1.0 + e) * np.exp(prm[N] * log_pr)
    HdM = H * dMp_dtan * tan_p * prm[NP]
    df_dp = -eta / pe + HdM * prm[LAM] * prm[XI] * x / pe
    Kp = Mp * prm[KP] / (prm[KP] + eps_dp) ** 2
    return eta - H * Mp, K, prm[SHEAR_RATIO] * K, df_dp, HdM / e, prm[AD] * (Mpt - eta), Kp, H * dMp_dsin3


# ------------------------------------------------------------------------------------------------ triaxial point
@jit
def _fmax(a, b):
    """np.maximum for floats (NaN if either is NaN)."""
    if a != a or b != b:
        return _NAN
    return a if a >= b else b


@jit
def _finite(a, b):
    return math.isfinite(a) and math.isfinite(b)


@jit
def _invariants(sa, sr, p_min):
    """p', the deviator (s_a, s_r), q, p' floored at p_min, eta and whether a deviator exists."""
    p = (sa + sr * 2.0) / 3.0
    s0 = sa - p
    s1 = sr - p
    q = np.sqrt(3.0 * (0.5 * (s0 * s0 + s1 * s1 * 2.0)))
    pe = _fmax(p, p_min)
    return s0, s1, q, pe, q / pe, q > 1e-9 * pe


@jit
def _yield(sa, sr, e, eps, prm, p_at, p_min):
    """f (IV) at a triaxial state; sin 3theta = sign(sigma'_a - sigma'_r) (0 on the hydrostatic axis)."""
    s0, s1, q, pe, eta, shear = _invariants(sa, sr, p_min)
    return yield_value(eta, pe, e, eps, np.sign(s0 - s1) if shear else 0.0, prm, p_at)[0]


@jit
def _evaluate(sa, sr, e, eps, d0, d1, prm, p_at, p_min):
    """(f, K, G, Dm_a, Dm_r, den, Da_a, Da_r, df/de, a_a, a_r) at a triaxial state, SIMSAND._evaluate for one point;
    (d0, d1) the substep load: at q = 0 its deviatoric direction gives the flow direction and the Lode angle."""
    s0, s1, q, pe, eta, shear = _invariants(sa, sr, p_min)
    if shear:
        sin3 = np.sign(s0 - s1)
        n0 = 1.5 * s0 / q
        n1 = 1.5 * s1 / q
    else:  # origin of loading: the deviatoric direction of the increment (not round-off of a volumetric one)
        m = (d0 + d1 * 2.0) / 3.0
        dd0 = d0 - m
        dd1 = d1 - m
        dd = dd0 * dd0 + dd1 * dd1 * 2.0
        sin3, n0, n1 = 0.0, 0.0, 0.0
        if dd > 1e-20 * (d0 * d0 + d1 * d1):
            scale = np.sqrt(1.5 / dd)
            sin3, n0, n1 = np.sign(dd0 - dd1), dd0 * scale, dd1 * scale
    f, K, G, df_dp, df_de, dil, Kp, _ = material_terms(eta, pe, e, eps, sin3, prm, p_at)
    a0 = n0 / pe
    a1 = n1 / pe
    kdf = df_dp * K
    return (f, K, G, K * dil + 2.0 * G * n0, K * dil + 2.0 * G * n1,
            df_dp * K * dil + 2.0 * G * (a0 * n0 + a1 * n1 * 2.0) + Kp,
            2.0 * G * a0 + kdf, 2.0 * (2.0 * G * a1 + kdf), df_de, a0 + df_dp / 3.0, a1 + df_dp / 3.0)


@jit
def _elastic(K, G, d0, d1):
    """D d eps = K d eps_v I + 2 G dev(d eps) in (sigma'_a, sigma'_r)."""
    dv = d0 + d1 * 2.0
    m = dv / 3.0
    return K * dv + 2.0 * G * (d0 - m), K * dv + 2.0 * G * (d1 - m)


@jit
def _solve_mixed(K, G, Dm0, Dm1, den, l0, l1, row0, row1, plastic, held0, held1, csr):
    """Strain increment meeting the prescribed stress increments of the held components with the stage tangent
    (SIMSAND._solve_mixed); NaN where the tangent on the held components falls below csr times the elastic one."""
    lam = K - 2.0 * G / 3.0
    D00, D01, D10, D11 = lam + 2.0 * G, 2.0 * lam, lam, 2.0 * lam + 2.0 * G
    scale = 1.0 / den if plastic else 0.0
    if held0 and held1:
        c0 = Dm0 * scale
        c1 = Dm1 * scale
        T00, T01, T10, T11 = D00 - c0 * row0, D01 - c0 * row1, D10 - c1 * row0, D11 - c1 * row1
        stiff = T00 * T11 - T01 * T10
        stiff_el = D00 * D11 - D01 * D10
        d0 = (l0 * T11 - T01 * l1) / stiff
        d1 = (T00 * l1 - T10 * l0) / stiff
    elif held1:
        c = Dm1 * scale
        T0, stiff, stiff_el = D10 - c * row0, D11 - c * row1, D11
        d0, d1 = l0, (l1 - T0 * l0) / stiff
    else:
        c = Dm0 * scale
        stiff, T1, stiff_el = D00 - c * row0, D01 - c * row1, D00
        d0, d1 = (l0 - T1 * l1) / stiff, l1
    if not stiff > csr * stiff_el:
        return _NAN, _NAN
    return d0, d1


@jit
def _rates(ev, l0, l1, v0, plastic, held0, held1, csr):
    """Stage increments (d sigma'_a, d sigma'_r, d eps_a, d eps_r, d lambda) for the substep load (l0, l1)."""
    _, K, G, Dm0, Dm1, den, Da0, Da1, df_de, _, _ = ev
    row0 = Da0 - df_de * v0
    row1 = Da1 - df_de * v0 * 2.0
    d0, d1 = l0, l1
    if held0 or held1:
        d0, d1 = _solve_mixed(K, G, Dm0, Dm1, den, l0, l1, row0, row1, plastic, held0, held1, csr)
    dlam = (row0 * d0 + row1 * d1) / den if plastic else 0.0
    x0, x1 = _elastic(K, G, d0, d1)
    return x0 - dlam * Dm0, x1 - dlam * Dm1, d0, d1, dlam


@jit
def _crossing(sa, sr, dsa, dsr, e, de, eps, f0, f1, prm, p_at, p_min, ftol):
    """Fraction of an elastic substep where f = 0 (Pegasus method along the linearised elastic path)."""
    a0, a1, alpha = 0.0, 1.0, 1.0
    for _ in range(30):
        alpha = a1 - f1 * (a1 - a0) / (f1 - f0)
        fa = _yield(sa + alpha * dsa, sr + alpha * dsr, e + alpha * de, eps, prm, p_at, p_min)
        if abs(fa) <= ftol:
            break
        if fa * f1 < 0.0:
            a0, f0 = a1, f1
        else:
            f0 = f0 * f1 / (f1 + fa)
        a1, f1 = alpha, fa
    return alpha


@jit
def _drift(sa, sr, e, eps, dea, der, v0, ev, held0, held1, prm, p_at, p_min, ftol, csr):
    """One correction back to f = 0 keeping the held stress components (SIMSAND._drift_correct); ``ev`` is the
    evaluation at the second stage of the substep. Returns the corrected state, strain increment and a failure flag."""
    f = _yield(sa, sr, e, eps, prm, p_at, p_min)
    todo = abs(f) > ftol
    _, K, G, Dm0, Dm1, den, Da0, Da1, df_de, A0, A1 = ev
    w0, w1, dir0, dir1 = 0.0, 0.0, -Dm0, -Dm1
    if held0 or held1:
        row0 = Da0 - df_de * v0
        row1 = Da1 - df_de * v0 * 2.0
        w0, w1 = _solve_mixed(K, G, Dm0, Dm1, den, Dm0 if held0 else 0.0, Dm1 if held1 else 0.0, row0, row1, False,
                              held0, held1, csr)
        x0, x1 = _elastic(K, G, w0, w1)
        dir0, dir1 = x0 - Dm0, x1 - Dm1
        den = den - (row0 * w0 + row1 * w1)
    consistent = den > 0.0
    dl = _fmax(f / den if todo and consistent else 0.0, -eps)  # eps_d^p stays >= 0
    dw0 = dl * w0
    dw1 = dl * w1
    sa = sa + dl * dir0
    sr = sr + dl * dir1
    e = e - v0 * (dw0 + dw1 * 2.0)
    bad = False
    if todo and not consistent:  # normal correction along the yield gradient on the free components
        b0 = 0.0 if held0 else A0
        b1 = 0.0 if held1 else A1
        aa = b0 * b0 + b1 * b1 * 2.0
        bad = not aa > 0.0
        c = f / (aa if aa > 0.0 else 1.0)
        sa, sr = sa - c * b0, sr - c * b1
    return sa, sr, e, eps + dl, dea + dw0, der + dw1, bad


@jit
def _increment(sa, sr, e, eps, v0, substep, l0, l1, held0, held1, prm, p_at, p_min, stol, ftol, csr, floor,
               max_substeps):
    """One increment of one point (SIMSAND._substeps): load (l0, l1) = the strain increment of a strain-controlled
    component, the stress increment (kPa) of a held one. Returns (sigma'_a, sigma'_r, e, eps_d^p, d eps_a, d eps_r,
    next substep hint, failure code)."""
    dT = min(2.0 * substep, 1.0)
    ea = er = 0.0
    if l0 == 0.0 and l1 == 0.0:  # a zero increment changes nothing
        return sa, sr, e, eps, ea, er, dT, 0
    T = 0.0
    nsub = 0
    both = held0 and held1
    while True:
        h = min(dT, 1.0 - T)
        d0 = h * l0
        d1 = h * l1
        ev0 = _evaluate(sa, sr, e, eps, d0, d1, prm, p_at, p_min)
        # stage 1 (forward Euler); plastic where on the surface and loading
        on_surface = ev0[0] >= -ftol
        ds1a, ds1r, de1a, de1r, dlam1 = _rates(ev0, d0, d1, v0, on_surface, held0, held1, csr)
        pl = on_surface and dlam1 > 0.0
        if on_surface and not pl:  # unloading from the surface
            ds1a, ds1r, de1a, de1r, dlam1 = _rates(ev0, d0, d1, v0, False, held0, held1, csr)
        if pl and not ev0[5] > 0.0:
            return sa, sr, e, eps, ea, er, dT, NO_UNIQUE_RESPONSE
        if not _finite(de1a, de1r):
            return sa, sr, e, eps, ea, er, dT, CONTROL_LOST
        # stage 2 at the Euler estimate
        ev1 = _evaluate(sa + ds1a, sr + ds1r, e + -v0 * (de1a + de1r * 2.0), eps + dlam1, d0, d1, prm, p_at, p_min)
        ds2a, ds2r, de2a, de2r, dlam2 = _rates(ev1, d0, d1, v0, pl, held0, held1, csr)
        if (held0 or held1) and not _finite(de2a, de2r) and _finite(ev1[3], ev1[4]):
            return sa, sr, e, eps, ea, er, dT, CONTROL_LOST_WITHIN
        na = sa + 0.5 * (ds1a + ds2a)
        nr = sr + 0.5 * (ds1r + ds2r)
        dea = 0.5 * (de1a + de2a)
        der = 0.5 * (de1r + de2r)
        eps_new = _fmax(eps + 0.5 * (dlam1 + dlam2), 0.0)
        e_new = e - v0 * (dea + der * 2.0)
        # local error: stress relative; hardening through H (absolute); pure stress control: strain error as stress
        sref = _fmax(np.sqrt(na * na + nr * nr * 2.0), floor)
        err = _fmax(0.5 * np.sqrt((ds2a - ds1a) ** 2 + (ds2r - ds1r) ** 2 * 2.0) / sref,
                    0.5 * abs(dlam2 - dlam1) * prm[KP] / (prm[KP] + eps_new) ** 2)
        if both:
            xa, xr = _elastic(ev0[1], ev0[2], de2a - de1a, de2r - de1r)
            err = _fmax(err, 0.5 * np.sqrt(xa * xa + xr * xr * 2.0) / sref)
        if not math.isfinite(err) or (pl and not ev1[5] > 0.0):
            err = math.inf
        ok = err <= stol
        frac = 1.0
        restart = cross = False
        if ok and not pl:  # an accepted elastic substep that ends outside the yield surface
            f_el = _yield(na, nr, e_new, eps_new, prm, p_at, p_min)
            if f_el > ftol:
                if on_surface:  # unloading then reloading inside the substep: shorten
                    restart = True
                    ok = False
                else:  # elastic to plastic: stop the substep at the crossing
                    cross = True
                    frac = _crossing(sa, sr, na - sa, nr - sr, e, e_new - e, eps, ev0[0], f_el, prm, p_at, p_min,
                                     ftol)
                    na = sa + frac * (na - sa)
                    nr = sr + frac * (nr - sr)
                    e_new = e + frac * (e_new - e)
                    dea *= frac
                    der *= frac
        if ok and pl:
            na, nr, e_new, eps_new, dea, der, bad = _drift(na, nr, e_new, eps_new, dea, der, v0, ev1, held0, held1,
                                                           prm, p_at, p_min, ftol, csr)
            if bad:
                return sa, sr, e, eps, ea, er, dT, DRIFT_FAILED
        low = ok and na + nr * 2.0 < 3.0 * p_min  # tension cutoff: isotropic p' = p_min for the rest
        if low:
            na = nr = p_min
        if ok and not (e_new > 0.0 and e_new < E_MAX_STIFFNESS and _finite(na, nr)):
            return sa, sr, e, eps, ea, er, dT, STATE_INVALID
        if ok:
            sa, sr, e, eps = na, nr, e_new, eps_new
            ea += dea
            er += der
            T += h * frac
        if low:
            T = 1.0
        if cross:
            dT = h * (1.0 - frac)
        elif restart:
            dT = 0.25 * h
        else:
            dT = min(max(0.9 * np.sqrt(stol / _fmax(err, 1e-30)), 0.1), 2.0 if ok else 1.0) * h
        nsub += 1
        if (dT < 1e-12 and T < 1.0 - 1e-12) or nsub > max_substeps:
            return sa, sr, e, eps, ea, er, dT, ERROR_CONTROL
        if not T < 1.0 - 1e-12:
            return sa, sr, e, eps, ea, er, min(dT, 1.0), 0


@jit
def update_points(stress, e, eps, v0, substep, dload, held0, held1, active, prm, p_at, p_min, stol, ftol, csr,
                  floor, max_substeps, stress_out, e_out, eps_out, deps_out, substep_out, code_out):
    """One increment at every active point (stress, dload (n, 2); e, eps, v0 = 1 + e_0, substep (n,); prm (n, ncol));
    inactive points are copied unchanged. Fills the outputs; code_out (n,) the failure codes (0: none)."""
    for i in range(stress.shape[0]):
        if active[i]:
            (stress_out[i, 0], stress_out[i, 1], e_out[i], eps_out[i], deps_out[i, 0], deps_out[i, 1],
             substep_out[i], code_out[i]) = _increment(
                stress[i, 0], stress[i, 1], e[i], eps[i], v0[i], substep[i], dload[i, 0], dload[i, 1], held0, held1,
                prm[i], p_at, p_min, stol, ftol, csr, floor, max_substeps)
        else:
            stress_out[i, 0], stress_out[i, 1], e_out[i], eps_out[i] = stress[i, 0], stress[i, 1], e[i], eps[i]
            deps_out[i, 0] = deps_out[i, 1] = 0.0
            substep_out[i] = min(2.0 * substep[i], 1.0)
            code_out[i] = 0


@jit
def triaxial_points(stress, e, eps, v0, substep, d_axial, substeps, drained, prm, p_at, p_min, stol, ftol, csr,
                    floor, max_substeps, records, fail_at, code_out):
    """A whole triaxial test per point: from (stress (n, 2), e, eps, substep), for each target j the axial strain
    increment d_axial[j] in ``substeps`` equal increments (drained: sigma'_r held; undrained: d eps_r = -d eps_a/2).
    records (5, n, n_targets) <- eps_a, eps_r, sigma'_a, sigma'_r, e at the end of each target, NaN from the target
    in which the point failed; fail_at (n,) that target (-1: none), code_out (n,) the failure code."""
    n_targets = d_axial.shape[0]
    for i in range(stress.shape[0]):
        sa, sr, ei, ki, sub = stress[i, 0], stress[i, 1], e[i], eps[i], substep[i]
        ea = er = 0.0
        code = 0
        fail_at[i] = -1
        for j in range(n_targets):
            l0 = d_axial[j]
            l1 = 0.0 if drained else -0.5 * l0
            for _k in range(substeps):
                sa, sr, ei, ki, dea, der, sub, code = _increment(sa, sr, ei, ki, v0[i], sub, l0, l1, False, drained,
                                                                 prm[i], p_at, p_min, stol, ftol, csr, floor,
                                                                 max_substeps)
                ea += dea
                er += der
                if code:
                    break
            if code:
                fail_at[i] = j
                records[:, i, j:] = _NAN
                break
            records[0, i, j] = ea
            records[1, i, j] = er
            records[2, i, j] = sa
            records[3, i, j] = sr
            records[4, i, j] = ei
        code_out[i] = code
