"""Predictions of unseen tests (docs/reference.md section 10): the interval score (P3) on hand cases, the CRPS of a
normal mixture (P4) against the Gaussian closed form and against the integral of its definition, the model-error
amplitude (P2) on residuals of a known distribution, and the coverage of the band (P1) on data drawn from it."""
import math

import numpy as np
import pytest
from scipy import integrate, stats

import inference
from inference.prediction import (
    band_scores,
    crps_normal_mixture,
    heldout_excess,
    interval_score,
    model_error_amplitude,
    prediction_bands,
)


def test_interval_score_hand_cases():
    # level 0.9: alpha 0.1, 2/alpha = 20; [1, 3] has width 2
    lower, upper = np.array([1.0, 1.0, 1.0]), np.array([3.0, 3.0, 3.0])
    observed = np.array([2.0, 0.5, 3.25])
    assert interval_score(lower, upper, observed, level=0.9) == pytest.approx([2.0, 2.0 + 20 * 0.5, 2.0 + 20 * 0.25])
    # on the bounds the observation is inside: no penalty
    assert interval_score([1.0], [3.0], [1.0], level=0.95) == pytest.approx([2.0])


def test_crps_of_one_gaussian_is_the_closed_form():
    # CRPS(N(mu, s^2), y) = s [z (2 Phi(z) - 1) + 2 phi(z) - 1/sqrt(pi)], z = (y - mu)/s (Gneiting & Raftery 2007)
    mu, s = 2.0, 0.5
    y = np.array([2.0, 2.3, 0.7, 5.0])
    z = (y - mu) / s
    closed = s * (z * (2 * stats.norm.cdf(z) - 1) + 2 * stats.norm.pdf(z) - 1 / math.sqrt(math.pi))
    got = crps_normal_mixture(y, np.full((1, y.size), mu), np.full((1, y.size), s))
    assert got == pytest.approx(closed, rel=1e-12)
    # at y = mu, sd 1: (sqrt 2 - 1)/sqrt(pi)
    assert crps_normal_mixture([0.0], [[0.0]], [[1.0]])[0] == pytest.approx((math.sqrt(2) - 1) / math.sqrt(math.pi))


def test_crps_of_a_mixture_is_the_integral_of_its_definition():
    # CRPS(F, y) = integral of (F(x) - 1{x >= y})^2 dx, by quadrature of the mixture's CDF
    means = np.array([0.0, 1.5, -0.7])
    sds = np.array([0.4, 1.0, 0.25])
    for y in (-1.0, 0.2, 3.0):
        def cdf(x):
            return stats.norm.cdf((x - means) / sds).mean()

        left = integrate.quad(lambda x: cdf(x) ** 2, -20.0, y, limit=200)[0]
        right = integrate.quad(lambda x: (1.0 - cdf(x)) ** 2, y, 20.0, limit=200)[0]
        got = crps_normal_mixture([y], means[:, None], sds[:, None])[0]
        assert got == pytest.approx(left + right, rel=1e-8)


def test_model_error_amplitude_on_residuals_of_known_variance():
    # held-out curves r = delta + eps: delta one N(0, a^2) offset per curve, eps N(0, s^2) per point; (P2) subtracts
    # s^2 from the mean square: E[estimate^2] = a^2; its standard error from the chi-square of the offsets
    rng = np.random.default_rng(5)
    a, s, curves, points = 0.06, 0.02, 400, 50
    excess = [heldout_excess(rng.normal(0.0, a) + rng.normal(0.0, s, points), s * s, 0.0) for _ in range(curves)]
    got = model_error_amplitude(excess)
    se = math.sqrt(2.0 / curves) * (a * a + s * s / points)
    assert abs(got**2 - a * a) < 4 * se
    # residuals the noise and the parameters' spread explain: no model error
    assert model_error_amplitude([heldout_excess(rng.normal(0.0, s, 10000), s * s, 0.5 * s * s)]) == 0.0
    with pytest.raises(ValueError):
        model_error_amplitude([])


def test_model_error_amplitude_of_a_change_from_the_initial_state():
    # a void ratio from e0 = 0.9 falling to 0.8: records e_num + delta (e_num - e0) + eps e_num with delta one
    # N(0, a^2) per curve and 0.1 % noise; the relative residuals' scatter grows with the change. The change form
    # recovers a (standard error from the chi-square of the offsets); the value form, relative to e, finds an
    # amplitude near a times the mean change over e, far below a, and NaN points (below the floor) are left out
    rng = np.random.default_rng(7)
    a, s, e0, curves = 0.1, 0.001, 0.9, 400
    e_num = np.linspace(e0, 0.8, 60)
    change, value = [], []
    for _ in range(curves):
        e_obs = e_num + rng.normal(0.0, a) * (e_num - e0) + rng.normal(0.0, s, e_num.size) * e_num
        r = (e_obs - e_num) / e_obs
        r[0] = np.nan
        change.append(heldout_excess(r, s * s, 0.0, e_num, e0))
        value.append(heldout_excess(r, s * s, 0.0))
    got = model_error_amplitude(change)
    assert abs(got**2 - a * a) < 4 * math.sqrt(2.0 / curves) * a * a
    assert model_error_amplitude(value) < 0.6 * a
    with pytest.raises(ValueError):
        heldout_excess(np.full(3, 0.01), s * s, 0.0, np.full(3, e0), e0)


def _one_curve_likelihood(x, y):
    obs = inference.Observations([inference.Test("held_out", {"q": inference.Curve(x, y, "eps_a", "q", "pct", "kPa")})])
    return inference.Likelihood(obs, lambda params: {"held_out": {"q": y}}, sigma="sigma_eps", floor=0.0)


def test_band_with_model_error_covers_data_drawn_from_it():
    # a new curve's records drawn from (P1): U = U_s (1 + delta + eps) with U_s one of the draws; the 95 % band holds
    # about 95 % of them (binomial tolerance), the noise-only band far fewer
    rng = np.random.default_rng(11)
    n_s, n = 200, 4000
    x = np.linspace(0.1, 10.0, n)
    truth = 100.0 + 20.0 * np.sqrt(x)
    draws = truth * (1.0 + 0.01 * rng.standard_normal((n_s, 1)))       # parameter uncertainty: 1 %
    sigma = np.full(n_s, 0.02)                                         # noise 2 %
    a = 0.08                                                           # model error 8 % (independent per point here)
    pick = rng.integers(0, n_s, n)
    y = draws[pick, np.arange(n)] * (1.0 + a * rng.standard_normal(n) + 0.02 * rng.standard_normal(n))
    like = _one_curve_likelihood(x, y)
    sims = {("held_out", "q"): draws}
    with_error = prediction_bands(like, sims, sigma, {"q": a})[("held_out", "q")]
    noise_only = prediction_bands(like, sims, sigma, {})[("held_out", "q")]
    tolerance = 4 * math.sqrt(0.95 * 0.05 / n)
    assert abs(with_error.coverage - 0.95) < tolerance
    assert noise_only.coverage < 0.6
    used = np.ones(n, bool)
    sd = np.abs(draws) * math.sqrt(0.02**2 + a**2)
    scores = band_scores(with_error, draws, sd, used)
    assert scores["coverage"] == pytest.approx(with_error.coverage)
    assert scores["mean_width"] == pytest.approx(np.mean(with_error.upper - with_error.lower))
    # the width of a normal's 95 % band is 2 x 1.96 sd; the mixture's is close to it for 1 % parameter spread
    assert scores["relative_width"] == pytest.approx(2 * 1.96 * math.sqrt(0.01**2 + 0.02**2 + a**2), rel=0.05)


def test_band_of_a_change_covers_data_drawn_from_it_and_narrows_at_the_start():
    # a void-ratio curve from e0 = 0.9: records e_s + a (e_s - e0) delta + 0.1 % e_s eps; the band of the change form
    # holds about 95 % of them and is as narrow as the noise's where e is still at e0, the band relative to e
    # (the same amplitude) as wide there as anywhere
    rng = np.random.default_rng(13)
    n_s, n, e0, a = 200, 4000, 0.9, 0.1
    x = np.linspace(0.0, 20.0, n)
    draws = e0 - 0.1 * (1.0 - np.exp(-x / 5.0)) * (1.0 + 0.02 * rng.standard_normal((n_s, 1)))
    sigma = np.full(n_s, 0.001)
    pick = draws[rng.integers(0, n_s, n), np.arange(n)]
    y = pick + a * (pick - e0) * rng.standard_normal(n) + 0.001 * pick * rng.standard_normal(n)
    obs = inference.Observations([inference.Test("held_out", {"e": inference.Curve(x, y, "eps_a", "e", "pct", "-")})])
    like = inference.Likelihood(obs, lambda params: {"held_out": {"e": y}}, sigma="sigma_eps", floor=0.0)
    sims = {("held_out", "e"): draws}
    change = prediction_bands(like, sims, sigma, {"e": a}, {("held_out", "e"): e0})[("held_out", "e")]
    value = prediction_bands(like, sims, sigma, {"e": a})[("held_out", "e")]
    assert abs(change.coverage - 0.95) < 4 * math.sqrt(0.95 * 0.05 / n)
    start = x < 0.05
    assert np.all(change.upper[start] - change.lower[start] < 2 * 1.96 * 0.0012 * e0)
    assert np.all(value.upper[start] - value.lower[start] > 2 * 1.96 * 0.09 * e0)
