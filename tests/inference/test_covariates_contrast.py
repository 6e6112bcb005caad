"""The few-test contrast of inference.diagnosis.attribution (a between-test covariate with fewer than 5 tests, e.g. the
two-rate SBP): false-alarm rate on white and AR(1) residuals, power on a planted contrast, direction, and no change with
5 or more tests."""
import math

import numpy as np
import pytest
from scipy import stats

from inference.diagnosis import attribute
from inference.diagnosis.attribution import MIN_PERMUTATION_TESTS

N = 40
SIGMA = 0.02
RATES = (1.67e-3, 1.85e-4)  # fast, slow (1/s)


def ar1(rng, n, phi, size=()):
    """Stationary AR(1) noise with marginal standard deviation SIGMA."""
    e = rng.normal(0.0, SIGMA, size + (n,))
    x = np.empty_like(e)
    x[..., 0] = e[..., 0]
    for i in range(1, n):
        x[..., i] = phi * x[..., i - 1] + np.sqrt(1.0 - phi**2) * e[..., i]
    return x


def rate_attribution(residuals, rates=RATES):
    tests = sorted({t for t, _ in residuals})
    (a,) = attribute(residuals, {"strain rate": dict(zip(tests, rates))})
    return a


def two_tests(rng, phi, shift=0.0, shape=None, curves=("cavity_pressure",)):
    """Residuals of a fast and a slow test, the fast one offset by ``shift`` (times the common ``shape``)."""
    out = {}
    for c in curves:
        common = np.zeros(N) if shape is None else shape
        out["fast", c] = common + shift + ar1(rng, N, phi)
        out["slow", c] = common + ar1(rng, N, phi)
    return out


@pytest.mark.parametrize("phi", [0.0, 0.3, 0.5])
def test_false_alarm_rate_close_to_nominal(phi):
    """Pure noise (white, AR(1) phi 0.3 and 0.5), 2 tests x 40 points, 1000 simulated pairs: rate at alpha 0.05 at
    most 0.07 (binomial SE 0.007; measured over 3000 pairs: 0.036, 0.047, 0.057, inference.diagnosis.attribution
    docstring), and not absurdly conservative."""
    rng = np.random.default_rng(2024)
    p = np.array([rate_attribution(two_tests(rng, phi)).p_value for _ in range(1000)])
    rate = np.mean(p <= 0.05)
    assert 0.02 <= rate <= 0.07, rate


def test_false_alarm_with_a_common_structured_misfit():
    """A misfit shared by both tests (a 3-sigma bump and a trend: wrong shape, not a rate effect) cancels in the
    paired contrast: the false-alarm rate stays nominal although every curve is structured."""
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 1.0, N)
    shape = 3 * SIGMA * np.exp(-((x - 0.6) / 0.1) ** 2) + 2 * SIGMA * x
    p = np.array([rate_attribution(two_tests(rng, 0.3, shape=shape)).p_value for _ in range(600)])
    assert np.mean(p <= 0.05) <= 0.07


@pytest.mark.parametrize("phi, shift", [(0.0, 1.0), (0.5, 2.5)])
def test_power_and_direction_on_a_planted_contrast(phi, shift):
    """Fast test recorded ``shift`` sigma above (or below) the slow one, white or AR(1) phi 0.5 noise: significant
    (p <= 0.05) in >= 90 % of 200 pairs (measured over 1000: 1 sigma white 0.98, 2 sigma AR(1) 0.5 0.90),
    z > 0 (the residual rises with the rate) and its sign is that of the Spearman correlation rate-residual pooled
    over the points (how inference.diagnosis.rank measures an item's direction); the reversed contrast gives z < 0."""
    rng = np.random.default_rng(11)
    hits = 0
    for k in range(200):
        sign = 1.0 if k % 2 == 0 else -1.0
        res = two_tests(rng, phi, shift=sign * shift * SIGMA)
        a = rate_attribution(res)
        z = a.contrast["cavity_pressure"]["z"]
        rho = stats.spearmanr(np.repeat(RATES, N), np.concatenate([res["fast", "cavity_pressure"],
                                                                    res["slow", "cavity_pressure"]]))[0]
        if a.p_value <= 0.05:
            hits += 1
            assert np.sign(z) == sign == np.sign(rho)
    assert hits >= 180, hits


def test_power_on_a_trend_growing_along_the_curve():
    """The SBP pattern: the fast test rises above the slow one towards the end of the curve (0 -> 3 sigma), AR(1)
    phi 0.3: p <= 0.05 in >= 90 % of 100 pairs (measured over 1000: 0.98)."""
    rng = np.random.default_rng(5)
    grow = 3 * SIGMA * np.linspace(0.0, 1.0, N)
    p = np.array([rate_attribution(two_tests(rng, 0.3, shift=grow)).p_value for _ in range(100)])
    assert np.mean(p <= 0.05) >= 0.9


def test_three_and_four_tests_use_the_rank_trend():
    """3 and 4 tests: contrast applies (p can be small), with z > 0 for a residual rising with the level and the
    curve names combined by Bonferroni."""
    rng = np.random.default_rng(3)
    for k in (3, 4):
        rates = 10.0 ** -np.arange(k)                 # decreasing rates
        res = {}
        for j, r in enumerate(rates):
            for c in ("q", "u"):
                res[f"T{j}", c] = SIGMA * (k - j) + ar1(rng, N, 0.3)  # faster -> larger residual, both curves
        (a,) = attribute(res, {"rate": {f"T{j}": r for j, r in enumerate(rates)}})
        assert a.contrast is not None and set(a.contrast) == {"q", "u"}
        assert all(d["z"] > 0 for d in a.contrast.values())
        assert a.p_value == pytest.approx(min(1.0, 2 * min(d["p"] for d in a.contrast.values())))
        assert a.p_value < 1e-3
        assert f"over {k} tests" in a.null


def test_five_or_more_tests_keep_the_permutation_null():
    rng = np.random.default_rng(1)
    for k in (MIN_PERMUTATION_TESTS, 6):
        res = {(f"T{j}", "q"): SIGMA * j + ar1(rng, N, 0.0) for j in range(k)}
        (a,) = attribute(res, {"rate": {f"T{j}": float(j) for j in range(k)}})
        assert a.contrast is None and "permutations" in a.null
        assert a.p_value == pytest.approx(2 / math.factorial(k))


def test_contrast_does_not_apply_without_a_common_abscissa_or_two_levels():
    """Curves of different lengths without abscissae (no pairing by index), or one level: the permutation null
    (p = 1 with 2 tests) and no contrast. A categorical condition gets the level contrast (z > 0: the level later in
    sorted order, "load", above "hold")."""
    rng = np.random.default_rng(0)
    res = {("fast", "q"): SIGMA + ar1(rng, N, 0.0), ("slow", "q"): ar1(rng, N - 5, 0.0)}
    a = rate_attribution(res)
    assert a.contrast is None and a.p_value == 1.0
    res = two_tests(rng, 0.0, shift=3 * SIGMA)
    (a,) = attribute(res, {"phase": {"fast": "load", "slow": "hold"}})
    assert a.contrast["cavity_pressure"]["levels"] == ["hold", "load"] and a.contrast["cavity_pressure"]["z"] > 0
    assert a.p_value < 1e-3
    (a,) = attribute(res, {"rate": {"fast": 1.0, "slow": 1.0}})
    assert a.contrast is None


def test_nan_points_are_dropped_pairwise():
    rng = np.random.default_rng(9)
    res = two_tests(rng, 0.0, shift=SIGMA)
    res["fast", "cavity_pressure"][:5] = np.nan
    a = rate_attribution(res)
    assert a.contrast["cavity_pressure"]["points"] == N - 5
    assert a.to_dict()["contrast"]["cavity_pressure"]["z"] > 0
