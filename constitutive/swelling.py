"""Delayed (time-dependent) swelling: a volumetric Kelvin element in series with any material-point model.

Natural clays keep expanding under constant stress after an unloading, and with the strain held their effective
stress rises (creep and relaxation after unloading). :class:`DelayedSwelling` adds that to a base model of
``constitutive`` (any :class:`~constitutive.base.MaterialModel`) by splitting the total strain increment into the
part the base model takes and a delayed isotropic swelling strain eps_s.

Compression positive, effective stresses in kPa, strains dimensionless (engineering shear), time in s, Voigt order
(11, 22, 33, 12, 23, 31); m = (1, 1, 1, 0, 0, 0). Equations (notes/swelling.md, for docs/reference.md):

(S1) strain split   d eps = d eps^b + (d eps_s/3) m: the base model receives d eps^b = d eps - (d eps_s/3) m; eps_s
                    (compression positive, <= 0 when the point has swollen) is the delayed volumetric strain;
(S2) equilibrium    eps_s^eq = kappa_s/(1 + e) min(0, ln(p'/p'_max)), p' the mean effective stress of the base model,
                    p'_max the largest p' the point has carried (initially its p'_0, :meth:`initial_state`): zero
                    on first loading, a swelling strain of slope kappa_s in e-ln p' below p'_max;
(S3) Kelvin rate    d eps_s/dt = (eps_s^eq - eps_s)/tau_s  (tau_s in s);
(S4) void ratio     the swelling strain changes the void ratio as any volumetric strain, de = -(1 + e_n) d eps_s,
                    on top of the base model's own update for d eps^b (so with Modified Cam Clay's convention
                    e_{n+1} = e_n - (1 + e_n) d eps_v exactly; with ANICREEP's default v = 1 + e0 the swelling part
                    uses 1 + e_n instead of 1 + e0, a difference of (e_n - e0) d eps_s).

After an instantaneous unloading from p'_max to p' held constant, (S2)-(S3) give
eps_s(t) = eps_s^eq (1 - exp(-t/tau_s)) while the void ratio's change with eps_s is neglected (tested with it).

Integration of one increment (backward Euler in time, per point, vectorized):
    eps_s,n+1 = (eps_s,n + a eps_s^eq(p'_{n+1}))/(1 + a),  a = dt/tau_s,
with e frozen at its start-of-increment value e_n in (S2) and p'_max,n+1 = max(p'_max,n, p'_{n+1}) (so
min(0, ln(p'_{n+1}/p'_max,n+1)) = min(0, ln(p'_{n+1}/p'_max,n))). The unknown x = eps_s,n+1 solves the scalar
    R(x) = x - (eps_s,n + a eps_s^eq(p'(x)))/(1 + a) = 0,
p'(x) the mean stress returned by the base update with d eps - ((x - eps_s,n)/3) m. For a base whose p' rises
with volumetric compression, R'(x) = 1 + c K_t >= 1 with c = a/(1 + a) kappa_s/((1 + e_n) p') where p' < p'_max,n
(else 0) and K_t = m.D^b.m/9 the base's volumetric tangent; so one evaluation at any x_0 brackets the root in
[x_0 - max(R(x_0), 0), x_0 - min(R(x_0), 0)], and the root is <= x_hi = eps_s,n/(1 + a) (eps_s^eq <= 0). The
iteration starts from the lagged estimate x_0 = (eps_s,n + a eps_s^eq(p'_n))/(1 + a), (S2) at the mean stress p'_n
at the start of the increment (x_hi on first loading, where it is the root), and goes on by Newton safeguarded by the
bracket: a Newton step that leaves the bracket, or follows an iterate that did not halve |R| (the kink of (S2) at
p' = p'_max), is replaced by false position between the bracket's ends with the Illinois modification (the R of an
end kept twice in a row is halved: superlinear where R has a kink), or by bisection while one end is not
evaluated. A point still at |R| > ``tolerance`` after ``max_iterations`` base updates raises the base's
IntegrationError; so does p' <= 0 where (S2) is active. On first loading
(eps_s,n = 0, p' >= p'_max,n) x = 0 at once: the base model receives d eps bit for bit, and the result is the base
model's. The elementwise arithmetic of each iteration is compiled (:mod:`constitutive._swelling_kernel`); the base
update, the logarithm of (S2) and the sums over the tangent stay numpy's.
Where the base model has compiled step loops of its own (Modified Cam Clay, ANICREEP), the laboratory drivers
(``mixed_control``, ``adaptive_control``) run the same iteration per point inside theirs
(:mod:`constitutive._swelling_steps`, :meth:`DelayedSwelling.compiled_steps`).

Tangent: differentiating R = 0 with the base tangent D^b = d sigma'/d eps^b,
    C = D^b - c/(9 (1 + c K_t)) (D^b m) (m^T D^b),
the consistent tangent of the increment when the base's is (``tangent_kind`` is the base's).
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
    iterating_rows,
    point_rows,
    updated_rows,
)
from .invariants import mean_stress

__all__ = ["DelayedSwelling", "SWELLING_SWITCH", "SWELLING_RANGES"]

#: the physics switch of the missing-physics catalog that adds delayed swelling
SWELLING_SWITCH = "swelling"
#: the parameters of delayed swelling: kappa_s the swelling-creep index (slope of the delayed swelling in e-ln p',
#: >= 0; 0 switches it off), tau_s its time constant (s)
SWELLING_RANGES = {"kappa_s": ParameterRange(0.0, None, (0.001, 0.05), lower_open=False),
                   "tau_s": ParameterRange(0.0, None, (1.0e2, 1.0e7), "s")}
#: the state variables the wrapper adds to the base model's
OWN_STATE = ("swelling_strain", "p_max")


class DelayedSwelling(MaterialModel):
    """A base material-point model with delayed volumetric swelling in series, equations (S1)-(S4) (module
    docstring).

    base    : the base model (a MaterialModel; its state must hold ``void_ratio``);
    kappa_s : swelling-creep index (-), >= 0: the delayed swelling at equilibrium is kappa_s ln(p'_max/p') in void
              ratio; scalar or (n,);
    tau_s   : time constant of the delayed swelling (s), > 0; scalar or (n,).

    State: the base model's plus ``swelling_strain`` (n,) eps_s (compression positive, <= 0 after swelling) and
    ``p_max`` (n,) the largest p' carried (kPa); ``void_ratio`` is the specimen's, swelling included (S4).
    ``update`` depends on dt (``rate_dependent``), the tangent is consistent when the base's is.
    """

    rate_dependent = True
    #: tolerance on the residual R of the swelling strain (a strain)
    tolerance = 1e-12
    max_iterations = 60

    def __init__(self, base, kappa_s, tau_s):
        if not isinstance(base, MaterialModel):
            raise ParameterError(f"delayed swelling: the base must be a constitutive MaterialModel, got "
                                 f"{type(base).__name__}")
        self.base = base
        self.name = f"{base.name} with delayed swelling"
        self.tangent_kind = base.tangent_kind
        self.max_strain_step = base.max_strain_step
        self.parameter_names = tuple(base.parameter_names) + tuple(SWELLING_RANGES)
        self.parameter_ranges = {**base.parameter_ranges, **SWELLING_RANGES}
        self.void_ratio_parameter = base.void_ratio_parameter
        self.kappa_s = self._checked("kappa_s", kappa_s)
        self.tau_s = self._checked("tau_s", tau_s)

    def parameters(self) -> dict:
        """The base model's parameter record with kappa_s and tau_s."""
        return {**self.base.parameters(), "kappa_s": self.kappa_s, "tau_s": self.tau_s}

    def replaced(self, changes: dict) -> DelayedSwelling:
        """The same base model and swelling with the parameters in ``changes`` replaced (kappa_s, tau_s here, the
        others in the base model, ``MaterialModel.replaced``)."""
        rest = {k: v for k, v in changes.items() if k not in SWELLING_RANGES}
        return DelayedSwelling(self.base.replaced(rest) if rest else self.base, changes.get("kappa_s", self.kappa_s),
                               changes.get("tau_s", self.tau_s))

    def initial_state(self, stress0, void_ratio0=None) -> dict:
        """The base model's initial state with eps_s = 0 and p'_max = p'_0 (> 0), the initial mean effective stress:
        the specimen has stood at its initial state long enough for the delayed element to be at rest (S2 gives
        eps_s^eq = 0 there), so nothing swells before the test unloads it."""
        stress0 = as_points(stress0, "stress0")
        state = self.base.initial_state(stress0, void_ratio0)
        p0 = mean_stress(stress0)
        if np.any(p0 <= 0.0):
            i = int(np.argmax(p0 <= 0.0))
            raise ValueError(f"{self.name}: initial mean effective stress p' = {p0[i]:g} kPa at point {i} must be > 0")
        return {**state, "swelling_strain": np.zeros(p0.shape[0]), "p_max": p0.copy()}

    @property
    def point_subsets(self):
        """``update`` takes ``points=`` where the base model does (``MaterialModel.point_subsets``)."""
        return self.base.point_subsets

    def compiled_steps(self, n):
        """Every step of ``mixed_control`` and ``adaptive_control`` in one compiled call
        (``_swelling_steps``) where the base model has compiled loops of its own (Modified Cam Clay, ANICREEP);
        else None (the Python driver)."""
        base = self.base.compiled_steps(n)
        from . import _swelling_steps as steps
        loops = None if base is None else steps.LOOPS.get(base.drive)
        if loops is None:
            return None
        names = [key for key, _ in base.state_columns]
        widths = [width for _, width in base.state_columns]
        void_column = sum(widths[:names.index("void_ratio")])
        table = np.column_stack([base.parameters, np.broadcast_to(self.kappa_s, (n,)),
                                 np.broadcast_to(self.tau_s, (n,))])
        settings = np.r_[base.settings, self.tolerance, self.max_iterations, sum(widths), base.parameters.shape[1],
                         void_column]
        return CompiledSteps(*loops, np.ascontiguousarray(table, dtype=float), settings,
                             tuple(base.state_columns) + steps.OWN_STATE_COLUMNS,
                             max(base.info_size, steps.INFO_SIZE), self.integration_failure)

    def integration_failure(self, code, info, dstrain) -> str:
        """The reason of a failed update of one point under the strain increment ``dstrain`` (6,): ``code`` and
        ``info`` as ``_swelling_steps`` gives them, or the base model's (its ``integration_failure``)."""
        from . import _swelling_steps as steps
        if code == steps.NEGATIVE_MEAN_STRESS:
            return (f"delayed swelling: p' = {info[0]:.4g} kPa <= 0 where the swelling law (S2) applies "
                    f"(p'_max = {info[1]:.4g} kPa)")
        if code == steps.NOT_CONVERGED:
            return (f"delayed swelling: the swelling strain did not converge in {self.max_iterations} base updates "
                    f"(|R| = {info[0]:.3g}, bracket [{info[1]:.6g}, {info[2]:.6g}], strain increment {dstrain}, "
                    f"dt {info[3]:.3g} tau_s)")
        return self.base.integration_failure(code, info, dstrain)

    def update(self, stress, state, dstrain, dt, tangent=True, points=None):
        """One increment of total strain ``dstrain`` (n, 6) over ``dt`` (s, scalar or (n,), >= 0), backward Euler
        (module docstring); ``points`` (n,): the rows are those points of the parameter arrays
        (``point_subsets``). Returns the new effective stress (n, 6), the new state and the tangent (n, 6, 6; also
        with ``tangent=False``: the Newton on eps_s needs the base's tangent anyway)."""
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        e = _per_point(state["void_ratio"], n)
        eps_n = state["swelling_strain"]
        a = _per_point(np.asarray(dt, dtype=float) / point_rows(self.tau_s, points), n)
        slope = _per_point(point_rows(self.kappa_s, points) / (1.0 + e), n)
        step = _Increment(self.base, stress, state, dstrain, dt, a, slope, self.tolerance, points)
        x_hi = eps_n / (1.0 + a)                                   # the least swelling possible
        p_n = mean_stress(stress)
        lagged = np.where(p_n < state["p_max"], slope * np.log(np.maximum(p_n, 1e-300) / state["p_max"]), 0.0)
        x = np.minimum(x_hi, (eps_n + a * lagged) / (1.0 + a))    # x_0, the lagged estimate
        active = np.ones(n, dtype=bool)
        result, bracket, evaluation = None, None, None
        for iteration in range(self.max_iterations):
            done = np.empty(n, dtype=bool)
            # after the first evaluation, where few points still iterate, the base updates only those
            rows = iterating_rows(self.base, active) if iteration else None
            evaluation, n_done, n_active = step.evaluate(x, active, done, rows, None if rows is None else evaluation)
            result = evaluation if n_done == n else _merge(done, evaluation, result) if n_done else result
            if not n_active:
                break
            if iteration == 0:  # the bracket of the root, R(lo) <= 0 <= R(hi), R at its ends (nan: not evaluated),
                # the end the last iterate replaced (+1 hi, -1 lo) and |R| of the last iterate (next_iterates)
                bracket = (x.copy(), x_hi.copy(), np.full(n, np.nan), np.full(n, np.nan), np.zeros(n),
                           np.full(n, np.inf))
            x_next = np.empty(n)
            _kernel().next_iterates(iteration == 0, x, step.residual, evaluation[5],
                                   evaluation[3][:, :3, :3].sum(axis=(1, 2)), active, bracket, x_next)
            x = x_next
        else:
            i = int(np.flatnonzero(active)[0])
            lo, hi, residual_before = (bracket[0], bracket[1], bracket[5]) if bracket else (x, x_hi, np.full(n, np.inf))
            raise IntegrationError(i, f"delayed swelling: the swelling strain did not converge in "
                                   f"{self.max_iterations} base updates (|R| = {residual_before[i]:.3g}, bracket "
                                   f"[{lo[i]:.6g}, {hi[i]:.6g}], strain increment {dstrain[i]}, dt {a[i]:.3g} tau_s)")
        x, s_b, st_b, D_b, p, c = result
        new_state = {**st_b, "void_ratio": st_b["void_ratio"] - (1.0 + e) * (x - eps_n), "swelling_strain": x,
                     "p_max": np.maximum(state["p_max"], p)}
        C = np.empty_like(D_b)
        _kernel().tangent(D_b, c, C)
        return s_b, new_state, C


class _Increment:
    """The residual R(x) of one increment (module docstring) at a trial swelling strain x = eps_s,n+1 (n,)."""

    def __init__(self, base, stress, state, dstrain, dt, a, slope, tolerance, points):
        self.base, self.stress, self.dstrain, self.dt, self.a, self.slope = base, stress, dstrain, dt, a, slope
        self.tolerance, self.points = tolerance, points
        self.base_state = {k: v for k, v in state.items() if k not in OWN_STATE}
        self.eps_n = np.ascontiguousarray(state["swelling_strain"], dtype=float)
        self.p_max = np.ascontiguousarray(state["p_max"], dtype=float)
        self.residual = None

    def evaluate(self, x, active, done, rows=None, last=None):
        """The base update at x: (x, base stress, base state, base tangent, p', c) with c = a/(1 + a)
        kappa_s/((1 + e_n) p') where (S2) acts, else 0; R(x) in ``self.residual``; ``done`` (n,) the ``active``
        points with |R| <= ``tolerance``, which leave ``active``; returns (that tuple, points done, points still
        active). With ``rows`` (the active points), only those are updated, the others keep the base results of the
        ``last`` evaluation (the same bits: their x has not changed). IntegrationError where (S2) acts at p' <= 0 on
        an ``active`` point."""
        n = x.size
        base_strain = np.empty((n, 6))
        _kernel().base_strains(self.dstrain, x, self.eps_n, base_strain)
        if rows is not None:
            s_b, st_b, D_b = updated_rows(self.base, rows, rows if self.points is None else self.points[rows],
                                          self.stress, self.base_state, base_strain, self.dt, last[1:4])
        elif self.points is None:
            s_b, st_b, D_b = self.base.update(self.stress, self.base_state, base_strain, self.dt, tangent=True)
        else:
            s_b, st_b, D_b = self.base.update(self.stress, self.base_state, base_strain, self.dt, points=self.points)
        p, ratio = np.empty(n), np.empty(n)
        i = _kernel().law_ratios(s_b, self.p_max, self.a, self.slope, active, p, ratio)
        if i >= 0:
            raise IntegrationError(i, f"delayed swelling: p' = {p[i]:.4g} kPa <= 0 where the swelling law (S2) "
                                   f"applies (p'_max = {self.p_max[i]:.4g} kPa)")
        self.residual, c = np.empty(n), np.empty(n)
        n_done, n_active = _kernel().residuals(x, p, self.p_max, np.log(ratio), self.a, self.slope, self.eps_n,
                                              self.tolerance, active, self.residual, c, done)
        return (x, s_b, st_b, D_b, p, c), n_done, n_active


def _kernel():
    """The compiled per-point steps of the iteration (:mod:`constitutive._swelling_kernel`), imported on first use
    (keeps importing this module free of numba)."""
    from . import _swelling_kernel
    return _swelling_kernel


def _per_point(values, n):
    """``values`` (scalar or broadcastable to (n,)) as a contiguous float (n,) array (the same one where it is)."""
    values = np.asarray(values, dtype=float)
    return values if values.shape == (n,) and values.flags.c_contiguous else np.ascontiguousarray(
        np.broadcast_to(values, (n,)))


def _merge(mask, new, old):
    """Per point, the tuple ``new`` where ``mask`` and ``old`` elsewhere (``old`` None: ``new``); state dicts too."""
    if old is None:
        return new
    shaped = {}                                            # the mask shaped for values of each number of dimensions

    def pick(a, b):
        if isinstance(a, dict):
            return {k: pick(a[k], b[k]) for k in a}
        nd = np.ndim(a)
        if nd not in shaped:
            shaped[nd] = mask.reshape((-1,) + (1,) * (nd - 1))
        return np.where(shaped[nd], a, b)

    return tuple(pick(a, b) for a, b in zip(new, old))
