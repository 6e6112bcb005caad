"""Unit tests of the TMCMC formulas against direct computations (docs/reference.md section 2)."""
import math

import numpy as np
import pytest

T = __import__("inference.tmcmc", fromlist=["tmcmc"])


def _cov(log_like, dq):
    w = np.exp(dq * (log_like - log_like.max()))
    return w.std() / w.mean()


def test_next_exponent_hits_cov_target():
    rng = np.random.default_rng(0)
    ll = rng.normal(-50, 20, 2000)
    p1 = T.choose_next_exponent(ll, 0.0)
    assert 0 < p1 < 1
    assert _cov(ll, p1) == pytest.approx(1.0, abs=1e-6)
    p2 = T.choose_next_exponent(ll, p1)
    assert p2 > p1 and _cov(ll, p2 - p1) == pytest.approx(1.0, abs=1e-6)


def test_next_exponent_caps_at_one_and_ignores_failed_particles():
    ll = np.array([-1.0, -1.1, -0.9, -1.05])
    assert T.choose_next_exponent(ll, 0.5) == 1.0
    ll = np.concatenate([np.random.default_rng(1).normal(-30, 10, 500), np.full(20, -np.inf)])
    p = T.choose_next_exponent(ll, 0.0)
    w = np.exp(p * (ll - ll[np.isfinite(ll)].max()))
    assert w.std() / w.mean() == pytest.approx(1.0, abs=1e-6)


def test_stage_weights_and_log_S():
    rng = np.random.default_rng(2)
    ll = rng.normal(-10, 3, 100)
    ll[3] = -np.inf
    w, log_s = T.stage_weights(ll, 0.3)
    direct = np.where(np.isfinite(ll), np.exp(0.3 * ll), 0.0)
    assert log_s == pytest.approx(math.log(direct.mean()), rel=1e-12)
    np.testing.assert_allclose(w, direct / direct.sum(), rtol=1e-12)
    assert w[3] == 0.0


def test_weighted_covariance_matches_numpy():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(500, 3))
    w = rng.random(500)
    w /= w.sum()
    np.testing.assert_allclose(T.weighted_covariance(x, w), np.cov(x.T, aweights=w, bias=True), rtol=1e-10)


@pytest.mark.parametrize("method", ["systematic", "multinomial"])
def test_resampling_reproduces_weights(method):
    rng = np.random.default_rng(4)
    w = rng.random(50) ** 3
    w /= w.sum()
    counts = np.zeros(50)
    reps = 400
    for r in range(reps):
        idx = T.resample(w, np.random.default_rng(r), method)
        assert np.all(np.diff(idx) >= 0)
        counts += np.bincount(idx, minlength=50)
    freq = counts / (reps * 50)
    # Monte-Carlo error of a multinomial frequency: sqrt(w(1-w)/(reps N)); 5 sigma
    np.testing.assert_array_less(np.abs(freq - w), 5 * np.sqrt(w * (1 - w) / (reps * 50)) + 1e-12)
    if method == "systematic":  # each index appears floor(N w) or ceil(N w) times
        idx = T.resample(w, np.random.default_rng(99), method)
        c = np.bincount(idx, minlength=50)
        assert np.all((c >= np.floor(50 * w)) & (c <= np.ceil(50 * w)))


def test_de_move_statistics_and_crossover_count():
    """Eqs. (13)-(15): with the symmetric rule the mean move is zero; the number of mutated components is
    1 + Binomial(d - 1, CR) (i_rand always mutated)."""
    rng = np.random.default_rng(5)
    n, d, cr = 40000, 6, 0.9
    cur = np.zeros((n, d))
    a = rng.normal(size=(n, d))
    b = rng.normal(size=(n, d))
    lam = rng.uniform(-0.1, 0.1, n)
    cross = rng.random((n, d)) <= cr
    i_rand = rng.integers(0, d, n)
    cross[np.arange(n), i_rand] = True
    gamma = 2.38 / math.sqrt(2 * 3 * d)
    prop = T.de_proposal(cur, None, a, b, gamma, lam, np.zeros((n, d)), cross)
    moved = prop != 0
    assert moved.sum(1).mean() == pytest.approx(1 + (d - 1) * cr, abs=4 * math.sqrt((d - 1) * cr * (1 - cr) / n))
    # mutated component variance: gamma^2 E[(1+lam)^2] Var(a - b) = gamma^2 (1 + c^2/3) 2
    var = prop[moved].var()
    assert var == pytest.approx(gamma**2 * (1 + 0.01 / 3) * 2, rel=0.03)
    assert abs(prop.mean()) < 5 * math.sqrt(var / moved.sum())
    # with theta_best the move is pulled toward it
    best = np.ones(d)
    pulled = T.de_proposal(cur, best, a, b, gamma, lam, np.zeros((n, d)), np.ones((n, d), bool))
    assert pulled.mean() == pytest.approx(gamma, rel=0.05)
