"""The laboratory drivers' whole step loops, compiled: :func:`drive_points` is ``mixed_control`` and
:func:`adapt_points` is ``adaptive_control`` (:mod:`constitutive.mixed_control`) for a model whose update of one
point is compiled, every step of a point in one call, built from the per-point pieces of
:mod:`constitutive._mixed_control_kernel` on one-row views (tests/constitutive/test_compiled_step_loop.py).

Every function here is inlined into the model's wrappers (``_mcc_kernel.drive``, ``_anicreep_steps.adapt``, ...):
the point update ``update`` is then a compile-time constant there, not a run-time argument, which numba cannot
cache. Compression positive, kPa, s, strains dimensionless.
"""
from __future__ import annotations

import numpy as np

from ._mixed_control_kernel import adaptive_inputs, aim_step, judge_steps, loop_failure, newton_correction, next_steps
from .jit import jit, next_substep


@jit(inline="always")
def _solve_point(update, prm, settings, work, start, inc, dt, control, unknown, undrained, newton, guess, trial,
                 scratch, info, failed_deps):
    """The Newton of one point over one (sub-)step, as ``mixed_control``'s ``_Step.solve`` for a point: from the
    ``start`` (stress (1, 6), state, tangent (1, 6, 6)) under the step increments ``inc`` (1, 6) over ``dt``, the
    unknown components ``unknown`` (and du when ``undrained``) from the tangent predictor or, where ``guess`` =
    (strain increments (1, 6), du (1,), use) is used, from its values, then Newton corrections after each model
    ``update`` (into ``trial``) until converged. ``scratch``: (deps (1, 6), du (1,), target
    (1, 6), dsig (1, 6), done (1,), ok (1,), a sub-step's increments (1, 6), no stress (0, 6)). Returns 0
    (converged: ``trial`` and deps, du hold the step), -1 (no convergence within max_iterations) or the model's
    failure code (``info`` filled, ``failed_deps`` the strain increment it failed on)."""
    s, st, C = start
    t_s, t_st, t_C = trial
    deps, du, target, dsig, done, ok, _, no_stress = scratch
    tol, max_iterations = newton[0], int(newton[1])
    n_u = unknown.size + (1 if undrained else 0)
    guessed = guess[2] and n_u > 0
    for c in range(6):
        deps[0, c] = inc[0, c] if control[c] else (guess[0][0, c] if guessed else 0.0)
    for a in range(unknown.size):
        target[0, a] = inc[0, unknown[a]]
    du[0] = guess[1][0] if guessed else 0.0
    done[0] = False
    if n_u and not guessed:  # the predictor with the start-of-step tangent
        for r in range(6):
            v = 0.0
            for c in range(6):
                v += C[0, r, c] * deps[0, c]
            dsig[0, r] = v
        newton_correction(dsig, no_stress, C, deps, du, target, unknown, undrained, done, tol, ok)
    for _ in range(max_iterations):
        code = update(s[0], st, deps[0], dt, prm, settings, t_s[0], t_st, t_C[0], info, work)
        if code != 0:
            failed_deps[:] = deps[0]
            return code
        if not n_u:
            return 0
        for c in range(6):
            dsig[0, c] = t_s[0, c] - s[0, c]
        newton_correction(dsig, t_s, t_C, deps, du, target, unknown, undrained, done, tol, ok)
        if ok[0]:
            return 0
    return -1


@jit(inline="always")
def _advance_point(update, prm, settings, work, committed, inc, dt, control, unknown, undrained, newton, cuts,
                   guess, moving, trial, scratch, total, info, failed_deps):
    """One step of one point from its ``committed`` (stress, state, tangent) under ``inc`` (1, 6) over ``dt``, as
    ``mixed_control``'s ``_Step.advance``: the Newton starts from ``guess`` (:func:`_solve_point`) where it is
    used; where it fails the step is taken as two halves (from the tangent predictor), recursively up to ``cuts``
    levels (depth-first bisection); the end in ``moving`` (stress, state, tangent), the strain and pore
    pressure increments summed in ``total`` ((1, 6), (1,)). Returns (converged, the code of the last model failure
    met on the way, 0 if none)."""
    m_s, m_st, m_C = moving
    t_s, t_st, t_C = trial
    deps, du, step_in = scratch[0], scratch[1], scratch[6]
    d_strain, d_u = total
    m_s[:] = committed[0]
    m_st[:] = committed[1]
    m_C[:] = committed[2]
    d_strain[:] = 0.0
    d_u[0] = 0.0
    last = 0
    units = 1 << cuts
    pos = 0
    level = 0
    while pos < units:
        frac = 1.0 / (1 << level)
        for c in range(6):
            step_in[0, c] = inc[0, c] * frac
        code = _solve_point(update, prm, settings, work, moving, step_in, dt * frac, control, unknown, undrained,
                            newton, (guess[0], guess[1], guess[2] and pos == 0 and level == 0), trial, scratch, info,
                            failed_deps)
        if code != 0:
            if code > 0:
                last = code
            if level >= cuts:
                return False, last
            level += 1
            continue
        m_s[:] = t_s
        m_st[:] = t_st
        m_C[:] = t_C
        for c in range(6):
            d_strain[0, c] += deps[0, c]
        d_u[0] += du[0]
        pos, level = next_substep(pos, level, units)
    return True, last


@jit(inline="always")
def drive_points(update, prm, settings, work, void_ratio_column, stress0, state0, steps, stop, newton, history,
                 ending):
    """``mixed_control`` compiled for a model whose update of one point is the compiled function ``update``
    (stress (6,), state (S,), deps (6,), dt, prm row, settings, stress_out, state_out, tangent_out (6, 6), info,
    work) -> 0 or a failure code > 0: every step of one point, then the next point (the points are independent).

    stress0 (n, 6), state0 (n, S) (``void_ratio_column`` its void ratio). steps: (control (K, 6) bool, fresh (K, 6)
    bool (a component that becomes stress-controlled at the step), unknown (K, 6) int (the stress-controlled
    components first), n_unknown (K,), inc (K, n, 6), dt (K, n), undrained (K,), record (K,), active (K, n),
    same_as_previous (K,) (the step's controls and drainage are those of the step before)). stop: (component (-1:
    none), target (n,), direction (n,)). newton: (tol, max_iterations, max_cuts, the previous step's predictor
    (``mixed_control(predictor="previous")``) as 0 or 1). history: (stress
    (n, R, 6), strain (n, R, 6), pore pressure, void ratio, time (n, R)), column 0 the start, then the recorded
    steps (NaN but the time where a point has failed). ending: (final stress (n, 6), final state (n, S), fail_step
    (n,) (-1: none; -2: the start's zero increment failed), fail_code (n,) (the last model failure code met in the
    failing step, 0 none), fail_info (n, I), fail_deps (n, 6) (its strain increment), stop_step (n,), stop_value
    (n,)). The arithmetic per point is that of ``mixed_control``, except that a cut step's strain increments are
    summed in order (the driver sums the halves' sums)."""
    control, fresh, unknown, n_unknown, inc, dt, undrained, record, active, same_as_previous = steps
    stop_component, stop_target, stop_direction = stop
    h_stress, h_strain, h_u, h_e, h_time = history
    final_stress, final_state, fail_step, fail_code, fail_info, fail_deps, stop_step, stop_value = ending
    max_cuts, previous = int(newton[2]), newton[3] != 0.0
    n, n_steps, n_state = stress0.shape[0], dt.shape[0], state0.shape[1]
    committed = (np.empty((1, 6)), np.empty(n_state), np.empty((1, 6, 6)))
    moving = (np.empty((1, 6)), np.empty(n_state), np.empty((1, 6, 6)))
    trial = (np.empty((1, 6)), np.empty(n_state), np.empty((1, 6, 6)))
    scratch = (np.empty((1, 6)), np.empty(1), np.empty((1, 6)), np.empty((1, 6)), np.empty(1, dtype=np.bool_),
               np.empty(1, dtype=np.bool_), np.empty((1, 6)), np.empty((0, 6)))
    total = (np.empty((1, 6)), np.empty(1))
    s, st, C = committed
    u, taking_row, prescribed, step_inc = np.empty(1), np.empty(1, dtype=np.bool_), np.empty((1, 6)), np.empty((1, 6))
    strain = np.empty(6)
    last_deps, last_du, guess_deps, guess_du = np.empty(6), 0.0, np.empty((1, 6)), np.empty(1)
    zero = np.zeros(6)
    info = np.empty(fail_info.shape[1])
    for i in range(n):
        s[0] = stress0[i]
        st[:] = state0[i]
        strain[:] = 0.0
        u[0] = 0.0
        t = 0.0
        prescribed[:] = 0.0
        alive, stopped = True, False
        last_dt = 0.0  # the time step of the point's previous step where it took it, else 0
        fail_step[i], fail_code[i], stop_step[i], stop_value[i] = -1, 0, -1, np.nan
        code = update(s[0], st, zero, 0.0, prm[i], settings, trial[0][0], trial[1], C[0], info, work)
        if code != 0:
            fail_step[i], fail_code[i] = -2, code
            fail_info[i] = info
            fail_deps[i] = 0.0
            continue
        column = 0
        for k in range(-1, n_steps):
            if k >= 0:
                taking = active[k, i] and not stopped
                taking_row[0] = taking
                aim_step(s, u, inc[k, i:i + 1], control[k], fresh[k], taking_row, prescribed, step_inc)
                kept = False
                if alive and taking:
                    unknowns = unknown[k, :n_unknown[k]]
                    cuts = max_cuts if n_unknown[k] or undrained[k] else 0
                    guessed = previous and same_as_previous[k] and last_dt > 0.0
                    if guessed:  # the previous step's increments scaled by the ratio of the time steps
                        ratio = dt[k, i] / last_dt
                        for c in range(6):
                            guess_deps[0, c] = last_deps[c] * ratio
                        guess_du[0] = last_du * ratio
                    ok, code = _advance_point(update, prm[i], settings, work, committed, step_inc, dt[k, i],
                                              control[k], unknowns, undrained[k], newton, cuts,
                                              (guess_deps, guess_du, guessed), moving, trial, scratch, total, info,
                                              fail_deps[i])
                    if not ok:
                        alive = False
                        fail_step[i], fail_code[i] = k, code
                        fail_info[i] = info
                    elif stop_component >= 0 and (stop_direction[i] * (moving[0][0, stop_component] - stop_target[i])
                                                  >= 0.0):
                        stopped, taking = True, False
                        stop_step[i], stop_value[i] = k, moving[0][0, stop_component]
                    else:
                        kept = True
                        s[:] = moving[0]
                        st[:] = moving[1]
                        C[:] = moving[2]
                        for c in range(6):
                            strain[c] += total[0][0, c]
                            last_deps[c] = total[0][0, c]
                        u[0] += total[1][0]
                        last_du = total[1][0]
                if taking:  # a step not taken (the point rests) leaves the previous step's predictor as it was
                    last_dt = dt[k, i] if kept else 0.0
                    t += dt[k, i]
                if not record[k]:
                    continue
                column += 1
            h_time[i, column] = t
            for c in range(6):
                h_stress[i, column, c] = s[0, c] if alive else np.nan
                h_strain[i, column, c] = strain[c] if alive else np.nan
            h_u[i, column] = u[0] if alive else np.nan
            h_e[i, column] = st[void_ratio_column] if alive else np.nan
        final_stress[i] = s[0]
        final_state[i] = st


@jit(inline="always")
def _path_at(path, i, tau, goal):
    """``mixed_control.LinearPath`` (offset, slope, duration, capped (n, 6)) of point i at stage time ``tau``, in
    ``goal`` (1, 6): offset + slope x f, f = tau/duration (at most 1 where capped)."""
    offset, slope, duration, capped = path
    for c in range(6):
        f = tau / duration[i, c]
        if capped[i, c]:
            f = min(f, 1.0)
        goal[0, c] = offset[i, c] + slope[i, c] * f


@jit(inline="always")
def _store_column(history, i, column, stress, strain, u, e, tau):
    """Column ``column`` of point i of the (stress, strain, pore pressure, void ratio, time) history."""
    h_stress, h_strain, h_u, h_e, h_time = history
    for c in range(6):
        h_stress[i, column, c] = stress[c]
        h_strain[i, column, c] = strain[c]
    h_u[i, column], h_e[i, column], h_time[i, column] = u, e, tau


@jit(inline="always")
def adapt_points(update, prm, settings, work, void_ratio_column, stress0, state0, control, undrained, path, segments,
                 records, going0, step_control, newton, history, ending):
    """``adaptive_control`` compiled for a model whose update of one point is the compiled function ``update`` (as
    in :func:`drive_points`): the steps of one point to the end of its path, then the next point.

    control (6,) bool; path: ``LinearPath``'s (offset, slope, duration, capped), each (n, 6); segments (ends,
    firsts, largest, rtols), each (S, n); records (R, n); going0 (n,) the points that move; step_control (atol,
    floor, strain_scale, strain_step, growth, max_rejections, max_cuts) (:func:`judge_steps`); newton (tol,
    max_iterations). history: (stress (n, R + 2, 6), strain (n, R + 2, 6), pore pressure, void ratio, time
    (n, R + 2)), NaN where not reached. ending: (final stress (n, 6), final state (n, S), failed (n,), fail_tau (n,)
    (the stage time of the failure; -1: the start's zero increment failed), fail_code (n,) (the model's failure
    code in the last Newton or one of the step control's, ``loop_failure``; 0 none), fail_info (n, I), fail_deps
    (n, 6), steps (n,) the accepted steps). The arithmetic per point is that of ``adaptive_control``."""
    ends, firsts, largest, rtols = segments
    final_stress, final_state, failed, fail_tau, fail_code, fail_info, fail_deps, steps_taken = ending
    tol = newton[0]
    n, n_state, n_records = stress0.shape[0], state0.shape[1], records.shape[0]
    unknown = np.empty(6, dtype=np.int64)
    count = 0
    for c in range(6):
        if not control[c]:
            unknown[count] = c
            count += 1
    unknown = unknown[:count]
    committed = (np.empty((1, 6)), np.empty(n_state), np.empty((1, 6, 6)))
    trial = (np.empty((1, 6)), np.empty(n_state), np.empty((1, 6, 6)))
    scratch = (np.empty((1, 6)), np.empty(1), np.empty((1, 6)), np.empty((1, 6)), np.empty(1, dtype=np.bool_),
               np.empty(1, dtype=np.bool_), np.empty((1, 6)), np.empty((0, 6)))
    s, st, C = committed
    t_s, t_st, t_C = trial
    deps, du = scratch[0], scratch[1]
    walk = (np.empty(1), np.empty(1), np.empty(1), np.empty((1, 6)), np.empty((1, 6)), np.empty(1), np.empty((1, 6)),
            np.empty(1), np.empty(1, dtype=np.int64), np.empty(1, dtype=np.int64), np.empty(1, dtype=np.int64),
            np.empty(1, dtype=np.int64), np.empty(1, dtype=np.int64), np.empty(1, dtype=np.bool_),
            np.empty(1, dtype=np.bool_), np.empty(1, dtype=np.bool_), np.empty(1, dtype=np.bool_), np.empty(1),
            np.empty((1, 6)), np.empty(1), np.empty((1, 6)), np.empty((1, 6)), np.empty(1),
            np.empty(1, dtype=np.int64))
    (tau, h, h_previous, d_stress, d_strain, d_u, strain, u, known, rejections, cuts, accepted, segment, going, take,
     dead, skip, h_before, d_strain_before, d_u_before, stress_origin, strain_origin, u_origin, stalled) = walk
    sizes = (np.empty(1), np.empty(1), np.empty(1, dtype=np.bool_))
    size, after, landing = sizes
    inc, guess_strain, guess_u, scale = np.empty((1, 6)), np.empty((1, 6)), np.empty(1), np.empty(1)
    goal, ds, ok = np.empty((1, 6)), np.empty((1, 6)), np.empty(1, dtype=np.bool_)
    zero = np.zeros(6)
    info = np.empty(fail_info.shape[1])
    for i in range(n):
        s[0] = stress0[i]
        st[:] = state0[i]
        failed[i], fail_tau[i], fail_code[i], steps_taken[i] = False, np.nan, 0, 0
        code = update(s[0], st, zero, 0.0, prm[i], settings, t_s[0], t_st, C[0], info, work)
        if code != 0:
            failed[i], fail_tau[i], fail_code[i] = True, -1.0, code
            fail_info[i] = info
            fail_deps[i] = 0.0
            continue
        tau[0], h_previous[0], d_u[0], u[0], h_before[0], d_u_before[0], u_origin[0] = 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0
        d_stress[:], d_strain[:], strain[:], d_strain_before[:], strain_origin[:] = 0.0, 0.0, 0.0, 0.0, 0.0
        known[0], rejections[0], cuts[0], accepted[0], segment[0], stalled[0] = 0, 0, 0, 0, 0, 0
        going[0], take[0], dead[0] = going0[i], False, False
        stress_origin[0] = s[0]
        _store_column(history, i, 0, s[0], strain[0], 0.0, st[void_ratio_column], 0.0)
        for r in range(n_records):
            if records[r, i] == 0.0 or not going[0]:
                _store_column(history, i, r + 1, s[0], strain[0], 0.0, st[void_ratio_column], 0.0)
        top = 0.0
        for c in range(6):
            top = max(top, abs(s[0, c]))
        _path_at(path, i, 0.0, goal)
        jumped = False
        for c in range(6):
            jumped = jumped or (not control[c] and abs(goal[0, c] - s[0, c]) > tol * (1.0 + top))
        skip[0] = jumped
        h[0] = min(firsts[0, i], largest[0, i])
        own_segments = (ends[:, i:i + 1], firsts[:, i:i + 1], largest[:, i:i + 1], rtols[:, i:i + 1])
        own_records = records[:, i:i + 1]
        alive = True
        while going[0]:
            next_steps(tau, h, segment, own_segments[0], own_records, going, size, after, landing)
            _path_at(path, i, after[0], goal)
            guessed = adaptive_inputs(control, goal, strain, s, u, known, size, h_previous, d_strain, d_u, h_before,
                                      d_strain_before, d_u_before, inc, guess_strain, guess_u, scale)
            code = _solve_point(update, prm[i], settings, work, committed, inc, size[0], control, unknown, undrained,
                                newton, (guess_strain, guess_u, guessed and known[0] > 0), trial, scratch, info,
                                fail_deps[i])
            ok[0] = code == 0
            for c in range(6):  # a step that failed keeps its start (no increments)
                ds[0, c] = t_s[0, c] - s[0, c] if ok[0] else 0.0
                if not ok[0]:
                    deps[0, c] = 0.0
            if not ok[0]:
                du[0] = 0.0
            judge_steps(ok, s, ds, deps, du, scale, sizes, step_control, walk, own_segments)
            if dead[0]:
                alive = False
                failed[i], fail_tau[i], fail_code[i] = True, tau[0], loop_failure(code, accepted[0], stalled[0])
                fail_info[i] = info
            if take[0]:
                s[:] = t_s
                st[:] = t_st
                C[:] = t_C
                if landing[0]:
                    for r in range(n_records):
                        if records[r, i] == tau[0]:
                            _store_column(history, i, r + 1, s[0], strain[0], u[0], st[void_ratio_column], tau[0])
        if alive:
            _store_column(history, i, n_records + 1, s[0], strain[0], u[0], st[void_ratio_column], tau[0])
        final_stress[i] = s[0]
        final_state[i] = st
        steps_taken[i] = accepted[0]
