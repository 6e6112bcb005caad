"""Predictions of unseen tests (docs/reference.md section 10): the interval score (P3) on hand cases, the CRPS of a
normal mixture (P4) against the Gaussian closed form and against the integral of its definition, the model-error
amplitude (P2) on residuals of a known distribution and a known growth with distance, the distance between tests'
conditions (Gower-scaled) by hand, and the coverage of the band (P1) on data drawn from it."""
import math

import numpy as np
import pytest
from scipy import integrate, stats

import inference
from inference.prediction import (
    ModelError,
    StateSpace,
    band_scores,
    crps_normal_mixture,
    interval_score,
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
    # s^2 from the mean square: E[estimate^2] = a^2; its standard error from the chi-square of the offsets. Every
    # left-out test at the same distance 1: a_k there is the estimate, at distance 0.25 half of it (a^2 linear in d)
    rng = np.random.default_rng(5)
    a, s, curves, points = 0.06, 0.02, 400, 50
    terms = [(rng.normal(0.0, a) + rng.normal(0.0, s, points), s * s, 1.0) for _ in range(curves)]
    error = ModelError.from_held_out({"q": terms})
    se = math.sqrt(2.0 / curves) * (a * a + s * s / points)
    assert abs(error.amplitude("q", 1.0) ** 2 - a * a) < 4 * se
    assert error.amplitude("q", 0.25) == pytest.approx(0.5 * error.amplitude("q", 1.0), rel=1e-12)
    assert error.amplitude("e", 1.0) == 0.0                   # a quantity no left-out test recorded
    # residuals the noise explains: no model error
    assert ModelError.from_held_out({"q": [(rng.normal(0.0, s, 10000), s * s * 1.5, 1.0)]}).amplitude("q", 2.0) == 0.0
    with pytest.raises(ValueError):
        ModelError.from_held_out({"q": []})


def test_model_error_grows_linearly_with_distance():
    # left-out tests at distances 0.5, 1 and 2 whose offsets have variance c d (a linear variogram, c = 0.004):
    # the pooled estimate gives a^2(d) = c d at any d, E[sum excess] / sum d = c; standard error from the offsets'
    # chi-square, sum over curves of 2 (c d_i)^2, divided by sum d
    rng = np.random.default_rng(8)
    c, s, points = 0.004, 0.01, 40
    d = np.repeat([0.5, 1.0, 2.0], 300)
    terms = [(rng.normal(0.0, math.sqrt(c * di)) + rng.normal(0.0, s, points), s * s, di) for di in d]
    error = ModelError.from_held_out({"q": terms})
    se = math.sqrt(np.sum(2.0 * (c * d + s * s / points) ** 2)) / d.sum()
    for at in (0.1, 1.0, 3.0):
        assert abs(error.amplitude("q", at) ** 2 / at - c) < 4 * se
    # left-out tests that each had a test in their own conditions: the amplitude does not depend on distance
    same = ModelError.from_held_out({"q": [(r, v, 0.0) for r, v, _ in terms]})
    assert same.amplitude("q", 0.0) == same.amplitude("q", 5.0) > 0.0


def test_distance_between_test_conditions_by_hand():
    # numbers scaled by their range over the tests (e0: 0.2, ln p0: ln 4), texts 0/1, a feature of one test only 1
    space = StateSpace({"A": {"e0": 0.8, "ln p0": math.log(100.0), "drainage": "drained"},
                        "B": {"e0": 1.0, "ln p0": math.log(400.0), "drainage": "drained"},
                        "C": {"e0": 0.9, "ln p0": math.log(100.0), "drainage": "undrained", "ln ocr": math.log(2.0)}})
    assert space.distance("A", "B") == pytest.approx(math.sqrt(1.0 + 1.0))
    assert space.distance("A", "C") == pytest.approx(math.sqrt(0.25 + 0.0 + 1.0 + 1.0))
    assert space.distance("B", "C") == pytest.approx(math.sqrt(0.25 + 1.0 + 1.0 + 1.0))
    assert space.distance("A", "A") == 0.0
    assert space.nearest("C", ["A", "B"]) == pytest.approx(1.5)
    # a feature equal in every test carries no distance
    flat = StateSpace({"A": {"e0": 0.8, "rate": -11.0}, "B": {"e0": 0.9, "rate": -11.0}})
    assert flat.distance("A", "B") == pytest.approx(1.0)


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
    with_error = prediction_bands(like, sims, sigma, {("held_out", "q"): a})[("held_out", "q")]
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
