"""Independent reference solutions for the FE solver (docs/reference.md section 6). Soil convention: compression
positive stresses (kPa); cavity strain eps_c = u_a/a0 > 0 for expansion.

Small strain throughout, as the FE (the docs/reference.md large-strain Gibson & Anderson form is available too).
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.sparse import diags, lil_matrix
from scipy.sparse.linalg import splu
from scipy.special import j0, j1, y0, y1

from .problem import GAMMA_W

__all__ = ["lame_cavity_pressure", "thick_cylinder_drained", "gibson_anderson", "undrained_strain_path",
           "terzaghi_degree", "terzaghi_pressure", "radial_coupled_elastic", "consolidation_coefficient",
           "randolph_wroth_eigenvalues", "randolph_wroth", "radial_diffusion"]


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
    FE's kinematics) or 1 - (1 + eps_c)^-2 (large strain, docs/reference.md). Excess pore pressure (pressure-independent
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


def consolidation_coefficient(k, G, nu, gamma_w=GAMMA_W):
    """Radial (plane strain) coefficient of consolidation c_h = (k/gamma_w) 2G(1 - nu)/(1 - 2 nu) (m2/s; k in m/s,
    G in kPa, drained nu), Randolph & Wroth (1979), docs/reference.md section 6."""
    return k / gamma_w * 2.0 * G * (1.0 - nu) / (1.0 - 2.0 * nu)


def _z0(x, alpha):
    """Z_0(x) = J_0(x) Y_1(alpha) - Y_0(x) J_1(alpha) (docs/reference.md section 6); its derivative is -Z_1."""
    return j0(x) * y1(alpha) - y0(x) * j1(alpha)


def _z1(x, alpha):
    """Z_1(x) = J_1(x) Y_1(alpha) - Y_1(x) J_1(alpha) = -dZ_0/dx; Z_1(alpha) = 0 (impermeable cavity)."""
    return j1(x) * y1(alpha) - y1(x) * j1(alpha)


def randolph_wroth_eigenvalues(outer_ratio, alpha_max):
    """The roots alpha_n < alpha_max of Z_0(alpha R*/a; alpha) = 0 (drained at R*), R*/a = outer_ratio > 1.

    Sign changes on a grid of 1/16 of the asymptotic root spacing pi/(R*/a - 1), refined by 60 vectorized
    bisections (relative accuracy ~1e-16)."""
    rho = float(outer_ratio)
    if not rho > 1.0:
        raise ValueError(f"outer_ratio R*/a = {outer_ratio} must exceed 1")
    step = min(np.pi / (rho - 1.0), 1.0) / 16.0
    x = np.arange(step, alpha_max + step, step)
    f = _z0(rho * x, x)
    i = np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)
    lo, hi, flo = x[i], x[i + 1], f[i]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        fm = _z0(rho * mid, mid)
        left = np.sign(fm) == np.sign(flo)
        lo, flo = np.where(left, mid, lo), np.where(left, fm, flo)
        hi = np.where(left, hi, mid)
    return 0.5 * (lo + hi)


def randolph_wroth(r_over_a, T, plastic_ratio, outer_ratio, s_u=1.0, n_terms=2000):
    """Excess pore pressure (kPa) during consolidation after an undrained cavity expansion, Randolph & Wroth (1979).

    Uncoupled radial diffusion du/dt = c_h (u_rr + u_r/r) for a <= r <= R* (elastic soil, cavity held), impermeable
    cavity du/dr(a) = 0, drained u(R*) = 0, initial u = 2 s_u ln(R_p/r) for r < R_p, 0 beyond (Gibson & Anderson),
    T = c_h t/a^2 (see consolidation_coefficient). With x = alpha_n r/a:
        u = sum_n A_n Z_0(alpha_n r/a) exp(-alpha_n^2 T),
        A_n = int x u_0 Z_0 dx / int x Z_0^2 dx = 2 s_u [Z_0(alpha_n) - Z_0(alpha_n R_p/a)] /
              ([beta^2 Z_1(beta)^2 - alpha_n^2 Z_0(alpha_n)^2]/2),  beta = alpha_n R*/a,
    from int x ln(X/x) Z_0 dx = x ln(X/x) Z_1 - Z_0 and int x Z_0^2 dx = x^2 (Z_0^2 + Z_1^2)/2.
    plastic_ratio R_p/a <= outer_ratio R*/a. Returns an array of shape (len(T), len(r_over_a)).
    ``n_terms`` bounds the number of eigenvalues; T = 0 needs many (slow convergence at the kink at R_p).
    """
    rho, X = float(outer_ratio), float(plastic_ratio)
    if not 1.0 <= X <= rho:
        raise ValueError(f"plastic_ratio R_p/a = {plastic_ratio} must lie in [1, R*/a = {outer_ratio}]")
    alpha = randolph_wroth_eigenvalues(rho, (n_terms + 1) * np.pi / (rho - 1.0))[:n_terms]
    beta = alpha * rho
    norm = 0.5 * (beta**2 * _z1(beta, alpha) ** 2 - alpha**2 * _z0(alpha, alpha) ** 2)
    A = 2.0 * s_u * (_z0(alpha, alpha) - _z0(alpha * X, alpha)) / norm
    x = np.atleast_1d(np.asarray(r_over_a, float))
    T = np.atleast_1d(np.asarray(T, float))
    modes = A[:, None] * _z0(alpha[:, None] * x[None, :], alpha[:, None])          # (n, len(r))
    return np.exp(-np.outer(T, alpha**2)) @ modes


def radial_diffusion(u0, a, R, c, times, n_nodes=801, rtol=1e-9):
    """Independent numerical solution of du/dt = c (u_rr + u_r/r) on a <= r <= R, du/dr(a) = 0, u(R) = 0.

    Vertex-centred finite volumes (nodes graded in ln r, node 0 on the cavity wall), method of lines integrated by
    scipy's implicit Radau with tolerance rtol. u0: callable r -> initial u. Returns (r nodes, u (len(times), n))."""
    r = a * np.geomspace(1.0, R / a, n_nodes)
    face = np.concatenate([[a], 0.5 * (r[1:] + r[:-1])])
    vol = 0.5 * (np.append(face[1:], R) ** 2 - face**2)[:-1]         # control volumes of the free nodes 0..n-2
    cond = c * face[1:] / np.diff(r)                                  # c r_f / (r_i+1 - r_i) per face
    n = n_nodes - 1
    main = np.zeros(n)
    main[:] -= cond
    main[1:] -= cond[:-1]
    Lmat = diags([main, cond[:-1], cond[:-1]], [0, 1, -1], shape=(n, n)).tocsc()
    Lmat = diags(1.0 / vol) @ Lmat
    sol = solve_ivp(lambda t, u: Lmat @ u, (0.0, float(np.max(times))), u0(r[:-1]), method="Radau",
                    t_eval=np.asarray(times, float), jac=Lmat, rtol=rtol, atol=1e-12)
    if not sol.success:
        raise RuntimeError(f"radial_diffusion: {sol.message}")
    return r, np.vstack([sol.y, np.zeros((1, sol.y.shape[1]))]).T
