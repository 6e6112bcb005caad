"""Biot coupled consolidation (u-p), backward Euler, global Newton-Raphson, banded LU, automatic step cutting.

Unknowns per node: u_r, u_z (m, tension/outward positive) and the excess pore pressure p = u - u0 (kPa). Per radian,
FE tension-positive stress (conversion to the soil convention in fem.material_point only). Over a time step dt,
with B, Q, H, S, K_hg from fem.element:

  momentum  R_u = sum_e [V B^T (sigma' - sigma'_0) + c_hg G_hg K_hg U - Q p] - A(t) F_pressure = 0
            (total stress sigma = sigma' - u m; the geostatic state sigma'_0, u0 is in equilibrium with the in-situ
            boundary tractions, so only increments appear and a step without load leaves the state unchanged);
  mass      R_p = -sum_e [Q^T (U - U_n) + dt (k/gamma_w) H p + tau S (p - p_n)] = 0
            (incompressible grains and water, Darcy flow q = -(k/gamma_w) grad p; backward Euler; the last term is
            the polynomial pressure projection of Dohrmann & Bochev / White & Borja, S = M - n_bar n_bar^T / V,
            tau = 1/(2 G_hg), docs/reference.md section 7).

Jacobian [[V B^T D B + K_hg, -Q], [-Q^T, -(dt k/gamma_w H + tau S)]] with the material tangent D; Dirichlet dofs are
eliminated (unit rows/columns). Nodes are numbered so that the band is narrow (the pressuremeter strip: 3 (n_z + 2)
dofs), and the system is solved with LAPACK dgbtrf/dgbtrs (full or modified Newton, see Solver._newton).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dgbtrf, dgbtrs
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

from constitutive import IntegrationError

from ._residual_kernel import (
    band_matrix,
    coupled_residual,
    extrapolate,
    newton_measures,
    step_rates,
    structural_zeros,
    trial_strain,
)
from .element import ElementGeometry
from .material_point import MaterialPoints
from .problem import DOFS, Problem, edges_of_set
from .result import Result, Snapshot

__all__ = ["Solver", "solve", "ConvergenceError"]

IU = np.array([0, 1, 3, 4, 6, 7, 9, 10])   # element-local dofs of (u_r1, u_z1, u_r2, ...) in (u_r, u_z, p) x 4
IP = np.array([2, 5, 8, 11])
# Floor of the per-dof residual reference, relative to the largest reference of the field. Far from the cavity in a
# holding phase the flux and volume-change levels fall to ~1e-8 of the wall values and the residual there is
# round-off (U - U_n of nearly equal displacements): measured 1e-23 against 3.8e-18 with a field maximum of 1.8e-10
# (120 radial cells, von Mises dissipation), i.e. round-off at ~5e-14 of the maximum. 1e-6 x rtol = 1e-12 clears it.
SCALE_FLOOR = 1e-6
# A rate-dependent material is asked for its tangent at iteration 1 of a step when iteration 1 of the step before
# missed the tolerance by more than this factor: a factorization is then likely (the one kept at the extrapolated
# start is as stale). A call with the tangent costs about 1.6 times one without it (ANICREEP, 240 points: 0.39 and
# 0.24 ms), so a tangent asked for with the residual saves 0.24 ms when a factorization follows and costs 0.15 ms
# when none does. Burswood ANICREEP expansions (fem.bench and 8 posterior draws, both rates; 18 solves, 304
# factorizations): second calls for the tangent 286 -> 131, with 30 tangents asked for in vain.
EAGER_TANGENT_MISS = 2.0
_EMPTY = np.zeros(0)   # "no such rate" for the compiled predictor (first order, or the first step of a phase)


class ConvergenceError(RuntimeError):
    """Newton failed even after the allowed number of step cuts."""


class _StepFailed(Exception):
    pass


def solve(problem: Problem, **overrides) -> Result:
    """Solve ``problem``; ``overrides`` (material=..., permeability=...) as in :meth:`Solver.solve`."""
    return Solver(problem).solve(**overrides)


class Solver:
    """Everything that does not depend on the material parameters, built once: element geometry, dof numbering,
    band structure, constraint masks, load vectors, monitor interpolation. :meth:`solve` may be called many times
    with new materials (the calibration loop)."""

    def __init__(self, problem: Problem):
        problem.validate()
        self.problem = pb = problem
        mesh = pb.mesh
        self.geom = ElementGeometry(mesh.nodes, mesh.cells)
        nn, ne = mesh.n_nodes, mesh.n_cells
        self.n_dofs = N = 3 * nn
        self.node_order = _band_order(mesh.cells, nn)
        nd = 3 * self.node_order[mesh.cells][:, :, None] + np.arange(3)   # (ne, 4, 3) global dofs
        self.edofs = edofs = nd.reshape(ne, 12)
        self.udofs = nd[:, :, :2].reshape(ne, 8)
        self.pdofs = nd[:, :, 2]
        diff = edofs[:, :, None] - edofs[:, None, :]
        self.kl = kl = int(np.abs(diff).max())
        self.rows = rows = 3 * kl + 1                                      # LAPACK band storage: 2 kl + ku + 1, ku = kl
        # constrained dofs and their scales (value = scale * A(t))
        cdofs, cscale = [], []
        for bc in pb.dirichlet:
            ids = mesh.node_set(bc.node_set)
            cdofs.append(3 * self.node_order[ids] + DOFS[bc.dof])
            cscale.append(np.full(ids.size, float(bc.scale)))
        cdofs = np.concatenate(cdofs) if cdofs else np.zeros(0, int)
        cscale = np.concatenate(cscale) if cscale else np.zeros(0)
        self.cdofs, first = np.unique(cdofs[::-1], return_index=True)      # later conditions win on shared dofs
        self.cscale = cscale[::-1][first]
        self.free = np.ones(N, bool)
        self.free[self.cdofs] = False
        is_p = np.arange(N) % 3 == 2
        self._ufree = np.flatnonzero(self.free & ~is_p)   # index arrays: cheaper than boolean masks per iteration
        self._pfree = np.flatnonzero(self.free & is_p)
        # band storage (C order (N, rows), passed transposed = Fortran (rows, N)): A[i, j] at [j, 2kl + i - j]
        flat = (edofs[:, None, :] * rows + 2 * kl + edofs[:, :, None] - edofs[:, None, :])
        keep = self.free[edofs][:, :, None] & self.free[edofs][:, None, :]
        local_uu = np.zeros((12, 12), bool)
        local_uu[np.ix_(IU, IU)] = True
        self._uu_sel = np.flatnonzero((keep & local_uu).reshape(ne, 12, 12)[:, IU][:, :, IU].ravel())
        self._uu_idx = flat[:, IU][:, :, IU].ravel()[self._uu_sel]
        self._up_sel = np.flatnonzero((keep & ~local_uu).ravel())
        self._up_idx = flat.ravel()[self._up_sel]
        self._diag_c = self.cdofs * rows + 2 * kl
        self.band_size = N * rows
        # two band Jacobians, factorized in place in turn (_factor)
        self._bands, self._next_band = (np.empty(self.band_size), np.empty(self.band_size)), 0
        # boundary pressure loads per unit amplitude
        self.f_pressure = np.zeros(N)
        for bc in pb.pressures:
            self.f_pressure += bc.scale * _pressure_vector(mesh, bc.node_set, self.node_order, N)
        # cavity wall (pressure = sum of radial nodal forces / wall area per radian)
        self.cavity_ur = None
        if "cavity" in mesh.node_sets and mesh.node_sets["cavity"].size:
            self.cavity_ur = 3 * self.node_order[mesh.node_sets["cavity"]]
            self.cavity_p = self.cavity_ur + 2
            self.cavity_area = _pressure_vector(mesh, "cavity", self.node_order, N)[self.cavity_ur].sum()
            self.cavity_radius = mesh.nodes[mesh.node_sets["cavity"], 0].mean()
        # monitors: excess pore pressure along the node row nearest mid-height, linear in r
        zmid = 0.5 * (mesh.nodes[:, 1].min() + mesh.nodes[:, 1].max())
        dz = np.abs(mesh.nodes[:, 1] - zmid)
        row = np.flatnonzero(dz <= dz.min() + 1e-12 * np.ptp(mesh.nodes[:, 1] + 1.0))
        row = row[np.argsort(mesh.nodes[row, 0])]
        self.monitor_nodes, self.monitor_r = 3 * self.node_order[row] + 2, mesh.nodes[row, 0]
        self.times, self.amplitudes, self.phase_of = pb.amplitude_table()
        g = self.geom
        if not structural_zeros(g.B, g.hg):
            raise RuntimeError("fem.element: B or K_hg has entries where the compiled residual assumes zeros")
        self._VBt = g.volume[:, None, None] * np.transpose(g.B, (0, 2, 1)).copy()
        self._absVBt = np.abs(self._VBt)
        self._abs_vol_row = np.abs(g.vol_row)
        driven = np.zeros(N, bool)
        driven[self.cdofs[self.cscale != 0.0]] = True
        self._cells_c = np.flatnonzero(np.any(driven[self.edofs], axis=1))   # cells moved by driven dofs
        self._has_pressure = bool(np.any(self.f_pressure))
        self._no_load = np.zeros(N)
        self._norm_pressure = np.linalg.norm(self.f_pressure)
        self._const_cache = {}

    # ------------------------------------------------------------------ public
    def solve(self, material=None, permeability=None) -> Result:
        """Run the loading history. ``material`` replaces the problem's model (same mesh, loads, initial state),
        ``permeability`` its k (m/s). Returns a fem.Result."""
        pb = self.problem
        model = pb.material if material is None else material
        k = np.broadcast_to(np.asarray(pb.permeability if permeability is None else permeability, float),
                            (pb.mesh.n_cells,))
        if not np.all(np.isfinite(k)) or np.any(k <= 0):
            raise ValueError(f"permeability k = {k.min()} m/s must be positive and finite")
        g = self.geom
        ne = pb.mesh.n_cells
        stress0 = pb.initial.effective_stress(ne)
        mp = MaterialPoints(model, stress0, pb.void_ratio0)
        self._mp = mp
        self._k = k / pb.gamma_w
        self._k_dt = (None, None)   # (dt, dt k/gamma_w per cell) of the last residual
        self._const_cache = {}
        self._lu = None
        self.stats = {"residuals": 0, "material_calls": 0, "tangent_calls": 0, "factorizations": 0, "cuts": 0}
        self._sig0_fe = -stress0[:, :4]
        first_dt = self.times[1] - self.times[0]
        first = mp.trial(np.zeros((ne, 4)), first_dt)
        self._D = first[2]   # tangent of the committed state (see _residual)
        self._rate_dependent = bool(getattr(model, "rate_dependent", True))
        # a rate-dependent material's first residual (x = 0, dt the first step) repeats this update: reused there
        self._first_trial = (first_dt, first) if self._rate_dependent else None
        if pb.hourglass_modulus is None:
            G = self._D[:, 3, 3].copy()
        else:
            G = np.full(ne, float(pb.hourglass_modulus))
        self._G = G
        self._hg = pb.hourglass_scale * G[:, None, None] * g.hg
        self._tau = (0.5 / G) if pb.stabilization else np.zeros(ne)
        self._S = self._tau[:, None, None] * (g.M - g.n_bar[:, :, None] * g.n_bar[:, None, :] / g.volume[:, None, None])
        self._absS = np.abs(self._S)
        self._f_geo = self._assemble_u(g.volume[:, None] * np.einsum("nij,ni->nj", g.B, self._sig0_fe)
                                       - g.vol_row * (g.volume * pb.initial.u0)[:, None])
        if self.cavity_ur is not None:
            self._f_geo_wall = self._f_geo[self.cavity_ur].sum()
        x = np.zeros(self.n_dofs)
        self._reaction = np.zeros(self.n_dofs)
        self._strain = np.zeros((ne, 4))
        self._scale = np.empty(self.n_dofs)   # scratch of _residual: the per-dof reference magnitudes
        self._rhs = np.empty(self.n_dofs)     # scratch of _residual: the right-hand side of the correction
        result = Result(self, pb)
        result.record(0.0, 0.0, x, self)
        if pb.save_fields != "none":
            result.snapshot(self.snapshot(0.0, x))
        self._velocity = self._acceleration = None
        self._eager_tangent = False
        for i in range(1, len(self.times)):
            if i > 1 and self.phase_of[i - 1] != self.phase_of[i - 2]:
                self._velocity = self._acceleration = None  # a new phase: the last rates say nothing of the next
            x = self._increment(x, self.times[i - 1], self.times[i], self.amplitudes[i - 1], self.amplitudes[i])
            result.record(self.times[i], self.amplitudes[i], x, self)
            last_of_phase = i == len(self.times) - 1 or self.phase_of[i] != self.phase_of[i - 1]
            if pb.save_fields == "all" or (pb.save_fields == "phases" and last_of_phase):
                result.snapshot(self.snapshot(self.times[i], x))
        return result.finish()

    def snapshot(self, t, x):
        inv = self.node_order
        disp = np.column_stack([x[3 * inv], x[3 * inv + 1]])
        p = x[3 * inv + 2]
        return Snapshot(t, disp, p, self.problem.initial.u0 + p, self._mp.stress.copy(), self._strain.copy())

    def cavity_pressure(self, x):
        """Total radial stress on the cavity wall (kPa, compression positive): the in-situ value plus the converged
        reaction increment (the residual at the constrained dofs), summed over the wall and divided by its area."""
        return (self._f_geo_wall + self._reaction[self.cavity_ur].sum()) / self.cavity_area

    # ------------------------------------------------------------------ stepping
    def _increment(self, x, t0, t1, a0, a1):
        """Advance from t0 to t1, halving the sub-step on failure (up to max_cuts halvings). The extrapolated
        predictor is second order: x_n + dt v_n + dt (dt_n + dt)/2 a_n, with v_n = (x_n - x_n-1)/dt_n the last
        converged sub-step's mean rate (the rate at its midpoint) and a_n = (v_n - v_n-1)/((dt_n + dt_n-1)/2) the
        change of the last two (first order, x_n + dt v_n, after one sub-step); after a failure the next sub-step
        starts without either."""
        pb = self.problem
        frac, h, depth = 0.0, 1.0, 0
        while frac < 1.0 - 1e-12:
            h = min(h, 1.0 - frac)
            f1 = frac + h
            dt = (t1 - t0) * h
            guess = None
            if pb.predictor == "extrapolate" and self._velocity is not None:
                guess = np.empty_like(x)
                if self._acceleration is None:
                    extrapolate(x, self._velocity, dt, _EMPTY, 0.0, guess)
                else:
                    extrapolate(x, self._velocity, dt, self._acceleration, 0.5 * dt * (self._dt_last + dt), guess)
            try:
                x_new = self._newton(x, dt, a0 + (a1 - a0) * f1, guess)
                velocity = np.empty_like(x)
                if self._velocity is None:
                    step_rates(x_new, x, dt, _EMPTY, 1.0, velocity, _EMPTY)
                    self._acceleration = None
                else:
                    self._acceleration = np.empty_like(x)
                    step_rates(x_new, x, dt, self._velocity, 0.5 * (dt + self._dt_last), velocity,
                               self._acceleration)
                self._velocity, self._dt_last = velocity, dt
                x = x_new
                frac = f1
            except _StepFailed as err:
                self._velocity = self._acceleration = None  # the cut sub-step starts from the tangent predictor
                self.stats["cuts"] += 1
                depth += 1
                if depth > pb.max_cuts:
                    raise ConvergenceError(
                        f"no convergence at t = {t0 + (t1 - t0) * frac:.6g} s (amplitude {a0 + (a1 - a0) * frac:.6g})"
                        f" after {pb.max_cuts} step cuts (sub-step {(t1 - t0) * h:.3g} s): {err}") from None
                h *= 0.5
        return x

    def _newton(self, x_n, dt, a1, guess=None):
        """One backward-Euler step to amplitude a1.

        Iteration 0 is the predictor. With a ``guess`` (problem.predictor 'extrapolate': every dof extrapolated
        from the last steps of the phase, _increment) Newton starts there, with the constrained dofs at
        their new values; the residual at the guess needs a material call and may already be converged, and the
        correction from it uses the last factorization (a fresh Jacobian only from iteration 1 on). Without
        one ('tangent', or the first step of a phase), the constrained dofs move to their new values with the
        Jacobian of the last factorization (kept across steps of equal dt), and for a rate-independent material
        (``rate_dependent`` False) the residual there needs no material call (_residual). Measured on the Burswood
        ANICREEP expansion (fem.bench): 215 residual evaluations and 16 factorizations (222 and 23 with the first
        order extrapolation alone) against 325 and 126 with the tangent predictor. From iteration 1 on: full Newton
        with the material's tangent (``problem.refresh_ratio`` = 0, the default: the Jacobian is refactored at every
        iteration that has not converged), or modified Newton (refresh_ratio > 0: the factorization is kept and
        refreshed only when an iteration reduces the relative residual by less than that factor). A linear material
        needs one factorization per time-step size either way. Measured on the Burswood expansion (fem.bench):
        MCC 218 residual evaluations (217 material calls, 19 factorizations) with full Newton against 256 (255, 6)
        with refresh_ratio 0.1."""
        pb = self.problem
        mp = self._mp
        x = x_n.copy() if guess is None else guess   # owned here: corrected in place
        if guess is not None:
            x[self.cdofs] = self.cscale * a1
        previous = np.inf
        eager, self._eager_tangent = self._eager_tangent, False
        for it in range(pb.max_iterations + 1):
            moved = it > 0 or guess is not None
            try:
                # a rate-dependent material is called at every residual, and its tangent is needed only when a
                # factorization follows (about 1 call in 10): asked for then (_tangent_at), not at every call,
                # unless a factorization is due should this residual not converge (no factorization of this dt
                # is kept), or likely (iteration 1, after a step whose iteration 1 missed by a wide margin)
                tangent = (not (moved and self._rate_dependent) or self._lu is None
                           or abs(self._lu[2] - dt) > 1e-9 * dt or (it == 1 and eager))
                R, D, trial, (finite, ru, rp), rhs = self._residual(
                    x, x_n, dt, a1, material_call=moved or self._rate_dependent, tangent=tangent)
            except IntegrationError as err:
                self._lu = None
                raise _StepFailed(f"material: {err}") from None
            if not finite:
                self._lu = None
                raise _StepFailed("non-finite residual")
            if moved:
                if ru <= pb.rtol and rp <= pb.rtol:
                    mp.commit(trial[0], trial[1])
                    self._D = D
                    self._strain = trial[2]
                    self._reaction = R + a1 * self.f_pressure if self._has_pressure else R
                    return x
                current = max(ru, rp)
                if it == 1:
                    self._eager_tangent = current > EAGER_TANGENT_MISS * pb.rtol
                if it > 0 and (pb.refresh_ratio == 0.0 or current > pb.refresh_ratio * previous):
                    self._lu = None
                previous = current
            if it == pb.max_iterations:
                break
            if not moved:
                dc = self.cscale * a1 - x_n[self.cdofs]
                dx = np.zeros_like(x)
                dx[self.cdofs] = dc
                rhs -= self._apply(D, dt, dx)
                rhs[self.cdofs] = dc
            if self._lu is None or abs(self._lu[2] - dt) > 1e-9 * dt:
                if D is None:
                    try:
                        D = self._tangent_at(trial[2], dt)
                    except IntegrationError as err:
                        raise _StepFailed(f"material: {err}") from None
                self._factor(self._stiffness(D), dt)
            x += self._back_substitute(rhs)
        self._lu = None
        raise _StepFailed(f"Newton did not converge in {pb.max_iterations} iterations (largest nodal residuals "
                          f"relative to the nodal force/flux levels: {ru:.3g} momentum, {rp:.3g} mass)")

    # ------------------------------------------------------------------ element work (vectorized over cells)
    def _residual(self, x, x_n, dt, a1, material_call=True, tangent=True):
        """Residual R, tangent, trial material state (soil stress, state, FE strain), the convergence measures
        (finite, ru, rp) of ``newton_measures`` and the right-hand side -R (zeros at the constrained dofs; a
        scratch array overwritten by the next call) at x. With material_call False (iteration 0 of a step, x = x_n,
        rate-independent material: a zero strain increment leaves the stress unchanged whatever dt) the committed
        stress and the tangent of the last converged iteration are used. With tangent False the tangent may be
        None (the material's choice; ``_tangent_at`` gives it when needed)."""
        stats, mp = self.stats, self._mp
        stats["residuals"] += 1
        if material_call:
            strain = np.empty_like(self._strain)
            trial_strain(self.geom.B, x, self.udofs, self._strain, strain, mp.dstrain)
            if self._first_trial is not None and dt == self._first_trial[0]:
                # the first residual: zero strain increment over the first step, the update made in solve()
                stress, state, D = self._first_trial[1]
            else:
                stats["material_calls"] += 1
                stress, state, D = mp.evaluate(dt, tangent=tangent)
            self._first_trial = None
        else:
            strain, stress, state, D = self._strain, mp.stress, mp.state, self._D
        g = self.geom
        if dt != self._k_dt[0]:
            self._k_dt = (dt, dt * self._k)
        R, scale, rhs = np.empty(self.n_dofs), self._scale, self._rhs
        coupled_residual(x, x_n, stress, self._sig0_fe, self._VBt, self._absVBt, self._hg, g.vol_row,
                         self._abs_vol_row, g.n_bar, self._k_dt[1], g.H, self._S, self._absS, self.udofs, self.pdofs,
                         a1 * self.f_pressure if self._has_pressure else self._no_load, R, scale)
        measures = newton_measures(R, scale, self._ufree, self._pfree, self.cdofs, SCALE_FLOOR, rhs)
        return R, D, (stress, state, strain), measures, rhs

    def _tangent_at(self, strain, dt):
        """The material tangent of the trial at total strain ``strain`` (the same update again, with the tangent)."""
        self.stats["tangent_calls"] += 1
        return self._mp.trial(strain - self._strain, dt)[2]

    def _assemble_u(self, f_e):
        return np.bincount(self.udofs.ravel(), f_e.ravel(), self.n_dofs)

    def _constant_part(self, dt):
        """Band entries of the coupling and pressure blocks for time step dt (cached; they depend only on dt)."""
        key = float(f"{dt:.10g}")  # equal increments differ in the last bits of t1 - t0
        ab = self._const_cache.get(key)
        if ab is None:
            g = self.geom
            ne = g.volume.shape[0]
            K = np.zeros((ne, 12, 12))
            Q = g.vol_row[:, :, None] * g.n_bar[:, None, :]
            K[:, IU[:, None], IP] = -Q
            K[:, IP[:, None], IU] = -np.transpose(Q, (0, 2, 1))
            K[:, IP[:, None], IP] = -(dt * self._k[:, None, None] * g.H + self._S)
            ab = np.bincount(self._up_idx, K.ravel()[self._up_sel], self.band_size)
            ab[self._diag_c] = 1.0
            if len(self._const_cache) > 64:
                self._const_cache.clear()
            self._const_cache[key] = (ab, K)
        return self._const_cache[key]

    def _stiffness(self, D, cells=slice(None)):
        """Element stiffness V B^T D B + K_hg (n, 8, 8) of the given cells."""
        return np.matmul(np.matmul(self._VBt[cells], D[cells]), self.geom.B[cells]) + self._hg[cells]

    def _apply(self, D, dt, dx):
        """Global product K dx (unconstrained Jacobian) for dx nonzero only at constrained dofs (the cells touching
        them), used to move the constrained dofs."""
        _, K = self._constant_part(dt)
        c = self._cells_c
        xe = dx[self.edofs[c]]
        ye = np.matmul(K[c], xe[:, :, None])[:, :, 0]
        ye[:, IU] += np.matmul(self._stiffness(D, c), xe[:, IU, None])[:, :, 0]
        return np.bincount(self.edofs[c].ravel(), ye.ravel(), self.n_dofs)

    def _factor(self, Kuu, dt):
        self.stats["factorizations"] += 1
        ab_const, _ = self._constant_part(dt)
        ab = self._bands[self._next_band]   # not the one of self._lu, which stays valid should this one fail
        band_matrix(ab_const, self._uu_idx, Kuu, self._uu_sel, ab)
        lu, piv, info = dgbtrf(ab.reshape(self.n_dofs, self.rows).T, self.kl, self.kl, overwrite_ab=1)
        if info != 0:
            raise _StepFailed(f"singular Jacobian (LAPACK dgbtrf info = {info}); check the boundary conditions")
        self._lu = (lu, piv, dt)
        self._next_band ^= 1

    def _back_substitute(self, rhs):
        lu, piv, _ = self._lu
        sol, info = dgbtrs(lu, self.kl, self.kl, rhs, piv, overwrite_b=1)
        return sol


def _band_order(cells, n_nodes):
    """New node numbers minimizing the bandwidth: the given order or reverse Cuthill-McKee, whichever is narrower."""
    i = np.repeat(cells, 4, axis=1).ravel()
    j = np.tile(cells, (1, 4)).ravel()
    graph = coo_matrix((np.ones(i.size), (i, j)), shape=(n_nodes, n_nodes)).tocsr()
    perm = reverse_cuthill_mckee(graph, symmetric_mode=True)
    rcm = np.empty(n_nodes, np.int64)
    rcm[perm] = np.arange(n_nodes)
    width = lambda order: np.abs(order[cells][:, :, None] - order[cells][:, None, :]).max()  # noqa: E731
    natural = np.arange(n_nodes)
    return natural if width(natural) <= width(rcm) else rcm


def _pressure_vector(mesh, name, order, n_dofs):
    """Consistent nodal forces (per radian) of a unit normal pressure pushing into the body on the set's edges:
    f_a = -n L (2 r_a + r_b)/6, n the outward normal of the edge (integral of N p n r ds, linear N and r)."""
    f = np.zeros(n_dofs)
    e = edges_of_set(mesh, name)
    xa, xb = mesh.nodes[e[:, 0]], mesh.nodes[e[:, 1]]
    d = xb - xa
    normal_L = np.column_stack([d[:, 1], -d[:, 0]])   # outward normal times edge length (counter-clockwise cells)
    fa = -normal_L * ((2 * xa[:, 0] + xb[:, 0]) / 6.0)[:, None]
    fb = -normal_L * ((xa[:, 0] + 2 * xb[:, 0]) / 6.0)[:, None]
    for nodes, fv in ((e[:, 0], fa), (e[:, 1], fb)):
        for c in range(2):
            np.add.at(f, 3 * order[nodes] + c, fv[:, c])
    return f
