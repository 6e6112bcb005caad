"""SIMSAND's numpy stress-point integrator, vectorised over points: explicit modified Euler with local error control
and consistent drift correction (Sloan, Abbo & Sheng 2001), per-point pseudo-time and substep size, mixed
(strain/stress) control, the elastic-plastic crossing by the Pegasus method and the tension cutoff at ``p_min``.

It runs in two stress spaces (:data:`GENERAL`: six components, used by ``SIMSAND.update``; :data:`TRIAXIAL`: the
axisymmetric triaxial space, the reference (test oracle) of the compiled triaxial integrator of
``constitutive.sand._simsand_kernel``) over the equations (III)-(VII) compiled once in that kernel (docs/reference.md
section 3; module docstring of :mod:`constitutive.sand.simsand`). Compression positive, effective stresses in kPa.

:class:`ModifiedEulerSubstepping` is a mixin of :class:`constitutive.sand.simsand.SIMSAND`: it reads the model's
``p_at``, ``p_min`` (kPa), ``stol``, ``ftol``, ``_point_params(n)`` and ``failure_reason(code)``.
"""
from __future__ import annotations

import numpy as np

from ..base import IntegrationError
from ..invariants import IDENTITY, STRESS_WEIGHTS, isotropic_stiffness
from .constants import CONTROL_STIFFNESS_RATIO, E_MAX_STIFFNESS, STRESS_ERROR_FLOOR

_SQRT3_HALF3 = 1.5 * np.sqrt(3.0)


def simsand_kernel():
    """The compiled equations and triaxial integrator (``constitutive.sand._simsand_kernel``), imported on first use
    (keeps ``import constitutive`` free of numba)."""
    from . import _simsand_kernel
    return _simsand_kernel


class GeneralStress:
    """Six-component stress space: Voigt (11, 22, 33, 12, 23, 31), engineering shear strain (FE, general paths).

    Stress-like tensors are stored with tensor components; ``weights`` turn a Voigt pair into a:b, ``strain_row``
    turns a tensor-component row into one acting on the engineering strain vector.
    """

    size = 6
    identity = IDENTITY
    weights = STRESS_WEIGHTS
    strain_row = np.ones(6)
    volumetric_row = IDENTITY

    @staticmethod
    def deviatoric_strain(deps):
        """Tensor components of the strain deviator."""
        d = deps - (deps[:, :3].sum(axis=1) / 3.0)[:, None] * IDENTITY
        d[:, 3:] *= 0.5
        return d

    @staticmethod
    def lode(s, J2s, shear):
        """sin 3theta (+1 triaxial compression) and d sin3theta/d sigma (deviatoric, orthogonal to s)."""
        s11, s22, s33, s12, s23, s31 = s.T
        J3 = s11 * s22 * s33 + 2.0 * s12 * s23 * s31 - s11 * s23**2 - s22 * s31**2 - s33 * s12**2
        scale = _SQRT3_HALF3 / (J2s * np.sqrt(J2s))
        sin3 = np.where(shear, np.clip(scale * J3, -1.0, 1.0), 0.0)
        ss = np.stack([s11 * s11 + s12 * s12 + s31 * s31,
                       s12 * s12 + s22 * s22 + s23 * s23,
                       s31 * s31 + s23 * s23 + s33 * s33,
                       s11 * s12 + s12 * s22 + s31 * s23,
                       s12 * s31 + s22 * s23 + s23 * s33,
                       s11 * s31 + s12 * s23 + s31 * s33], axis=1)
        ss[:, :3] -= (2.0 / 3.0) * J2s[:, None]
        grad = np.where(shear[:, None], scale[:, None] * (ss - (1.5 * J3 / J2s)[:, None] * s), 0.0)
        return sin3, grad

    @staticmethod
    def stiffness(K, G):
        return isotropic_stiffness(K, G)


class TriaxialStress:
    """Axisymmetric triaxial space: stress (sigma'_a, sigma'_r), strain (eps_a, eps_r), eps_r each lateral strain.

    The same equations as :class:`GeneralStress` restricted to diagonal states with two equal lateral components
    (q = |sigma'_a - sigma'_r|, sin 3theta = sign(sigma'_a - sigma'_r)); the Lode gradient vanishes there.
    Used by the numpy integrator only with ``triaxial_integrator="numpy"``: the reference (test oracle) of the
    compiled triaxial integrator (:mod:`constitutive.sand._simsand_kernel`), which is what the triaxial paths run.
    """

    size = 2
    identity = np.array([1.0, 1.0])
    weights = np.array([1.0, 2.0])
    strain_row = np.array([1.0, 2.0])
    volumetric_row = np.array([1.0, 2.0])

    @staticmethod
    def deviatoric_strain(deps):
        return deps - ((deps[:, 0] + 2.0 * deps[:, 1]) / 3.0)[:, None]

    @staticmethod
    def lode(s, J2s, shear):
        return np.where(shear, np.sign(s[:, 0] - s[:, 1]), 0.0), None

    @staticmethod
    def stiffness(K, G):
        lam = K - 2.0 * G / 3.0
        D = np.empty(K.shape + (2, 2))
        D[:, 0, 0] = lam + 2.0 * G
        D[:, 0, 1] = 2.0 * lam
        D[:, 1, 0] = lam
        D[:, 1, 1] = 2.0 * lam + 2.0 * G
        return D


GENERAL = GeneralStress()
TRIAXIAL = TriaxialStress()


class MixedControl:
    """Which components of a stress space have prescribed stress increments (``held``) and which prescribed strain
    increments (``free``); ``size`` is the number held (0: pure strain control)."""

    def __init__(self, n_components, held):
        self.held = np.asarray(held, dtype=int)
        self.mask = np.isin(np.arange(n_components), self.held)
        self.free = np.flatnonzero(~self.mask)
        self.size = self.held.size


class ModifiedEulerSubstepping:
    """The numpy integrator of SIMSAND (module docstring), mixed into the model class."""

    # ------------------------------------------------------------------ local evaluation
    def _evaluate(self, space, sig, e, eps_dp, par, gradients=True, dstrain=None):
        """Invariants, yield function (IV) and, with ``gradients``, moduli (III), flow (V) and consistency terms.

        ``space`` is GENERAL or TRIAXIAL; ``par`` the parameters of the same points ((ncol, m), _point_params);
        ``dstrain`` (the substep strain) gives the deviatoric flow direction at q = 0. Returns a dict of arrays.
        """
        identity = space.identity
        p = (sig @ space.volumetric_row) / 3.0 if space.size == 2 else sig[:, :3].sum(axis=1) / 3.0
        s = sig - p[:, None] * identity
        J2 = 0.5 * ((s * s) @ space.weights)
        q = np.sqrt(3.0 * J2)
        pe = np.maximum(p, self.p_min)
        eta = q / pe
        shear = q > 1e-9 * pe  # a deviator exists; else the origin of loading or a hydrostatic state
        J2s = np.where(shear, J2, 1.0)
        sin3, lode_grad = space.lode(s, J2s, shear)
        d_dir = None
        if dstrain is not None and not np.all(shear):
            # origin of loading: the deviatoric direction (and its Lode angle) of the strain increment
            d_dir = space.deviatoric_strain(dstrain)
            dd = (d_dir * d_dir) @ space.weights
            shearing = ~shear & (dd > 1e-20 * (dstrain * dstrain).sum(axis=1))  # not round-off of a volumetric one
            sin3 = np.where(shearing, space.lode(d_dir, np.where(shearing, 0.5 * dd, 1.0), shearing)[0], sin3)
        kernel = simsand_kernel()  # the equations (III)-(VII), shared with the compiled triaxial integrator
        e = np.ascontiguousarray(e, dtype=float)
        eps_dp = np.ascontiguousarray(eps_dp, dtype=float)
        sin3 = np.ascontiguousarray(sin3, dtype=float)
        if not gradients:
            f, Mp = kernel.yield_value(eta, pe, e, eps_dp, sin3, par, self.p_at)
            return {"p": p, "q": q, "eta": eta, "Mp": Mp, "f": f}
        f, K, G, df_dp, df_de, dil, Kp, HdM_dsin3 = kernel.material_terms(eta, pe, e, eps_dp, sin3, par, self.p_at)
        # nhat = dq/dsigma = 3 s/(2 q) (nhat:nhat = 3/2); at q = 0 along the deviatoric strain increment
        nhat = 1.5 * s / np.where(shear, q, 1.0)[:, None]
        if d_dir is not None:
            scale = np.sqrt(1.5 / np.where(shearing, dd, 1.0)) * shearing
            nhat = np.where(shear[:, None], nhat, d_dir * scale[:, None])
        a_dev = nhat / pe[:, None]  # df/dq = 1/p'
        if lode_grad is not None:
            a_dev = a_dev - HdM_dsin3[:, None] * lode_grad
        # plastic potential (V): m = A_d (M_pt - eta) I/3 + nhat (strain-like), D m = K A_d (M_pt - eta) I + 2 G nhat
        Dm = (K * dil)[:, None] * identity + 2.0 * G[:, None] * nhat
        den = df_dp * K * dil + 2.0 * G * ((a_dev * nhat) @ space.weights) + Kp
        # row acting on a strain increment: a:D d eps + (df/de) de, with de = -(1 + e_0) d eps_v (caller adds v0)
        Da = space.strain_row * (2.0 * G[:, None] * a_dev + (df_dp * K)[:, None] * identity)
        return {"p": p, "q": q, "eta": eta, "f": f, "K": K, "G": G, "Dm": Dm, "den": den, "Da": Da, "df_de": df_de,
                "a": a_dev + (df_dp / 3.0)[:, None] * identity}

    @staticmethod
    def _elastic(space, ev, deps):
        """D d eps = K d eps_v I + 2 G dev(d eps) (stress-like, tensor components)."""
        dv = deps @ space.volumetric_row
        return (ev["K"] * dv)[:, None] * space.identity + 2.0 * ev["G"][:, None] * space.deviatoric_strain(deps)

    def _rates(self, space, ev, dload, v0, plastic, control):
        """Stage increments (d sigma, d eps, d lambda) for one substep.

        ``dload`` holds the prescribed strain increments on strain-controlled components and the prescribed stress
        increments on the stress-controlled ones (``control`` = indices of the latter, possibly empty); the unknown
        strains follow from the tangent of the stage (elastic, or elasto-plastic where ``plastic``).
        """
        row = ev["Da"] - (ev["df_de"] * v0)[:, None] * space.volumetric_row
        if control.size == 0:
            deps = dload
        else:
            deps = self._solve_mixed(space, ev, dload, row, plastic, control)
        dlam = np.where(plastic, np.einsum("ij,ij->i", row, deps) / ev["den"], 0.0)
        return self._elastic(space, ev, deps) - dlam[:, None] * ev["Dm"], deps, dlam

    @staticmethod
    def _solve_mixed(space, ev, dload, row, plastic, control):
        """Strain increment meeting the prescribed stress increments on ``control`` with the stage tangent
        T = D - D m (x) row / den (plastic points) or D; NaN rows where the path is uncontrollable."""
        held, free = control.held, control.free
        D = space.stiffness(ev["K"], ev["G"])
        scale = np.where(plastic, 1.0 / ev["den"], 0.0)
        deps = dload.copy()
        if held.size == 1:  # one stress-controlled component (drained triaxial): scalar equation
            i = held[0]
            D_row = D[:, i, :]
            T_row = D_row - (ev["Dm"][:, i] * scale)[:, None] * row
            d_free = np.where(control.mask, 0.0, dload)
            stiff, stiff_el = T_row[:, i], D_row[:, i]
            deps[:, i] = (dload[:, i] - np.einsum("ij,ij->i", T_row, d_free)) / stiff
        else:
            Dm_s = ev["Dm"][:, held] * scale[:, None]
            T_sf = D[:, held][:, :, free] - Dm_s[:, :, None] * row[:, None, free]
            D_ss = D[:, held][:, :, held]
            T_ss = D_ss - Dm_s[:, :, None] * row[:, None, held]
            rhs = dload[:, held] - np.einsum("nij,nj->ni", T_sf, dload[:, free])
            deps[:, held] = np.linalg.solve(T_ss, rhs[:, :, None])[:, :, 0]
            stiff, stiff_el = np.linalg.det(T_ss), np.linalg.det(D_ss)
        # controllable: the tangent on the stress-controlled components stays above a fraction of the elastic one
        deps[~(stiff > CONTROL_STIFFNESS_RATIO * stiff_el)] = np.nan
        return deps

    # ------------------------------------------------------------------ integration
    def _integrate(self, space, stress, state, dload, control, raise_errors=True, active=None):
        """Modified Euler substepping with error control (Sloan et al. 2001) over one increment of all points.

        ``control``: indices of the stress-controlled components (empty: strain control).
        Returns (stress, void ratio, eps_d^p, strain increment, plastic flag of the last substep, failed mask,
        proposed first substep of the next increment).
        A point that fails raises IntegrationError, or with ``raise_errors=False`` is left at its last accepted
        substep and flagged in the failed mask while the others carry on. Points outside ``active`` (bool (n,),
        default all) are left unchanged.
        """
        with np.errstate(all="ignore"):
            return self._substeps(space, stress, state, dload, MixedControl(space.size, control), raise_errors, active)

    def _substeps(self, space, stress, state, dload, control, raise_errors, active):
        n = stress.shape[0]
        par_all = self._point_params(n)
        sig = stress.copy()
        e = np.array(state["void_ratio"], dtype=float)
        v0_all = 1.0 + np.asarray(state["void_ratio_initial"], dtype=float)
        eps = np.array(state["eps_dp"], dtype=float)
        strain = np.zeros_like(stress)
        T = np.zeros(n)
        # first trial substep (fraction of the increment): twice the last size proposed by the error control
        dT = np.minimum(2.0 * np.array(state.get("substep", np.ones(n)), dtype=float), 1.0)
        plastic_end = np.zeros(n, dtype=bool)
        nsub = np.zeros(n, dtype=int)
        failed = np.zeros(n, dtype=bool)
        moving = np.any(dload != 0.0, axis=1)  # a zero increment (zero loads) changes nothing
        act = np.flatnonzero(moving if active is None else moving & active)
        stol, ftol = self.stol, self.ftol
        k = simsand_kernel()
        par = None
        while act.size:
            if par is None or par.shape[1] != act.size:
                par = par_all[:, act]
            s0, e0, k0, v0 = sig[act], e[act], eps[act], v0_all[act]
            fail = np.zeros(act.size, dtype=bool)

            def flag(mask, code):
                if raise_errors and np.any(mask):
                    raise IntegrationError(int(act[np.argmax(mask)]), self.failure_reason(code))
                fail[mask] = True
            h = np.minimum(dT[act], 1.0 - T[act])
            dl = h[:, None] * dload[act]
            ev0 = self._evaluate(space, s0, e0, k0, par, dstrain=dl)
            on_surface = ev0["f"] >= -ftol
            # stage 1 (forward Euler); plastic where on the surface and loading
            dsig1, deps1, dlam1 = self._rates(space, ev0, dl, v0, on_surface, control)
            pl = on_surface & (dlam1 > 0.0)
            if np.any(on_surface & ~pl):  # unloading from the surface (elastic; mixed control: re-solve)
                dsig1, deps1, dlam1 = self._rates(space, ev0, dl, v0, pl, control)
            flag(pl & ~(ev0["den"] > 0.0), k.NO_UNIQUE_RESPONSE)
            flag(~np.all(np.isfinite(deps1), axis=1), k.CONTROL_LOST)
            ddv1 = -v0 * (deps1 @ space.volumetric_row)
            # stage 2 at the Euler estimate
            ev1 = self._evaluate(space, s0 + dsig1, e0 + ddv1, k0 + dlam1, par, dstrain=dl)
            dsig2, deps2, dlam2 = self._rates(space, ev1, dl, v0, pl, control)
            if control.size:
                flag(~np.all(np.isfinite(deps2), axis=1) & np.all(np.isfinite(ev1["Dm"]), axis=1) & ~fail,
                     k.CONTROL_LOST_WITHIN)
            sig_new = s0 + 0.5 * (dsig1 + dsig2)
            deps_new = 0.5 * (deps1 + deps2)
            eps_new = np.maximum(k0 + 0.5 * (dlam1 + dlam2), 0.0)
            e_new = e0 - v0 * (deps_new @ space.volumetric_row)
            # local error (Sloan et al. 2001): stress relative; hardening through the mobilised ratio H (absolute);
            # under pure stress control the strain error through the elastic stiffness
            dnorm = np.sqrt(((dsig2 - dsig1) ** 2) @ space.weights)
            snorm = np.sqrt((sig_new**2) @ space.weights)
            floor = STRESS_ERROR_FLOOR * self.p_at
            err = 0.5 * dnorm / np.maximum(snorm, floor)
            err = np.maximum(err, 0.5 * np.abs(dlam2 - dlam1) * par[k.KP] / (par[k.KP] + eps_new) ** 2)
            if control.free.size == 0:  # pure stress control: the strain error, as the stress error it would make
                dstr = self._elastic(space, ev0, deps2 - deps1)
                err = np.maximum(err, 0.5 * np.sqrt((dstr**2) @ space.weights) / np.maximum(snorm, floor))
            err = np.where(np.isfinite(err) & ~(pl & ~(ev1["den"] > 0.0)), err, np.inf)
            ok = (err <= stol) & ~fail
            frac = np.ones(act.size)
            # accepted elastic substeps that end outside the yield surface
            el = np.flatnonzero(ok & ~pl)
            restart = np.zeros(act.size, dtype=bool)
            cross = np.zeros(act.size, dtype=bool)
            if el.size:
                f_el = self._evaluate(space, sig_new[el], e_new[el], eps_new[el], par[:, el], gradients=False)["f"]
                out = f_el > ftol
                restart[el[out & on_surface[el]]] = True  # unloading then reloading inside the substep: shorten
                c = out & ~on_surface[el]
                if np.any(c):  # elastic to plastic: stop the substep at the crossing (Pegasus on f)
                    ci = el[c]
                    cross[ci] = True
                    frac[ci] = self._crossing(space, s0[ci], sig_new[ci] - s0[ci], e0[ci], e_new[ci] - e0[ci],
                                              k0[ci], ev0["f"][ci], f_el[c], par[:, ci])
                    sig_new[ci] = s0[ci] + frac[ci, None] * (sig_new[ci] - s0[ci])
                    e_new[ci] = e0[ci] + frac[ci] * (e_new[ci] - e0[ci])
                    deps_new[ci] *= frac[ci, None]
            ok &= ~restart
            # drift correction of accepted plastic substeps
            c = np.flatnonzero(ok & pl)
            if c.size:
                sig_new[c], e_new[c], eps_new[c], deps_new[c], bad = self._drift_correct(
                    space, sig_new[c], e_new[c], eps_new[c], deps_new[c], v0[c], par[:, c], control,
                    {key: v[c] for key, v in ev1.items()})
                fc = np.zeros(act.size, dtype=bool)
                fc[c[bad]] = True
                flag(fc, k.DRIFT_FAILED)
            # tension cutoff (sand carries no tension): isotropic p' = p_min for the rest of the increment
            low = ok & ((sig_new @ space.volumetric_row if space.size == 2 else sig_new[:, :3].sum(axis=1))
                        < 3.0 * self.p_min)
            if np.any(low):
                sig_new[low] = self.p_min * space.identity
            flag(ok & ~((e_new > 0.0) & (e_new < E_MAX_STIFFNESS) & np.all(np.isfinite(sig_new), axis=1)),
                 k.STATE_INVALID)
            ok &= ~fail
            # commit accepted substeps
            acc = act[ok]
            sig[acc], e[acc], eps[acc] = sig_new[ok], e_new[ok], eps_new[ok]
            strain[acc] += deps_new[ok]
            T[acc] += (h * frac)[ok]
            T[act[low]] = 1.0  # cut off: the rest of the increment is absorbed at p' = p_min
            plastic_end[acc] = pl[ok]
            # next substep: q = 0.9 sqrt(STOL/R) in [0.1, 2] (<= 1 after a rejection); a restart quarters it
            fac = np.clip(0.9 * np.sqrt(stol / np.maximum(err, 1e-30)), 0.1, np.where(ok, 2.0, 1.0))
            dT[act] = np.where(cross, h * (1.0 - frac), np.where(restart, 0.25, fac) * h)
            nsub[act] += 1
            flag(~fail & ((dT[act] < 1e-12) & (T[act] < 1.0 - 1e-12) | (nsub[act] > self.max_substeps)),
                 k.ERROR_CONTROL)
            failed[act[fail]] = True
            act = act[(T[act] < 1.0 - 1e-12) & ~fail]
        return sig, e, eps, strain, plastic_end, failed, np.minimum(dT, 1.0)

    def _crossing(self, space, s0, dsig, e0, de, eps, f0, f1, par, iterations=30):
        """Fraction alpha of an elastic substep where f = 0 (Pegasus method along the linearised elastic path)."""
        a0, a1 = np.zeros_like(f0), np.ones_like(f0)
        alpha = a1.copy()
        for _ in range(iterations):
            alpha = a1 - f1 * (a1 - a0) / (f1 - f0)
            fa = self._evaluate(space, s0 + alpha[:, None] * dsig, e0 + alpha * de, eps, par, gradients=False)["f"]
            if np.all(np.abs(fa) <= self.ftol):
                break
            swap = fa * f1 < 0.0
            a0, f0 = np.where(swap, a1, a0), np.where(swap, f1, f0 * f1 / (f1 + fa))
            a1, f1 = alpha, fa
        return alpha

    def _drift_correct(self, space, sig, e, eps, deps, v0, par, control, ev):
        """One correction back to f = 0 (Sloan et al. 2001), keeping prescribed stress components.

        Consistent correction at fixed total strain on strain-controlled components: d sigma = d lambda (D w - D m),
        d eps = d lambda w, w the strain on stress-controlled components that keeps their stress (w = 0 under
        strain control), d lambda = f / (a:D m + K_p - row . w). It converges quadratically; what remains (of order
        f^2) is carried by the consistency condition of the next substep. Where the denominator is not positive
        (softening under mixed control) the stress alone is projected along the yield gradient restricted to the
        free components (normal correction). The yield function is evaluated at the end of the substep; gradients,
        moduli and flow come from ``ev``, the evaluation at the second-stage state of the same substep (a nearby
        state: the correction is of the order of the local error). Returns the corrected (stress, void ratio,
        eps_d^p, strain increment) and a mask of points where no correction is possible.
        """
        f = self._evaluate(space, sig, e, eps, par, gradients=False)["f"]
        todo = np.abs(f) > self.ftol
        if control.size:
            held = control.mask
            row = ev["Da"] - (ev["df_de"] * v0)[:, None] * space.volumetric_row
            w = self._solve_mixed(space, ev, np.where(held, ev["Dm"], 0.0), row, np.zeros(f.shape, dtype=bool),
                                  control)
            dir_sig = self._elastic(space, ev, w) - ev["Dm"]
            den = ev["den"] - np.einsum("ij,ij->i", row, w)
        else:
            held = np.zeros(space.size, dtype=bool)
            w, dir_sig, den = np.zeros_like(deps), -ev["Dm"], ev["den"]
        consistent = den > 0.0
        dl = np.where(todo & consistent, f / np.where(consistent, den, 1.0), 0.0)
        dl = np.maximum(dl, -eps)  # eps_d^p stays >= 0
        dw = dl[:, None] * w
        sig = sig + dl[:, None] * dir_sig
        e = e - v0 * (dw @ space.volumetric_row)
        normal = todo & ~consistent
        bad = np.zeros(f.shape, dtype=bool)
        if np.any(normal):  # normal correction: a = df/dp I/3 + a_dev on the free components
            a = np.where(held, 0.0, ev["a"])
            aa = (a * a) @ space.weights
            bad = normal & ~(aa > 0.0)
            sig = sig - np.where(normal, f / np.where(aa > 0.0, aa, 1.0), 0.0)[:, None] * a
        return sig, e, eps + dl, deps + dw, bad
