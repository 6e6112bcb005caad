"""ANICREEP: anisotropic elasto-viscoplastic model for soft clay (Yin et al. 2010, 2011), REFERENCE.md section 4.

Compression positive, effective stresses in kPa, strains dimensionless, time in s. Voigt order
(11, 22, 33, 12, 23, 31); stress-like vectors (sigma', s, the fabric tensor alpha_d, the surface gradient) carry
tensor shear components, strain vectors carry engineering shear (gamma_12 = 2 eps_12).

Equations (REFERENCE.md section 4; Yin, Karstunen et al. 2010, 2011; Wheeler et al. 2003 for the S-CLAY1 surfaces):

(E)  elasticity     K = (1 + e0) p'/kappa, G = 3K(1 - 2nu)/(2(1 + nu)); integrated exactly along the increment of
                    elastic strain: p' = p'_n exp((1 + e0) d eps_v^e/kappa), s = s_n + 2 G_bar de^e with the secant
                    moduli K_bar = p'_n (1 + e0)/kappa (exp(x) - 1)/x, x = (1 + e0) d eps_v^e/kappa, G_bar/K_bar = G/K;
(F)  surfaces       f = 3/2 (s - p' alpha_d):(s - p' alpha_d) - (M^2 - alpha^2)(p'_m - p') p',
                    alpha^2 = 3/2 alpha_d:alpha_d; the dynamic surface through the current stress has
                    p'_m^d = p' + 3/2 (s - p' alpha_d):(s - p' alpha_d) / ((M^2 - alpha^2) p'); the reference surface
                    has size p'_m^r;
(V)  flow           d eps^vp/dt = mu (p'_m^d/p'_m^r)^beta g,  g = (df/dsigma')/(p' (M^2 - alpha^2)), normalized so
                    that the triaxial components are the REFERENCE ones: g_p = (M^2 - eta^2)/(M^2 - alpha^2),
                    g_q = 2(eta - alpha)/(M^2 - alpha^2);  beta = (lambda - kappa)/C_alpha_e,
                    mu = C_alpha_e/((1 + e0) tau) (M^2 - alpha_K0^2)/(M^2 - eta_K0^2);
(H)  hardening      dp'_m^r = p'_m^r (1 + e0)/(lambda - kappa) d eps_v^vp  (integrated exactly: exponential);
(R)  rotational     d alpha_d = omega [(3s/(4p') - alpha_d) <d eps_v^vp> + omega_d (s/(3p') - alpha_d) d eps_d^vp],
                    d eps_d^vp = sqrt(2/3 de^vp:de^vp) >= 0 (a magnitude, REFERENCE convention);
(K)  from M         sin phi' = 3M/(6 + M), K0_nc = 1 - sin phi', eta_K0 = 3(1 - K0_nc)/(1 + 2K0_nc),
                    alpha_K0 = (eta_K0^2 + 3 eta_K0 - M^2)/3,
                    omega_d = 3(4M^2 - 4eta_K0^2 - 3eta_K0)/(8(eta_K0^2 + 2eta_K0 - M^2)),
                    omega = (1 + e0)/(lambda - kappa) ln[(10M^2 + 2 alpha_K0 omega_d)/(M^2 + 2 alpha_K0 omega_d)].

Switches of the one implementation:
  ``anisotropy=False``  alpha_d = 0 and omega = 0 (isotropic creep model; alpha_K0 -> 0 in mu and in p'_m^r0);
  ``viscous=False``     rate-independent limit (beta -> infinity): consistency f(sigma', p'_m^r) = 0 on the same
                        surfaces with an elastic domain (S-CLAY1-like); with anisotropy=False it is Modified Cam Clay
                        (with (1 + e0) in place of (1 + e)).

Integration of one increment (backward Euler, all points at once):
  unknowns X = (sigma'_{n+1} (6), alpha_d,{n+1} (6), z), the viscoplastic multiplier d lambda = d lambda_ref exp(z),
  d eps^vp = d lambda g(sigma'_{n+1}, alpha_{n+1}); d lambda_ref = mu dt (viscous) or 1 (rate independent);
  residuals  R_sigma = (sigma' - sigma'_E(d eps - d eps^vp))/p'_m,n^r   (E)
             R_alpha = alpha - alpha_n - d alpha                            (R), backward Euler
             R_z     = ln(p'_m^d/p'_m^r) - z/beta                           (V) in log form: d lambda =
                       mu dt (p'_m^d/p'_m^r)^beta  <=>  ln(d lambda/(mu dt)) = beta ln(p'_m^d/p'_m^r);
                       rate independent: R_z = ln(p'_m^d/p'_m^r) (1/beta = 0), and R_z = z with d lambda = 0 for
                       points whose elastic trial lies inside the reference surface.
  The log form stays well scaled for beta = 20-60 (and beyond: C_alpha_e -> 0) and for multipliers from 1e-300 to
  O(1). The local Jacobian is obtained by complex-step differentiation of the residual (exact to round-off), Newton
  steps are limited to dz <= 3 and backtracked on the residual norm; points that do not converge are sub-stepped
  (halved recursively); IntegrationError names the point when that fails too.

The returned tangent is the consistent (algorithmic) tangent d sigma'_{n+1}/d(d eps) of this update (implicit
function theorem on the converged residual, complex-step exact); for points that had to be sub-stepped it is the
consistent tangent of the last sub-step (an approximation).
"""
from __future__ import annotations

import numpy as np

from .base import IntegrationError, MaterialModel, ParameterError, as_points, check_parameter
from .invariants import IDENTITY, STRESS_WEIGHTS, mean_stress

__all__ = ["ANICREEP", "anisotropy_constants"]

_NX = 13  # unknowns per point: stress (6), alpha_d (6), z
_H = 1e-30  # complex-step size
#: strain Voigt (engineering shear) deviator -> 2 x tensor deviator in stress Voigt layout
_ENG_TO_2TENSOR = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])


def anisotropy_constants(M):
    """K0_nc, eta_K0, alpha_K0 and omega_d from the critical-state ratio M (REFERENCE.md section 4, (K)).

    sin phi' = 3M/(6 + M); K0_nc = 1 - sin phi'; eta_K0 = 3(1 - K0_nc)/(1 + 2 K0_nc);
    alpha_K0 = (eta_K0^2 + 3 eta_K0 - M^2)/3; omega_d = 3(4M^2 - 4 eta_K0^2 - 3 eta_K0)/(8(eta_K0^2 + 2 eta_K0 - M^2)).
    """
    M = np.asarray(M, dtype=float)
    sin_phi = 3.0 * M / (6.0 + M)
    k0_nc = 1.0 - sin_phi
    eta_k0 = 3.0 * (1.0 - k0_nc) / (1.0 + 2.0 * k0_nc)
    alpha_k0 = (eta_k0**2 + 3.0 * eta_k0 - M**2) / 3.0
    omega_d = 3.0 * (4.0 * M**2 - 4.0 * eta_k0**2 - 3.0 * eta_k0) / (8.0 * (eta_k0**2 + 2.0 * eta_k0 - M**2))
    return k0_nc, eta_k0, alpha_k0, omega_d


def _dot(a, b):
    """a:b for stress-like Voigt vectors (tensor shear components), over the last axis."""
    return np.sum(STRESS_WEIGHTS * a * b, axis=-1)


def _expm1_over_x(x):
    """(exp(x) - 1)/x, complex-step safe (series for |x| < 1e-3, truncation error < 1e-18)."""
    small = np.abs(x.real) < 1e-3
    xs = np.where(small, x, 0.0)
    xb = np.where(small, 1.0, x)
    series = 1.0 + xs * (0.5 + xs * (1.0 / 6.0 + xs * (1.0 / 24.0 + xs / 120.0)))
    return np.where(small, series, np.expm1(xb) / xb)


def _surface(sig, alp, M2):
    """Mean stress p', deviator s, size p'_m^d of the surface (F) through sig and the normalized gradient g (V).

    Works on arrays (..., 6) (real or complex for complex-step differentiation).
    """
    p = (sig[..., 0] + sig[..., 1] + sig[..., 2]) / 3.0
    s = sig - p[..., None] * IDENTITY
    xi = s - p[..., None] * alp
    Ma = M2 - 1.5 * _dot(alp, alp)
    pmd = p + 1.5 * _dot(xi, xi) / (Ma * p)
    # df/dsigma' = 3 xi - [xi:alpha_d + (M^2 - alpha^2)(p'_m - 2p')/3] I; g = df/dsigma' / (p' (M^2 - alpha^2))
    grad = 3.0 * xi - (_dot(xi, alp) + Ma * (pmd - 2.0 * p) / 3.0)[..., None] * IDENTITY
    g = grad / (p * Ma)[..., None]
    return p, s, Ma, pmd, g


class ANICREEP(MaterialModel):
    """Anisotropic elasto-viscoplastic soft-clay model (module docstring: equations and integration).

    Parameters (scalars or arrays of shape (n,) over points):
        M         : critical-state stress ratio in triaxial compression, 0 < M < 3 (sin phi' < 1);
        lambda_   : slope of the NCL in e-ln p' (> kappa);
        kappa     : slope of the swelling line in e-ln p' (> 0);
        nu        : Poisson's ratio, -1 < nu < 0.5;
        e0        : initial void ratio (> 0); (1 + e0) is used in K and in the hardening law, as REFERENCE.md states;
        C_alpha_e : natural-log secondary compression index de/dln t (> 0; needed only when viscous);
        tau       : reference time of sigma'_p0 in s (> 0, default 86400 s = 24 h);
        sigma_p0  : vertical preconsolidation stress at the reference rate, kPa (> 0);
        anisotropy: True (S-CLAY1 rotated surfaces with rotational hardening) or False (alpha_d = 0, omega = 0);
        viscous   : True (overstress viscoplasticity) or False (rate-independent limit, consistency condition);
        vertical_axis : 1, 2 or 3, the Voigt component that is the deposition (vertical, K0-consolidation) axis of
                    the initial fabric alpha_d = alpha_K0 (e_v e_v - I/3). Default 1 (the axial direction of the lab
                    drivers); the axisymmetric FE maps r->1, z->2, theta->3, so the pressuremeter needs 2.

    State (dict of arrays over n points): ``alpha`` (n, 6) the deviatoric fabric tensor alpha_d (stress-like Voigt),
    ``pm_ref`` (n,) the reference-surface size p'_m^r (kPa), ``void_ratio`` (n,), ``vp_strain`` (n, 6) accumulated
    viscoplastic strain (engineering Voigt), ``vp_shear`` (n,) accumulated eps_d^vp magnitude, ``overstress`` (n,)
    p'_m^d/p'_m^r at the end of the increment.
    """

    name = "ANICREEP"
    tangent_kind = "consistent"
    parameter_names = ("M", "lambda_", "kappa", "nu", "e0", "C_alpha_e", "tau", "sigma_p0")
    #: Newton tolerance on the scaled residuals (stress / p'_m,n^r, alpha, log-overstress)
    tolerance = 1e-10
    max_iterations = 40
    max_substep_depth = 8
    #: largest increase of z = ln(d lambda/d lambda_ref) in one Newton step (d lambda grows at most e^3 times)
    max_dz = 3.0

    def __init__(self, M, lambda_, kappa, nu, e0, sigma_p0, C_alpha_e=None, tau=86400.0, *, anisotropy=True,
                 viscous=True, vertical_axis=1):
        name = self.name
        self.M = check_parameter("M", M, lower=0.0, upper=3.0, model=name)
        self.lambda_ = check_parameter("lambda_", lambda_, lower=0.0, model=name)
        self.kappa = check_parameter("kappa", kappa, lower=0.0, model=name)
        k, lam = np.broadcast_arrays(self.kappa, self.lambda_)
        if np.any(k >= lam):
            bad = k >= lam
            raise ParameterError(f"{name}: parameter kappa = {k[bad].ravel()[0]:g} must be < lambda_ = "
                                 f"{lam[bad].ravel()[0]:g}")
        self.nu = check_parameter("nu", nu, lower=-1.0, upper=0.5, model=name)
        self.e0 = check_parameter("e0", e0, lower=0.0, model=name)
        self.sigma_p0 = check_parameter("sigma_p0", sigma_p0, lower=0.0, model=name)
        self.tau = check_parameter("tau", tau, lower=0.0, model=name)
        self.anisotropy = bool(anisotropy)
        self.viscous = bool(viscous)
        self.rate_dependent = self.viscous  # the rate-independent limit does not depend on dt
        if self.viscous:
            if C_alpha_e is None:
                raise ParameterError(f"{name}: parameter C_alpha_e is required when viscous=True")
            self.C_alpha_e = check_parameter("C_alpha_e", C_alpha_e, lower=0.0, model=name)
        else:
            self.C_alpha_e = None if C_alpha_e is None else check_parameter("C_alpha_e", C_alpha_e, lower=0.0,
                                                                             model=name)
        if vertical_axis not in (1, 2, 3):
            raise ParameterError(f"{name}: parameter vertical_axis = {vertical_axis!r} must be 1, 2 or 3")
        self.vertical_axis = int(vertical_axis)

        shapes = [np.shape(v) for v in (self.M, self.lambda_, self.kappa, self.nu, self.e0, self.sigma_p0, self.tau,
                                         self.C_alpha_e if self.C_alpha_e is not None else 1.0)]
        try:
            self._shape = np.broadcast_shapes(*shapes)
        except ValueError:
            raise ParameterError(f"{name}: parameter arrays have incompatible shapes {shapes}") from None
        if len(self._shape) > 1:
            raise ParameterError(f"{name}: parameters must be scalars or arrays of shape (n,), got {self._shape}")

        k0_nc, eta_k0, alpha_k0, omega_d = anisotropy_constants(self.M)
        M2 = self.M**2
        if self.anisotropy and np.any(self.M <= alpha_k0):
            bad = np.broadcast_to(self.M <= alpha_k0, np.shape(self.M))
            raise ParameterError(f"{name}: parameter M = {np.asarray(self.M)[bad].ravel()[0]:g} must exceed "
                                 f"alpha_K0 = {np.asarray(alpha_k0)[bad].ravel()[0]:g}")
        self.k0_nc, self.eta_k0 = k0_nc, eta_k0
        if self.anisotropy:
            arg_den = M2 + 2.0 * alpha_k0 * omega_d
            if np.any(arg_den <= 0.0):
                bad = np.broadcast_to(arg_den <= 0.0, np.shape(self.M))
                raise ParameterError(f"{name}: parameter M = {np.asarray(self.M)[bad].ravel()[0]:g} gives "
                                     f"M^2 + 2 alpha_K0 omega_d <= 0 (no rotational-hardening rate omega)")
            self.alpha_k0 = alpha_k0
            self.omega_d = omega_d
            self.omega = (1.0 + self.e0) / (self.lambda_ - self.kappa) * np.log((10.0 * M2 + 2.0 * alpha_k0 * omega_d)
                                                                              / arg_den)
        else:
            self.alpha_k0 = np.zeros_like(alpha_k0)
            self.omega_d = np.zeros_like(omega_d)
            self.omega = np.zeros(np.broadcast_shapes(np.shape(self.e0), np.shape(self.M)))
        if self.viscous:
            self.beta = (self.lambda_ - self.kappa) / self.C_alpha_e
            self.mu = (self.C_alpha_e / ((1.0 + self.e0) * self.tau)
                       * (M2 - self.alpha_k0**2) / (M2 - eta_k0**2))
        else:
            self.beta = np.inf
            self.mu = np.nan

    # ------------------------------------------------------------------ helpers
    def _n_points(self, n, what):
        if self._shape and self._shape[0] not in (1, n):
            raise ValueError(f"{self.name}: parameters are given for {self._shape[0]} points but {what} has {n}")

    def _point_parameters(self, n):
        """Everything the local solver needs, as (n,) arrays."""
        prm = {
            "M2": self.M**2,
            "c_e": (1.0 + self.e0) / self.kappa,                  # (E)
            "c_p": (1.0 + self.e0) / (self.lambda_ - self.kappa),  # (H)
            "r_G": 1.5 * (1.0 - 2.0 * self.nu) / (1.0 + self.nu),  # G/K
            "omega": self.omega, "omega_d": self.omega_d,
            "inv_beta": 1.0 / self.beta if self.viscous else 0.0,
            "mu": self.mu if self.viscous else 1.0,
            "e0": self.e0,
        }
        return {k: np.broadcast_to(np.asarray(v, dtype=float), (n,)) for k, v in prm.items()}

    def initial_fabric(self, n):
        """alpha_d = alpha_K0 (e_v e_v - I/3) for the vertical axis, (n, 6) stress-like Voigt."""
        unit = -IDENTITY / 3.0
        unit[self.vertical_axis - 1] += 1.0
        return np.broadcast_to(self.alpha_k0, (n,))[:, None] * unit

    def reference_size(self, n):
        """p'_m^r0 (kPa): the surface (F) with alpha = alpha_K0 (0 without anisotropy) through the K0_nc state at
        sigma'_v = sigma'_p0: p' = (1 + 2K0_nc) sigma'_p0/3, q = (1 - K0_nc) sigma'_p0."""
        k0, a, M2 = (np.broadcast_to(v, (n,)) for v in (self.k0_nc, self.alpha_k0, self.M**2))
        sp = np.broadcast_to(self.sigma_p0, (n,))
        p = (1.0 + 2.0 * k0) * sp / 3.0
        q = (1.0 - k0) * sp
        return p + (q - a * p) ** 2 / ((M2 - a * a) * p)

    # ------------------------------------------------------------------ state
    def initial_state(self, stress0, void_ratio0=None) -> dict:
        """State at effective stress ``stress0`` (n, 6): alpha_d = alpha_K0 about the vertical axis, p'_m^r from
        sigma'_p0 (``reference_size``), void ratio ``void_ratio0`` (default e0). A stress outside the reference surface
        (sigma'_p0 below the in-situ state) is allowed: it carries an initial overstress and creeps at once."""
        stress0 = as_points(stress0, "stress0")
        n = stress0.shape[0]
        self._n_points(n, "stress0")
        p = mean_stress(stress0)
        if np.any(p <= 0.0):
            i = int(np.argmax(p <= 0.0))
            raise ValueError(f"{self.name}: initial mean effective stress p' = {p[i]:g} kPa at point {i} must be > 0")
        e = np.broadcast_to(self.e0 if void_ratio0 is None else
                            check_parameter("void_ratio0", void_ratio0, lower=0.0, model=self.name), (n,)).copy()
        alpha = self.initial_fabric(n)
        pm_ref = self.reference_size(n)
        _, _, _, pmd, _ = _surface(stress0, alpha, np.broadcast_to(self.M**2, (n,)))
        return {"alpha": alpha.copy(), "pm_ref": pm_ref.copy(), "void_ratio": e, "vp_strain": np.zeros((n, 6)),
                "vp_shear": np.zeros(n), "overstress": pmd / pm_ref}

    # ------------------------------------------------------------------ update
    def update(self, stress, state, dstrain, dt):
        """One increment of strain ``dstrain`` (n, 6) over time ``dt`` (s, scalar or (n,), >= 0).

        Returns the new effective stress (n, 6), the new state and the consistent tangent (n, 6, 6)."""
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        self._n_points(n, "stress")
        dt = np.broadcast_to(np.asarray(dt, dtype=float), (n,))
        if np.any(~np.isfinite(dt) | (dt < 0.0)):
            raise ValueError(f"{self.name}: time increment dt = {dt[~np.isfinite(dt) | (dt < 0.0)][0]} must be >= 0")
        prm = self._point_parameters(n)
        new_stress, alpha, pm_ref, dvp, tangent, ratio = self._integrate(
            stress, state["alpha"], state["pm_ref"], dstrain, dt, prm, np.arange(n), 0)
        dvp_d = np.sqrt(2.0 / 3.0 * np.sum(np.array([1, 1, 1, 0.5, 0.5, 0.5])
                                           * (dvp - dvp[:, :3].sum(1, keepdims=True) / 3.0 * IDENTITY) ** 2, axis=1))
        new_state = {"alpha": alpha, "pm_ref": pm_ref,
                     "void_ratio": state["void_ratio"] - (1.0 + prm["e0"]) * dstrain[:, :3].sum(axis=1),
                     "vp_strain": state["vp_strain"] + dvp,
                     "vp_shear": state["vp_shear"] + dvp_d, "overstress": ratio}
        return new_stress, new_state, tangent

    def _integrate(self, stress, alpha, pm_ref, deps, dt, prm, points, depth):
        """One increment for a set of points; failed points are halved recursively. ``points`` index the caller's
        arrays (for the error message)."""
        out = self._local_solve(stress, alpha, pm_ref, deps, dt, prm)
        ok = out[-1]
        out = list(out[:-1])
        if np.all(ok):
            return tuple(out)
        bad = ~ok
        if depth >= self.max_substep_depth:
            i = int(np.argmax(bad))
            raise IntegrationError(int(points[i]), f"local Newton did not converge after {depth} levels of "
                                   f"sub-stepping (strain increment {deps[i]}, dt {dt[i]:g} s, stress {stress[i]})")
        sub = {k: v[bad] for k, v in prm.items()}
        half, hdt = 0.5 * deps[bad], 0.5 * dt[bad]
        s1, a1, pm1, dvp1, _, _ = self._integrate(stress[bad], alpha[bad], pm_ref[bad], half, hdt, sub, points[bad],
                                                  depth + 1)
        s2, a2, pm2, dvp2, t2, r2 = self._integrate(s1, a1, pm1, half, hdt, sub, points[bad], depth + 1)
        for k, v in enumerate((s2, a2, pm2, dvp1 + dvp2, t2, r2)):
            out[k][bad] = v
        return tuple(out)

    @staticmethod
    def _residual(X, deps, d):
        """Residuals (..., 13) of the backward-Euler system (module docstring) at unknowns X (..., 13) and strain
        increment deps (..., 6); ``d`` holds the start-of-increment data broadcastable against X[..., 0]."""
        sig, alp, z = X[..., :6], X[..., 6:12], X[..., 12]
        p, s, Ma, pmd, g = _surface(sig, alp, d["M2"])
        dlam = d["dlam_ref"] * np.exp(z)
        tr_g = g[..., 0] + g[..., 1] + g[..., 2]
        g_dev = g - (tr_g / 3.0)[..., None] * IDENTITY
        dv = dlam * tr_g                                                     # d eps_v^vp
        dd = dlam * np.sqrt(2.0 / 3.0 * _dot(g_dev, g_dev) + 1e-30)          # d eps_d^vp (magnitude)
        deps_e = deps - dlam[..., None] * STRESS_WEIGHTS * g                 # engineering strain Voigt
        dve = deps_e[..., 0] + deps_e[..., 1] + deps_e[..., 2]
        x = d["c_e"] * dve
        p_e = d["p_n"] * np.exp(x)                                           # (E)
        k_bar = d["p_n"] * d["c_e"] * _expm1_over_x(x)
        dev_e = (deps_e - (dve / 3.0)[..., None] * IDENTITY) * _ENG_TO_2TENSOR
        sig_e = d["s_n"] + (d["r_G"] * k_bar)[..., None] * dev_e + p_e[..., None] * IDENTITY
        r_sig = (sig - sig_e) / d["pm_n"][..., None]
        dv_plus = np.where(dv.real > 0.0, dv, 0.0)
        r_alp = alp - d["alpha_n"] - d["omega"][..., None] * (                 # (R)
            (0.75 * s / p[..., None] - alp) * dv_plus[..., None]
            + d["omega_d"][..., None] * (s / (3.0 * p[..., None]) - alp) * dd[..., None])
        ln_ratio = np.log(pmd) - d["ln_pm_n"] - d["c_p"] * dv                # (H): ln(p'_m^d / p'_m^r)
        r_z = np.where(d["active"], ln_ratio - d["inv_beta"] * z, z)         # (V) in log form
        shape = np.broadcast_shapes(r_sig.shape, r_alp.shape)
        parts = [np.broadcast_to(r_sig, shape), np.broadcast_to(r_alp, shape),
                 np.broadcast_to(r_z[..., None], shape[:-1] + (1,))]
        return np.concatenate(parts, axis=-1), ln_ratio, dlam, g

    def _local_solve(self, stress, alpha, pm_ref, deps, dt, prm):
        n = stress.shape[0]
        p_n = mean_stress(stress)
        d = {"M2": prm["M2"], "c_e": prm["c_e"], "c_p": prm["c_p"], "r_G": prm["r_G"], "omega": prm["omega"],
             "omega_d": prm["omega_d"], "inv_beta": prm["inv_beta"], "p_n": p_n,
             "s_n": stress - p_n[:, None] * IDENTITY, "alpha_n": alpha, "pm_n": pm_ref, "ln_pm_n": np.log(pm_ref)}
        viscous = self.viscous
        with np.errstate(all="ignore"):
            # elastic trial and starting point of z
            d0 = dict(d, dlam_ref=np.zeros(n), active=np.ones(n, bool))
            X = np.concatenate([stress, alpha, np.zeros((n, 1))], axis=1)
            Xt = X.copy()
            res, _, _, _ = self._residual(Xt, deps, d0)
            Xt[:, :6] -= res[:, :6] * pm_ref[:, None]  # trial stress sigma'_E(d eps)
            p_t, _, _, pmd_t, g_t = _surface(Xt[:, :6], alpha, prm["M2"])
            L_t = np.log(pmd_t) - np.log(pm_ref)
            tr_g = g_t[:, :3].sum(1)
            g_dev = g_t - (tr_g / 3.0)[:, None] * IDENTITY
            K_t = p_t * prm["c_e"]
            A = (K_t * tr_g**2 + 2.0 * prm["r_G"] * K_t * _dot(g_dev, g_dev)) / pmd_t + prm["c_p"] * tr_g
            A_el = (K_t * tr_g**2 + 2.0 * prm["r_G"] * K_t * _dot(g_dev, g_dev)) / pmd_t
            dlam_c = L_t / np.where(A > 0.0, A, A_el)  # linearized return to the reference surface
            if viscous:
                dlam_ref = prm["mu"] * dt
                active = np.ones(n, bool)
                z0 = L_t / prm["inv_beta"]
                use_c = (L_t > 0.0) & (dlam_c > 0.0) & (dlam_ref > 0.0)
                z0 = np.where(use_c, np.minimum(z0, np.log(np.where(use_c, dlam_c / dlam_ref, 1.0))), z0)
                # scalar Newton on the linearized (V): L_t - A dlam_ref e^z - z/beta = 0 (concave, decreasing in z,
                # started right of its root), a cheap predictor for the full local Newton
                lin = use_c & (A > 0.0)
                for _ in range(8):
                    dl = dlam_ref * np.exp(z0)
                    phi = L_t - A * dl - prm["inv_beta"] * z0
                    z0 = np.where(lin, z0 + phi / (A * dl + prm["inv_beta"]), z0)
            else:
                active = L_t > 1e-12
                dlam_ref = active.astype(float)
                z0 = np.where(active, np.log(np.where(active & (dlam_c > 0), dlam_c, 1e-300)), 0.0)
            valid_trial = np.isfinite(L_t) & (p_t > 0.0)
            z0 = np.where(valid_trial & np.isfinite(z0), z0, 0.0)
            X = Xt.copy()
            X[:, 12] = z0
            # stress predictor: linearized return sigma'_E - d lambda D W g (tangent elastic D at the trial state)
            dl0 = np.where(valid_trial & active, dlam_ref * np.exp(z0), 0.0)
            pred = X[:, :6] - (dl0 * K_t)[:, None] * (tr_g[:, None] * IDENTITY + 2.0 * prm["r_G"][:, None] * g_dev)
            ok_pred = valid_trial & (mean_stress(pred) > 0.0) & np.all(np.isfinite(pred), axis=1)
            X[:, :6] = np.where(ok_pred[:, None], pred, X[:, :6])
            d["dlam_ref"], d["active"] = dlam_ref, active

            eye = np.eye(_NX)
            dirs = np.concatenate([np.zeros((1, _NX)), eye], axis=0) * (1j * _H)  # real evaluation + 13 directions
            jac = np.zeros((n, _NX, _NX))
            res = np.full((n, _NX), np.inf)
            todo = np.arange(n)
            for _ in range(self.max_iterations):
                dt_ = {k: (v[todo][:, None] if np.ndim(v) else v) for k, v in d.items()}
                Rc, _, _, _ = self._residual(X[todo][:, None, :] + dirs, deps[todo][:, None, :], dt_)
                R = Rc[:, 0].real
                J = np.swapaxes(Rc[:, 1:].imag / _H, 1, 2)
                res[todo], jac[todo] = R, J
                finite = np.all(np.isfinite(R), axis=1) & np.all(np.isfinite(J), axis=(1, 2))
                conv = finite & (np.max(np.abs(R), axis=1) <= self.tolerance)
                keep = finite & ~conv
                todo, R, J = todo[keep], R[keep], J[keep]
                if todo.size == 0:
                    break
                try:
                    dX = -np.linalg.solve(J, R[..., None])[..., 0]
                except np.linalg.LinAlgError:
                    dX = -np.stack([np.linalg.lstsq(Ji, Ri, rcond=None)[0] for Ji, Ri in zip(J, R)])
                over = dX[:, 12] > self.max_dz
                dX[over] *= (self.max_dz / dX[over, 12])[:, None]
                # backtracking on ||R||^2
                m0 = np.sum(R * R, axis=1)
                step = np.ones(todo.size)
                dsub = {k: (v[todo] if np.ndim(v) else v) for k, v in d.items()}
                for _ls in range(10):
                    Xn = X[todo] + step[:, None] * dX
                    Rn, _, _, _ = self._residual(Xn, deps[todo], dsub)
                    mn = np.sum(Rn * Rn, axis=1)
                    bad = ~(np.isfinite(mn) & ((mn <= (1.0 - 1e-4 * step) * m0) | (mn <= self.tolerance**2)))
                    if not np.any(bad):
                        break
                    step = np.where(bad, 0.5 * step, step)
                X[todo] = Xn
            converged = np.all(np.isfinite(res), axis=1) & (np.max(np.abs(res), axis=1) <= self.tolerance)
            R, ln_ratio, dlam, g = self._residual(X, deps, d)
            # consistent tangent: d X/d(d eps) = -J^{-1} dR/d(d eps), dR/d(d eps) by complex step
            Rd, _, _, _ = self._residual(X[:, None, :], deps[:, None, :] + 1j * _H * np.eye(6),
                                         {k: (v[:, None] if np.ndim(v) else v) for k, v in d.items()})
            dR = np.swapaxes(Rd.imag / _H, 1, 2)  # (n, 13, 6)
            safe_jac = np.where(converged[:, None, None], jac, np.eye(_NX))
            dX = -np.linalg.solve(safe_jac, dR)
            ratio = np.exp(ln_ratio)
        tangent = dX[:, :6, :]
        dvp = dlam[:, None] * STRESS_WEIGHTS * g
        alpha_new = X[:, 6:12] - (X[:, 6:9].sum(1) / 3.0)[:, None] * IDENTITY
        pm_new = pm_ref * np.exp(prm["c_p"] * dvp[:, :3].sum(1))
        converged &= np.all(np.isfinite(tangent), axis=(1, 2)) & (mean_stress(X[:, :6]) > 0.0)
        return X[:, :6].copy(), alpha_new, pm_new, dvp, tangent, ratio, converged
