"""ANICREEP: anisotropic elasto-viscoplastic model for soft clay (Yin et al. 2010, 2011), docs/reference.md section 4.

Compression positive, effective stresses in kPa, strains dimensionless, time in s. Voigt order
(11, 22, 33, 12, 23, 31); stress-like vectors (sigma', s, the fabric tensor alpha_d, the surface gradient) carry
tensor shear components, strain vectors carry engineering shear (gamma_12 = 2 eps_12).

Equations (docs/reference.md section 4; Yin, Karstunen et al. 2010, 2011; Wheeler et al. 2003 for the S-CLAY1 surfaces):

(E)  elasticity     K = (1 + e0) p'/kappa, G = 3K(1 - 2nu)/(2(1 + nu)); integrated exactly along the increment of
                    elastic strain: p' = p'_n exp((1 + e0) d eps_v^e/kappa), s = s_n + 2 G_bar de^e with the secant
                    moduli K_bar = p'_n (1 + e0)/kappa (exp(x) - 1)/x, x = (1 + e0) d eps_v^e/kappa, G_bar/K_bar = G/K;
(F)  surfaces       f = 3/2 (s - p' alpha_d):(s - p' alpha_d) - (M^2 - alpha^2)(p'_m - p') p',
                    alpha^2 = 3/2 alpha_d:alpha_d; the dynamic surface through the current stress has
                    p'_m^d = p' + 3/2 (s - p' alpha_d):(s - p' alpha_d) / ((M^2 - alpha^2) p'); the reference surface
                    has size p'_m^r;
(V)  flow           d eps^vp/dt = mu (p'_m^d/p'_m^r)^beta g,  g = (df/dsigma')/(p' (M^2 - alpha^2)), normalized so
                    that the triaxial components are those of docs/reference.md: g_p = (M^2 - eta^2)/(M^2 - alpha^2),
                    g_q = 2(eta - alpha)/(M^2 - alpha^2);  beta = (lambda - kappa)/C_alpha_e,
                    mu = C_alpha_e/((1 + e0) tau) (M^2 - alpha_K0^2)/(M^2 - eta_K0^2);
(H)  hardening      dp'_m^r = p'_m^r (1 + e0)/(lambda - kappa) d eps_v^vp  (integrated exactly: exponential);
                    with destructuration (D) this is the hardening of the intrinsic size p'_mi^r;
(D)  destructuration (switch ``destructuration=True``; S-CLAY1S of Koskinen, Karstunen & Wheeler 2002 in the
                    elasto-viscoplastic form of Yin, Karstunen, Chang, Koskinen & Lojander 2011, "EVP-SCLAY1S"):
                    p'_m^r = (1 + chi) p'_mi^r, the bonding chi >= 0 decaying with viscoplastic strain
                    d chi = -xi chi (|d eps_v^vp| + xi_d d eps_d^vp),
                    integrated exactly at the increment's constant rates (as (H)):
                    chi_{n+1} = chi_n exp(-xi (|d eps_v^vp| + xi_d d eps_d^vp)).
                    The structured (natural) soil yields at the apparent size (1 + chi) p'_mi^r and softens towards
                    the intrinsic (reconstituted) response as chi decays: a peak and post-peak strength loss in
                    undrained shear, a steep post-yield compression curve that joins the intrinsic NCL. Under
                    isotropic loading (d eps_d^vp = 0, rate independent, eta = 0 so p' = p'_m^r):
                    p' = (1 + chi0 exp(-xi eps_v^vp)) p'_mi0 exp(c_p eps_v^vp), c_p = (1 + e0)/(lambda - kappa),
                    eps_v = eps_v^vp + kappa/(1 + e0) ln(p'/p'_0): a closed-form stress-strain curve (tested).
(R)  rotational     d alpha_d = omega [(3s/(4p') - alpha_d) <d eps_v^vp> + omega_d (s/(3p') - alpha_d) d eps_d^vp],
                    d eps_d^vp = sqrt(2/3 de^vp:de^vp) >= 0 (a magnitude, the convention of docs/reference.md);
(K)  from M         sin phi' = 3M/(6 + M), K0_nc = 1 - sin phi', eta_K0 = 3(1 - K0_nc)/(1 + 2K0_nc),
                    alpha_K0 = (eta_K0^2 + 3 eta_K0 - M^2)/3,
                    omega_d = 3(4M^2 - 4eta_K0^2 - 3eta_K0)/(8(eta_K0^2 + 2eta_K0 - M^2)),
                    omega = (1 + e0)/(lambda - kappa) ln[(10M^2 + 2 alpha_K0 omega_d)/(M^2 + 2 alpha_K0 omega_d)].
(I)  initial fabric alpha_d,0 = alpha_0 (e_v e_v - I/3) about the vertical axis e_v, alpha_0 = alpha_K0 of (K) unless
                    given (the parameter ``alpha0``: a natural clay's fabric measured or calibrated, 0 <= alpha_0 <
                    M); alpha_0 also sets the initial reference surface (the surface (F) inclined at alpha_0 through
                    the K0_nc state at sigma'_v = sigma'_p0) and replaces alpha_K0 in mu of (V). ``omega_ratio``
                    (default 1) scales the rate omega of (R): omega_ratio = 0 keeps the fabric at alpha_d,0 (S-CLAY1's
                    inclined surface without rotational hardening; with viscous=False the inclined Modified Cam Clay
                    ellipse of Wheeler et al. 2003, Eq. 1).

Switches of the one implementation:
  ``anisotropy=False``  alpha_d = 0 and omega = 0 (isotropic creep model; alpha_K0 -> 0 in mu and in p'_m^r0);
  ``destructuration=True``  bonding (D) with parameters chi0, xi, xi_d; off (default) or with chi0 = 0 the model
                        is bit-identical to the model without (D) (every (D) operation in the kernel is guarded by
                        chi > 0);
  ``viscous=False``     rate-independent limit (beta -> infinity): consistency f(sigma', p'_m^r) = 0 on the same
                        surfaces with an elastic domain (S-CLAY1-like); with anisotropy=False it is Modified Cam Clay
                        (with (1 + e0) in place of (1 + e) unless ``specific_volume="current"``).

Specific volume (constructor keyword ``specific_volume``, docs/reference.md section 4 "Specific volume"): the
factor v written (1 + e0) above in (E), (H), mu of (V) and omega of (K) is
  ``"initial"`` (default)  v = 1 + e0, a constant (Yin et al.); the void ratio follows e = e_n - (1 + e0) d eps_v;
  ``"current"``           v = v_n = 1 + e_n, the specific volume at the start of each increment, frozen over the
                        increment and its sub-steps; e = e_n - v_n d eps_v. This is Modified Cam Clay's convention
                        (``constitutive.mcc``): K = (1 + e) p'/kappa, dp'_m^r = p'_m^r (1 + e)/(lambda - kappa)
                        d eps_v^vp. With v_n frozen, an isotropic normally consolidated rate-independent increment
                        gives d eps_v = lambda ln(p'_{n+1}/p'_n)/v_n, so e = e_0 - lambda ln(p'/p'_0) holds exactly
                        for any step size, and the volumetric strain sum_n (e_n - e_{n+1})/(1 + e_n) tends to the
                        logarithmic ln((1 + e_0)/(1 + e)) as the steps shrink (tested).
  The option is a constructor option (``option_names``), so a model rebuilt with other parameters
  (``MaterialModel.replaced``) keeps it.

Integration of one increment (backward Euler, per point, compiled: :mod:`constitutive._anicreep_kernel` and
:mod:`constitutive._anicreep_points`):
  unknowns X = (sigma'_{n+1} (6), alpha_d,{n+1} (6), z), the viscoplastic multiplier d lambda = d lambda_ref exp(z),
  d eps^vp = d lambda g(sigma'_{n+1}, alpha_{n+1}); d lambda_ref = mu dt (viscous) or 1 (rate independent);
  residuals  R_sigma = (sigma' - sigma'_E(d eps - d eps^vp))/p'_m,n^r   (E)
             R_alpha = alpha - alpha_n - d alpha                            (R), backward Euler
             R_z     = ln(p'_m^d/p'_m^r) - z/beta                           (V) in log form, p'_m^r at the end of the
                       increment from (H) and (D) (chi is an explicit function of d eps^vp, not an unknown): d lambda =
                       mu dt (p'_m^d/p'_m^r)^beta  <=>  ln(d lambda/(mu dt)) = beta ln(p'_m^d/p'_m^r);
                       rate independent: R_z = ln(p'_m^d/p'_m^r) (1/beta = 0), and R_z = z with d lambda = 0 for
                       points whose elastic trial lies inside the reference surface.
  The log form stays well scaled for beta = 20-60 (and beyond: C_alpha_e -> 0) and for multipliers from 1e-300 to
  O(1). The local Jacobian is analytic (chain rule written out in the kernel; tested against complex-step
  differentiation of an independent residual), Newton steps are limited to dz <= 3 and backtracked on the residual
  norm, starting from a linearized return (scalar Newton on the linearized (V)); points that do not converge are
  sub-stepped (halved recursively); IntegrationError names the point when that fails too. Points are independent:
  a batch gives bit-identical results to separate calls.

The returned tangent is the consistent (algorithmic) tangent d sigma'_{n+1}/d(d eps) of this update (implicit
function theorem on the converged residual, from the LU factors of the analytic Jacobian); for points that had to
be sub-stepped it is the consistent tangent of the last sub-step (an approximation).
"""
from __future__ import annotations

import importlib

import numpy as np

from .base import (
    CompiledSteps,
    IntegrationError,
    MaterialModel,
    ParameterError,
    ParameterRange,
    as_points,
    check_parameter,
    collapsed_void_ratio,
    point_rows,
)
from .invariants import IDENTITY, mean_stress

__all__ = ["ANICREEP", "SPECIFIC_VOLUMES", "anisotropy_constants"]

_NO_TANGENT = np.empty((1, 6, 6))  # tangent_out of a call without the tangent (row 0 only, never written)


_COMPILED = {}


def _kernel(module="_anicreep_kernel"):
    """A module of the compiled integrator (``_anicreep_kernel``: the local solve of one increment;
    ``_anicreep_points``: the integration of points), imported on first use (keeps ``import constitutive`` free of
    numba)."""
    if module not in _COMPILED:
        _COMPILED[module] = importlib.import_module(f".{module}", __package__)
    return _COMPILED[module]


#: default reference time tau of sigma'_p0 (s): 24 h, the duration of a standard oedometer load stage
REFERENCE_TIME = 86400.0
#: the values of the ``specific_volume`` option (module docstring)
SPECIFIC_VOLUMES = ("initial", "current")


def anisotropy_constants(M):
    """K0_nc, eta_K0, alpha_K0 and omega_d from the critical-state ratio M (docs/reference.md section 4, (K)).

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


class ANICREEP(MaterialModel):
    """Anisotropic elasto-viscoplastic soft-clay model (module docstring: equations and integration).

    Parameters (scalars or arrays of shape (n,) over points):
        M         : critical-state stress ratio in triaxial compression, 0 < M < 3 (sin phi' < 1);
        lambda_   : slope of the NCL in e-ln p' (> kappa);
        kappa     : slope of the swelling line in e-ln p' (> 0);
        nu        : Poisson's ratio, -1 < nu < 0.5;
        e0        : initial void ratio (> 0); (1 + e0) is used in K and in the hardening law, as docs/reference.md
                    states (with ``specific_volume="current"`` only as the default initial void ratio);
        C_alpha_e : natural-log secondary compression index de/dln t (> 0; needed only when viscous);
        tau       : reference time of sigma'_p0 in s (> 0, default 86400 s = 24 h);
        sigma_p0  : vertical preconsolidation stress at the reference rate, kPa (> 0);
        anisotropy: True (S-CLAY1 rotated surfaces with rotational hardening) or False (alpha_d = 0, omega = 0);
        viscous   : True (overstress viscoplasticity) or False (rate-independent limit, consistency condition);
        destructuration: False (default) or True (bonding (D), S-CLAY1S/EVP-SCLAY1S), which needs
        chi0      : initial bonding chi_0 >= 0 (the apparent-to-intrinsic size ratio is 1 + chi_0; roughly the
                    sensitivity minus one). ``sigma_p0`` is then the apparent (natural, structured) preconsolidation
                    stress: the intrinsic initial size is p'_mi^r0 = p'_m^r0/(1 + chi_0), so chi_0 changes how much of
                    the yield stress is structure, not where the natural soil yields;
        xi        : absolute rate of destructuration (>= 0; S-CLAY1S "a", typically 8-12 for Finnish and Scottish soft
                    clays);
        xi_d      : relative weight of deviatoric viscoplastic strain in destructuration (>= 0; "b", typically
                    0.2-0.4);
        alpha0    : initial fabric alpha_0 of (I), 0 <= alpha0 < M (needs anisotropy=True; default alpha_K0 of (K));
        omega_ratio: factor on the rotational-hardening rate omega of (K), >= 0 (needs anisotropy=True; default 1; 0
                    fixes the fabric at its initial value);
        vertical_axis : 1, 2 or 3, the Voigt component that is the deposition (vertical, K0-consolidation) axis of
                    the initial fabric alpha_d = alpha_0 (e_v e_v - I/3). Default 1 (the axial direction of the lab
                    drivers); the axisymmetric FE maps r->1, z->2, theta->3, so the pressuremeter needs 2.
        specific_volume : "initial" (v = 1 + e0 in (E), (H), mu and omega; default) or "current" (v = 1 + e_n frozen
                    over each increment; module docstring).

    State (dict of arrays over n points): ``alpha`` (n, 6) the deviatoric fabric tensor alpha_d (stress-like Voigt),
    ``pm_ref`` (n,) the reference-surface size p'_m^r (kPa), ``void_ratio`` (n,), ``vp_strain`` (n, 6) accumulated
    viscoplastic strain (engineering Voigt), ``vp_shear`` (n,) accumulated eps_d^vp magnitude, ``overstress`` (n,)
    p'_m^d/p'_m^r at the end of the increment, ``chi`` (n,) the bonding (zeros without destructuration; the intrinsic
    size is pm_ref/(1 + chi)).
    """

    name = "ANICREEP"
    tangent_kind = "consistent"
    parameter_names = ("M", "lambda_", "kappa", "nu", "e0", "C_alpha_e", "tau", "sigma_p0", "chi0", "xi", "xi_d",
                       "alpha0", "omega_ratio")
    parameter_ranges = {
        "M": ParameterRange(0.0, 3.0, (0.8, 1.8)),
        "lambda_": ParameterRange(0.0, None, (0.05, 0.5)),
        "kappa": ParameterRange(0.0, None, (0.005, 0.05)),
        "nu": ParameterRange(-1.0, 0.5, (0.1, 0.4)),
        "e0": ParameterRange(0.0, None, (0.5, 3.0)),
        "C_alpha_e": ParameterRange(0.0, None, (0.002, 0.03)),
        "tau": ParameterRange(0.0, None, (3600.0, 172800.0), "s"),
        "sigma_p0": ParameterRange(0.0, None, (10.0, 500.0), "kPa"),
        "chi0": ParameterRange(0.0, None, (0.0, 20.0), lower_open=False),
        "xi": ParameterRange(0.0, None, (5.0, 15.0), lower_open=False),
        "xi_d": ParameterRange(0.0, None, (0.1, 0.5), lower_open=False),
        "alpha0": ParameterRange(0.0, 3.0, (0.3, 0.6), lower_open=False),
        "omega_ratio": ParameterRange(0.0, None, (0.5, 1.5), lower_open=False),
    }
    required_parameters = ("M", "lambda_", "kappa", "nu", "e0", "sigma_p0")
    switches = {"viscous": True, "anisotropy": True, "destructuration": False}
    switch_parameters = {"viscous": ("C_alpha_e",), "destructuration": ("chi0", "xi", "xi_d")}
    parameter_defaults = {"tau": REFERENCE_TIME}
    void_ratio_parameter = True
    parameter_constraints = ("kappa < lambda_",)
    oriented = True
    #: Newton tolerance on the scaled residuals (stress / p'_m,n^r, alpha, log-overstress)
    tolerance = 1e-10
    max_iterations = 40
    max_substep_depth = 8
    #: largest increase of z = ln(d lambda/d lambda_ref) in one Newton step (d lambda grows at most e^3 times)
    max_dz = 3.0
    #: integrate each point in the Voigt components in play (3 without shear, 4 axisymmetric, else 6; same answer,
    #: 7 or 9 local unknowns instead of 13: _anicreep_kernel docstring); False integrates all 6 (the tests' oracle)
    reduce_components = True

    option_names = ("specific_volume",)

    def __init__(self, M, lambda_, kappa, nu, e0, sigma_p0, C_alpha_e=None, tau=REFERENCE_TIME, *, anisotropy=True,
                 viscous=True, destructuration=False, chi0=None, xi=None, xi_d=None, alpha0=None, omega_ratio=None,
                 vertical_axis=1, specific_volume="initial"):
        name = self.name
        if specific_volume not in SPECIFIC_VOLUMES:
            raise ParameterError(f"{name}: specific_volume = {specific_volume!r} must be one of "
                                 f"{', '.join(map(repr, SPECIFIC_VOLUMES))}")
        self.specific_volume = specific_volume
        self.M = self._checked("M", M)
        self.lambda_ = self._checked("lambda_", lambda_)
        self.kappa = self._checked("kappa", kappa)
        k, lam = np.broadcast_arrays(self.kappa, self.lambda_)
        if np.any(k >= lam):
            bad = k >= lam
            raise ParameterError(f"{name}: parameter kappa = {k[bad].ravel()[0]:g} must be < lambda_ = "
                                 f"{lam[bad].ravel()[0]:g}")
        self.nu = self._checked("nu", nu)
        self.e0 = self._checked("e0", e0)
        self.sigma_p0 = self._checked("sigma_p0", sigma_p0)
        self.tau = self._checked("tau", tau)
        self.anisotropy = bool(anisotropy)
        self.viscous = bool(viscous)
        self.rate_dependent = self.viscous  # the rate-independent limit does not depend on dt
        if self.viscous:
            if C_alpha_e is None:
                raise ParameterError(f"{name}: parameter C_alpha_e is required when viscous=True")
            self.C_alpha_e = self._checked("C_alpha_e", C_alpha_e)
        else:
            self.C_alpha_e = None if C_alpha_e is None else self._checked("C_alpha_e", C_alpha_e)
        self.destructuration = bool(destructuration)
        for key, value in (("chi0", chi0), ("xi", xi), ("xi_d", xi_d)):
            if self.destructuration:
                if value is None:
                    raise ParameterError(f"{name}: parameter {key} is required when destructuration=True")
                value = self._checked(key, value)
            elif value is not None:
                raise ParameterError(f"{name}: parameter {key} = {value!r} given but destructuration=False")
            setattr(self, key, value)
        for key, value in (("alpha0", alpha0), ("omega_ratio", omega_ratio)):
            if value is not None and not self.anisotropy:
                raise ParameterError(f"{name}: parameter {key} = {value!r} given but anisotropy=False")
            setattr(self, key, None if value is None else self._checked(key, value))
        if vertical_axis not in (1, 2, 3):
            raise ParameterError(f"{name}: parameter vertical_axis = {vertical_axis!r} must be 1, 2 or 3")
        self.vertical_axis = int(vertical_axis)

        shapes = [np.shape(v) for v in (self.M, self.lambda_, self.kappa, self.nu, self.e0, self.sigma_p0, self.tau,
                                         self.C_alpha_e if self.C_alpha_e is not None else 1.0,
                                         *((self.chi0, self.xi, self.xi_d) if self.destructuration else ()),
                                         *(v for v in (self.alpha0, self.omega_ratio) if v is not None))]
        try:
            self._shape = np.broadcast_shapes(*shapes)
        except ValueError:
            raise ParameterError(f"{name}: parameter arrays have incompatible shapes {shapes}") from None
        if len(self._shape) > 1:
            raise ParameterError(f"{name}: parameters must be scalars or arrays of shape (n,), got {self._shape}")

        k0_nc, eta_k0, alpha_k0, omega_d = anisotropy_constants(self.M)
        M2 = self.M**2
        fabric = alpha_k0 if self.alpha0 is None else self.alpha0
        if self.anisotropy and np.any(self.M <= fabric):
            bad = np.broadcast_arrays(self.M <= fabric, self.M, fabric)
            which = "alpha_K0" if self.alpha0 is None else "alpha0"
            raise ParameterError(f"{name}: parameter M = {bad[1][bad[0]].ravel()[0]:g} must exceed "
                                 f"{which} = {bad[2][bad[0]].ravel()[0]:g}")
        self.k0_nc, self.eta_k0 = k0_nc, eta_k0
        if self.anisotropy:
            arg_den = M2 + 2.0 * alpha_k0 * omega_d
            if np.any(arg_den <= 0.0):
                bad = np.broadcast_to(arg_den <= 0.0, np.shape(self.M))
                raise ParameterError(f"{name}: parameter M = {np.asarray(self.M)[bad].ravel()[0]:g} gives "
                                     f"M^2 + 2 alpha_K0 omega_d <= 0 (no rotational-hardening rate omega)")
            self.alpha_k0 = alpha_k0
            self.omega_d = omega_d
            self._rotation_log = np.log((10.0 * M2 + 2.0 * alpha_k0 * omega_d) / arg_den)  # omega/c_p, (K)
            if self.omega_ratio is not None:
                self._rotation_log = self._rotation_log * self.omega_ratio
            #: alpha_0 of (I): the initial fabric, the inclination of the initial reference surface, mu's alpha
            self.fabric0 = fabric
        else:
            self.alpha_k0 = np.zeros_like(alpha_k0)
            self.omega_d = np.zeros_like(omega_d)
            self._rotation_log = np.zeros(np.shape(self.M))
            self.fabric0 = self.alpha_k0
        self.beta = (self.lambda_ - self.kappa) / self.C_alpha_e if self.viscous else np.inf
        initial = self._volume_columns(1.0 + self.e0)
        #: omega of (K) and mu of (V) (1/s; nan when rate independent) with v = 1 + e0
        self.omega, self.mu = initial["omega"], (initial["mu"] if self.viscous else np.nan)

    # ------------------------------------------------------------------ helpers
    def _n_points(self, n, what):
        if self._shape and self._shape[0] not in (1, n):
            raise ValueError(f"{self.name}: parameters are given for {self._shape[0]} points but {what} has {n}")

    def _time_increments(self, dt, n):
        """``dt`` (s, scalar or broadcastable to (n,)) as a contiguous float (n,) array; ValueError unless every one
        is finite and >= 0."""
        if np.ndim(dt) == 0:  # one time increment for every point (the FE): checked once
            dt = float(dt)
            if not (dt >= 0.0 and dt < np.inf):
                raise ValueError(f"{self.name}: time increment dt = {dt} must be >= 0")
            return np.full(n, dt)
        dt = np.asarray(dt, dtype=float)
        if dt.shape != (n,) or not dt.flags.c_contiguous:
            dt = np.ascontiguousarray(np.broadcast_to(dt, (n,)))
        if n and not (dt.min() >= 0.0 and dt.max() < np.inf):  # a nan fails the first comparison
            raise ValueError(f"{self.name}: time increment dt = {dt[~np.isfinite(dt) | (dt < 0.0)][0]} must be >= 0")
        return dt

    def _volume_columns(self, v):
        """The kernel columns that carry the specific volume ``v`` (scalar or (n,)): c_e = v/kappa of (E),
        c_p = v/(lambda - kappa) of (H), omega = c_p ln[(10M^2 + 2 alpha_K0 omega_d)/(M^2 + 2 alpha_K0 omega_d)] of
        (K) (times omega_ratio) and mu = C_alpha_e/(v tau) (M^2 - alpha_0^2)/(M^2 - eta_K0^2) of (V) in 1/s (1,
        unused, when rate independent; alpha_0 of (I))."""
        c_p = v / (self.lambda_ - self.kappa)
        M2 = self.M**2
        return {"c_e": v / self.kappa, "c_p": c_p, "omega": c_p * self._rotation_log,
                "mu": (self.C_alpha_e / (v * self.tau) * (M2 - self.fabric0**2) / (M2 - self.eta_k0**2)
                       if self.viscous else 1.0)}

    def _kernel_columns(self, n):
        """Everything the local solver needs, in the column order of ``_anicreep_kernel.PARAMETER_COLUMNS``
        (``kernel_parameters``), with v = 1 + e0."""
        prm = {
            "M2": self.M**2,
            **self._volume_columns(1.0 + self.e0),                 # (E), (H), (K), (V)
            "r_G": 1.5 * (1.0 - 2.0 * self.nu) / (1.0 + self.nu),  # G/K
            "omega_d": self.omega_d,
            "inv_beta": 1.0 / self.beta if self.viscous else 0.0,
            "xi": self.xi if self.destructuration else 0.0,                  # (D)
            "xi_d": self.xi_d if self.destructuration else 0.0,
        }
        return [prm[k] for k in _kernel().PARAMETER_COLUMNS]

    def _current_volume_parameters(self, v, n, points=None):
        """The kernel's parameter rows with the specific volume ``v`` = 1 + e_n per point ((n,),
        ``specific_volume="current"``; of the points ``points`` of the parameter arrays where given): c_e, c_p and
        omega are proportional to v, mu to 1/v (``_volume_columns``); their values at v = 1 are built once per n.
        The rows of all points are one array per n, rewritten at every call (the kernel reads them during the call
        only; a model is not shared between threads)."""
        every = points is None or self.parameter_points() == 1   # the rows are those of n points of the same table
        size = n if every else self.parameter_points()
        cache = self.__dict__.setdefault("_unit_volume_cache", {})
        if size not in cache:
            columns = _kernel().PARAMETER_COLUMNS
            cache[size] = (self.kernel_parameters(size).copy(),
                           [(columns.index(k), np.broadcast_to(np.asarray(x, dtype=float), (size,)).copy(), k == "mu")
                            for k, x in self._volume_columns(1.0).items() if k != "mu" or self.viscous])
        prm, scaled = cache[size]
        if not every:
            prm = prm[points]
        for column, at_unit_volume, inverse in scaled:
            (np.divide if inverse else np.multiply)(at_unit_volume if every else at_unit_volume[points], v,
                                                    out=prm[:, column])
        return prm

    def initial_fabric(self, n):
        """alpha_d = alpha_0 (e_v e_v - I/3) for the vertical axis, (n, 6) stress-like Voigt ((I))."""
        unit = -IDENTITY / 3.0
        unit[self.vertical_axis - 1] += 1.0
        return np.broadcast_to(self.fabric0, (n,))[:, None] * unit

    def reference_size(self, n):
        """p'_m^r0 (kPa): the surface (F) with alpha = alpha_0 of (I) (0 without anisotropy) through the K0_nc state at
        sigma'_v = sigma'_p0: p' = (1 + 2K0_nc) sigma'_p0/3, q = (1 - K0_nc) sigma'_p0 (with destructuration the
        apparent size (1 + chi_0) p'_mi^r0)."""
        k0, a, M2 = (np.broadcast_to(v, (n,)) for v in (self.k0_nc, self.fabric0, self.M**2))
        sp = np.broadcast_to(self.sigma_p0, (n,))
        p = (1.0 + 2.0 * k0) * sp / 3.0
        q = (1.0 - k0) * sp
        return p + (q - a * p) ** 2 / ((M2 - a * a) * p)

    # ------------------------------------------------------------------ state
    def initial_state(self, stress0, void_ratio0=None) -> dict:
        """State at effective stress ``stress0`` (n, 6): alpha_d = alpha_0 of (I) about the vertical axis, p'_m^r from
        sigma'_p0 (``reference_size``), chi = chi_0 (0 without destructuration), void ratio ``void_ratio0`` (default
        e0). A stress outside the reference surface
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
        pmd = _kernel().surface_size_points(np.ascontiguousarray(stress0), alpha,
                                            np.ascontiguousarray(self.kernel_parameters(n)[:, 0]))
        chi = np.broadcast_to(self.chi0 if self.destructuration else 0.0, (n,)).astype(float)
        return {"alpha": alpha.copy(), "pm_ref": pm_ref.copy(), "void_ratio": e, "vp_strain": np.zeros((n, 6)),
                "vp_shear": np.zeros(n), "overstress": pmd / pm_ref, "chi": chi}

    # ------------------------------------------------------------------ update
    point_subsets = True

    def update(self, stress, state, dstrain, dt, tangent=True, points=None):
        """One increment of strain ``dstrain`` (n, 6) over time ``dt`` (s, scalar or (n,), >= 0); ``points`` (n,):
        the rows are those points of the parameter arrays (``MaterialModel.point_subsets``).

        Returns the new effective stress (n, 6), the new state and the consistent tangent (n, 6, 6), or None in its
        place with ``tangent=False`` (the same stress and state; about a third less work)."""
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        if points is None:
            self._n_points(n, "stress")
        dt = self._time_increments(dt, n)
        new_stress, alpha, dvp = np.empty((n, 6)), np.empty((n, 6)), np.empty((n, 6))
        pm_ref, chi, vp_shear, ratio = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
        stiffness = np.empty((n, 6, 6)) if tangent else _NO_TANGENT
        e = state["void_ratio"]
        if self.specific_volume == "current":
            v = 1.0 + e
            prm = self._current_volume_parameters(v, n, points)
        else:
            v, prm = 1.0 + point_rows(self.e0, points), self.kernel_rows(n, points)
        failed = _kernel("_anicreep_points").update_points(
            np.ascontiguousarray(stress), np.ascontiguousarray(state["alpha"], dtype=float),
            np.ascontiguousarray(state["pm_ref"], dtype=float), np.ascontiguousarray(state["chi"], dtype=float),
            np.ascontiguousarray(dstrain), dt, prm, self.viscous, self.tolerance,
            self.max_iterations, self.max_dz, self.max_substep_depth, self.reduce_components, bool(tangent),
            new_stress, alpha, pm_ref, chi, dvp, vp_shear, ratio, stiffness)
        if failed >= 0:
            raise IntegrationError(failed, self.integration_failure(_kernel().LOCAL_NEWTON_FAILED,
                                                                    np.r_[dt[failed], stress[failed]], dstrain[failed]))
        e_new = e - v * (dstrain[:, 0] + dstrain[:, 1] + dstrain[:, 2])
        collapsed = e_new <= 0.0
        if collapsed.any():
            i = int(np.argmax(collapsed))
            raise IntegrationError(i, self.integration_failure(_kernel().VOID_RATIO_COLLAPSED, (e_new[i], e[i]),
                                                               dstrain[i]))
        new_state = {"alpha": alpha, "pm_ref": pm_ref, "void_ratio": e_new,
                     "vp_strain": state["vp_strain"] + dvp,
                     "vp_shear": state["vp_shear"] + vp_shear,
                     "overstress": ratio, "chi": chi}
        return new_stress, new_state, stiffness if tangent else None

    def integration_failure(self, code, info, dstrain) -> str:
        """The reason of a failed update of one point under the strain increment ``dstrain`` (6,), ``code`` and
        ``info`` as ``_anicreep_steps.point_update`` gives them ((dt, stress (6,) at the increment's start), or the
        new and the old void ratio)."""
        if code == _kernel().VOID_RATIO_COLLAPSED:
            return collapsed_void_ratio(info[0], info[1], dstrain)
        return (f"local Newton did not converge after {self.max_substep_depth} levels of sub-stepping (strain "
                f"increment {dstrain}, dt {info[0]:g} s, stress {info[1:7]})")

    def compiled_steps(self, n):
        """Every step of ``mixed_control`` and ``adaptive_control`` in one compiled call
        (``_anicreep_steps.drive``, ``adapt``)."""
        from . import _anicreep_steps as steps
        kernel = _kernel()
        table = np.empty((n, len(kernel.PARAMETER_COLUMNS) + 1))
        table[:, :-1] = self.kernel_parameters(n)
        table[:, -1] = 1.0 + self.e0
        current = self.specific_volume == "current"
        if current:  # the columns that carry v at v = 1 (``_current_volume_parameters``)
            for key, value in self._volume_columns(1.0).items():
                if key != "mu" or self.viscous:
                    table[:, kernel.PARAMETER_COLUMNS.index(key)] = value
        settings = np.array([current, self.viscous, self.tolerance, self.max_iterations, self.max_dz,
                             self.max_substep_depth, self.reduce_components], dtype=float)
        return CompiledSteps(steps.drive, steps.adapt, table, settings, steps.STATE_COLUMNS, 7,
                             self.integration_failure)

