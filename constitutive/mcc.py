"""Modified Cam Clay (docs/reference.md section 4, "Modified Cam Clay"), implicit return mapping per point, compiled
(:mod:`constitutive._mcc_kernel`, numba; points are independent: a batch gives the bits of separate calls).

Compression positive, effective stresses in kPa, Voigt order (11, 22, 33, 12, 23, 31), engineering shear strain.

Equations (docs/reference.md section 4):
    elasticity      K = (1 + e) p'/kappa, and either a constant shear modulus G or a constant Poisson's ratio nu
                    (G = 3K(1 - 2nu)/(2(1 + nu)));
    yield surface   f = q^2 + M^2 p'(p' - p'_c);
    flow rule       associated, d eps^p = dlambda df/dsigma';
    hardening       dp'_c = p'_c (1 + e)/(lambda - kappa) d eps_v^p.

Integration of one strain increment (backward Euler, closest-point projection in p'-q):
    - the specific volume v = 1 + e is frozen at its start-of-increment value v_n within the increment, and the void
      ratio is updated as e_{n+1} = e_n - v_n d eps_v. With that choice the rate equations for p' and p'_c integrate
      exactly:  p' = p'_n exp(v_n d eps_v^e / kappa),  p'_c = p'_cn exp(v_n d eps_v^p / (lambda - kappa)),
      so the kappa-lines and the NCL e = e_N - lambda ln p' are reproduced exactly (de = -kappa d ln p' elastically)
      whatever the step size, and undrained (isochoric) paths have exact p'-p'_c relations;
    - constant-nu option: the deviatoric stress uses the secant shear modulus G_bar = 3 K_bar (1 - 2nu)/(2(1 + nu)),
      K_bar = (p' - p'_n)/d eps_v^e the secant bulk modulus of the increment (Potts & Zdravkovic 1999), which tends to
      the tangent one as the increment vanishes;
    - unknowns (d eps_v^p, dlambda) per point, residuals r1 = d eps_v^p - dlambda df/dp',  r2 = f/p'_cn^2,
      Newton with backtracking line search; points whose Newton fails are sub-stepped (halved recursively, up to
      ``max_substep_depth`` levels, v frozen within each sub-step) and only then raise IntegrationError, whose
      reason says whether the state there is unstable (``_mcc_kernel.stability_margin`` < 0: plastic softening on
      the dry side of critical faster than the elastic stiffness, 1 + H/(n:D:n) < 0 with
      H = M^2 p' p'_c (2p' - p'_c) M^2 v/(lambda - kappa), n:D:n = K (df/dp')^2 + 3G (df/dq)^2: no plastic state
      follows it under a small strain increment, e.g. a heavily overconsolidated point with lambda - kappa small).
The returned tangent is the consistent (algorithmic) tangent of this update, obtained from the implicit-function
theorem on the local system; for points that had to be sub-stepped it is the tangent of the last sub-step.
"""
from __future__ import annotations

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
)
from .invariants import deviatoric_stress, mean_stress


def _kernel():
    """The compiled return mapping, imported on first use (keeps ``import constitutive`` free of numba)."""
    from . import _mcc_kernel
    return _mcc_kernel


class ModifiedCamClay(MaterialModel):
    """Modified Cam Clay with pressure-dependent elasticity (docs/reference.md section 4).

    Parameters (scalars or arrays of shape (n,) over points):
        M       : critical-state stress ratio q/p' (> 0);
        lambda_ : slope of the NCL in e-ln p' (> kappa);
        kappa   : slope of the swelling line in e-ln p' (> 0);
        G or nu : a constant shear modulus G (kPa, > 0) or a constant Poisson's ratio nu (-1 < nu < 0.5); exactly one;
        pc0 or ocr : initial size of the yield surface p'_c0 (kPa). Give either ``pc0`` directly (same for every
                  initial stress) or ``ocr`` >= 1 (default 1, normally consolidated): p'_c0 = ocr * p'_c(sigma'_0),
                  where p'_c(sigma'_0) = p' + q^2/(M^2 p') is the size of the surface through the initial stress, so for
                  an isotropic initial stress ocr = R0 = p'_c0/p'_0 of the undrained closed form.

    State (dict of arrays over n points): ``pc`` p'_c (kPa), ``void_ratio`` e, ``plastic_strain`` (n, 6).
    """

    name = "Modified Cam Clay"
    rate_dependent = False
    tangent_kind = "consistent"
    parameter_names = ("M", "lambda_", "kappa", "G", "nu", "pc0", "ocr")
    parameter_ranges = {
        "M": ParameterRange(0.0, None, (0.8, 1.6)),
        "lambda_": ParameterRange(0.0, None, (0.05, 0.5)),
        "kappa": ParameterRange(0.0, None, (0.005, 0.05)),
        "G": ParameterRange(0.0, None, (1.0e3, 5.0e4), "kPa"),
        "nu": ParameterRange(-1.0, 0.5, (0.1, 0.4)),
        "pc0": ParameterRange(0.0, None, (10.0, 1000.0), "kPa"),
        "ocr": ParameterRange(1.0, None, (1.0, 10.0), lower_open=False),
    }
    required_parameters = ("M", "lambda_", "kappa")
    exactly_one = (("G", "nu"),)
    at_most_one = (("pc0", "ocr"),)
    catalog_switches = {"viscous": False, "anisotropy": False}
    parameter_constraints = ("kappa < lambda_",)
    #: Newton tolerance on the scaled residuals (b r1, f/p'_cn^2), b = v/(lambda - kappa)
    tolerance = 1e-11
    max_iterations = 30
    max_substep_depth = 10

    def __init__(self, M, lambda_, kappa, G=None, nu=None, pc0=None, ocr=None):
        self.M = self._checked("M", M)
        self.kappa = self._checked("kappa", kappa)
        self.lambda_ = self._checked("lambda_", lambda_)
        bad = np.broadcast_to(self.kappa >= self.lambda_, np.broadcast(self.kappa, self.lambda_).shape)
        if np.any(bad):
            kappa, lambda_ = np.broadcast_arrays(self.kappa, self.lambda_)
            raise ParameterError(f"{self.name}: parameter kappa = {kappa[bad].ravel()[0]:g} must be < lambda_ = "
                                 f"{lambda_[bad].ravel()[0]:g}")
        if (G is None) == (nu is None):
            raise ParameterError(f"{self.name}: give exactly one of G (constant shear modulus) or nu (constant "
                                 f"Poisson's ratio), got G={G}, nu={nu}")
        self.G = None if G is None else self._checked("G", G)
        self.nu = None if nu is None else self._checked("nu", nu)
        if pc0 is not None and ocr is not None:
            raise ParameterError(f"{self.name}: give at most one of pc0 or ocr, got pc0={pc0}, ocr={ocr}")
        self.pc0 = None if pc0 is None else self._checked("pc0", pc0)
        self.ocr = self._checked("ocr", 1.0 if ocr is None else ocr) if pc0 is None else None

    # ------------------------------------------------------------------ state
    def initial_state(self, stress0, void_ratio0=None) -> dict:
        """State at effective stress ``stress0`` (n, 6) and void ratio ``void_ratio0`` (scalar or (n,), > 0)."""
        stress0 = as_points(stress0, "stress0")
        n = stress0.shape[0]
        if void_ratio0 is None:
            raise ParameterError(f"{self.name}: void_ratio0 is required")
        e0 = np.broadcast_to(check_parameter("void_ratio0", void_ratio0, lower=0.0, model=self.name), (n,)).copy()
        p = mean_stress(stress0)
        if np.any(p <= 0.0):
            i = int(np.argmax(p <= 0.0))
            raise ValueError(f"{self.name}: initial mean effective stress p' = {p[i]:g} kPa at point {i} must be > 0")
        M = np.broadcast_to(self.M, (n,))
        pc_through = p + deviatoric_stress(stress0) ** 2 / (M * M * p)
        if self.pc0 is not None:
            pc = np.broadcast_to(self.pc0, (n,)).copy()
            outside = pc < pc_through * (1.0 - 1e-12)
            if np.any(outside):
                i = int(np.argmax(outside))
                raise ValueError(f"{self.name}: initial stress at point {i} lies outside the yield surface: "
                                 f"pc0 = {pc[i]:g} kPa < {pc_through[i]:g} kPa needed")
        else:
            pc = np.broadcast_to(self.ocr, (n,)) * pc_through
        return {"pc": pc, "void_ratio": e0, "plastic_strain": np.zeros((n, 6))}

    # ----------------------------------------------------------------- update
    def _kernel_columns(self, n):
        """Columns of ``_mcc_kernel.PARAMETER_COLUMNS`` (``kernel_parameters``): M^2, lambda, kappa, G or nu."""
        return [self.M**2, self.lambda_, self.kappa, self.G if self.G is not None else self.nu]

    point_subsets = True

    def update(self, stress, state, dstrain, dt, tangent=True, points=None):
        """One increment of strain ``dstrain`` (n, 6); ``dt`` is not used (rate independent); ``points`` (n,): the
        rows are those points of the parameter arrays (``MaterialModel.point_subsets``). Returns the new effective
        stress (n, 6), the new state and the consistent tangent (n, 6, 6)."""
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        e = np.ascontiguousarray(np.broadcast_to(np.asarray(state["void_ratio"], dtype=float), (n,)))
        new_stress, pc, deps_p, tangent = np.empty((n, 6)), np.empty(n), np.empty((n, 6)), np.empty((n, 6, 6))
        where = np.empty(5)
        failed = _kernel().update_points(
            np.ascontiguousarray(stress), np.ascontiguousarray(state["pc"], dtype=float), e,
            np.ascontiguousarray(dstrain), self.kernel_rows(n, points), self.G is not None, self.tolerance,
            self.max_iterations, self.max_substep_depth, new_stress, pc, deps_p, tangent, where)
        if failed >= 0:
            raise IntegrationError(failed, self.integration_failure(_kernel().RETURN_MAPPING_FAILED, where,
                                                                    dstrain[failed]))
        e_new = e - (1.0 + e) * (dstrain[:, 0] + dstrain[:, 1] + dstrain[:, 2])
        collapsed = e_new <= 0.0
        if collapsed.any():
            i = int(np.argmax(collapsed))
            raise IntegrationError(i, self.integration_failure(_kernel().VOID_RATIO_COLLAPSED, (e_new[i], e[i]),
                                                               dstrain[i]))
        new_state = {"pc": pc, "void_ratio": e_new, "plastic_strain": state["plastic_strain"] + deps_p}
        return new_stress, new_state, tangent

    def integration_failure(self, code, info, dstrain) -> str:
        """The reason of a failed update of one point under the strain increment ``dstrain`` (6,): ``code`` and
        ``info`` as ``_mcc_kernel.point_update`` gives them (the return mapping's (p', q, p'_c, fraction done,
        stability margin), or the new and old void ratio)."""
        if code == _kernel().VOID_RATIO_COLLAPSED:
            return collapsed_void_ratio(info[0], info[1], dstrain)
        p, q, pc_f, done, margin = info[:5]
        at = (f"at p' = {p:.4g} kPa, q = {q:.4g} kPa, p'_c = {pc_f:.4g} kPa, {done:.3g} of the strain increment "
              f"{dstrain} done")
        if margin < 0.0:
            return (f"unstable material point {at}: plastic softening faster than the elastic stiffness "
                    f"(1 + H/(n:D:n) = {margin:.3g} < 0; dry side of critical, lambda - kappa small), no plastic "
                    f"state follows under a small strain increment")
        return f"local Newton did not converge after {self.max_substep_depth} levels of sub-stepping {at}"

    def compiled_steps(self, n):
        """Every step of ``mixed_control`` in one compiled call (``_mcc_kernel.drive``)."""
        kernel = _kernel()
        settings = np.array([float(self.G is not None), self.tolerance, self.max_iterations, self.max_substep_depth])
        return CompiledSteps(kernel.drive, kernel.adapt, self.kernel_parameters(n), settings, kernel.STATE_COLUMNS,
                             5, self.integration_failure)
