"""The compiled per-point steps of the mixed-control driver (:mod:`constitutive.mixed_control`): the increments
aimed at in a step, the start, Newton corrections and end of a step's Newton on the unknown strain components (and
the excess pore pressure when undrained), and the step control of ``adaptive_control``. Arrays over n points,
updated in place; only IEEE arithmetic and comparisons per point, so the results are the bits of the equivalent
numpy expressions (tests/constitutive/test_compiled_steps.py). Compression positive, kPa, strains dimensionless.
The whole step loops built from these pieces are in :mod:`constitutive._step_loops`.
"""
from __future__ import annotations

import numpy as np

from .jit import jit

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


#: a step of at most this fraction of its path's duration is negligible (``judge_steps``): a step control that cuts
#: or shrinks steps below it creeps up to a state it cannot pass instead of following the path
NEGLIGIBLE_STEP = 1e-12
#: the most accepted negligible steps in a row before a point fails as stalled (``judge_steps``): a response whose
#: rate grows without bound under the held load or strain rate (creep rupture), which the steps follow towards an
#: instant they never reach; one negligible step (landing on a record a rounding error away) is not a stall
STALL_STEPS = 100
#: the most accepted steps of one point along one adaptive path (``judge_steps``): a laboratory stage takes a few
#: thousand (a record is a step's end, so a test of more than this many records cannot be followed); a last guard
#: against a walk whose steps neither stall nor reach the end
MAX_STEPS = 200_000
#: the step control's own failure codes (negative; a model's failure codes are positive, 0 none)
STEP_LIMIT, STALLED = -2, -3
#: the reasons of the step control's own failure codes
LOOP_FAILURES = {
    STEP_LIMIT: f"the step control took {MAX_STEPS} steps without reaching the end of the path",
    STALLED: (f"the steps fell below {NEGLIGIBLE_STEP:g} of the path's duration for {STALL_STEPS} steps in a row: the "
              "response runs away (a strain rate that grows without bound under the held load: creep rupture or an "
              "unstable state)"),
}


@jit
def loop_failure(code, accepted, stalled):
    """The failure code of a point that the step control of ``adaptive_control`` ended (``judge_steps``' dead),
    from the code of its last step's Newton (``code``: a model's code > 0, or -1 for a Newton that did not converge,
    which gives 0), its accepted steps and its negligible steps in a row."""
    if accepted >= MAX_STEPS:
        return STEP_LIMIT
    if stalled >= STALL_STEPS:
        return STALLED
    return max(code, 0)


@jit
def judge_steps(ok, stress, ds, deps, du, scale, sizes, control, walk, segments):
    """The step control of ``adaptive_control`` after a step, per point, in place: accept or reject, the next
    step size and segment, the increments and totals of the accepted steps. ``ok`` (n,) converged; ``stress`` (n, 6)
    at the step start; ``ds``, ``deps`` (n, 6), ``du`` (n,) the step's increments; ``scale`` (n,) the stress scale
    S; ``sizes`` (size, after, landing); ``control`` (atol, floor, strain_scale, strain_step, growth,
    max_rejections, max_cuts); ``walk`` the per-point records (tau, h, h_previous, d_stress, d_strain, d_u, strain,
    u, known, rejections, cuts, accepted, segment, going, take, dead, skip, h_before, d_strain_before, d_u_before,
    stress_origin, strain_origin, u_origin, stalled): ``known`` the previous steps of the segment whose increments
    are rates of its path (up to 2: the one before in the ``_before`` arrays), ``skip`` the next accepted step is not
    one (it jumps to the stress target), ``_origin`` the values at the segment start, ``stalled`` the negligible
    steps (:data:`NEGLIGIBLE_STEP`) accepted in a row; ``segments`` (ends, firsts, largest, rtols). A point is dead
    (:func:`loop_failure` says why) when its Newton fails ``max_cuts`` times in a row or on a negligible step, after
    :data:`STALL_STEPS` negligible steps in a row, or at :data:`MAX_STEPS` accepted steps before its end."""
    size, after, landing = sizes
    atol, floor, strain_scale, strain_step, growth, max_rejections, max_cuts = control
    (tau, h, h_previous, d_stress, d_strain, d_u, strain, u, known, rejections, cuts, accepted, segment, going,
     take, dead, skip, h_before, d_strain_before, d_u_before, stress_origin, strain_origin, u_origin, stalled) = walk
    ends, firsts, largest, rtols = segments
    for i in range(tau.size):
        take[i] = dead[i] = False
        if not going[i]:
            continue
        negligible = size[i] <= NEGLIGIBLE_STEP * ends[ends.shape[0] - 1, i]
        if not ok[i]:  # Newton failed: a quarter of the step, unless it is negligible (no creeping up to a failure)
            cuts[i] += 1
            rejections[i] = 0
            dead[i] = cuts[i] > max_cuts or negligible
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
        stalled[i] = stalled[i] + 1 if negligible else 0
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
        if going[i] and (accepted[i] >= MAX_STEPS or stalled[i] >= STALL_STEPS):  # a failure, not an endless loop
            dead[i] = True
            going[i] = False
