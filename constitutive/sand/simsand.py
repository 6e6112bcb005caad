"""SIMSAND: critical-state sand model of the paper's appendix (docs/reference.md section 3, Eqs. (I)-(VII)).

Compression positive, effective stresses in kPa, Voigt order (11, 22, 33, 12, 23, 31) with engineering shear strain.
p' = tr(sigma')/3, q = sqrt(3/2 s:s), eta = q/p', sin 3theta from :func:`constitutive.invariants.lode_sin3theta`
(+1 in triaxial compression).

Equations (numbers of docs/reference.md section 3):

- (I)-(II) d eps = d eps^e + d eps^p; isotropic hypo-elasticity d sigma' = K d eps_v^e I + 2 G d e^e.
- (III)    K = K_0 p_at (2.97 - e)^2 / (1 + e) (p'/p_at)^n,  E = 3 K (1 - 2 nu),  G = 3 K (1 - 2 nu) / (2 (1 + nu)).
- (IV)     f = q/p' - M_p H,  H = eps_d^p / (k_p + eps_d^p)  (hyperbolic hardening, eps_d^p accumulated deviatoric
           plastic strain).
- (V)      dg/dp' = A_d (M_pt - q/p'), dg/dq = 1: plastic strain rate d eps^p = d lambda [A_d (M_pt - eta) I/3
           + 3 s / (2 q)], so d eps_v^p = A_d (M_pt - eta) d eps_d^p and d eps_d^p = d lambda.
- (VI)     e_c = e_ref exp[-lambda_c (p'/p_at)^xi].
- (VII)    tan phi_p = (e_c/e)^n_p tan phi_mu, tan phi_pt = (e_c/e)^(-n_d) tan phi_mu, M = 6 sin phi/(3 - sin phi).
- Lode dependence (Sheng, Sloan & Yu 2000) on M_p and M_pt, each with its own c = (3 - sin phi)/(3 + sin phi):
  M(theta) = M_c [2 c^4 / (1 + c^4 - (1 - c^4) sin 3theta)]^(1/4).

Two physics switches of the one model (both True by default, the model of docs/reference.md section 3; used by the
missing-physics catalog ``constitutive.physics_catalog`` to build a base class without the physics and its enriched
class):

- ``lode_dependence=False``: M(theta) = M_c for every Lode angle (circular deviatoric section, as in Cam-clay-type
  sand models): M_p and M_pt are evaluated at sin 3theta = +1 and the Lode part of the yield gradient vanishes. One
  mechanism for every integrator: the parameter column ``_lode`` (1.0 or 0.0) read by
  ``_simsand_kernel.lode_argument``. Triaxial extension then fails at eta = -M_c(phi_mu) instead of -c M_c.
- ``state_dependent_dilatancy=False``: the interlocking of (VII) is off, tan phi_p = tan phi_pt = tan phi_mu
  whatever the density and pressure (n_p = n_d = 0): the peak ratio is M_mu H, the dilatancy A_d (M_mu - eta) of
  (V); no peak above the critical-state ratio. n_p and n_d are then not parameters of the model (omit them or give
  0; a non-zero value raises ParameterError).

Generalisation to six components: the yield gradient a = df/dsigma' includes the p'- and Lode-angle dependence of
M_p (through e_c(p') and sin 3theta); the flow direction is the stress-space gradient of g from (V) (radial in the
deviatoric plane). The void ratio enters M_p and M_pt and follows the total volumetric strain,
e = e_0 - (1 + e_0) eps_v (linearised small strain, as the laboratory void ratio is computed from Delta V / V_0).

Stress-point integration: explicit modified Euler with local error control and consistent drift correction
(Sloan, Abbo & Sheng 2001), with per-point pseudo-time and substep size. The scheme exists twice, each over the same
compiled equations (III)-(VII) of ``constitutive.sand._simsand_kernel`` (one source, numba-compiled for arrays and for
floats): vectorised numpy over points in the six-component space (``update``, strain control;
:mod:`constitutive.sand.substepping`), and a compiled per-point kernel in the triaxial space (``update_triaxial``
and the fast ``triaxial_test``, where prescribed stress components are held at every stage of every substep). The
numpy integrator also runs in the triaxial space with ``triaxial_integrator="numpy"``: the reference the kernel is
tested against (the same results bit for bit point by point; in a batch the numpy crossing iteration runs until every
crossing point of the batch converged, which moves results by about 1e-8 relative). The elastic-plastic transition
inside a substep is located by the Pegasus method on the yield function. At the origin of loading (q = 0 and
eps_d^p = 0 the yield surface degenerates to the hydrostatic axis) the deviatoric flow direction and the Lode angle
are taken from the deviatoric strain increment (for stress-controlled components, from the prescribed part). Below
``p_min`` (kPa) the stress is cut off to the isotropic state p' = p_min for the rest of the increment (tension
cutoff: liquefied sand carries no effective stress); stiffness and friction are evaluated with p' >= p_min.

The returned tangent is the continuum elasto-plastic tangent at the end of the increment
(D - D m (x) D a / (a:D m + K_p), including the void-ratio term of M_p) where the last substep was plastic or the
increment is zero on the yield surface, else the elastic D: ``tangent_kind = "continuum"``. Good for lab-test
mixed-control iterations; not the algorithmic tangent (an FE Newton converges linearly with it).
"""
from __future__ import annotations

import numpy as np

from ..base import IntegrationError, MaterialModel, ParameterError, ParameterRange, as_points, check_parameter
from ..invariants import IDENTITY, isotropic_stiffness
from .constants import CONTROL_STIFFNESS_RATIO, E_MAX_STIFFNESS, FAILURE_REASONS, P_AT, STRESS_ERROR_FLOOR
from .substepping import GENERAL, TRIAXIAL, ModifiedEulerSubstepping, simsand_kernel

__all__ = ["SIMSAND", "P_AT", "E_MAX_STIFFNESS", "FAILURE_REASONS", "friction_ratio", "friction_from_angle"]


def friction_ratio(tan_phi, sin3theta, derivatives=True):
    """M(theta) for the friction angle with tangent ``tan_phi`` ((VII) and Sheng, Sloan & Yu 2000).

    M_c = 6 sin phi/(3 - sin phi) in triaxial compression (sin 3theta = +1), c M_c in extension (sin 3theta = -1),
    c = (3 - sin phi)/(3 + sin phi). Returns M, or (M, dM/dtan_phi, dM/dsin3theta) when ``derivatives``.
    (The formula is ``_simsand_kernel.friction_terms``, shared by both integrators.)
    """
    t, s = np.broadcast_arrays(np.asarray(tan_phi, dtype=float), np.asarray(sin3theta, dtype=float))
    terms = simsand_kernel().friction_terms(np.ascontiguousarray(t.ravel()), np.ascontiguousarray(s.ravel()))
    terms = tuple(x.reshape(t.shape)[()] for x in terms)
    return terms if derivatives else terms[0]


def friction_from_angle(phi_deg):
    """M = 6 sin phi / (3 - sin phi) (triaxial compression) for phi in degrees."""
    s = np.sin(np.radians(phi_deg))
    return 6.0 * s / (3.0 - s)


class SIMSAND(ModifiedEulerSubstepping, MaterialModel):
    """SIMSAND sand model (docs/reference.md section 3).

    Parameters (scalars or arrays of shape (n,), one per point or particle; stresses in kPa, compression positive):
        nu       Poisson's ratio, -1 < nu < 0.5
        K_0      bulk stiffness constant of (III) (dimensionless) > 0 (not the earth-pressure coefficient)
        n        stiffness exponent of (III), 0 <= n < 1
        e_ref    void ratio of the critical state line at p' = 0 (VI), 0 < e_ref < 2.97
        lambda_c CSL parameter lambda of (VI) >= 0 (named lambda_c: ``lambda`` is a Python keyword)
        xi       CSL exponent of (VI) > 0
        phi_mu   critical-state friction angle in degrees, 0 < phi_mu < 90
        k_p      plastic hardening constant of (IV) > 0
        A_d      stress-dilatancy constant of (V) >= 0
        n_p      interlocking exponent for the peak angle (VII) >= 0 (required with state_dependent_dilatancy)
        n_d      interlocking exponent for the phase-transformation angle (VII) >= 0 (likewise)

    Switches (module docstring): ``lode_dependence`` (default True: Sheng et al. M(theta); False: M = M_c for every
    Lode angle) and ``state_dependent_dilatancy`` (default True: (VII) with n_p, n_d; False: n_p = n_d = 0, so
    phi_p = phi_pt = phi_mu; n_p, n_d omitted, or 0).

    Options: ``p_at`` (kPa, 101.325), ``p_min`` (kPa, tension cutoff and stiffness floor, default 0.1),
    ``stol`` (relative local error tolerance of the substepping, default 1e-3: curves within about 1e-3 of the
    converged ones), ``ftol`` (yield-function drift
    tolerance, default 1e-8), ``max_substeps`` (per increment and point, default 1000), ``triaxial_integrator``
    ("compiled", default: :meth:`update_triaxial` and :meth:`triaxial_test` run the numba kernel of
    :mod:`constitutive.sand._simsand_kernel`; "numpy": the vectorised numpy integrator in the triaxial space, kept as
    the reference (test oracle) of the kernel, about ten times slower).

    State (dict of (n,) arrays): ``void_ratio`` e, ``void_ratio_initial`` e_0 (reference of e = e_0 - (1 + e_0)
    eps_v), ``eps_dp`` accumulated deviatoric plastic strain eps_d^p (>= 0), ``substep`` the last substep size proposed
    by the error control, as a fraction of an increment (the next increment tries twice it first; a hint only).
    Mechanical state: e, eps_d^p and the stress; e_0 is a reference constant.
    """

    name = "SIMSAND"
    rate_dependent = False
    tangent_kind = "continuum"
    parameter_names = ("nu", "K_0", "n", "e_ref", "lambda_c", "xi", "phi_mu", "k_p", "A_d", "n_p", "n_d")
    parameter_ranges = {
        "nu": ParameterRange(-1.0, 0.5, (0.1, 0.35)),
        "K_0": ParameterRange(0.0, None, (50.0, 300.0)),
        "n": ParameterRange(0.0, 1.0, (0.3, 0.7), lower_open=False),
        "e_ref": ParameterRange(0.0, E_MAX_STIFFNESS, (0.6, 1.2)),
        "lambda_c": ParameterRange(0.0, None, (0.005, 0.1), lower_open=False),
        "xi": ParameterRange(0.0, None, (0.3, 1.0)),
        "phi_mu": ParameterRange(0.0, 90.0, (25.0, 40.0), "degree"),
        "k_p": ParameterRange(0.0, None, (0.0005, 0.01)),
        "A_d": ParameterRange(0.0, None, (0.3, 1.5), lower_open=False),
        "n_p": ParameterRange(0.0, None, (0.5, 5.0), lower_open=False),
        "n_d": ParameterRange(0.0, None, (0.5, 5.0), lower_open=False),
    }
    required_parameters = ("nu", "K_0", "n", "e_ref", "lambda_c", "xi", "phi_mu", "k_p", "A_d")
    switches = {"lode_dependence": True, "state_dependent_dilatancy": True}
    switch_parameters = {"state_dependent_dilatancy": ("n_p", "n_d")}
    catalog_switches = {"viscous": False, "anisotropy": False}
    max_strain_step = None

    def __init__(self, nu, K_0, n, e_ref, lambda_c, xi, phi_mu, k_p, A_d, n_p=None, n_d=None, *,
                 lode_dependence=True, state_dependent_dilatancy=True,
                 p_at=P_AT, p_min=0.1, stol=1e-3, ftol=1e-8, max_substeps=1000, triaxial_integrator="compiled"):
        m = self.name
        for k, v in (("lode_dependence", lode_dependence), ("state_dependent_dilatancy", state_dependent_dilatancy)):
            if not isinstance(v, (bool, np.bool_)):
                raise ParameterError(f"{m}: {k} must be True or False, got {v!r}")
        self.lode_dependence = bool(lode_dependence)
        self.state_dependent_dilatancy = bool(state_dependent_dilatancy)
        for k, v in (("n_p", n_p), ("n_d", n_d)):
            if self.state_dependent_dilatancy and v is None:
                raise ParameterError(f"{m}: parameter {k} is required with state_dependent_dilatancy=True")
            if not self.state_dependent_dilatancy and v is not None and np.any(np.asarray(v, dtype=float) != 0.0):
                raise ParameterError(f"{m}: {k} = {v} given but state_dependent_dilatancy=False (the interlocking of "
                                     "(VII) is off: n_p = n_d = 0)")
        if not self.state_dependent_dilatancy:
            n_p = 0.0 if n_p is None else n_p
            n_d = 0.0 if n_d is None else n_d
        for k, v in (("nu", nu), ("K_0", K_0), ("n", n), ("e_ref", e_ref), ("lambda_c", lambda_c), ("xi", xi),
                     ("phi_mu", phi_mu), ("k_p", k_p), ("A_d", A_d), ("n_p", n_p), ("n_d", n_d)):
            setattr(self, k, self._checked(k, v))
        self.p_at = float(check_parameter("p_at", p_at, lower=0.0, model=m))
        self.p_min = float(check_parameter("p_min", p_min, lower=0.0, model=m))
        self.stol = float(check_parameter("stol", stol, lower=0.0, upper=1.0, model=m))
        self.ftol = float(check_parameter("ftol", ftol, lower=0.0, upper=1.0, model=m))
        self.max_substeps = int(check_parameter("max_substeps", max_substeps, lower=1.0, lower_open=False, model=m))
        if triaxial_integrator not in ("compiled", "numpy"):
            raise ParameterError(f"{m}: triaxial_integrator must be 'compiled' or 'numpy', got {triaxial_integrator!r}")
        self.triaxial_integrator = triaxial_integrator
        sizes = {np.size(getattr(self, k)) for k in self.parameter_names} - {1}
        for k in self.parameter_names:
            if np.ndim(getattr(self, k)) > 1:
                raise ParameterError(f"{m}: parameter {k} must be a scalar or a 1-D array, got shape "
                                     f"{np.shape(getattr(self, k))}")
        if len(sizes) > 1:
            shapes = {k: np.shape(getattr(self, k)) for k in self.parameter_names}
            raise ParameterError(f"{m}: per-point parameter arrays must share one length, got {shapes}")
        self.n_sets = sizes.pop() if sizes else 1
        # derived constants, (III) and (VII)
        self._tan_mu = np.tan(np.radians(self.phi_mu))
        self._log_tan_mu = np.log(self._tan_mu)
        self._log_e_ref = np.log(self.e_ref)
        self._shear_ratio = 1.5 * (1.0 - 2.0 * self.nu) / (1.0 + self.nu)  # G/K
        self._lode = 1.0 if self.lode_dependence else 0.0  # the column _lode of _simsand_kernel.lode_argument

    # ------------------------------------------------------------------ parameters per point
    def _point_params(self, n):
        """Parameters as a (len(PARAMETER_COLUMNS), n) array in the row order of
        ``_simsand_kernel.PARAMETER_COLUMNS`` (n must equal the number of parameter sets where they are arrays)."""
        if self.n_sets not in (1, n):
            raise ValueError(f"{self.name}: {n} points but parameter arrays of length {self.n_sets}")
        columns = simsand_kernel().PARAMETER_COLUMNS
        return np.array([np.broadcast_to(getattr(self, k), (n,)) for k in columns], dtype=float)

    # ------------------------------------------------------------------ closed-form pieces
    def critical_void_ratio(self, p):
        """e_c(p') of (VI); p' in kPa, a scalar or an array whose first axis runs over the parameter sets (per-point
        parameters broadcast along it, e.g. curves (n_sets, n_records))."""
        p = np.asarray(p, float)

        def lead(v):  # a parameter (scalar or (n_sets,)) aligned with the first axis of p
            return np.reshape(v, np.shape(v) + (1,) * max(p.ndim - 1, 0))
        return lead(self.e_ref) * np.exp(-lead(self.lambda_c) * (p / self.p_at) ** lead(self.xi))

    def bulk_modulus(self, p, e):
        """K of (III) in kPa (p' floored at p_min)."""
        pe = np.maximum(np.asarray(p, float), self.p_min)
        return self.K_0 * self.p_at * (E_MAX_STIFFNESS - e) ** 2 / (1.0 + e) * (pe / self.p_at) ** self.n

    def shear_modulus(self, p, e):
        """G = 3 K (1 - 2 nu) / (2 (1 + nu)) in kPa."""
        return self._shear_ratio * self.bulk_modulus(p, e)

    def friction_ratios(self, p, e, sin3theta=1.0):
        """(M_p, M_pt) of (VII) at p' (kPa), void ratio e and sin 3theta, with the Lode dependence when the model has
        it (else M_c of each angle whatever sin 3theta)."""
        r = self.critical_void_ratio(np.maximum(p, self.p_min)) / e
        s3 = simsand_kernel().lode_argument(np.asarray(sin3theta, dtype=float), self._lode)
        Mp = friction_ratio(r**self.n_p * self._tan_mu, s3, derivatives=False)
        Mpt = friction_ratio(r ** (-self.n_d) * self._tan_mu, s3, derivatives=False)
        return Mp, Mpt

    # ------------------------------------------------------------------ state
    def initial_state(self, stress0, void_ratio0=None) -> dict:
        """State at ``stress0`` (n, 6) and void ratio ``void_ratio0`` (scalar or (n,), required).

        eps_d^p starts at the value that puts ``stress0`` on the yield surface (IV) (zero for isotropic stress):
        eps_d^p = k_p eta / (M_p - eta). Raises ValueError if eta >= M_p (stress beyond peak strength) or p' <= 0.
        """
        stress0 = as_points(stress0, "stress0")
        n = stress0.shape[0]
        if void_ratio0 is None:
            raise ValueError(f"{self.name}: initial_state needs void_ratio0")
        e0 = np.broadcast_to(np.asarray(void_ratio0, float), (n,)).copy()
        bad = ~((e0 > 0.0) & (e0 < E_MAX_STIFFNESS))
        if np.any(bad):
            raise ValueError(f"{self.name}: void_ratio0 = {e0[bad][0]} must lie in (0, {E_MAX_STIFFNESS})")
        par = self._point_params(n)
        ev = self._evaluate(GENERAL, stress0, e0, np.zeros(n), par, gradients=False)
        p = ev["p"]
        if np.any(p <= 0.0):
            raise ValueError(f"{self.name}: initial mean stress p' = {p[p <= 0][0]} kPa must be > 0")
        eta, Mp = ev["eta"], ev["Mp"]
        if np.any(eta >= Mp):
            i = int(np.argmax(eta >= Mp))
            raise ValueError(f"{self.name}: initial stress ratio q/p' = {eta[i]:.4g} at point {i} is not below the "
                             f"peak-strength ratio M_p = {Mp[i]:.4g}")
        eps_dp = par[simsand_kernel().KP] * eta / (Mp - eta)
        return {"void_ratio": e0, "void_ratio_initial": e0.copy(), "eps_dp": eps_dp, "substep": np.ones(n)}

    # ------------------------------------------------------------------ public updates
    def update(self, stress, state, dstrain, dt=0.0, tangent=True):
        """Integrate a strain increment (n, 6) from ``stress`` (n, 6) and ``state``; returns (stress, state, tangent).

        ``dt`` is unused (rate-independent model). The tangent is the continuum one at the end state (module doc).
        """
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        if dstrain.shape[0] != stress.shape[0]:
            raise ValueError(f"{self.name}: stress has {stress.shape[0]} points, dstrain {dstrain.shape[0]}")
        sig, e, eps, _, plastic, _, sub = self._integrate(GENERAL, stress, state, dstrain, np.array([], dtype=int))
        new_state = self._state(state, e, eps, sub)
        return sig, new_state, self._tangent(sig, new_state, plastic, dstrain)

    def _tangent(self, sig, state, plastic, dstrain):
        """Continuum tangent at the end state: D - D m (x) row / den where the last substep was plastic, or where the
        increment is zero and the stress lies on the yield surface (a loading predictor); elastic D elsewhere."""
        n = sig.shape[0]
        par = self._point_params(n)
        ev = self._evaluate(GENERAL, sig, state["void_ratio"], state["eps_dp"], par, dstrain=dstrain)
        D = isotropic_stiffness(ev["K"], ev["G"])
        plastic = plastic | (~np.any(dstrain != 0.0, axis=1) & (ev["f"] >= -self.ftol))
        if np.any(plastic):
            row = ev["Da"] - (ev["df_de"] * (1.0 + state["void_ratio_initial"]))[:, None] * IDENTITY
            upd = ev["Dm"][:, :, None] * (row / ev["den"][:, None])[:, None, :]
            D = D - np.where(plastic[:, None, None], upd, 0.0)
        return D

    def failure_reason(self, code):
        """The message of an integrator failure code (``FAILURE_REASONS``)."""
        return FAILURE_REASONS[code].format(ratio=CONTROL_STIFFNESS_RATIO, max_substeps=self.max_substeps)

    def _kernel_options(self):
        """The scalar arguments every compiled integrator takes after ``prm``."""
        return (self.p_at, self.p_min, self.stol, self.ftol, CONTROL_STIFFNESS_RATIO, STRESS_ERROR_FLOOR * self.p_at,
                self.max_substeps)

    def _kernel_columns(self, n):
        """Rows of ``_point_params`` as the columns of the compiled integrator (``kernel_parameters``)."""
        return self._point_params(n)

    def update_triaxial(self, stress, state, dload, stress_control=(False, True), raise_errors=True, active=None):
        """Fast path for axisymmetric triaxial states (the same equations and integrator in two components).

        stress (n, 2) = (sigma'_a, sigma'_r) in kPa; ``dload`` (n, 2): per component the strain increment where
        strain-controlled, the stress increment (kPa) where ``stress_control`` is True (default: drained triaxial,
        radial stress prescribed). Undrained triaxial: strain control with d eps_r = -d eps_a/2.
        Returns (stress, state, strain increment (n, 2) = (d eps_a, d eps_r), failed (n,) bool); failed points
        raise IntegrationError (the first failed point) unless ``raise_errors`` is False (they then stay at their
        last accepted substep). Points outside ``active`` (bool (n,), default all) are left unchanged.
        Runs the compiled kernel (``_simsand_kernel.update_points``), or the numpy reference with
        ``triaxial_integrator="numpy"``.
        """
        stress = np.asarray(stress, dtype=float).reshape(-1, 2)
        dload = np.broadcast_to(np.asarray(dload, dtype=float), stress.shape)
        held = np.asarray(stress_control, dtype=bool)
        if self.triaxial_integrator == "numpy":
            sig, e, eps, deps, _, failed, sub = self._integrate(TRIAXIAL, stress, state, dload, np.flatnonzero(held),
                                                                raise_errors, active)
            return sig, self._state(state, e, eps, sub), deps, failed
        n = stress.shape[0]
        sig, e, eps, deps, sub, code = np.empty((n, 2)), np.empty(n), np.empty(n), np.empty((n, 2)), np.empty(n), \
            np.empty(n, dtype=np.int64)
        simsand_kernel().update_points(
            np.ascontiguousarray(stress), *self._kernel_state(state, n), np.ascontiguousarray(dload), bool(held[0]),
            bool(held[1]), np.ones(n, dtype=bool) if active is None else np.asarray(active, dtype=bool),
            self.kernel_parameters(n), *self._kernel_options(), sig, e, eps, deps, sub, code)
        failed = code > 0
        if raise_errors and np.any(failed):
            i = int(np.argmax(failed))
            raise IntegrationError(i, self.failure_reason(code[i]))
        return sig, self._state(state, e, eps, sub), deps, failed

    @staticmethod
    def _kernel_state(state, n):
        """(e, eps_d^p, 1 + e_0, substep) as contiguous (n,) arrays."""
        return tuple(np.ascontiguousarray(np.broadcast_to(np.asarray(v, dtype=float), (n,))) for v in (
            state["void_ratio"], state["eps_dp"], 1.0 + np.asarray(state["void_ratio_initial"], dtype=float),
            state.get("substep", 1.0)))

    def triaxial_test(self, e0, p0, axial_strain, *, drained=True, substeps=1, on_failure="raise"):
        """Fast triaxial compression/extension from the isotropic state (e0, p0 kPa) in the triaxial space.

        Drained: constant sigma'_r, axial strain control (the radial stress is held at every stage of every substep,
        so the result does not depend on the step size beyond the error tolerance). Undrained: isochoric,
        d eps_r = -d eps_a/2, constant total radial stress, excess pore pressure u = -(sigma'_r - p0).
        axial_strain (n_points,) requested strains from 0, each interval split in ``substeps`` steps; e0, p0 scalars
        or (n,). Returns named curves (n, n_points) as :mod:`constitutive.labtests` (axial_strain, radial_strain,
        volumetric_strain, q, p, e, excess_pore_pressure, axial_stress, radial_stress) and ``failed`` (n,):
        with ``on_failure="nan"`` a point whose integration fails is frozen and its curves are NaN from there; with
        "raise" an IntegrationError names the point that failed first (earliest target, then lowest index).
        The whole test runs point by point in the compiled kernel (``_simsand_kernel.triaxial_points``); with
        ``triaxial_integrator="numpy"`` increment by increment through the numpy reference of :meth:`update_triaxial`.
        """
        if on_failure not in ("raise", "nan"):
            raise ValueError(f"on_failure must be 'raise' or 'nan', got {on_failure!r}")
        targets = np.asarray(axial_strain, dtype=float).ravel()
        n = max(self.n_sets, np.size(e0), np.size(p0))
        p0 = np.broadcast_to(np.asarray(p0, dtype=float), (n,))
        state = self.initial_state(p0[:, None] * IDENTITY, np.broadcast_to(np.asarray(e0, dtype=float), (n,)))
        sig = np.stack([p0, p0], axis=1)
        d_axial = np.diff(np.concatenate([[0.0], targets])) / substeps
        if self.triaxial_integrator == "numpy":
            rec, failed = self._triaxial_records_numpy(sig, state, d_axial, drained, substeps, on_failure)
        else:
            rec, fail_at, code = np.empty((5, n, targets.size)), np.empty(n, dtype=np.int64), \
                np.empty(n, dtype=np.int64)
            simsand_kernel().triaxial_points(sig, *self._kernel_state(state, n), d_axial, int(substeps),
                                             bool(drained), self.kernel_parameters(n), *self._kernel_options(), rec,
                                             fail_at, code)
            failed = code > 0
            if on_failure == "raise" and np.any(failed):
                i = int(np.argmin(np.where(failed, fail_at, targets.size)))  # earliest target, then lowest index
                raise IntegrationError(i, self.failure_reason(code[i]))
        eps_a, eps_r, sig_a, sig_r, e = rec
        return {"axial_strain": eps_a, "radial_strain": eps_r, "volumetric_strain": eps_a + 2.0 * eps_r,
                "q": sig_a - sig_r, "p": (sig_a + 2.0 * sig_r) / 3.0, "e": e,
                "excess_pore_pressure": p0[:, None] - sig_r, "axial_stress": sig_a, "radial_stress": sig_r,
                "failed": failed}

    def _triaxial_records_numpy(self, sig, state, d_axial, drained, substeps, on_failure):
        """The numpy reference of ``_simsand_kernel.triaxial_points`` (test oracle): records (5, n, n_targets) of
        eps_a, eps_r, sigma'_a, sigma'_r, e (NaN once a point failed) and the failed mask."""
        n = sig.shape[0]
        control = (False, True) if drained else (False, False)
        strain = np.zeros((n, 2))
        alive = np.ones(n, dtype=bool)
        rec = np.full((5, n, d_axial.size), np.nan)
        for j, d_a in enumerate(d_axial):
            dload = np.zeros((n, 2))
            dload[:, 0] = d_a
            if not drained:
                dload[:, 1] = -0.5 * d_a
            for _ in range(substeps):
                sig, state, deps, failed = self.update_triaxial(sig, state, dload, control,
                                                                raise_errors=on_failure == "raise", active=alive)
                strain += deps
                alive &= ~failed
            for key, val in enumerate((strain[:, 0], strain[:, 1], sig[:, 0], sig[:, 1], state["void_ratio"])):
                rec[key][:, j] = np.where(alive, val, np.nan)
        return rec, ~alive

    @staticmethod
    def _state(state, e, eps, substep):
        return {"void_ratio": e, "void_ratio_initial": np.array(state["void_ratio_initial"], dtype=float),
                "eps_dp": eps, "substep": substep}
