"""The compiled per-point steps of the mixed-control driver (:mod:`constitutive.mixed_control`): the increments
aimed at in a step, the start, Newton corrections and end of a step's Newton on the unknown strain components (and
the excess pore pressure when undrained), and the step control of ``adaptive_control``. Arrays over n points,
updated in place; only IEEE arithmetic and comparisons per point, so the results are the bits of the equivalent
numpy expressions (tests/constitutive/test_compiled_steps.py). Compression positive, kPa, strains dimensionless.

:func:`drive_points` is the whole of ``mixed_control`` (tangent predictor) for a model whose update of one point is
compiled: every step of a point in one call, built from the same pieces on one-row views
(tests/constitutive/test_compiled_step_loop.py).
"""
from __future__ import annotations

import numpy as np

from .jit import jit, next_substep

#: m of sigma = sigma' + u m (the normal Voigt components as weights)
_NORMAL_WEIGHT = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])


@jit
def aim_step(stress, u, inc, control, fresh, taking, prescribed, step_inc):
    """The increments of one step of ``mixed_control``, per point, in place: ``prescribed`` (n, 6), the accumulated
    prescribed total stress, moves on by ``inc`` (n, 6) on the stress-controlled components of the points
    ``taking`` the step, from the actual total stress sigma' + u m where the component is ``fresh``-ly
    stress-controlled; ``step_inc`` (n, 6): ``inc`` on the strain-controlled components, the prescribed minus the
    actual total stress on the others."""
    for i in range(stress.shape[0]):
        for c in range(6):
            total = stress[i, c] + u[i] * _NORMAL_WEIGHT[c]
            if control[c]:
                aimed = prescribed[i, c] + 0.0
            else:
                aimed = (total if fresh[c] else prescribed[i, c]) + inc[i, c]
            if taking[i]:
                prescribed[i, c] = aimed
            step_inc[i, c] = inc[i, c] if control[c] else prescribed[i, c] - total


@jit
def newton_correction(dsig, s_new, tangent, deps, du, target, unknown, undrained, done, tol, ok):
    """One Newton correction of the mixed-control unknowns, in place, per point (the points ``done`` and those whose
    residual is zero are left alone); ``ok`` (n,) set where the residual before it has converged (``s_new`` (n, 6)
    given; with ``s_new`` of zero rows, as for the predictor, the check is skipped: ``ok`` False).

    Residual (``mixed_control``): r_a = dsig_c - target_a on the unknown stress components c = unknown[a]
    (+ du on a normal one when undrained) and, undrained, r_v = the sum of the normal strain increments. Converged:
    max |r_a| <= tol (1 kPa + max |s_new|) and |r_v| <= 1e-3 tol. Jacobian: the tangent's block on the unknowns,
    bordered by the normal unknowns when undrained; each point's small system by Gaussian elimination with partial
    pivoting."""
    k = unknown.size
    m = k + 1 if undrained else k
    jac = np.empty((m, m))
    r = np.empty(m)
    for i in range(dsig.shape[0]):
        ok[i] = False
        if done[i]:
            continue
        worst, zero = 0.0, True
        for a in range(k):
            v = dsig[i, unknown[a]] - target[i, a]
            if undrained and unknown[a] < 3:
                v += du[i]
            r[a] = v
            worst = max(worst, abs(v))
            zero = zero and v == 0.0
        if undrained:
            r[k] = deps[i, 0] + deps[i, 1] + deps[i, 2]
            zero = zero and r[k] == 0.0
        if s_new.shape[0]:
            top = 0.0
            for c in range(6):
                top = max(top, abs(s_new[i, c]))
            ok[i] = worst <= tol * (1.0 + top) and (not undrained or abs(r[k]) <= 1e-3 * tol)
        if zero or ok[i]:
            continue
        for a in range(k):
            for b in range(k):
                jac[a, b] = tangent[i, unknown[a], unknown[b]]
            if undrained:
                jac[a, k] = jac[k, a] = 1.0 if unknown[a] < 3 else 0.0
        if undrained:
            jac[k, k] = 0.0
        for a in range(m):
            r[a] = -r[a]
        for a in range(m):  # elimination with partial pivoting
            p = a
            for b in range(a + 1, m):
                if abs(jac[b, a]) > abs(jac[p, a]):
                    p = b
            if p != a:
                for c in range(m):
                    jac[a, c], jac[p, c] = jac[p, c], jac[a, c]
                r[a], r[p] = r[p], r[a]
            for b in range(a + 1, m):
                f = jac[b, a] / jac[a, a]
                for c in range(a + 1, m):
                    jac[b, c] -= f * jac[a, c]
                r[b] -= f * r[a]
        for a in range(m - 1, -1, -1):
            v = r[a]
            for c in range(a + 1, m):
                v -= jac[a, c] * r[c]
            r[a] = v / jac[a, a]
        for a in range(k):
            deps[i, unknown[a]] += r[a]
        if undrained:
            du[i] += r[k]


@jit
def start_step(inc, active, control, unknown, guess_deps, guess_du, which, guessed, deps, du, target, done):
    """The start of a mixed-control step's Newton, per point, in ``deps`` (n, 6), ``du`` (n,), ``target`` (n, k) and
    ``done`` (n,): ``deps`` the prescribed increments ``inc`` on the strain-controlled components of the ``active``
    points, zero elsewhere, or where ``guessed`` and ``which`` (an active point) the unknowns from ``guess_deps``
    and du from ``guess_du`` (else du = 0); ``target`` the prescribed stress increments of the k unknown
    components; ``done`` the points that take no predictor (inactive or guessed). Returns whether any point takes
    the predictor."""
    predict = False
    for i in range(inc.shape[0]):
        start = guessed and active[i] and which[i]
        for c in range(6):
            deps[i, c] = (inc[i, c] if active[i] else 0.0) if control[c] else (guess_deps[i, c] if start else 0.0)
        for a in range(unknown.size):
            target[i, a] = inc[i, unknown[a]]
        du[i] = guess_du[i] if start else 0.0
        done[i] = not active[i] or start
        predict = predict or not done[i]
    return predict


@jit
def correct_all(s_new, stress, tangent, deps, du, target, unknown, undrained, done, tol, ok):
    """One Newton correction (:func:`newton_correction`) after an update to ``s_new`` from ``stress``; the points
    whose residual had converged join ``done`` (in place). Returns whether every point is done."""
    newton_correction(s_new - stress, s_new, tangent, deps, du, target, unknown, undrained, done, tol, ok)
    every = True
    for i in range(done.size):
        done[i] = done[i] or ok[i]
        every = every and done[i]
    return every


@jit
def finish_step(done, excluded, active, deps, du, converged):
    """The end of a mixed-control step's Newton, per point, in place: ``converged`` the ``active`` points ``done`` and
    not ``excluded``; ``deps`` (n, 6) and ``du`` (n,) zero elsewhere. Returns whether an active point failed."""
    failed = False
    for i in range(done.size):
        converged[i] = done[i] and not excluded[i] and active[i]
        failed = failed or (active[i] and not converged[i])
        if not converged[i]:
            du[i] = 0.0
            for c in range(6):
                deps[i, c] = 0.0
    return failed


@jit
def next_steps(tau, h, segment, ends, records, going, size, after, landing):
    """The next step of each point ``going`` (in place): ``size`` h shortened to land on the next record or segment
    end (``landing``), ending at stage time ``after``."""
    for i in range(tau.size):
        stop = ends[segment[i], i]
        for r in range(records.shape[0]):
            if tau[i] < records[r, i] < stop:
                stop = records[r, i]
        landing[i] = going[i] and h[i] >= stop - tau[i]
        size[i] = stop - tau[i] if landing[i] else h[i]
        after[i] = stop if landing[i] else tau[i] + size[i]


@jit
def adaptive_inputs(control, goal, strain, stress, u, known, size, h_previous, d_strain, d_u, h_before,
                    d_strain_before, d_u_before, inc, guess_strain, guess_u, scale):
    """The inputs of a step of ``adaptive_control`` of size ``size`` (n,), per point, in place: ``inc`` (n, 6) the
    change of the strain (strain-controlled rows) or of the total stress (the others) to the path's ``goal``
    (n, 6); ``scale`` (n,) the stress scale 1 kPa + max |sigma'|; and where the segment has ``known`` (n,)
    previous steps, the increments of the unknowns guessed from their rates (``guess_strain`` (n, 6), ``guess_u``
    (n,)): the previous step's rate d/h_previous, extrapolated linearly with the one before (``_before``, over
    h_before) where known > 1, times ``size``. Returns whether any point is known."""
    any_known = False
    for i in range(size.size):
        top = abs(stress[i, 0])
        for c in range(6):
            stress_change = goal[i, c] - stress[i, c] - u[i] * _NORMAL_WEIGHT[c]
            inc[i, c] = goal[i, c] - strain[i, c] if control[c] else stress_change
            v = abs(stress[i, c])
            if v > top or v != v:
                top = v
        scale[i] = 1.0 + top
        any_known = any_known or known[i] > 0
    if not any_known:
        return False
    for i in range(size.size):
        slope = size[i] / h_previous[i] if known[i] > 1 else 0.0
        for c in range(6):
            rate = d_strain[i, c] / h_previous[i]
            rate = rate + slope * (rate - d_strain_before[i, c] / h_before[i])
            guess_strain[i, c] = rate * size[i]
        rate = d_u[i] / h_previous[i]
        rate = rate + slope * (rate - d_u_before[i] / h_before[i])
        guess_u[i] = rate * size[i]
    return True


@jit
def judge_steps(ok, stress, ds, deps, du, scale, sizes, control, walk, segments):
    """The step control of ``adaptive_control`` after a step, per point, in place: accept or reject, the next
    step size and segment, the increments and totals of the accepted steps. ``ok`` (n,) converged; ``stress`` (n, 6)
    at the step start; ``ds``, ``deps`` (n, 6), ``du`` (n,) the step's increments; ``scale`` (n,) the stress scale
    S; ``sizes`` (size, after, landing); ``control`` (atol, floor, strain_scale, strain_step, growth,
    max_rejections, max_cuts); ``walk`` the per-point records (tau, h, h_previous, d_stress, d_strain, d_u, strain,
    u, known, rejections, cuts, accepted, segment, going, take, dead, skip, h_before, d_strain_before, d_u_before,
    stress_origin, strain_origin, u_origin): ``known`` the previous steps of the segment whose increments are rates
    of its path (up to 2: the one before in the ``_before`` arrays), ``skip`` the next accepted step is not one (it
    jumps to the stress target), ``_origin`` the values at the segment start; ``segments`` (ends, firsts, largest,
    rtols)."""
    size, after, landing = sizes
    atol, floor, strain_scale, strain_step, growth, max_rejections, max_cuts = control
    (tau, h, h_previous, d_stress, d_strain, d_u, strain, u, known, rejections, cuts, accepted, segment, going,
     take, dead, skip, h_before, d_strain_before, d_u_before, stress_origin, strain_origin, u_origin) = walk
    ends, firsts, largest, rtols = segments
    for i in range(tau.size):
        take[i] = dead[i] = False
        if not going[i]:
            continue
        if not ok[i]:  # Newton failed: a quarter of the step, unless it is negligible (no creeping up to a failure)
            cuts[i] += 1
            rejections[i] = 0
            dead[i] = cuts[i] > max_cuts or size[i] <= 1e-12 * ends[ends.shape[0] - 1, i]
            going[i] = not dead[i]
            h[i] = min(0.25 * size[i], largest[segment[i], i])
            continue
        cuts[i] = 0
        rtol = rtols[segment[i], i]
        ratio = size[i] / h_previous[i]
        err = 0.0
        for c in range(6):
            err = max(err, abs(deps[i, c]) / strain_step)
        if rtol < np.inf:  # the increments against the change since the segment start
            err = max(err, abs(du[i]) / (rtol * abs(u[i] + du[i] - u_origin[i]) + floor * scale[i]))
            for c in range(6):
                err = max(err, abs(ds[i, c]) / (rtol * abs(stress[i, c] + ds[i, c] - stress_origin[i, c])
                                                + floor * scale[i]),
                          abs(deps[i, c]) / (rtol * abs(strain[i, c] + deps[i, c] - strain_origin[i, c])
                                             + floor * strain_scale))
        if known[i] and rtol < np.inf:
            change = abs(du[i] - ratio * d_u[i]) / scale[i]
            magnitude = abs(du[i]) / scale[i]
            for c in range(6):
                change = max(change, abs(ds[i, c] - ratio * d_stress[i, c]) / scale[i],
                             abs(deps[i, c] - ratio * d_strain[i, c]) / strain_scale)
                magnitude = max(magnitude, abs(ds[i, c]) / scale[i], abs(deps[i, c]) / strain_scale)
            err = max(err, change / (rtol * magnitude + atol))
        factor = min(max(0.9 / max(err, 1e-12), 0.2), growth)
        if err > 1.0 and rejections[i] < max_rejections:
            rejections[i] += 1
            h[i] = min(size[i] * factor, largest[segment[i], i])
            continue
        take[i] = True
        rejections[i] = 0
        proposal = size[i] * factor
        if landing[i]:  # a step shortened to land keeps its proposal
            proposal = max(proposal, h[i])
        for c in range(6):
            d_strain_before[i, c] = d_strain[i, c]
            d_stress[i, c], d_strain[i, c] = ds[i, c], deps[i, c]
            strain[i, c] += deps[i, c]
        d_u_before[i], d_u[i] = d_u[i], du[i]
        u[i] += du[i]
        tau[i], h_before[i], h_previous[i] = after[i], h_previous[i], size[i]
        known[i] = known[i] if skip[i] else min(known[i] + 1, 2)
        skip[i] = False
        accepted[i] += 1
        if tau[i] >= ends[segment[i], i]:
            if segment[i] == ends.shape[0] - 1:
                going[i] = False
            else:
                segment[i] += 1
                proposal = firsts[segment[i], i]
                known[i] = 0
                for c in range(6):
                    stress_origin[i, c] = stress[i, c] + ds[i, c]
                    strain_origin[i, c] = strain[i, c]
                u_origin[i] = u[i]
        h[i] = min(proposal, largest[segment[i], i])


# The compiled step loop. Its three functions are inlined into the model's wrapper (e.g. ``_mcc_kernel.drive``):
# the point update ``update`` is then a compile-time constant there, not a run-time argument, which numba cannot
# cache.
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
                last_dt = dt[k, i] if kept else 0.0
                if taking:
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
    code in the last Newton, 0 none), fail_info (n, I), fail_deps (n, 6), steps (n,) the accepted steps). The
    arithmetic per point is that of ``adaptive_control``."""
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
            np.empty((1, 6)), np.empty(1), np.empty((1, 6)), np.empty((1, 6)), np.empty(1))
    (tau, h, h_previous, d_stress, d_strain, d_u, strain, u, known, rejections, cuts, accepted, segment, going, take,
     dead, skip, h_before, d_strain_before, d_u_before, stress_origin, strain_origin, u_origin) = walk
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
        known[0], rejections[0], cuts[0], accepted[0], segment[0] = 0, 0, 0, 0, 0
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
                failed[i], fail_tau[i], fail_code[i] = True, tau[0], max(code, 0)
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
