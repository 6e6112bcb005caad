"""The compiled per-point steps of the mixed-control driver (constitutive.mixed_control: aim_step, start_step,
correct_all) and of the delayed-swelling iteration (constitutive._swelling_kernel) against their definitions written
as vectorized numpy expressions (the equations of the modules' docstrings): bit for bit, on random points that mix
every branch (active or not, strain- or stress-controlled, guessed or not, below p'_max or not, with residuals of
either sign, nan and signed zeros among them).
"""

import numpy as np
import pytest

from constitutive import _swelling_kernel as sk
from constitutive.mixed_control import (
    NORMAL,
    adaptive_inputs,
    aim_step,
    correct_all,
    finish_step,
    newton_correction,
    start_step,
)

N = 64


def same(a, b):
    """Equal bit for bit (nan in the same places, signed zeros told apart)."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8))


def signed_values(rng, shape):
    """Normal values with exact zeros of both signs and a few nan."""
    v = rng.normal(size=shape)
    v.flat[::7] = 0.0
    v.flat[3::11] = -0.0
    v.flat[5::29] = np.nan
    return v


@pytest.mark.parametrize("seed", range(4))
def test_aim_step_is_the_vectorized_aim(seed):
    """prescribed <- where(taking, where(fresh, total, prescribed) + where(control, 0, inc), prescribed) and
    step increment where(control, inc, prescribed - total), total = sigma' + u m."""
    rng = np.random.default_rng(seed)
    stress, inc, prescribed = (signed_values(rng, (N, 6)) for _ in range(3))
    u = signed_values(rng, N)
    control, before = rng.random(6) < 0.5, rng.random(6) < 0.5
    fresh = ~control & before
    taking = rng.random(N) < 0.7
    total = stress + u[:, None] * NORMAL
    aimed = np.where(fresh, total, prescribed) + np.where(control, 0.0, inc)
    want_prescribed = np.where(taking[:, None], aimed, prescribed)
    want_inc = np.where(control, inc, want_prescribed - total)
    got_inc = np.empty((N, 6))
    aim_step(stress, u, inc, control, fresh, taking, prescribed, got_inc)
    assert same(prescribed, want_prescribed) and same(got_inc, want_inc)


@pytest.mark.parametrize("seed, guessed", [(0, False), (1, True), (2, True)])
def test_start_step_is_the_vectorized_start(seed, guessed):
    """deps = inc on the strain-controlled components of the active points (0 elsewhere), the unknowns and du
    from the guess where a point is guessed; target = inc on the unknowns; done = not active or guessed."""
    rng = np.random.default_rng(seed)
    control = np.array([True, False, False, True, True, True])
    unknown = np.flatnonzero(~control)
    inc, guess_deps = signed_values(rng, (N, 6)), signed_values(rng, (N, 6))
    guess_du = signed_values(rng, N)
    active, which = rng.random(N) < 0.8, rng.random(N) < 0.5
    start = active & which if guessed else np.zeros(N, dtype=bool)
    want_deps = np.where(control & active[:, None], inc, 0.0)
    want_deps = np.where(control | ~start[:, None], want_deps, guess_deps)
    want_du = np.where(start, guess_du, 0.0)
    deps, du, target, done = np.empty((N, 6)), np.empty(N), np.empty((N, unknown.size)), np.empty(N, dtype=bool)
    predict = start_step(inc, active, control, unknown, guess_deps, guess_du, which, guessed, deps, du, target, done)
    assert same(deps, want_deps) and same(du, want_du) and same(target, inc[:, unknown])
    assert np.array_equal(done, ~active | start) and predict == bool((active & ~start).any())


@pytest.mark.parametrize("undrained", [False, True])
def test_correct_all_is_one_correction_then_the_union(undrained):
    """correct_all = newton_correction on s_new - stress, then done |= converged, returning whether all are done."""
    rng = np.random.default_rng(5)
    unknown = np.array([1, 2])
    stress, s_new = 100.0 * rng.normal(size=(N, 6)), 100.0 * rng.normal(size=(N, 6))
    s_new[:10] = stress[:10]                                  # zero increments: converged where the target is zero
    tangent = rng.normal(size=(N, 6, 6)) + 4.0 * np.eye(6)
    deps, du = 1e-3 * rng.normal(size=(N, 6)), rng.normal(size=N)
    target = rng.normal(size=(N, 2))
    target[:10] = 0.0
    deps[:10, :3] = 0.0
    du[:10] = 0.0
    done = rng.random(N) < 0.3
    want_deps, want_du, ok = deps.copy(), du.copy(), np.empty(N, dtype=bool)
    newton_correction(s_new - stress, s_new, tangent, want_deps, want_du, target, unknown, undrained, done, 1e-10, ok)
    want_done = done | ok
    assert ok[:10][~done[:10]].all()
    every = correct_all(s_new, stress, tangent, deps, du, target, unknown, undrained, done, 1e-10,
                        np.empty(N, dtype=bool))
    assert same(deps, want_deps) and same(du, want_du) and np.array_equal(done, want_done)
    assert every == bool(want_done.all())
    done[:] = True
    assert correct_all(s_new, stress, tangent, deps, du, target, unknown, undrained, done, 1e-10,
                       np.empty(N, dtype=bool))


def test_finish_step_keeps_the_converged_increments():
    """converged = done & ~excluded & active; deps and du where(converged, ., 0); returns whether an active point
    did not converge."""
    rng = np.random.default_rng(2)
    done, excluded, active = (rng.random(N) < f for f in (0.8, 0.1, 0.9))
    deps, du = signed_values(rng, (N, 6)), signed_values(rng, N)
    want = done & ~excluded & active
    want_deps, want_du = np.where(want[:, None], deps, 0.0), np.where(want, du, 0.0)
    converged = np.empty(N, dtype=bool)
    failed = finish_step(done, excluded, active, deps, du, converged)
    assert np.array_equal(converged, want) and same(deps, want_deps) and same(du, want_du)
    assert failed == bool((active & ~want).any())
    assert not finish_step(np.ones(N, dtype=bool), np.zeros(N, dtype=bool), active, deps, du, converged)


@pytest.mark.parametrize("seed", range(3))
def test_adaptive_inputs_are_the_vectorized_inputs(seed):
    """inc = where(control, goal - strain, goal - sigma' - u m); S = 1 + max |sigma'| (nan propagates); the guess
    (rate d/h_previous extrapolated with slope size/h_previous where known > 1, times size) where any is known."""
    rng = np.random.default_rng(seed)
    control = rng.random(6) < 0.5
    goal, strain, stress, d_strain, d_before = (signed_values(rng, (N, 6)) for _ in range(5))
    u, d_u, d_u_before = (signed_values(rng, N) for _ in range(3))
    size, h_previous, h_before = (rng.uniform(0.0, 2.0, N) for _ in range(3))
    h_previous[::17] = 0.0
    known = rng.integers(0, 3, N) * (seed > 0)
    inc, guess_strain, guess_u, scale = np.empty((N, 6)), np.empty((N, 6)), np.empty(N), np.empty(N)
    with np.errstate(divide="ignore", invalid="ignore"):
        guessed = adaptive_inputs(control, goal, strain, stress, u, known, size, h_previous, d_strain, d_u, h_before,
                                  d_before, d_u_before, inc, guess_strain, guess_u, scale)
        assert same(inc, np.where(control, goal - strain, goal - stress - u[:, None] * NORMAL))
        assert same(scale, 1.0 + np.abs(stress).max(axis=1)) and guessed == bool(known.any())
        if guessed:
            slope = np.where(known > 1, size / h_previous, 0.0)
            rate_strain, rate_u = d_strain / h_previous[:, None], d_u / h_previous
            rate_strain = rate_strain + slope[:, None] * (rate_strain - d_before / h_before[:, None])
            rate_u = rate_u + slope * (rate_u - d_u_before / h_before)
            assert same(guess_strain, rate_strain * size[:, None]) and same(guess_u, rate_u * size)


def swelling_point_values(rng):
    """Points of a swelling increment: p' around p'_max (some <= 0), a and kappa_s/(1 + e) with zeros."""
    p_max = rng.uniform(50.0, 200.0, N)
    p = p_max * rng.uniform(-0.2, 1.5, N)
    p[::9] = p_max[::9]
    a, slope = rng.uniform(0.0, 3.0, N), rng.uniform(0.0, 0.02, N)
    a[::5], slope[::6] = 0.0, 0.0
    return p, p_max, a, slope


def test_swelling_base_strains_and_law_ratios():
    """(S1) d eps - ((x - eps_s,n)/3) m; the argument of (S2)'s logarithm where (S2) acts (1 elsewhere) and the
    first active point where it acts at p' <= 0."""
    rng = np.random.default_rng(3)
    dstrain = signed_values(rng, (N, 6))
    x, eps_n = signed_values(rng, N), signed_values(rng, N)
    out = np.empty((N, 6))
    sk.base_strains(dstrain, x, eps_n, out)
    assert same(out, dstrain - ((x - eps_n) / 3.0)[:, None] * np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]))
    p, p_max, a, slope = swelling_point_values(rng)
    s_b = rng.normal(size=(N, 6))
    s_b[:, 2] = 3.0 * p - s_b[:, 0] - s_b[:, 1]
    p = (s_b[:, 0] + s_b[:, 1] + s_b[:, 2]) / 3.0
    law = (p < p_max) & (a > 0.0) & (slope > 0.0)
    got_p, ratio = np.empty(N), np.empty(N)
    for active in (np.ones(N, dtype=bool), ~(law & (p <= 0.0)), rng.random(N) < 0.5):
        bad = sk.law_ratios(s_b, p_max, a, slope, active, got_p, ratio)
        hits = np.flatnonzero(active & law & (p <= 0.0))
        assert bad == (hits[0] if hits.size else -1)
        assert same(got_p, p) and same(ratio, np.where(law & (p > 0.0), p, p_max) / p_max)


def test_swelling_residuals_and_next_iterates_are_the_vectorized_iteration():
    """R = x - (eps_s,n + a eps_s^eq)/(1 + a), c, the points done; then the bracket update (Illinois) and the
    safeguarded Newton / false-position / bisection iterate, as numpy expressions over the points, twice in a row
    (the first evaluation's bracket, then a later one's)."""
    rng = np.random.default_rng(11)
    p, p_max, a, slope = swelling_point_values(rng)
    p = np.abs(p) + 1.0
    eps_n = -0.01 * rng.random(N)
    x = eps_n / (1.0 + a) - 0.005 * rng.random(N)
    x[::13] = eps_n[::13] / (1.0 + a[::13])
    volumetric = rng.uniform(-50.0, 5000.0, N)
    tol = 1e-12
    lo, hi = x.copy(), eps_n / (1.0 + a)
    bracket = (lo.copy(), hi.copy(), np.full(N, np.nan), np.full(N, np.nan), np.zeros(N), np.full(N, np.inf))
    want = [b.copy() for b in bracket]
    active, want_active = np.ones(N, dtype=bool), np.ones(N, dtype=bool)
    for first in (True, False):
        s_b = np.repeat(p[:, None], 6, axis=1)
        s_b[:, 3:] = 0.0
        p, ratio = np.empty(N), np.empty(N)
        sk.law_ratios(s_b, p_max, a, slope, active, p, ratio)
        log_ratio = np.log(ratio)
        below = p < p_max
        law = below & (a > 0.0) & (slope > 0.0)
        want_residual = x - (eps_n + a * np.where(below, slope * log_ratio, 0.0)) / (1.0 + a)
        want_c = np.where(law, a / (1.0 + a) * slope / np.where(law, p, 1.0), 0.0)
        want_done = want_active & (np.abs(want_residual) <= tol)
        want_active &= ~want_done
        residual, c, done = np.empty(N), np.empty(N), np.empty(N, dtype=bool)
        counts = sk.residuals(x, p, p_max, log_ratio, a, slope, eps_n, tol, active, residual, c, done)
        assert same(residual, want_residual) and same(c, want_c)
        assert np.array_equal(done, want_done) and np.array_equal(active, want_active)
        assert counts == (want_done.sum(), want_active.sum())
        # the iteration of the bracket, as the module docstring states it
        w_lo, w_hi, r_lo, r_hi, side, before = want
        if first:
            w_lo, w_hi = x - np.maximum(residual, 0.0), np.minimum(w_hi, x - np.minimum(residual, 0.0))
        up, down = want_active & (residual > 0.0), want_active & (residual < 0.0)
        r_lo = np.where(up & (side > 0.0), 0.5 * r_lo, r_lo)
        r_hi = np.where(down & (side < 0.0), 0.5 * r_hi, r_hi)
        w_hi, r_hi = np.where(up, x, w_hi), np.where(up, residual, r_hi)
        w_lo, r_lo = np.where(down, x, w_lo), np.where(down, residual, r_lo)
        side = np.where(up, 1.0, np.where(down, -1.0, side))
        progress = np.abs(residual) <= 0.5 * before
        slope_r = 1.0 + c * volumetric / 9.0
        newton = x - residual / np.where(slope_r > 0.0, slope_r, 1.0)
        both = np.isfinite(r_lo) & np.isfinite(r_hi)
        secant = w_lo - np.where(both, r_lo, 0.0) * (w_hi - w_lo) / np.where(both, r_hi - r_lo, 1.0)
        fallback = np.where(both & (secant > w_lo) & (secant < w_hi), secant, 0.5 * (w_lo + w_hi))
        want_x = np.where(want_active, np.where((slope_r > 0.0) & (newton >= w_lo) & (newton <= w_hi) & progress,
                                                newton, fallback), x)
        want = [w_lo, w_hi, r_lo, r_hi, side, np.abs(residual)]
        x_next = np.empty(N)
        sk.next_iterates(first, x, residual, c, volumetric, active, bracket, x_next)
        assert all(same(g, w) for g, w in zip(bracket, want)) and same(x_next, want_x)
        x = x_next
        p = p * (1.0 + 0.01 * rng.normal(size=N))


def test_swelling_tangent_is_the_rank_one_update():
    """C = D^b - c/(9 (1 + c K_t)) (D^b m)(m^T D^b), K_t = m.D^b.m/9 (sums in index order), as the numpy
    expression."""
    rng = np.random.default_rng(4)
    D_b = signed_values(rng, (N, 6, 6))
    c = np.abs(signed_values(rng, N))
    c[::3] = 0.0
    Dm, mD = D_b[:, :, 0] + D_b[:, :, 1] + D_b[:, :, 2], D_b[:, 0, :] + D_b[:, 1, :] + D_b[:, 2, :]
    K_t = (Dm[:, 0] + Dm[:, 1] + Dm[:, 2]) / 9.0
    out = np.empty_like(D_b)
    sk.tangent(D_b, c, out)
    assert same(out, D_b - (c / (9.0 * (1.0 + c * K_t)))[:, None, None] * Dm[:, :, None] * mD[:, None, :])
