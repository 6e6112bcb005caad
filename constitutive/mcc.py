"""Modified Cam Clay (REFERENCE.md section 4, "Modified Cam Clay"), implicit return mapping, vectorized over points.

Compression positive, effective stresses in kPa, Voigt order (11, 22, 33, 12, 23, 31), engineering shear strain.

Equations (REFERENCE.md section 4):
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
      ``max_substep_depth`` levels) and only then raise IntegrationError.
The returned tangent is the consistent (algorithmic) tangent of this update, obtained from the implicit-function
theorem on the local system; for points that had to be sub-stepped it is the tangent of the last sub-step.
"""
from __future__ import annotations

import numpy as np

from .base import IntegrationError, MaterialModel, ParameterError, as_points, check_parameter
from .invariants import IDENTITY, STRESS_WEIGHTS, deviator, deviatoric_stress, mean_stress
from .von_mises import DEVIATORIC_UNIT


def _expm1_over_x(z):
    """phi(z) = (exp(z) - 1)/z and its derivative phi'(z), accurate near z = 0 (series for |z| < 1e-2)."""
    small = np.abs(z) < 1e-2
    zs = np.where(small, z, 0.0)
    zb = np.where(small, 1.0, z)
    ez = np.exp(zb)
    phi_big = np.expm1(zb) / zb
    dphi_big = (ez * (zb - 1.0) + 1.0) / (zb * zb)
    # phi = sum z^k/(k+1)!, phi' = sum k z^(k-1)/(k+1)!, k <= 6: truncation below 1e-16 for |z| < 1e-2
    phi_small = 1 + zs * (1 / 2 + zs * (1 / 6 + zs * (1 / 24 + zs * (1 / 120 + zs * (1 / 720 + zs / 5040)))))
    dphi_small = 1 / 2 + zs * (2 / 6 + zs * (3 / 24 + zs * (4 / 120 + zs * (5 / 720 + zs * 6 / 5040))))
    return np.where(small, phi_small, phi_big), np.where(small, dphi_small, dphi_big)


class ModifiedCamClay(MaterialModel):
    """Modified Cam Clay with pressure-dependent elasticity (REFERENCE.md section 4).

    Parameters (scalars or arrays of shape (n,) over points):
        M       : critical-state stress ratio q/p' (> 0);
        lambda_ : slope of the NCL in e-ln p' (> kappa);
        kappa   : slope of the swelling line in e-ln p' (> 0);
        G or nu : a constant shear modulus G (kPa, > 0) or a constant Poisson's ratio nu (-1 < nu < 0.5); exactly one;
        pc0 or ocr : initial size of the yield surface p'_c0 (kPa). Give either ``pc0`` directly (same for every
                  initial stress) or ``ocr`` >= 1 (default 1, normally consolidated): p'_c0 = ocr * p'_c(sigma'_0), where
                  p'_c(sigma'_0) = p' + q^2/(M^2 p') is the size of the surface through the initial stress, so for an
                  isotropic initial stress ocr = R0 = p'_c0/p'_0 of the undrained closed form.

    State (dict of arrays over n points): ``pc`` p'_c (kPa), ``void_ratio`` e, ``plastic_strain`` (n, 6).
    """

    name = "Modified Cam Clay"
    rate_dependent = False
    tangent_kind = "consistent"
    parameter_names = ("M", "lambda_", "kappa", "G", "nu", "pc0", "ocr")
    #: Newton tolerance on the scaled residuals (b r1, f/p'_cn^2), b = v/(lambda - kappa)
    tolerance = 1e-11
    max_iterations = 30
    max_substep_depth = 10

    def __init__(self, M, lambda_, kappa, G=None, nu=None, pc0=None, ocr=None):
        self.M = check_parameter("M", M, lower=0.0, model=self.name)
        self.kappa = check_parameter("kappa", kappa, lower=0.0, model=self.name)
        self.lambda_ = check_parameter("lambda_", lambda_, lower=0.0, model=self.name)
        bad = np.broadcast_to(self.kappa >= self.lambda_, np.broadcast(self.kappa, self.lambda_).shape)
        if np.any(bad):
            k, l = np.broadcast_arrays(self.kappa, self.lambda_)
            raise ParameterError(f"{self.name}: parameter kappa = {k[bad].ravel()[0]:g} must be < lambda_ = "
                                 f"{l[bad].ravel()[0]:g}")
        if (G is None) == (nu is None):
            raise ParameterError(f"{self.name}: give exactly one of G (constant shear modulus) or nu (constant "
                                 f"Poisson's ratio), got G={G}, nu={nu}")
        self.G = None if G is None else check_parameter("G", G, lower=0.0, model=self.name)
        self.nu = None if nu is None else check_parameter("nu", nu, lower=-1.0, upper=0.5, model=self.name)
        if pc0 is not None and ocr is not None:
            raise ParameterError(f"{self.name}: give at most one of pc0 or ocr, got pc0={pc0}, ocr={ocr}")
        self.pc0 = None if pc0 is None else check_parameter("pc0", pc0, lower=0.0, model=self.name)
        self.ocr = (check_parameter("ocr", 1.0 if ocr is None else ocr, lower=1.0, lower_open=False, model=self.name)
                    if pc0 is None else None)

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
    def update(self, stress, state, dstrain, dt):
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        prm = {"M": self.M, "lam": self.lambda_, "kap": self.kappa}
        prm["G" if self.G is not None else "nu"] = self.G if self.G is not None else self.nu
        prm = {k: np.broadcast_to(v, (n,)) for k, v in prm.items()}
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # failed trials are sub-stepped
            new_stress, pc, deps_p, tangent = self._integrate(stress, state["pc"], state["void_ratio"], dstrain,
                                                              prm, np.arange(n), 0)
        e = state["void_ratio"]
        new_state = {"pc": pc, "void_ratio": e - (1.0 + e) * dstrain[:, :3].sum(axis=1),
                     "plastic_strain": state["plastic_strain"] + deps_p}
        return new_stress, new_state, tangent

    def _integrate(self, stress, pc, e, deps, prm, points, depth):
        """One increment for a set of points; failed points are sub-stepped recursively. ``points`` are the
        indices of these points in the caller's arrays (for error messages)."""
        new_stress, pc_new, deps_p, tangent, ok = self._local_solve(stress, pc, 1.0 + e, deps, prm)
        if np.all(ok):
            return new_stress, pc_new, deps_p, tangent
        bad = ~ok
        if depth >= self.max_substep_depth:
            raise IntegrationError(int(points[bad][0]), f"local Newton did not converge after {depth} levels of "
                                   f"sub-stepping (strain increment {deps[bad][0]})")
        sub = {k: v[bad] for k, v in prm.items()}
        half = 0.5 * deps[bad]
        s1, pc1, dp1, _ = self._integrate(stress[bad], pc[bad], e[bad], half, sub, points[bad], depth + 1)
        e1 = e[bad] - (1.0 + e[bad]) * half[:, :3].sum(axis=1)
        s2, pc2, dp2, t2 = self._integrate(s1, pc1, e1, half, sub, points[bad], depth + 1)
        new_stress[bad], pc_new[bad], deps_p[bad], tangent[bad] = s2, pc2, dp1 + dp2, t2
        return new_stress, pc_new, deps_p, tangent

    def _local_solve(self, stress, pcn, v, deps, prm):
        """Backward-Euler return mapping for all points (one Newton for the plastic ones). Returns stress, p'_c,
        plastic strain increment, consistent tangent and a converged mask."""
        n = stress.shape[0]
        M2 = prm["M"] ** 2
        a = v / prm["kap"]
        b = v / (prm["lam"] - prm["kap"])
        p_n = mean_stress(stress)
        s_n = deviator(stress)
        deps_v = deps[:, :3].sum(axis=1)
        Pde = deps @ DEVIATORIC_UNIT  # P symmetric: 2 x the strain-increment deviator (stress Voigt)
        const_G = "G" in prm
        c_nu = None if const_G else 3.0 * (1.0 - 2.0 * prm["nu"]) / (2.0 * (1.0 + prm["nu"]))
        pc_ref2 = pcn * pcn

        def evaluate(y, dl):
            """Residuals and the quantities needed for the Jacobian at d eps_v^p = y, dlambda = dl."""
            z = a * (deps_v - y)
            p = p_n * np.exp(z)
            p_x = a * p
            if const_G:
                Gb, Gb_x = prm["G"], np.zeros(n)
            else:
                phi, dphi = _expm1_over_x(z)
                Gb, Gb_x = c_nu * p_n * a * phi, c_nu * p_n * a * a * dphi
            s_tr = s_n + Gb[:, None] * Pde
            q_tr = np.sqrt(1.5 * np.sum(STRESS_WEIGHTS * s_tr * s_tr, axis=1))
            q_tr_safe = np.where(q_tr > 0.0, q_tr, 1.0)
            n_tr = 1.5 * STRESS_WEIGHTS * s_tr / q_tr_safe[:, None]  # dq_tr/ds_tr
            den = 1.0 + 6.0 * Gb * dl
            q = q_tr / den
            pc = pcn * np.exp(b * y)
            r1 = y - dl * M2 * (2.0 * p - pc)
            r2 = (q * q + M2 * p * (p - pc)) / pc_ref2
            return dict(p=p, p_x=p_x, Gb=Gb, Gb_x=Gb_x, s_tr=s_tr, n_tr=n_tr, den=den, q=q, pc=pc, r1=r1, r2=r2)

        def jacobian(y, dl, ev):
            p, p_x, Gb, Gb_x, den, q, pc = (ev[k] for k in ("p", "p_x", "Gb", "Gb_x", "den", "q", "pc"))
            dqtr_dG = np.sum(ev["n_tr"] * Pde, axis=1)
            q_x = (dqtr_dG - 6.0 * dl * q) / den * Gb_x
            q_l = -6.0 * Gb * q / den
            pc_y = b * pc
            r1_x = -2.0 * dl * M2 * p_x
            r2_x = (2.0 * q * q_x + M2 * (2.0 * p - pc) * p_x) / pc_ref2
            J11 = 1.0 + dl * M2 * pc_y - r1_x
            J12 = -M2 * (2.0 * p - pc)
            J21 = -M2 * p * pc_y / pc_ref2 - r2_x
            J22 = 2.0 * q * q_l / pc_ref2
            return J11, J12, J21, J22, r1_x, r2_x

        def merit(ev):
            return (b * ev["r1"]) ** 2 + ev["r2"] ** 2

        y = np.zeros(n)
        dl = np.zeros(n)
        ev = evaluate(y, dl)
        plastic = ev["r2"] > self.tolerance
        ok = np.ones(n, dtype=bool)
        if np.any(plastic):
            active = plastic.copy()
            for _ in range(self.max_iterations):
                J11, J12, J21, J22, _, _ = jacobian(y, dl, ev)
                det = J11 * J22 - J12 * J21
                det = np.where(det != 0.0, det, np.finfo(float).tiny)
                dy = -(J22 * ev["r1"] - J12 * ev["r2"]) / det
                dd = -(-J21 * ev["r1"] + J11 * ev["r2"]) / det
                dy, dd = np.where(active, dy, 0.0), np.where(active, dd, 0.0)
                m0 = merit(ev)
                step = np.ones(n)
                for _ls in range(12):  # backtracking on the merit function, dlambda kept >= 0
                    y_t = y + step * dy
                    dl_t = np.where(dl + step * dd < 0.0, 0.5 * dl, dl + step * dd)
                    ev_t = evaluate(y_t, dl_t)
                    m_t = merit(ev_t)
                    worse = active & ~(np.isfinite(m_t) & ((m_t < m0) | (m_t <= self.tolerance ** 2)))
                    if not np.any(worse):
                        break
                    step = np.where(worse, 0.5 * step, step)
                y, dl, ev = y_t, dl_t, ev_t  # inactive points had a zero step: ev_t is their ev
                done = (np.abs(b * ev["r1"]) <= self.tolerance) & (np.abs(ev["r2"]) <= self.tolerance)
                active &= ~done
                if not np.any(active):
                    break
            ok = ~active & np.isfinite(ev["p"]) & np.isfinite(ev["q"])
            if not np.all(ok):  # failed points (sub-stepped by the caller) get a finite elastic trial
                y, dl = np.where(ok, y, 0.0), np.where(ok, dl, 0.0)
                ev = evaluate(y, dl)

        # stress, plastic strain increment
        s = ev["s_tr"] / ev["den"][:, None]
        new_stress = s + ev["p"][:, None] * IDENTITY
        deps_p = (y / 3.0)[:, None] * IDENTITY + (3.0 * dl)[:, None] * STRESS_WEIGHTS * s

        # consistent tangent: sigma = p' 1 + s_tr/den; (y, dl) from the implicit-function theorem on (r1, r2)
        J11, J12, J21, J22, r1_x, r2_x = jacobian(y, dl, ev)
        Gb, Gb_x, den, q = ev["Gb"], ev["Gb_x"], ev["den"], ev["q"]
        q_eps = (Gb / den)[:, None] * (ev["n_tr"] @ DEVIATORIC_UNIT)
        R1_e = r1_x[:, None] * IDENTITY
        R2_e = r2_x[:, None] * IDENTITY + (2.0 * q / pc_ref2)[:, None] * q_eps
        det = J11 * J22 - J12 * J21
        pl = (y != 0.0) | (dl != 0.0)
        det = np.where(pl & (det != 0.0), det, 1.0)
        Y = np.where(pl[:, None], -(J22[:, None] * R1_e - J12[:, None] * R2_e) / det[:, None], 0.0)
        L = np.where(pl[:, None], -(-J21[:, None] * R1_e + J11[:, None] * R2_e) / det[:, None], 0.0)
        dx = IDENTITY - Y  # d(d eps_v^e)/d(d eps)
        tangent = (np.einsum("i,nj->nij", IDENTITY, ev["p_x"][:, None] * dx)
                   + (Gb / den)[:, None, None] * DEVIATORIC_UNIT
                   + np.einsum("ni,nj->nij", (Pde - (6.0 * dl)[:, None] * s) / den[:, None], Gb_x[:, None] * dx)
                   - np.einsum("ni,nj->nij", (6.0 * Gb / den)[:, None] * s, L))
        return new_stress, ev["pc"], deps_p, tangent, ok
