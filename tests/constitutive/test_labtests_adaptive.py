"""The mixed-control Newton of constitutive.labtests (compiled correction, predictors, points that do not move) and
``adaptive_control`` against independent oracles: numpy's dense solver, the exact response of linear elasticity, the
closed form of isotropic creep, one-point runs."""
import numpy as np
import pytest

from constitutive import ANICREEP, IntegrationError, LinearElastic, labtests
from constitutive.anicreep import anisotropy_constants
from constitutive.mixed_control import (
    LOOP_FAILURES,
    MAX_STEPS,
    NEGLIGIBLE_STEP,
    STALL_STEPS,
    STALLED,
    STEP_LIMIT,
    judge_steps,
    loop_failure,
    newton_correction,
)

TRIAXIAL_STRESS = np.array([False, False, False, True, True, True])
AXIAL_STRAIN = np.array([True, False, False, True, True, True])
OEDOMETER_STRESS = np.array([False, True, True, True, True, True])
CLAY = dict(M=1.2, lambda_=0.40, kappa=0.026, nu=0.3, e0=2.0)


@pytest.mark.parametrize("control, undrained", [(TRIAXIAL_STRESS, False), (TRIAXIAL_STRESS, True),
                                                (AXIAL_STRAIN, False), (AXIAL_STRAIN, True),
                                                (OEDOMETER_STRESS, False), (OEDOMETER_STRESS, True)])
def test_newton_correction_solves_the_bordered_system(control, undrained):
    """One correction of the unknown strains (and du) equals numpy.linalg.solve of J x = -r, J the tangent's block
    on the unknowns bordered by the normal unknowns (undrained: a zero diagonal, so the elimination must pivot; the
    first block pivot is made tiny as well). Points whose residual is within the tolerance are flagged and left
    alone."""
    rng = np.random.default_rng(7)
    n = 40
    unknown = np.flatnonzero(~control)
    k = unknown.size
    tangent = rng.normal(size=(n, 6, 6)) + 4.0 * np.eye(6)
    tangent[:, unknown[0], unknown[0]] = 1e-13
    dsig, deps, du = rng.normal(size=(n, 6)), 1e-3 * rng.normal(size=(n, 6)), rng.normal(size=n)
    target = rng.normal(size=(n, k))
    normal = (unknown < 3).astype(float)
    r = dsig[:, unknown] - target + (du[:, None] * normal if undrained else 0.0)
    jac = tangent[:, unknown][:, :, unknown]
    if undrained:
        r = np.concatenate([r, deps[:, :3].sum(axis=1)[:, None]], axis=1)
        border = np.zeros((n, k + 1, k + 1))
        border[:, :k, :k] = jac
        border[:, :k, k] = border[:, k, :k] = normal
        jac = border
    x = np.linalg.solve(jac, -r[:, :, None])[:, :, 0]
    converged = np.arange(n) % 4 == 0  # residuals within the tolerance: untouched
    dsig[converged] = 0.0
    dsig[np.ix_(converged, unknown)] = target[converged] - (du[converged, None] * normal if undrained else 0.0)
    if undrained:
        deps[converged, 2] = -deps[converged, 0] - deps[converged, 1]
    got_deps, got_du, ok = deps.copy(), du.copy(), np.zeros(n, dtype=bool)
    newton_correction(dsig, np.full((n, 6), 100.0), tangent, got_deps, got_du, target, unknown, undrained,
                       np.zeros(n, dtype=bool), 1e-10, ok)
    assert np.array_equal(ok, converged)
    want_deps, want_du = deps.copy(), du.copy()
    want_deps[:, unknown] += np.where(converged[:, None], 0.0, x[:, :k])
    if undrained:
        want_du += np.where(converged, 0.0, x[:, k])
    np.testing.assert_allclose(got_deps, want_deps, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got_du, want_du, rtol=1e-10, atol=1e-12)


def _viscous(**kw):
    return ANICREEP(**{"sigma_p0": 40.0, "C_alpha_e": 0.02, "specific_volume": "current", **CLAY, **kw})


def _oedometer_loading_steps(model, n=1):
    """sigma'_v ramped from 30 to 120 kPa in 60 equal steps over 600 s, then held for 1e5 s in 40 geometric steps."""
    s0 = np.zeros((n, 6))
    s0[:, 0], s0[:, 1:3] = 30.0, 18.0
    state0 = model.initial_state(s0)
    hold = np.diff(np.geomspace(1.0, 1e5, 41))
    inc = np.zeros((60 + 40, 6))
    inc[:60, 0] = 90.0 / 60
    return s0, state0, inc, np.r_[np.full(60, 10.0), hold]


def test_previous_increment_predictor_converges_to_the_same_steps_in_fewer_updates():
    """mixed_control(predictor="previous") solves the same steps as the tangent predictor (results within the Newton
    tolerance) with fewer model updates on a viscous oedometer ramp and hold (measured 0.8x); the Python driver, whose
    updates can be counted (the compiled one iterates the same: test_compiled_step_loop.py)."""
    results, updates = [], []
    for predictor in ("tangent", "previous"):
        model = _viscous()
        calls = []
        update = model.update
        model.update = lambda *a, **k: calls.append(1) or update(*a, **k)
        s0, state0, inc, dt = _oedometer_loading_steps(model)
        results.append(labtests.mixed_control(model, s0, state0, np.array([False] + [True] * 5), inc, dt,
                                              predictor=predictor, compiled=False))
        updates.append(len(calls))
    for key in ("stress", "strain", "void_ratio"):
        np.testing.assert_allclose(results[1][key], results[0][key], rtol=1e-8, atol=1e-12)
    assert updates[1] < 0.9 * updates[0]


class _Brittle(LinearElastic):
    """Linear elasticity whose points ``fragile`` fail in an update over a positive time (``over_time``) or past
    sigma'_11 = 40 kPa."""

    def __init__(self, E, nu, fragile, over_time):
        super().__init__(E, nu)
        self.fragile, self.over_time = np.asarray(fragile), over_time

    def update(self, stress, state, dstrain, dt, tangent=True):
        out = super().update(stress, state, dstrain, dt, tangent)
        timed = np.broadcast_to(dt, (stress.shape[0],)) > 0.0 if self.over_time else False
        bad = np.flatnonzero(self.fragile & (timed | (out[0][:, 0] > 40.0)))
        if bad.size:
            raise IntegrationError(int(bad[0]), "brittle")
        return out


def test_points_that_do_not_move_are_not_integrated_over_the_step():
    """A point outside a step (``active``) takes no update over the step's time: a state its model cannot
    integrate (here: any positive dt) does not fail the batch."""
    model = _Brittle(1e4, 0.3, [False, True, False], over_time=True)
    s0 = np.full((3, 6), 0.0)
    s0[:, :3] = 20.0
    inc = np.zeros((5, 6))
    inc[:, 0] = 1.0
    active = np.array([True, False, True])
    hist = labtests.mixed_control(model, s0, model.initial_state(s0), TRIAXIAL_STRESS, inc, np.full(5, 10.0),
                                  active=np.broadcast_to(active, (5, 3)))
    assert not hist["failed"].any()
    np.testing.assert_allclose(hist["stress"][[0, 2], -1, 0], 25.0, rtol=1e-12)
    np.testing.assert_array_equal(hist["stress"][1, -1], s0[1])


def _ramp(model, n, records, segments, active=None):
    """adaptive_control of every normal stress ramped from 20 kPa (sigma'_a at 0.3 kPa/s, sigma'_r at 0.1 kPa/s),
    shear strains held."""
    s0 = np.zeros((n, 6))
    s0[:, :3] = 20.0

    def target(tau):
        out = np.zeros((n, 6))
        out[:, 0] = 20.0 + 0.3 * tau
        out[:, 1] = out[:, 2] = 20.0 + 0.1 * tau
        return out

    return s0, labtests.adaptive_control(model, s0, model.initial_state(s0), TRIAXIAL_STRESS, target, segments,
                                         records, active=active)


def test_adaptive_control_lands_on_every_record_exactly():
    """Linear elasticity (backward Euler exact): the strains at records in any order (repeated, at the start, at a
    segment end) are D^-1 (sigma'(tau) - sigma'_0); a point outside ``active`` keeps its start; the steps of a linear
    path grow geometrically (the growth rule (b))."""
    E, nu = 1e4, 0.3
    model = LinearElastic(E, nu)
    records = np.array([50.0, 0.0, 7.5, 100.0, 50.0, 31.0])
    segments = ([50.0, 100.0], [0.5, 0.5], [np.inf, np.inf], [0.1, np.inf])
    s0, hist = _ramp(model, 2, records[:, None], segments, active=np.array([True, False]))
    assert not hist["failed"].any()
    tau = hist["time"][0, 1:-1]
    np.testing.assert_array_equal(tau, records)
    d_axial, d_radial = 0.3 * tau, 0.1 * tau
    # the stresses are held to the Newton tolerance, 1e-10 (1 kPa + max |sigma'|): strains to 1e-12
    np.testing.assert_allclose(hist["strain"][0, 1:-1, 0], (d_axial - 2 * nu * d_radial) / E, rtol=0, atol=1e-12)
    np.testing.assert_allclose(hist["strain"][0, 1:-1, 1], (d_radial - nu * (d_axial + d_radial)) / E, rtol=0,
                               atol=1e-12)
    np.testing.assert_allclose(hist["stress"][0, -1, :3], [50.0, 30.0, 30.0], rtol=1e-12)
    np.testing.assert_array_equal(hist["stress"][1], np.broadcast_to(s0[1], (8, 6)))
    # (b) from 0.5 s at 1.1 per step to 50 s, the records adding landings; the second segment in steps of largest
    assert hist["steps"][0] <= np.ceil(np.log(50.0 / 0.5 * 0.1 + 1) / np.log(1.1)) + 8 + 2
    assert hist["steps"][1] == 0


def _creep_hold(rates, p_over, t_records):
    """adaptive_control of the isotropic viscous model (anisotropy off, specific volume of e0) held at
    p' = p_over p'_m0: the closed form y = e0 - e = C ln(1 + A t/C), A = (C r/tau)(p'/p'_m0)^beta
    (tests/constitutive/test_family_specific_volume.py). Returns (max |y - exact| / y at the end per rate, steps)."""
    C, tau = 0.02, 86400.0
    m = ANICREEP(sigma_p0=40.0, C_alpha_e=C, tau=tau, anisotropy=False, **CLAY)
    s0 = np.zeros((1, 6))
    s0[:, :3] = p_over * m.reference_size(1)[0]
    state0 = m.initial_state(s0)
    eta_k0 = anisotropy_constants(CLAY["M"])[1]
    r = CLAY["M"] ** 2 / (CLAY["M"] ** 2 - eta_k0**2)
    A = C * r / tau * (s0[0, 0] / state0["pm_ref"][0]) ** ((CLAY["lambda_"] - CLAY["kappa"]) / C)
    exact = C * np.log1p(A * t_records / C)
    errors, steps = [], []
    for rate in rates:
        segments = ([t_records[-1]], [0.1], [np.inf], [rate])
        hist = labtests.adaptive_control(m, s0, state0, TRIAXIAL_STRESS, labtests.LinearPath.constant(s0),
                                         segments, t_records[:, None])
        y = CLAY["e0"] - hist["void_ratio"][0, 1:-1]
        errors.append(np.max(np.abs(y - exact)) / exact[-1])
        steps.append(int(hist["steps"][0]))
    # the reference stepping: mixed_control on the geometric grid of 20 steps per decade from 0.1 s, plus the records
    grid = np.unique(np.concatenate([np.geomspace(0.1, t_records[-1], 181), t_records]))
    hist = labtests.mixed_control(m, s0, state0, TRIAXIAL_STRESS, np.zeros((grid.size, 6)),
                                  np.diff(np.concatenate([[0.0], grid])), record=np.isin(grid, t_records))
    y = CLAY["e0"] - hist["void_ratio"][0, 1:]
    grid_error = np.max(np.abs(y - exact)) / exact[-1]
    return np.array(errors), steps, C / A, grid_error


def test_adaptive_creep_hold_converges_to_the_closed_form_at_first_order():
    """Creep from t = 0 (t0 = C/A = 811 s, p' = 1.25 p'_m0) held to 1e8 s: the error of the curve relative to its
    end, first order in the rate change (backward Euler): measured 0.33 %, 0.18 %, 0.093 % in 174, 298, 556 steps
    at 0.1, 0.05, 0.025. The geometric grid of 20 steps per decade from 0.1 s (mixed_control, 181 steps) gives
    0.49 %: here the strain grows at a steady rate from the start, so the growth rule takes about its steps."""
    t = np.geomspace(1.0, 1e8, 33)
    errors, steps, t0, grid_error = _creep_hold([0.1, 0.05, 0.025], 1.25, t)
    assert 5e2 < t0 < 2e3
    assert errors[0] <= grid_error           # no less accurate than the step table's geometric grid
    np.testing.assert_allclose(errors[:-1] / errors[1:], 2.0, rtol=0.15)
    assert steps[0] <= 181


def test_adaptive_batch_equals_single_points():
    """Each point chooses its own steps from its own response: three viscous particles (different creep indices,
    one inactive) in one call equal their one-point calls to round-off."""
    ca = np.array([0.005, 0.02, 0.05])
    t = np.geomspace(10.0, 1e6, 9)
    s0 = np.zeros((3, 6))
    s0[:, 0], s0[:, 1:3] = 60.0, 36.0
    segments = ([1e6], [0.1], [np.inf], [0.1])

    def run(rows):
        m = _viscous(C_alpha_e=ca[rows])
        return labtests.adaptive_control(m, s0[rows], m.initial_state(s0[rows]), OEDOMETER_STRESS,
                                         labtests.LinearPath.constant(np.where(OEDOMETER_STRESS, 0.0, s0[rows])),
                                         segments,
                                         np.broadcast_to(t[:, None], (9, len(rows))), strain_step=0.0025)
    batch = run([0, 1, 2])
    for i in range(3):
        one = run([i])
        for key in ("stress", "strain", "void_ratio", "time"):
            np.testing.assert_allclose(batch[key][i], one[key][0], rtol=1e-13, atol=1e-15)
        assert batch["steps"][i] == one["steps"][0]
    assert len(set(batch["steps"])) > 1


def test_adaptive_failure_freezes_only_that_point():
    """A point whose update fails whatever its step (past 40 kPa) is cut ``max_cuts`` times, then fails with the
    model's reason and NaN records past the failure; the others finish as in a call without it."""
    model = _Brittle(1e4, 0.3, [False, True], over_time=False)
    records = np.array([10.0, 50.0, 100.0])[:, None]
    segments = ([100.0], [1.0], [np.inf], [0.1])
    s0, hist = _ramp(model, 2, records, segments)
    assert hist["failed"].tolist() == [False, True]
    assert "brittle" in hist["reasons"][1]
    assert np.all(np.isfinite(hist["stress"][1, :3])) and np.all(np.isnan(hist["stress"][1, 3:]))  # fails at 40 kPa
    alone = _ramp(LinearElastic(1e4, 0.3), 1, records, segments)[1]
    np.testing.assert_allclose(hist["stress"][0], alone["stress"][0], rtol=1e-12)


def _walk(n, accepted=0, stalled=0):
    """``judge_steps``' per-point records of n points at stage time 0 (their docstring's order)."""
    return [np.zeros(n), np.ones(n), np.ones(n), np.zeros((n, 6)), np.zeros((n, 6)), np.zeros(n), np.zeros((n, 6)),
            np.zeros(n), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
            np.broadcast_to(accepted, (n,)).astype(np.int64), np.zeros(n, dtype=np.int64), np.ones(n, dtype=bool),
            np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), np.ones(n), np.zeros((n, 6)),
            np.zeros(n), np.zeros((n, 6)), np.zeros((n, 6)), np.zeros(n),
            np.broadcast_to(stalled, (n,)).astype(np.int64)]


def _judge(walk, size, after):
    """``judge_steps`` of converged steps of ``size`` ending at ``after`` (n,) with no increments (error 0) along a
    path of 100 s; returns the walk's (accepted, going, take, dead, stalled)."""
    n = len(size)
    segments = (np.full((1, n), 100.0), np.ones((1, n)), np.full((1, n), 100.0), np.full((1, n), np.inf))
    control = (1e-6, 1e-2, 1e-2, np.inf, 4.0, 12, 8)
    zeros = np.zeros((n, 6))
    judge_steps(np.ones(n, dtype=bool), zeros, zeros, zeros, np.zeros(n), np.ones(n),
                (np.asarray(size, dtype=float), np.asarray(after, dtype=float), np.zeros(n, dtype=bool)), control,
                tuple(walk), segments)
    return walk[11], walk[13], walk[14], walk[15], walk[23]


def test_a_point_whose_steps_never_reach_the_end_of_its_path_fails_at_the_step_limit():
    """The step control (``judge_steps``) ends a point's walk as a failure once it has accepted MAX_STEPS steps short
    of its path's end (a last guard against a walk that would loop for ever): of two points one step short of the
    limit, the one whose step reaches the end finishes, the other is dead with the step limit's reason; a point
    further from the limit goes on."""
    walk = _walk(3, accepted=[MAX_STEPS - 1, MAX_STEPS - 1, MAX_STEPS - 2])
    accepted, going, take, dead, _ = _judge(walk, [1.0, 1.0, 1.0], [1.0, 100.0, 1.0])   # to tau 1, 100 (the end), 1
    assert take.all() and accepted.tolist() == [MAX_STEPS, MAX_STEPS, MAX_STEPS - 1]
    assert dead.tolist() == [True, False, False]
    assert going.tolist() == [False, False, True]
    code = loop_failure(-1, accepted[0], walk[23][0])
    assert code == STEP_LIMIT and str(MAX_STEPS) in LOOP_FAILURES[code]


def test_a_point_whose_steps_stall_fails_after_stall_steps_negligible_steps_in_a_row():
    """A response that runs away (creep rupture: the steps shrink towards an instant they never reach) fails as
    stalled at its STALL_STEPS-th accepted step in a row below NEGLIGIBLE_STEP of the path (100 s: 1e-10 s); a step
    above it resets the count, and a point with fewer such steps in a row goes on."""
    tiny = 0.5 * NEGLIGIBLE_STEP * 100.0
    walk = _walk(3, stalled=[STALL_STEPS - 1, STALL_STEPS - 1, 0])
    accepted, going, take, dead, stalled = _judge(walk, [tiny, 1.0, tiny], [tiny, 1.0, tiny])
    assert take.all() and accepted.tolist() == [1, 1, 1]
    assert dead.tolist() == [True, False, False] and going.tolist() == [False, True, True]
    assert stalled.tolist() == [STALL_STEPS, 0, 1]
    code = loop_failure(-1, accepted[0], stalled[0])
    assert code == STALLED and f"{STALL_STEPS} steps in a row" in LOOP_FAILURES[code]
    assert loop_failure(-1, accepted[1], stalled[1]) == 0 and loop_failure(3, accepted[1], stalled[1]) == 3


@pytest.mark.parametrize("compiled", [True, False])
def test_a_compression_past_the_solids_fails_where_the_void_ratio_reaches_zero(compiled):
    """ANICREEP (isotropic, rate independent) with the current specific volume, compressed isotropically from
    p' = 40 kPa: elastic to its surface's size p'_m0 (``reference_size``), then along the normal compression line;
    de = -v d eps_v with d eps_v = kappa/v dln p', then lambda/v dln p', so e = e0 - kappa ln(p'_m0/40) -
    lambda ln(p'/p'_m0), which reaches zero at p'* = p'_m0 exp((e0 - kappa ln(p'_m0/40))/lambda) (115.3 kPa for
    e0 = 0.3, lambda = 0.4, sigma'_p0 = 60 kPa: p'_m0 = 55.6 kPa): the ramp to 200 kPa fails there with the void
    ratio's reason (the compiled loop and the Python one alike) instead of going on with a negative void ratio
    (with the specific volume's compressibilities lambda/v, a compression that runs away). The records before it
    hold that e."""
    model = ANICREEP(**{**CLAY, "e0": 0.3}, sigma_p0=60.0, specific_volume="current", anisotropy=False,
                     viscous=False)
    s0 = np.full((1, 6), 40.0)
    s0[:, 3:] = 0.0
    end = s0.copy()
    end[:, :3] = 200.0
    path = labtests.LinearPath.ramp(s0, end, 160.0)
    records = np.arange(2.0, 160.0, 2.0)[:, None]                       # every 2 kPa
    hist = labtests.adaptive_control(model, s0, model.initial_state(s0), TRIAXIAL_STRESS,
                                     path if compiled else path.values, ([160.0], [1.0], [np.inf], [0.1]), records,
                                     compiled=compiled)
    assert hist["failed"].tolist() == [True]
    assert "void ratio" in hist["reasons"][0] and "beyond the solids" in hist["reasons"][0]
    p = hist["stress"][0, 1:-1, 0]
    reached = np.isfinite(p)
    pm0 = model.reference_size(1)[0]
    e_yield = 0.3 - CLAY["kappa"] * np.log(pm0 / 40.0)
    collapse = pm0 * np.exp(e_yield / 0.4)
    assert p[reached].max() < collapse < p[reached].max() + 2.0 + 1e-9     # the last record before the collapse
    e = hist["void_ratio"][0, 1:-1][reached]
    on_line = p[reached] > pm0
    np.testing.assert_allclose(e[on_line], e_yield - 0.4 * np.log(p[reached][on_line] / pm0), atol=2e-3)
