"""Independent reference solutions for the FE solver (REFERENCE.md section 6). Soil convention: compression
positive stresses (kPa); cavity strain eps_c = u_a/a0 > 0 for expansion.

Small strain throughout, as the FE (the REFERENCE large-strain Gibson & Anderson form is available too).
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import diags, lil_matrix
from scipy.sparse.linalg import splu

from .problem import GAMMA_W

__all__ = ["lame_cavity_pressure", "thick_cylinder_drained", "gibson_anderson", "undrained_strain_path",
           "terzaghi_degree", "terzaghi_pressure", "radial_coupled_elastic"]


def lame_cavity_pressure(G, eps_c):
    """Infinite elastic medium: sigma_a - sigma_h0 = 2 G eps_c (kPa)."""
    return 2.0 * G * np.asarray(eps_c)


def thick_cylinder_drained(E, nu, eps_c, a0, R):
    """Drained plane-strain thick cylinder, outer boundary fixed: eps_c [2G R^2 + 2(lambda_L + G) a0^2]/(R^2 - a0^2)."""
    G = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    return np.asarray(eps_c) * (2 * G * R**2 + 2 * (lam + G) * a0**2) / (R**2 - a0**2)


def gibson_anderson(G, s_u, eps_c, large_strain=False):
    """Undrained expansion of a cavity in Tresca soil (plane strain); returns (pressure rise, R_p/a).

    Elastic while 2 G eps_c <= s_u. Beyond: s_u [1 + ln(G/s_u) + ln(dV/V)] with dV/V = 2 eps_c (small strain, the
    FE's kinematics) or 1 - (1 + eps_c)^-2 (large strain, REFERENCE.md). Excess pore pressure (pressure-independent
    material): 2 s_u ln(R_p/r) inside the plastic radius R_p = a sqrt(G dV/(s_u V)), zero outside.
    """
    eps = np.asarray(eps_c, dtype=float)
    dv = 1.0 - (1.0 + eps) ** -2 if large_strain else 2.0 * eps
    plastic = 2 * G * eps > s_u
    ratio = np.sqrt(np.maximum(G * dv / s_u, 1.0))
    rise = np.where(plastic, s_u * (1.0 + np.log(G / s_u) + np.log(np.maximum(dv, 1e-300))), 2 * G * eps)
    return rise, np.where(plastic, ratio, 1.0)


def undrained_strain_path(model, stress0, void_ratio0, eps_c, n_steps=4000):
    """Exact undrained (isochoric, plane strain) small-strain cavity expansion with any rate-independent model.

    Each point at r follows eps_r = -eps_theta = eps (soil convention: eps_r = +e, eps_theta = -e, eps_z = 0) with
    e = eps_c a0^2/r^2, so with g(e) = sigma'_r - sigma'_theta along that path
        sigma_a - sigma_h0 = integral_a^inf g/r dr = 1/2 integral_0^eps_c g(e)/e de,
    and the excess pore pressure at the wall is (sigma_a - sigma_h0) - (sigma'_r(eps_c) - sigma'_r0).
    Returns (e grid, cavity pressure rise, excess pore pressure at the wall), arrays over e (kPa).
    """
    e = np.linspace(0.0, eps_c, n_steps + 1)
    stress = np.asarray(stress0, float).reshape(1, 6)
    state = model.initial_state(stress, void_ratio0)
    de = np.zeros((1, 6))
    de[0, 0], de[0, 2] = e[1], -e[1]
    g = np.empty(e.size)
    sr = np.empty(e.size)
    g[0], sr[0] = stress[0, 0] - stress[0, 2], stress[0, 0]
    for i in range(1, e.size):
        stress, state, _ = model.update(stress, state, de, 0.0)
        g[i], sr[i] = stress[0, 0] - stress[0, 2], stress[0, 0]
    # integrand g/e, with its e -> 0 limit from the first step (g0 = 0 for an isotropic start)
    integrand = np.empty(e.size)
    integrand[1:] = (g[1:] - g[0]) / e[1:]
    integrand[0] = integrand[1]
    rise = 0.5 * np.concatenate([[0.0], np.cumsum(0.5 * (integrand[1:] + integrand[:-1]) * np.diff(e))])
    if g[0] != 0.0:
        raise ValueError("undrained_strain_path needs sigma'_r0 = sigma'_theta0 (axisymmetric in-situ state)")
    return e, rise, rise - (sr - sr[0])


def terzaghi_degree(Tv, n_terms=200):
    """Average degree of consolidation U(T_v) = 1 - sum 2/M^2 exp(-M^2 T_v), M = pi (2m + 1)/2."""
    M = np.pi * (2 * np.arange(n_terms) + 1) / 2
    T = np.atleast_1d(np.asarray(Tv, float))[:, None]
    return 1.0 - np.sum(2 / M**2 * np.exp(-M**2 * T), axis=1)


def terzaghi_pressure(z_over_H, Tv, p0, n_terms=200):
    """Excess pore pressure p0 sum 2/M sin(M Z) exp(-M^2 T_v), Z = distance from the drained face / H."""
    M = np.pi * (2 * np.arange(n_terms) + 1) / 2
    Z = np.asarray(z_over_H, float)[..., None]
    return p0 * np.sum(2 / M * np.sin(M * Z) * np.exp(-M**2 * Tv), axis=-1)


def radial_coupled_elastic(E, nu, k, a0, R, eps_c_rate, t_end, n_cells=400, n_steps=4000, gamma_w=GAMMA_W,
                           outer_scale=0.0):
    """One-dimensional radial (plane strain) coupled consolidation of an elastic annulus a0 < r < R; independent of
    the FE code. Cavity wall impermeable and driven at u_a = a0 eps_c_rate t; outer boundary drained with
    u_r(R) = outer_scale u_a.

    Equilibrium gives (lambda + 2G) eps_v - p = f(t) (one function of time); mass balance d eps_v/dt =
    (k/gamma_w) lap p; compatibility integral eps_v r dr = R u_R - a0 u_a. Finite volumes in r (graded toward both
    ends), BDF2 in time, unknowns (p_i, f). The wall total radial stress rise is 2G eps_c - f (sigma'_r = (lambda
    + 2G) eps_v - 2G u/r). Returns dict of arrays over time: t, eps_c, pressure_rise (kPa), excess_pore_pressure
    at the wall (kPa, extrapolated from the first cells with zero gradient).
    """
    G = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    Mod = lam + 2 * G
    kw = k / gamma_w
    # cells: half graded geometrically from a0, half toward R
    s = np.geomspace(1.0, 50.0, n_cells // 2)
    left = np.concatenate([[0.0], np.cumsum(s)]) / s.sum() * (R - a0) / 2
    faces = np.concatenate([a0 + left, (R - left[::-1])[1:]])
    xc = 0.5 * (faces[1:] + faces[:-1])
    vol = 0.5 * (faces[1:] ** 2 - faces[:-1] ** 2)
    n = xc.size
    # flux matrix: (kw * lap) integrated over cells, p = 0 beyond the outer face
    cond = kw * faces[1:-1] / np.diff(xc)
    L = lil_matrix((n + 1, n + 1))
    main = np.zeros(n)
    main[:-1] -= cond
    main[1:] -= cond
    main[-1] -= kw * R / (R - xc[-1])
    Lp = diags([main, cond, cond], [0, 1, -1], shape=(n, n)).tolil()
    L[:n, :n] = Lp
    # storage: (d/dt) vol_i (p_i + f)/Mod
    Mst = lil_matrix((n + 1, n + 1))
    Mst[np.arange(n), np.arange(n)] = vol / Mod
    Mst[np.arange(n), n] = vol / Mod
    A_con = np.concatenate([vol / Mod, [vol.sum() / Mod]])     # constraint row: integral eps_v r dr
    dt = t_end / n_steps
    y = np.zeros(n + 1)
    y_old = y.copy()
    out_t, out_f, out_p = [0.0], [0.0], [0.0]

    def system(c0):
        Amat = (c0 / dt) * Mst - L
        Amat = Amat.tolil()
        Amat[n, :] = A_con
        return splu(Amat.tocsc())

    lu1, lu2 = system(1.0), system(1.5)
    Mst = Mst.tocsr()
    for i in range(1, n_steps + 1):
        t = i * dt
        ua = a0 * eps_c_rate * t
        rhs_con = R * outer_scale * ua - a0 * ua
        if i == 1:
            rhs = Mst @ y / dt
            rhs[n] = rhs_con
            y_new = lu1.solve(rhs)
        else:
            rhs = Mst @ (2.0 * y - 0.5 * y_old) / dt
            rhs[n] = rhs_con
            y_new = lu2.solve(rhs)
        y_old, y = y, y_new
        out_t.append(t)
        out_f.append(y[n])
        # wall value: quadratic extrapolation with zero gradient at a0 from the first two cell centres
        d1, d2 = xc[0] - a0, xc[1] - a0
        out_p.append(y[0] - (y[1] - y[0]) * d1**2 / (d2**2 - d1**2))
    t = np.array(out_t)
    eps = eps_c_rate * t
    f = np.array(out_f)
    # total radial stress rise at the wall: sigma'_r = Mod eps_v - 2G u/r (tension +), total = that - p
    # => cavity pressure rise = 2G eps_c - f (compression positive)
    return {"t": t, "eps_c": eps, "pressure_rise": 2 * G * eps - f, "excess_pore_pressure": np.array(out_p)}
