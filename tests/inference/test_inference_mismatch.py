"""Residual screening (inference.diagnosis): predictive bands, structure tests, regions, covariate attribution.

False-alarm rates are checked by Monte Carlo against the nominal alpha (or the exact attained size of a discrete
test) with a tolerance of 4 binomial standard errors sqrt(a(1-a)/reps); the slow tests repeat with 10x more draws.
"""
import itertools
import json
import math

import numpy as np
import pytest
from scipy import stats

from inference import Curve, Likelihood, Observations, Test
from inference.diagnosis import (
    attribute,
    holm,
    lag1_test,
    predictive_bands,
    relative_residuals,
    runs_test,
    scale_test,
    scan_test,
    screen,
    segment,
)
from inference.diagnosis.structure import SCAN_DRAWS

ALPHA = 0.05


def _tol(rate, reps):
    return 4.0 * math.sqrt(rate * (1 - rate) / reps)


def _likelihood(sim, obs, x, sigma=0.02):
    """One test per key (test, curve) of sim/obs, curves on the abscissa x."""
    tests = {}
    for (t, c), y in obs.items():
        tests.setdefault(t, {})[c] = Curve(x, y)
    return Likelihood(Observations([Test(t, cs) for t, cs in tests.items()]), lambda p: {}, sigma=sigma)


def _synthetic(rng, n_tests=5, n=100, sigma=0.02, planted=None):
    """Base-model curves and recordings U_obs = U_sim (1 + eps (+ planted relative misfit))."""
    x = np.linspace(0.1, 10.0, n)
    sim = {(f"T{j}", "q"): 100.0 * (1 - np.exp(-x / (1.5 + j))) for j in range(n_tests)}
    obs = {}
    for k, v in sim.items():
        rel = sigma * rng.standard_normal(n) + (planted(k, x) if planted else 0.0)
        obs[k] = v * (1 + rel)
    return x, sim, obs


# ------------------------------------------------------------------ runs test: exact law against enumeration
def _runs_counts(n):
    """counts[n1, R]: number of sign sequences of length n with n1 positives and R runs (dynamic programming)."""
    counts = np.zeros((n + 1, n + 2, 2))  # positives so far, runs so far, last sign
    counts[1, 1, 1] = counts[0, 1, 0] = 1
    for _ in range(n - 1):
        new = np.zeros_like(counts)
        new[1:, :, 1] += counts[:-1, :, 1]            # + after +: same run
        new[1:, 1:, 1] += counts[:-1, :-1, 0]         # + after -: new run
        new[:, :, 0] += counts[:, :, 0]
        new[:, 1:, 0] += counts[:, :-1, 1]
        counts = new
    return counts.sum(axis=2)


def test_runs_p_value_equals_enumeration_over_all_sequences():
    n = 12
    for bits in itertools.product((0, 1), repeat=n):
        if bits[0] or sum(bits) not in (5, 6):  # a slice of all sequences is enough and keeps this fast
            continue
        s = np.where(np.array(bits) == 1, 1.0, -1.0)
        n1 = int(np.sum(s > 0))
        runs = 1 + int(np.sum(s[1:] != s[:-1]))
        same = [b for b in itertools.product((0, 1), repeat=n) if sum(b) == n1]
        n_runs = np.array([1 + sum(b[i] != b[i + 1] for i in range(n - 1)) for b in same])
        assert runs_test(s)[0] == runs
        assert runs_test(s)[2] == pytest.approx(np.mean(n_runs <= runs), rel=1e-12)
        if runs > 6:
            break


@pytest.mark.parametrize("n, reps", [(20, 1500), (50, 1500), (200, 1000),
                                     pytest.param(20, 20000, marks=pytest.mark.slow),
                                     pytest.param(50, 20000, marks=pytest.mark.slow),
                                     pytest.param(200, 20000, marks=pytest.mark.slow)])
def test_runs_false_alarm_equals_exact_size(n, reps):
    """Realized rate on iid normal residuals = the exact attained size (enumeration by dynamic programming) <= alpha."""
    counts = _runs_counts(n)
    size = 0.0
    for n1 in range(1, n):
        pmf = counts[n1] / counts[n1].sum()
        reject = np.cumsum(pmf) <= ALPHA + 1e-12
        size += stats.binom.pmf(n1, n, 0.5) * pmf[reject].sum()
    assert size <= ALPHA
    rng = np.random.default_rng(n)
    rate = np.mean([runs_test(rng.standard_normal(n))[2] <= ALPHA for _ in range(reps)])
    assert abs(rate - size) <= _tol(size, reps), (rate, size)


# ------------------------------------------------------------------ lag-1, scale, scan: size and power
def _false_alarm(test, n, reps, seed):
    rng = np.random.default_rng(seed)
    return np.mean([test(rng.standard_normal(n)) <= ALPHA for _ in range(reps)])


TESTS = {
    "lag1": lambda r: lag1_test(r)[1],
    "scale": lambda r: scale_test(r, 1.0)[2],
    "scan": lambda r: scan_test(r, 1.0)[2],
}


@pytest.mark.parametrize("name", sorted(TESTS))
@pytest.mark.parametrize("n", [20, 60, 200])
def test_false_alarm_rate_is_nominal(name, n):
    reps = 1500
    rate = _false_alarm(TESTS[name], n, reps, seed=7 + n)
    assert abs(rate - ALPHA) <= _size_tol(name, reps), rate


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TESTS))
@pytest.mark.parametrize("n", [20, 60, 200])
def test_false_alarm_rate_is_nominal_many(name, n):
    reps = 20000
    rate = _false_alarm(TESTS[name], n, reps, seed=1000 + n)
    assert abs(rate - ALPHA) <= _size_tol(name, reps), rate


def _size_tol(name, reps):
    """4 standard errors of the realized rate; the scan test's fixed Monte Carlo null table (SCAN_DRAWS draws) adds its
    own error to the size it attains: variance alpha(1-alpha)/SCAN_DRAWS."""
    extra = 1.0 / SCAN_DRAWS if name == "scan" else 0.0
    return 4.0 * math.sqrt(ALPHA * (1 - ALPHA) * (1.0 / reps + extra))


def _structured(kind, n, rng):
    t = np.linspace(0.0, 1.0, n)
    shape = 2.0 * np.exp(-0.5 * ((t - 0.5) / 0.1) ** 2) if kind == "bump" else 2.0 * t
    return shape + rng.standard_normal(n)


@pytest.mark.parametrize("kind, detector", [("bump", "scan"), ("trend", "scan"), ("trend", "lag1"),
                                            ("trend", "scale")])
def test_power_on_two_sigma_structure(kind, detector):
    """A smooth bump of peak 2 sigma (width 0.1 of the curve) or a trend 0 -> 2 sigma, 100 points: power >= 0.9."""
    rng = np.random.default_rng(3)
    power = np.mean([TESTS[detector](_structured(kind, 100, rng)) <= ALPHA for _ in range(200)])
    assert power >= 0.9, power


def test_holm_adjustment_by_hand():
    # sorted p (0.01, 0.02, 0.03, 0.2) -> 4*0.01, 3*0.02, 2*0.03, max(1*0.2, previous)
    np.testing.assert_allclose(holm([0.03, 0.2, 0.01, 0.02]), [0.06, 0.2, 0.04, 0.06])


@pytest.mark.parametrize("reps", [800, pytest.param(10000, marks=pytest.mark.slow)])
def test_fitted_residuals_keep_the_false_alarm_rate_below_alpha(reps):
    """Residuals of a least-squares quadratic fit (p = 3, what a calibration does to the noise): every test's
    realized false-alarm rate stays <= alpha within sampling error (fitting makes the one-sided tests conservative)."""
    rng = np.random.default_rng(11)
    n = 40
    t = np.linspace(-1, 1, n)
    basis = np.column_stack([np.ones(n), t, t * t])
    hat = basis @ np.linalg.pinv(basis)
    rates = {name: 0 for name in ("runs", "lag1", "scale", "scan")}
    for _ in range(reps):
        r = rng.standard_normal(n)
        r = r - hat @ r
        s = math.sqrt(np.mean(r * r))  # sigma fitted to the same residuals too
        rates["runs"] += runs_test(r)[2] <= ALPHA
        rates["lag1"] += lag1_test(r)[1] <= ALPHA
        rates["scale"] += scale_test(r, s)[2] <= ALPHA
        rates["scan"] += scan_test(r, s)[2] <= ALPHA
    for name, k in rates.items():
        assert k / reps <= ALPHA + _tol(ALPHA, reps), (name, k / reps)


# ------------------------------------------------------------------ regions
def test_planted_regions_are_recovered_within_a_few_points():
    """Two rectangles of +/- 2 sigma over 20 points each in a 120-point curve, 40 noise seeds."""
    errors, found_both = [], 0
    for seed in range(40):
        rng = np.random.default_rng(seed)
        r = rng.standard_normal(120)
        r[30:50] += 2.0
        r[80:100] -= 2.0
        regions = segment("T", "q", np.arange(120.0), 0.02 * r, 0.02, alpha=ALPHA, family_size=4)
        plus = [g for g in regions if g.sign == "+"]
        minus = [g for g in regions if g.sign == "-"]
        if plus and minus:
            found_both += 1
            errors += [abs(plus[0].i_start - 30), abs(plus[0].i_stop - 50), abs(minus[0].i_start - 80),
                       abs(minus[0].i_stop - 100)]
            assert plus[0].mean_relative == pytest.approx(0.04, abs=0.015)
            assert minus[0].x_start == minus[0].i_start  # abscissa = index here
    assert found_both >= 38
    assert np.median(errors) <= 1 and np.quantile(errors, 0.9) <= 4, (np.median(errors), np.quantile(errors, 0.9))


# ------------------------------------------------------------------ predictive bands
def test_band_of_one_sample_is_the_normal_quantile():
    rng = np.random.default_rng(0)
    x, sim, obs = _synthetic(rng, n_tests=2, n=30)
    like = _likelihood(sim, obs, x)
    bands = predictive_bands(like, {k: v[None, :] for k, v in sim.items()}, 0.02, level=0.9)
    z = stats.norm.ppf(0.95)
    for k, v in sim.items():
        np.testing.assert_allclose(bands[k].upper, v * (1 + z * 0.02), rtol=1e-9)
        np.testing.assert_allclose(bands[k].lower, v * (1 - z * 0.02), rtol=1e-9)


def test_band_of_a_mixture_solves_the_mixture_cdf_and_covers_replicates():
    rng = np.random.default_rng(1)
    x, sim, obs = _synthetic(rng, n_tests=3, n=80)
    n_s = 50
    samples = {k: v[None, :] * (1 + 0.03 * rng.standard_normal((n_s, 1))) for k, v in sim.items()}
    sigmas = 0.02 * np.exp(0.2 * rng.standard_normal(n_s))
    # recordings drawn from the predictive itself: pick a sample per point, then multiply by (1 + eps)
    pick = rng.integers(0, n_s, 80)
    obs = {k: s[pick, np.arange(80)] * (1 + sigmas[pick] * rng.standard_normal(80)) for k, s in samples.items()}
    like = _likelihood(sim, obs, x)
    bands = predictive_bands(like, samples, sigmas, level=0.9)
    n_in = 0
    for k, s in samples.items():
        b = bands[k]
        for q, u in ((0.05, b.lower), (0.95, b.upper)):  # independent evaluation of the mixture CDF with scipy
            cdf = stats.norm.cdf(u[None, :], loc=s, scale=np.abs(s) * sigmas[:, None]).mean(axis=0)
            np.testing.assert_allclose(cdf, q, atol=1e-8)
        n_in += np.sum(~b.outside)
    assert abs(n_in / 240 - 0.9) <= 4 * math.sqrt(0.09 / 240)


# ------------------------------------------------------------------ covariate attribution
def _smooth_random(rng, x):
    return np.sin(2 * np.pi * (rng.uniform(0.3, 1.5) * x / x.max() + rng.uniform()))


def test_planted_covariate_is_attributed_and_an_independent_one_is_not():
    """r = 2 sigma g(A) + noise with A = p'-like covariate that differs between tests; B smooth and independent."""
    false_b, top_a = 0, 0
    seeds = 20
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        x = np.linspace(0.0, 1.0, 60)
        a = {(f"T{j}", "q"): (1 + j) * (1 - np.exp(-3 * x)) for j in range(5)}     # grows at test-specific levels
        b = {k: _smooth_random(rng, x) for k in a}
        g = {k: np.tanh(v - 2.5) for k, v in a.items()}
        res = {k: 0.02 * (2.0 * g[k] + rng.standard_normal(60)) for k in a}
        ranking = attribute(res, {"A": a, "B": b}, n_shifts=500, seed=seed)
        by = {r.name: r for r in ranking}
        top_a += ranking[0].name == "A" and by["A"].p_value <= 0.01
        false_b += by["B"].p_value <= ALPHA
    assert top_a == seeds
    assert false_b / seeds <= ALPHA + _tol(ALPHA, seeds), false_b


def test_between_test_covariate_is_attributed_by_permutation_of_tests():
    """Residual offset growing with each test's (log) strain rate; the confining pressure is unrelated."""
    rng = np.random.default_rng(5)
    rates = {f"T{j}": 10.0 ** (j - 3) for j in range(6)}
    pressure = dict(zip(rates, rng.permutation([50.0, 100.0, 200.0, 400.0, 800.0, 1600.0])))
    res = {(t, c): 0.02 * (1.5 * math.log10(rates[t]) / 3 + rng.standard_normal(40))
           for t in rates for c in ("q", "u")}
    ranking = attribute(res, {"rate": rates, "p0": pressure})
    by = {r.name: r for r in ranking}
    assert ranking[0].name == "rate" and by["rate"].kind == "between"
    assert by["rate"].p_value <= 2 / 720 and "720 permutations" in by["rate"].null
    assert by["p0"].r2 < by["rate"].r2


def test_categorical_phase_covariate():
    rng = np.random.default_rng(2)
    x = np.linspace(0, 1, 90)
    phase = np.where(x < 0.5, "load", np.where(x < 0.7, "hold", "unload"))
    res = {(f"T{j}", "p"): 0.02 * (np.where(phase == "hold", 2.0, 0.0) + rng.standard_normal(90)) for j in range(3)}
    ranking = attribute(res, {"phase": {t: phase for t in ("T0", "T1", "T2")}}, n_shifts=500)
    assert ranking[0].r2 > 0.3 and ranking[0].p_value <= 0.01


# ------------------------------------------------------------------ screen: negative controls, misses, report
def _fit_sigma(sim, obs):
    r = np.concatenate([obs[k] / sim[k] - 1 for k in sim])
    return float(np.sqrt(np.mean(r * r)))


def _screen_rates(seeds, planted):
    alarms = 0
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        x, sim, obs = _synthetic(rng, planted=planted)
        report = screen(_likelihood(sim, obs, x), sim, _fit_sigma(sim, obs), alpha=ALPHA)
        alarms += report.verdict == "structured mismatch"
        if report.regions:  # a region is only ever reported with a structured verdict
            assert report.verdict == "structured mismatch"
    return alarms / seeds


def test_negative_control_base_model_plus_noise():
    """Data = base model x (1 + noise), sigma_eps fitted: false alarms over seeds <= alpha within sampling error."""
    seeds = 60
    assert _screen_rates(seeds, None) <= ALPHA + _tol(ALPHA, seeds)


@pytest.mark.slow
def test_negative_control_many_seeds():
    seeds = 600
    assert _screen_rates(seeds, None) <= ALPHA + _tol(ALPHA, seeds)


def test_planted_bump_is_not_missed():
    """A 2.5-sigma smooth bump in one of five curves (20 tests in the Holm family): missed in < 10 % of seeds."""
    def bump(k, x):
        return 0.05 * np.exp(-0.5 * ((x - 5.0) / 0.7) ** 2) if k[0] == "T2" else 0.0
    assert _screen_rates(30, bump) >= 0.9


def test_report_serializes_and_reads():
    rng = np.random.default_rng(4)
    x, sim, obs = _synthetic(rng, planted=lambda k, x: 0.06 * (x > 6) * (k[0] == "T1"))
    like = _likelihood(sim, obs, x)
    samples = {k: v[None, :] * (1 + 0.003 * rng.standard_normal((40, 1))) for k, v in sim.items()}
    report = screen(like, sim, 0.02, samples, 0.02, covariates={"strain": {k: x for k in sim}})
    data = json.loads(report.to_json())
    assert data["verdict"] == "structured mismatch" and data["family_size"] == 20
    region = data["regions"][0]
    assert region["test"] == "T1" and region["sign"] == "+" and abs(region["x_start"] - 6.0) < 0.5
    assert {c["test"] for c in data["curves"] if c["structured"]} == {"T1"}
    text = report.to_markdown()
    assert "structured mismatch" in text and "recorded above simulated" in text and "position along curve" in text


def test_residuals_follow_eq_1_and_respect_the_floor():
    x = np.array([0.0, 1.0, 2.0])
    like = _likelihood({}, {("T", "q"): np.array([0.0, 11.0, 18.0])}, x)
    r = relative_residuals(like, {("T", "q"): np.array([0.0, 10.0, 20.0])})["T", "q"]
    assert np.isnan(r[0]) and r[1] == pytest.approx(0.1) and r[2] == pytest.approx(-0.1)


def test_bad_input_names_the_field():
    rng = np.random.default_rng(0)
    x, sim, obs = _synthetic(rng, n_tests=2, n=10)
    like = _likelihood(sim, obs, x)
    res = relative_residuals(like, sim)
    with pytest.raises(ValueError, match="covariate 'rate', test T0, curve q: 3 values for 10 points"):
        attribute(res, {"rate": {("T0", "q"): np.ones(3)}})
    with pytest.raises(ValueError, match="unknown test 'T9'"):
        attribute(res, {"rate": {"T9": 1.0}})
    with pytest.raises(ValueError, match="sigma_eps = -1"):
        screen(like, sim, -1.0)
    with pytest.raises(ValueError, match="alpha = 2"):
        screen(like, sim, 0.02, alpha=2.0)
    with pytest.raises(ValueError, match=r"shape \(3, 10\), expected \(2, 10\)|has shape"):
        predictive_bands(like, {("T0", "q"): np.ones((2, 10)), ("T1", "q"): np.ones((3, 10))}, 0.02)
