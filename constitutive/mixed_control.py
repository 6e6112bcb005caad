"""The generic mixed-control driver of the laboratory tests, vectorized over points (a batch of particles).

:func:`mixed_control`: at every step each of the 6 Voigt components has either a prescribed strain increment or a
prescribed stress increment, and optionally the step is undrained (volume held constant, an excess pore pressure
increment du added to the unknowns, the prescribed stresses then being *total* stresses: sigma = sigma' + u 1). The
unknown strain components (and du) are found by Newton iterations using the model's tangent; points iterate
independently, so a batched run equals the individual runs to round-off. :func:`adaptive_control` drives the same
controls along a prescribed path in time with step sizes chosen per point (the holds of a rate-dependent model).
The named tests built on them are in :mod:`constitutive.labtests`; the per-point arithmetic of a step (its aim, the
Newton's start, corrections and end, the adaptive step control) is compiled in
:mod:`constitutive._mixed_control_kernel`; for a model with a compiled update of one point
(``MaterialModel.compiled_steps``: Modified Cam Clay, ANICREEP, delayed swelling on either) the whole of
:func:`mixed_control` is, one call for every step of every point (the per-step Python glue otherwise costs several
times the model's own arithmetic).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._mixed_control_kernel import (
    LOOP_FAILURES,
    MAX_STEPS,
    NEGLIGIBLE_STEP,
    STALL_STEPS,
    STALLED,
    STEP_LIMIT,
    adaptive_inputs,
    aim_step,
    correct_all,
    finish_step,
    judge_steps,
    loop_failure,
    newton_correction,
    next_steps,
    start_step,
)
from .base import IntegrationError, iterating_rows, updated_rows

__all__ = ["mixed_control", "adaptive_control", "LinearPath", "batch_size", "newton_correction", "judge_steps",
           "NORMAL", "MAX_STEPS", "STALL_STEPS", "NEGLIGIBLE_STEP", "LOOP_FAILURES", "STEP_LIMIT", "STALLED",
           "loop_failure"]

#: the normal Voigt components (11, 22, 33)
NORMAL = np.array([True, True, True, False, False, False])


def batch_size(model, *arrays) -> int:
    """Number of points implied by the model's parameter arrays and the given arrays (scalars count as 1)."""
    sizes = {int(np.size(v)) for v in model.parameters().values() if v is not None}
    sizes |= {int(np.shape(a)[0]) for a in arrays if np.ndim(a) >= 1}
    sizes.discard(1)
    if len(sizes) > 1:
        raise ValueError(f"inconsistent batch sizes {sorted(sizes)} among model parameters and test conditions")
    return sizes.pop() if sizes else 1


def _where_state(mask, a, b):
    """Per-point selection between two state dicts: a where mask, else b."""
    return {k: np.where(mask.reshape((-1,) + (1,) * (np.ndim(a[k]) - 1)), a[k], b[k]) for k in a}


def mixed_control(model, stress0, state0, strain_control, increments, dt, undrained=False, record=None,
                  on_failure="raise", tol=1e-10, max_iterations=25, max_cuts=8, active=None, stop=None,
                  predictor="tangent", compiled=True):
    """Drive ``model`` through n_steps mixed strain/stress-controlled increments.

    stress0 (n, 6) effective stress (kPa), state0 the model state at stress0.
    strain_control: bool (6,) or (n_steps, 6); True where the strain increment is prescribed.
    increments: (n_steps, 6) or (n_steps, n, 6); prescribed strain increments (dimensionless, compression positive)
        on strain-controlled components, prescribed stress increments (kPa; total stress when undrained,
        effective = total otherwise) on the others.
    dt: (n_steps,) time increments (s), or (n_steps, n) per point (the points' times then differ).
    undrained: bool or (n_steps,) bool: volume held constant during the step (needs at least one stress-controlled
        normal component); drained steps keep the excess pore pressure.
    record: bool (n_steps,), steps at whose end the results are stored (default all); the initial state is always
        stored first.
    active: bool (n_steps, n), the points that take each step (default all); a point outside a step keeps its
        stress, state, strain, pore pressure, time and prescribed stresses unchanged (several tests with different
        numbers of steps share one call, the shorter ones padded with inactive steps).
    stop: (component, target (n,), direction (n,) of +1 or -1) or None: a point whose effective stress component
        would reach or pass ``target`` in the ``direction`` (direction x (sigma'_c - target) >= 0) at the end of a
        step does not take that step nor any later one (it stays at the start of that step): the caller locates
        the crossing within that step (``stopped``, ``stop_step`` and ``stop_value`` returned).
    Newton: converged when the stress residual is below ``tol`` x (1 kPa + max |sigma'|) and the volume residual
    below 1e-3 ``tol``; the iterations start from the tangent predictor (``predictor="tangent"``) or, with
    ``"previous"``, from the unknowns' increments of the point's previous step scaled by the ratio of the time steps
    (where that step had the same controls and a positive dt; the results then differ within the tolerance). A
    point that does not converge (or whose model update raises IntegrationError) repeats the step as two half
    steps (recursively, up to ``max_cuts`` times, that point only); then it raises IntegrationError
    (``on_failure="raise"``) or is frozen with NaN curves from then on (``"nan"``). A step with every strain
    prescribed has no unknown: a failure there is the model's own (it sub-steps within its update) and is final at
    once, without cuts. A point outside a step is not integrated over it (its model update takes dt = 0).
    compiled: a model that has a compiled step loop (``MaterialModel.compiled_steps``) takes every step of a point
    in one compiled call (the same arithmetic per point; a cut step's strain increments summed in order); False:
    the steps in Python, calling the model's ``update``.
    Returns a dict of arrays over (n, n_records): ``stress`` (..., 6), ``strain`` (..., 6), ``pore_pressure``,
    ``void_ratio``, ``time``; plus ``state`` and ``final_stress`` (n, 6) at the end (a failed point's at its last
    converged step, the state's stress), ``failed`` (n,), ``reasons`` {failed point: why, the model's
    IntegrationError reason where it raised one}, and with ``stop``: ``stopped`` (n,), ``stop_step`` (n,)
    the step a stopped point did not take (-1 otherwise) and ``stop_value`` (n,) its component at the end of that
    step (NaN otherwise).
    """
    if on_failure not in ("raise", "nan"):
        raise ValueError(f"on_failure must be 'raise' or 'nan', got {on_failure!r}")
    if predictor not in ("tangent", "previous"):
        raise ValueError(f"predictor must be 'tangent' or 'previous', got {predictor!r}")
    stress = np.array(stress0, dtype=float)
    n = stress.shape[0]
    dt = np.atleast_1d(np.asarray(dt, dtype=float))
    n_steps = dt.shape[0]
    control = np.broadcast_to(np.asarray(strain_control, dtype=bool), (n_steps, 6))
    inc = np.asarray(increments, dtype=float)
    inc = np.broadcast_to(inc[:, None, :] if inc.ndim == 2 else inc, (n_steps, n, 6))
    und = np.broadcast_to(np.asarray(undrained, dtype=bool), (n_steps,))
    record = np.ones(n_steps, dtype=bool) if record is None else np.asarray(record, dtype=bool)
    active = None if active is None else np.broadcast_to(np.asarray(active, dtype=bool), (n_steps, n))
    if not np.all(np.isfinite(stress)):
        raise ValueError("mixed_control: the initial stress must be finite at every point")
    no_stress_row = und & ~np.any(~control & NORMAL, axis=1)
    if no_stress_row.any():
        raise ValueError(f"step {int(np.argmax(no_stress_row))}: an undrained step needs a stress-controlled normal "
                         f"component")
    stopped = np.zeros(n, dtype=bool)
    stop_step, stop_value = np.full(n, -1), np.full(n, np.nan)
    if stop is not None:
        stop_component = int(stop[0])
        stop_target, stop_direction = (np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in stop[1:])
    kernel = model.compiled_steps(n) if compiled else None
    if kernel is not None:
        return _compiled_history(kernel, stress, state0, control, inc, np.broadcast_to(dt.T, (n, n_steps)).T, und,
                                 record, active, stop, on_failure,
                                 (tol, max_iterations, max_cuts, float(predictor == "previous")))

    state = state0
    strain = np.zeros((n, 6))
    u = np.zeros(n)
    t = 0.0
    alive = np.ones(n, dtype=bool)
    prescribed = np.zeros((n, 6))  # accumulated prescribed total stress on stress-controlled components
    reasons = {}
    _, _, tangent = model.update(stress, state, np.zeros((n, 6)), 0.0)
    out = {k: [] for k in ("stress", "strain", "pore_pressure", "void_ratio", "time")}

    def store():  # the arrays are replaced at every step, never changed in place: stored as they are
        rows = (stress, strain, u, state["void_ratio"])
        if not alive.all():
            nan = ~alive
            rows = tuple(np.where(nan.reshape((-1,) + (1,) * (np.ndim(r) - 1)), np.nan, r) for r in rows)
        for key, row in zip(("stress", "strain", "pore_pressure", "void_ratio"), rows):
            out[key].append(row)
        out["time"].append(np.full(n, t))

    store()
    steps = {}  # one _Step per (control row, drainage)
    fresh = ~control & np.vstack([np.ones((1, 6), dtype=bool), control[:-1]])  # become stress-controlled at step k
    last_key, last_deps, last_du, last_dt = None, np.zeros((n, 6)), np.zeros(n), np.zeros(n)
    for k in range(n_steps):
        key = (control[k].tobytes(), bool(und[k]))
        if key not in steps:
            steps[key] = _Step(model, control[k], bool(und[k]), tol, max_iterations)
        step = steps[key]
        # stress-controlled components aim at the accumulated prescribed total stress, so that the Newton
        # tolerance does not accumulate into a drift; a component that becomes stress-controlled starts from the
        # actual total stress
        taking = ~stopped if active is None else active[k] & ~stopped  # the points that take step k
        step_inc = np.empty((n, 6))
        aim_step(stress, u, inc[k], control[k], fresh[k], taking, prescribed, step_inc)
        moving = alive & taking
        guess = None
        if predictor == "previous" and key == last_key:
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(last_dt > 0.0, dt[k] / last_dt, 0.0)
            guess = (last_deps * ratio[:, None], last_du * ratio, last_dt > 0.0)
        res = step.advance(moving, stress, state, tangent, step_inc, dt[k], max_cuts if step.n_u else 0,
                           guess)
        failed = moving & ~res["ok"]
        if failed.any():
            for i in np.flatnonzero(failed):
                reasons[int(i)] = f"step {k}: " + res["reasons"].get(int(i), (
                    f"mixed-control Newton did not converge after {max_cuts} step cuts"))
            if on_failure == "raise":
                first = int(np.flatnonzero(failed)[0])
                raise IntegrationError(first, reasons[first])
            alive &= ~failed
        keep = alive & taking
        if stop is not None:
            past = keep & (stop_direction * (res["stress"][:, stop_component] - stop_target) >= 0.0)
            stop_step[past], stop_value[past] = k, res["stress"][past, stop_component]
            stopped |= past
            taking &= ~past
            keep &= ~past
        if keep.all():
            stress, state, tangent = res["stress"], res["state"], res["tangent"]
            strain, u = strain + res["deps"], u + res["du"]
        else:
            stress = np.where(keep[:, None], res["stress"], stress)
            state = _where_state(keep, res["state"], state)
            tangent = np.where(keep[:, None, None], res["tangent"], tangent)
            strain = strain + np.where(keep[:, None], res["deps"], 0.0)
            u = u + np.where(keep, res["du"], 0.0)
        t = t + (dt[k] if active is None and stop is None else np.where(taking, dt[k], 0.0))
        if predictor == "previous":
            last_key = key
            last_deps = np.where(keep[:, None], res["deps"], last_deps)
            last_du = np.where(keep, res["du"], last_du)
            last_dt = np.where(keep, dt[k], np.where(taking, 0.0, last_dt))  # a point resting keeps its predictor
        if record[k]:
            store()

    hist = {k: np.stack(v, axis=1) for k, v in out.items()}
    hist.update(state=state, final_stress=stress, failed=~alive, reasons=reasons)
    if stop is not None:
        hist.update(stopped=stopped, stop_step=stop_step, stop_value=stop_value)
    return hist


_NO_STRESS = np.zeros((0, 6))


def _failure_reasons(kernel, at_start, failed, failures, cuts, where):
    """{failed point: "<where>: <reason>"} of a compiled loop: the model's reason where a model update failed
    (``failures``: code, info, strain increment per point), else the Newton's after ``cuts`` step cuts; ``where(i)``
    the failure's step or time. A point whose start (the tangent at a zero increment) failed (``at_start``) raises
    the model's IntegrationError, as the Python driver does."""
    code, info, deps = failures
    first = np.flatnonzero(at_start)
    if first.size:
        i = int(first[0])
        raise IntegrationError(i, kernel.failure(code[i], info[i], deps[i]))
    return {int(i): f"{where(i)}: " + (kernel.failure(code[i], info[i], deps[i]) if code[i] > 0 else
                                       LOOP_FAILURES[code[i]] if code[i] < 0 else
                                       f"mixed-control Newton did not converge after {cuts} step cuts")
            for i in np.flatnonzero(failed)}


def _compiled_history(kernel, stress, state0, control, inc, dt, undrained, record, active, stop, on_failure, newton):
    """``mixed_control``'s history through the model's compiled step loop (``kernel``, :class:`CompiledSteps`);
    the arguments as normalized there, ``dt`` (K, n), ``newton`` (tol, max_iterations, max_cuts, previous-step
    predictor as 0 or 1)."""
    n, n_steps = stress.shape[0], dt.shape[0]
    unknown = np.argsort(control, axis=1, kind="stable")  # the stress-controlled first
    fresh = ~control & np.vstack([np.ones((1, 6), dtype=bool), control[:-1]])
    steps = tuple(_kernel_array(a) for a in (
        control, fresh, unknown, np.count_nonzero(~control, axis=1), inc, dt, undrained, record,
        np.ones((n_steps, n), dtype=bool) if active is None else active,
        np.r_[False, np.all(control[1:] == control[:-1], axis=1) & (undrained[1:] == undrained[:-1])]))
    if stop is None:
        stops = (-1, np.zeros(n), np.zeros(n))
    else:
        stops = (int(stop[0]), *(_kernel_array(np.broadcast_to(np.asarray(v, dtype=float), (n,)))
                                 for v in stop[1:]))
    columns = 1 + int(np.count_nonzero(record))
    history = (np.empty((n, columns, 6)), np.empty((n, columns, 6)), np.empty((n, columns)), np.empty((n, columns)),
               np.empty((n, columns)))
    flat = kernel.pack(state0, n)
    ending = (np.empty((n, 6)), np.empty_like(flat), np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64),
              np.empty((n, kernel.info_size)), np.empty((n, 6)), np.empty(n, dtype=np.int64), np.empty(n))
    kernel.drive(_kernel_array(kernel.parameters), _kernel_array(kernel.settings), _kernel_array(stress),
                 _kernel_array(flat), steps, stops, np.array(newton, dtype=float), history, ending)
    final_stress, final_state, fail_step, fail_code, fail_info, fail_deps, stop_step, stop_value = ending
    failed = fail_step >= 0
    reasons = _failure_reasons(kernel, fail_step == -2, failed, ending[3:6], newton[2],
                               lambda i: f"step {fail_step[i]}")
    if failed.any() and on_failure == "raise":
        first = int(np.flatnonzero(failed)[np.argmin(fail_step[failed])])
        raise IntegrationError(first, reasons[first])
    hist = dict(zip(("stress", "strain", "pore_pressure", "void_ratio", "time"), history))
    hist.update(state=kernel.unpack(final_state), final_stress=final_stress, failed=failed, reasons=reasons)
    if stop is not None:
        hist.update(stopped=stop_step >= 0, stop_step=stop_step, stop_value=stop_value)
    return hist


class _Step:
    """One mixed-control increment: Newton on the unknown strain components (and du when undrained)."""

    def __init__(self, model, control, undrained, tol, max_iterations):
        self.model, self.control, self.undrained = model, control, undrained
        self.tol, self.max_iterations = tol, max_iterations
        self.unknown = np.flatnonzero(~control)
        self.n_u = self.unknown.size + int(undrained)

    def solve(self, active, stress, state, tangent, inc, dt, guess=None):
        """Newton for the ``active`` points (others get a zero strain increment and are ignored); ``guess``: None
        (predictor with the start-of-step tangent) or (strain increment (n, 6), du (n,), which (n,)): the unknown
        components of the points ``which`` start from it. Returns the results dict with ``ok`` (converged active
        points; an active point that failed keeps its start values)."""
        n = stress.shape[0]
        deps, du, target, done = np.empty((n, 6)), np.empty(n), np.empty((n, self.unknown.size)), np.empty(n, bool)
        guessed = guess is not None and self.n_u > 0
        predict = start_step(inc, active, self.control, self.unknown, guess[0] if guessed else deps,
                             guess[1] if guessed else du, guess[2] if guessed else active, guessed, deps, du,
                             target, done)
        if self.n_u and predict:  # predictor with the start-of-step tangent for the points ``done`` leaves
            lin = np.einsum("nij,nj->ni", tangent, deps)
            newton_correction(lin, _NO_STRESS, np.ascontiguousarray(tangent), deps, du, target, self.unknown,
                              self.undrained, done, self.tol, np.empty(n, dtype=bool))
        done = ~active
        excluded = np.zeros(n, dtype=bool)
        reasons = {}
        # a point's strain increment is frozen once it has converged, so the last update holds every converged
        # point's converged values (the kernels are per point): no per-iteration merge
        s_new, st_new, C = stress, state, tangent
        # the points that do not move (inactive, excluded) take a zero increment over a zero time: whatever their
        # state, the model's update of them cannot fail
        dt = np.where(active, dt, 0.0)
        ok = np.empty(n, dtype=bool)
        for _ in range(self.max_iterations):
            # the points done keep their last update (the same bits again): where they are many, only the others
            rows = iterating_rows(self.model, ~done)
            try:
                if rows is None:
                    s_new, st_new, C = self.model.update(stress, state, deps, dt)
                else:
                    s_new, st_new, C = updated_rows(self.model, rows, rows, stress, state, deps, dt, (s_new, st_new, C))
            except IntegrationError as err:
                bad = int(err.point)
                if excluded[bad] or not active[bad]:  # (never a point of ``rows``: those are iterating)
                    raise
                excluded[bad] = done[bad] = True
                reasons[bad] = err.reason
                deps[bad], du[bad], dt[bad] = 0.0, 0.0, 0.0
                if done.all():
                    break
                continue
            if not self.n_u:
                done[:] = True
                break
            if correct_all(s_new, stress, np.ascontiguousarray(C), deps, du, target, self.unknown, self.undrained,
                           done, self.tol, ok):
                break
        converged = np.empty(n, dtype=bool)
        if finish_step(done, excluded, active, deps, du, converged):
            # a failed point keeps its start (it may be cut and repeated, and is updated as inactive)
            failed = active & ~converged
            s_new = np.where(failed[:, None], stress, s_new)
            st_new = _where_state(failed, state, st_new)
            C = np.where(failed[:, None, None], tangent, C)
        return {"stress": s_new, "state": st_new, "tangent": C, "deps": deps, "du": du, "ok": converged,
                "reasons": reasons}

    def advance(self, active, stress, state, tangent, inc, dt, cuts_left, guess=None):
        """Solve the step (``guess`` as in :meth:`solve`); points that fail repeat it as two half steps (recursively,
        ``cuts_left`` levels)."""
        res = self.solve(active, stress, state, tangent, inc, dt, guess)
        bad = active & ~res["ok"]
        if cuts_left == 0 or not bad.any():
            return res
        first = self.advance(bad, stress, state, tangent, 0.5 * inc, 0.5 * dt, cuts_left - 1)
        again = bad & first["ok"]
        second = self.advance(again, first["stress"], first["state"], first["tangent"], 0.5 * inc, 0.5 * dt,
                              cuts_left - 1)
        fixed = again & second["ok"]
        res["stress"] = np.where(fixed[:, None], second["stress"], res["stress"])
        res["state"] = _where_state(fixed, second["state"], res["state"])
        res["tangent"] = np.where(fixed[:, None, None], second["tangent"], res["tangent"])
        res["deps"] = np.where(fixed[:, None], first["deps"] + second["deps"], res["deps"])
        res["du"] = np.where(fixed, first["du"] + second["du"], res["du"])
        res["ok"] = res["ok"] | fixed
        res["reasons"] = {**res["reasons"], **first["reasons"], **second["reasons"]}
        return res


@dataclass(frozen=True)
class LinearPath:
    """A path of stage time tau (s), per point and Voigt component ((n, 6) arrays): offset + slope x f with
    f = tau/duration (duration > 0), capped at 1 where ``capped`` (a ramp that then holds its end). Calling it at
    stage times tau (n,) gives the (n, 6) values (``adaptive_control``'s ``target``)."""
    offset: np.ndarray
    slope: np.ndarray
    duration: np.ndarray
    capped: np.ndarray

    @classmethod
    def ramp(cls, start, end, duration, capped=False):
        """From ``start`` (n, 6) to ``end`` over ``duration`` (n,) s."""
        return cls(start, end - start, np.broadcast_to(np.asarray(duration, dtype=float)[..., None], start.shape),
                   np.broadcast_to(capped, start.shape))

    @classmethod
    def constant(cls, value):
        """``value`` (n, 6) at every time."""
        return cls.ramp(value, value, 1.0)

    def values(self, tau):
        """The path at stage times ``tau`` (..., n): (..., n, 6)."""
        f = np.asarray(tau, dtype=float)[..., None] / self.duration
        return self.offset + self.slope * np.where(self.capped, np.minimum(f, 1.0), f)

    __call__ = values

    @classmethod
    def stacked(cls, paths):
        """The paths of consecutive groups of points as one path over all of them."""
        return cls(*(np.concatenate([getattr(p, f) for p in paths]) for f in ("offset", "slope", "duration",
                                                                              "capped")))

    def where(self, mask, other):
        """This path on the components (and points) ``mask`` (broadcast to (n, 6)), ``other`` elsewhere."""
        return LinearPath(*(np.where(mask, a, b) for a, b in zip(
            (self.offset, self.slope, self.duration, self.capped),
            (other.offset, other.slope, other.duration, other.capped))))


def _kernel_array(a, dtype=None):
    """``a`` as a C-contiguous, writable array (of ``dtype``), as the compiled step loops are given every array: numba
    compiles a read-only array apart, and a broadcast view of one point is contiguous but read-only, so that one
    point and a batch would compile the loops twice. (0.15 us when nothing is copied; ``np.require`` takes 0.7.)"""
    a = np.ascontiguousarray(a, dtype=dtype)
    return a if a.flags.writeable else a.copy()


def _per_point(a, n):
    """(K,) or (K, n) values as a contiguous (K, n) array."""
    a = np.asarray(a, dtype=float)
    return np.ascontiguousarray(np.broadcast_to(a[:, None] if a.ndim == 1 else a, (a.shape[0], n)))


def adaptive_control(model, stress0, state0, strain_control, target, segments, records, undrained=False,
                     active=None, atol=1e-6, floor=1e-2, strain_scale=1e-2, strain_step=np.inf, growth=4.0, tol=1e-10,
                     max_iterations=25, max_cuts=8, max_rejections=12, compiled=True):
    """Drive ``model`` along a path of stage time tau (s) with step sizes chosen per point from how its response
    changes (the holds of the laboratory programmes, where a fixed geometric grid wastes its early steps).

    strain_control (6,) as in :func:`mixed_control` (one row for the whole path). target(tau) -> (n, 6): at the
    stage times tau (n,) the prescribed strain since the start on the strain rows and the prescribed total stress
    on the stress rows (effective when drained; undrained the pore pressure starts at zero). segments: (ends, firsts,
    largest, rtols), each (S, n): the path is smooth within a segment, which ends at ``ends`` (increasing; the last
    is the path's end), starts with a step ``firsts``, takes steps of at most ``largest`` (s) and is controlled with
    ``rtols`` (inf: steps of ``largest``, within ``strain_step``). records: (R, n) stage times within the path at
    which the state is stored ((S,) and (R,): the same for every point). active: (n,) the points that move (the
    others keep their start).

    Step control, on y = (sigma'/S, epsilon/strain_scale, u/S) (S = 1 kPa + max |sigma'| at the step start) with
    dy_k the increments of a step of h_k, Y_k the change of y since the segment start after it:
      (a) rate: c = max |dy_k - (h_k/h_{k-1}) dy_{k-1}| (= h_k^2 |y''|, twice backward Euler's local error)
          <= rtol max |dy_k| + atol: the step is at most the fraction rtol of the time over which the rates change
          (|y'|/|y''|), so backward Euler's error, first order, is about rtol/2 times the change of y in that time
          where errors are damped over it (a hold creeping as 1/t: rtol = 0.11 is 20 steps per decade);
      (b) growth: |dy_k| <= rtol |Y_k| + floor per component: where y grows at a steady rate, which damps no error,
          the steps are those of a geometric grid of ratio 1 + rtol in the time since the segment start; where
          nothing moves yet (|dy_k| below ``floor``) the steps grow freely;
      (c) strain: |d epsilon_k| <= strain_step (the model's own integration, e.g. a specific volume frozen over the
          increment, is first order in the strain step).
    (a) needs a previous step of the segment (not one that jumped to a stress target away from the start state).
    With err the largest of the ratios of (a)-(c), a step with err > 1 is repeated with h x max(0.2, 0.9/err)
    (taken as it comes after ``max_rejections`` in a row); the next step is h x min(growth, 0.9/err), at most
    ``largest``, shortened to land on the records and segment ends. A point whose Newton fails (:class:`_Step`)
    repeats the step at a quarter of h, at most ``max_cuts`` times in a row, then fails (as it does when a step
    below 1e-12 of the path fails: it would creep up to a state it cannot pass); so does a point that takes
    ``STALL_STEPS`` steps in a row below 1e-12 of the path (a response that runs away under the held load: creep
    rupture) or ``MAX_STEPS`` steps in all. The Newton iterations
    start from the rates of the previous step (extrapolated linearly from the two before where the segment has
    them; the tangent predictor for a first step).

    compiled: where ``target`` is a :class:`LinearPath` and the model has a compiled step loop
    (``MaterialModel.compiled_steps``), every step of a point in one compiled call (the same arithmetic); False:
    the steps in Python.

    Returns the history of :func:`mixed_control` over (n, R + 2) columns: the start, the records (in the given
    order; NaN where a point failed before it) and the end (NaN for a failed point), with ``state``,
    ``final_stress`` (a failed point's last converged ones), ``failed``, ``reasons`` and ``steps`` (n,) the
    accepted steps per point.
    """
    stress = np.array(stress0, dtype=float)
    n = stress.shape[0]
    control = np.asarray(strain_control, dtype=bool)
    if len(segments) != 4:
        raise ValueError("segments: (ends, firsts, largest, rtols)")
    segments = tuple(_per_point(a, n) for a in segments)
    rec = _per_point(records, n)
    going = np.ones(n, dtype=bool) if active is None else np.array(active, dtype=bool)
    settings = (float(atol), float(floor), float(strain_scale), float(strain_step), float(growth),
                int(max_rejections), int(max_cuts))
    kernel = model.compiled_steps(n) if compiled and isinstance(target, LinearPath) else None
    if kernel is not None:
        return _compiled_adaptive(kernel, stress, state0, control, bool(undrained), target, segments, rec, going,
                                  settings, (tol, max_iterations))
    step = _Step(model, control, bool(undrained), tol, max_iterations)
    state = state0
    _, _, tangent = model.update(stress, state, np.zeros((n, 6)), 0.0)
    columns = rec.shape[0] + 2
    out = {"stress": np.full((n, columns, 6), np.nan), "strain": np.full((n, columns, 6), np.nan),
           "pore_pressure": np.full((n, columns), np.nan), "void_ratio": np.full((n, columns), np.nan),
           "time": np.full((n, columns), np.nan)}
    tau, strain, u = np.zeros(n), np.zeros((n, 6)), np.zeros(n)

    def store(rows, cols):
        for key, value in (("stress", stress), ("strain", strain), ("pore_pressure", u),
                           ("void_ratio", state["void_ratio"]), ("time", tau)):
            out[key][rows, cols] = value[rows]

    store(np.arange(n), 0)
    rows, cols = np.nonzero((rec.T == 0.0) | ~going[:, None])
    store(rows, cols + 1)
    scale = 1.0 + np.abs(stress).max(axis=1)
    jumped = np.any(~control & (np.abs(target(tau) - stress) > tol * scale[:, None]), axis=1)
    h = np.minimum(segments[1][0], segments[2][0])
    walk = (tau, h, np.ones(n), np.zeros((n, 6)), np.zeros((n, 6)), np.zeros(n), strain, u,
            np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
            np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), going, np.zeros(n, dtype=bool),
            np.zeros(n, dtype=bool), jumped, np.ones(n), np.zeros((n, 6)), np.zeros(n), stress.copy(),
            np.zeros((n, 6)), np.zeros(n), np.zeros(n, dtype=np.int64))
    (_, _, h_previous, _, d_strain, d_u, _, _, known, _, _, accepted, segment, _, take, dead, _, h_before,
     d_strain_before, d_u_before, _, _, _, stalled) = walk                   # the names of judge_steps (its docstring)
    sizes = (np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool))
    alive = np.ones(n, dtype=bool)
    reasons = {}
    while going.any():
        next_steps(tau, h, segment, segments[0], rec, going, *sizes)
        size, after, landing = sizes
        inc, guess_strain, guess_u, scale = np.empty((n, 6)), np.empty((n, 6)), np.empty(n), np.empty(n)
        # the rates at the end of the step extrapolated from the previous one or two: the guess of the points known
        guessed = adaptive_inputs(control, target(after), strain, stress, u, known, size, h_previous, d_strain, d_u,
                                  h_before, d_strain_before, d_u_before, inc, guess_strain, guess_u, scale)
        guess = (guess_strain, guess_u, known > 0) if guessed else None
        res = step.solve(going.copy(), stress, state, tangent, inc, np.where(going, size, 0.0), guess)
        ds = res["stress"] - stress
        judge_steps(res["ok"], stress, ds, res["deps"], res["du"], scale, sizes, settings, walk, segments)
        for i in np.flatnonzero(dead):
            alive[i] = False
            code = loop_failure(0, accepted[i], stalled[i])
            reasons[int(i)] = (f"at stage time {tau[i]:g} s: " + (LOOP_FAILURES[code] if code else res[
                "reasons"].get(int(i), f"mixed-control Newton did not converge after {max_cuts} step cuts")))
        if take.all():
            stress, state, tangent = res["stress"], res["state"], res["tangent"]
        elif take.any():
            stress = np.where(take[:, None], res["stress"], stress)
            state = _where_state(take, res["state"], state)
            tangent = np.where(take[:, None, None], res["tangent"], tangent)
        if (take & landing).any():
            rows, cols = np.nonzero((take & landing)[:, None] & (rec.T == tau[:, None]))
            store(rows, cols + 1)
    store(np.flatnonzero(alive), columns - 1)
    out.update(state=state, final_stress=stress, failed=~alive, reasons=reasons, steps=accepted)
    return out


def _compiled_adaptive(kernel, stress, state0, control, undrained, path, segments, rec, going, step_control, newton):
    """``adaptive_control``'s history through the model's compiled step loop (``kernel``, :class:`CompiledSteps`);
    the arguments as normalized there, ``newton`` (tol, max_iterations)."""
    n, columns = stress.shape[0], rec.shape[0] + 2
    history = (np.full((n, columns, 6), np.nan), np.full((n, columns, 6), np.nan), np.full((n, columns), np.nan),
               np.full((n, columns), np.nan), np.full((n, columns), np.nan))
    flat = kernel.pack(state0, n)
    ending = (np.empty((n, 6)), np.empty_like(flat), np.empty(n, dtype=bool), np.empty(n), np.empty(n, dtype=np.int64),
              np.empty((n, kernel.info_size)), np.empty((n, 6)), np.empty(n, dtype=np.int64))
    shaped = tuple(_kernel_array(np.broadcast_to(a, (n, 6)), t) for a, t in zip(
        (path.offset, path.slope, path.duration, path.capped), (float, float, float, bool)))
    kernel.adapt(_kernel_array(kernel.parameters), _kernel_array(kernel.settings), _kernel_array(stress),
                 _kernel_array(flat), _kernel_array(control), undrained, shaped,
                 tuple(_kernel_array(a) for a in segments), _kernel_array(rec), _kernel_array(going), step_control,
                 np.array(newton, dtype=float), history, ending)
    final_stress, final_state, failed, fail_tau, _, _, _, steps = ending
    reasons = _failure_reasons(kernel, failed & (fail_tau == -1.0), failed, ending[4:7], step_control[-1],
                               lambda i: f"at stage time {fail_tau[i]:g} s")
    hist = dict(zip(("stress", "strain", "pore_pressure", "void_ratio", "time"), history))
    hist.update(state=kernel.unpack(final_state), final_stress=final_stress, failed=failed, reasons=reasons,
                steps=steps)
    return hist
