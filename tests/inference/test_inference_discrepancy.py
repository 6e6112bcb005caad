"""The model-form discrepancy of the likelihood (inference.discrepancy, Eqs. (D1)-(D3)): it nests the paper's
likelihood at zero amplitude, equals a dense multivariate normal written here independently (on long curves through
the reduced-rank expansion (D3) too), and its evidence tells a smooth misfit of model form from noise."""
import math

import numpy as np
import pytest
from scipy.stats import multivariate_normal

import inference
from inference import Curve, Discrepancy, Likelihood, Observations, Test
from inference.discrepancy import CurveDiscrepancy, normalized_abscissa, reduced_rank_basis

X1 = np.linspace(0.5, 10.0, 12)
X2 = np.linspace(1.0, 6.0, 7)


def observations():
    return Observations([
        Test("t1", {"q": Curve(X1, 10.0 + 3.0 * X1), "e": Curve(X1, 1.0 - 0.01 * X1)}),
        Test("t2", {"q": Curve(X2, 12.0 + 2.0 * X2)}),
    ])


def forward(params):
    a = params["a"]
    return {"t1": {"q": (X1, a * (10.0 + 3.0 * X1)), "e": (X1, 1.0 - 0.0102 * X1)},
            "t2": {"q": (X2, a * (12.0 + 2.0 * X2))}}


def test_zero_amplitude_is_the_papers_likelihood_with_groups_and_weights():
    obs = observations()
    groups = {"stress": ["q"], "volume": ["e"]}
    base = Likelihood(obs, forward, weights={"t2": 0.5}, groups=groups).bind(["a", "sigma_eps_stress",
                                                                             "sigma_eps_volume"])
    with_delta = Likelihood(obs, forward, weights={"t2": 0.5}, groups=groups, discrepancy=Discrepancy())
    with_delta.bind(["a", "sigma_eps_stress", "sigma_eps_volume", "delta_q", "delta_e", "delta_length"])
    for a in (0.97, 1.0, 1.04):
        ref = base([a, 0.02, 0.005])
        got = with_delta([a, 0.02, 0.005, 0.0, 0.0, 0.3])
        assert got == pytest.approx(ref, rel=1e-10, abs=1e-8)


def test_the_curve_terms_equal_a_dense_normal_density_written_here():
    obs = observations()
    like = Likelihood(obs, forward, discrepancy=Discrepancy(length=(0.01, 1.0)))
    like.bind(["a", "sigma_eps", "delta_q", "delta_e", "delta_length"])
    theta = [1.03, 0.02, 0.05, 0.01, 0.2]
    sim = forward({"a": 1.03})
    expected = 0.0
    for t in obs:
        n_test = sum(c.y.size for c in t.curves.values())
        for name, c in t.curves.items():
            r = (c.y - sim[t.name][name][1]) / c.y
            u = (c.x - c.x.min()) / (c.x.max() - c.x.min())
            floor = 3.0 * np.median(np.diff(u))
            ell = max(0.2, floor)
            amp = 0.05 if name == "q" else 0.01
            s2 = 0.02**2 * len(t.curves) * c.y.size / n_test
            cov = s2 * np.eye(u.size) + amp**2 * np.exp(-np.subtract.outer(u, u) ** 2 / (2 * ell**2))
            cov += 1e-10 * amp**2 * np.eye(u.size)
            expected += multivariate_normal(np.zeros(u.size), cov).logpdf(r)
            expected += 0.5 * c.y.size * math.log(len(t.curves) * c.y.size / n_test)
    assert like(theta) == pytest.approx(expected, rel=1e-10)


def test_batch_rows_give_the_bits_of_single_rows():
    obs = observations()

    def batch_forward(plist):
        return [forward(p) for p in plist]

    like = Likelihood(obs, batch_forward, batch=True, discrepancy=Discrepancy())
    like.bind(["a", "sigma_eps", "delta_q", "delta_e", "delta_length"])
    rng = np.random.default_rng(3)
    thetas = np.column_stack([rng.uniform(0.95, 1.05, 70), rng.uniform(0.01, 0.05, 70),
                              rng.uniform(0.001, 0.3, (70, 2)), rng.uniform(0.05, 1.0, 70)])
    values, reasons = like.evaluate_many(thetas)
    assert all(r is None for r in reasons)
    for i in (0, 63, 64, 69):  # both sides of a block boundary
        assert like.evaluate_many(thetas[i:i + 1])[0][0] == values[i]


def test_a_long_curve_row_by_row_equals_a_dense_normal_density_and_bad_rows_are_nan():
    """(D2) of one curve of 90 irregular points for parameter sets from noise-dominated to amplitude-dominated and
    from short to long length scales, against scipy's multivariate normal on the covariance written here; a row
    with a non-finite residual is NaN without touching the others; a singular covariance (no noise, no amplitude)
    is refused."""
    rng = np.random.default_rng(5)
    u = np.sort(rng.uniform(0.0, 1.0, 90))
    curve = CurveDiscrepancy(u, n_curves=3, n_test=200, min_spacings=3.0)
    sigma = np.array([0.02, 0.002, 0.01, 0.0005])
    amplitude = np.array([0.001, 0.05, 0.02, 0.04])
    length = np.array([0.05, 0.9, 0.2, 0.01])
    residuals = rng.normal(0.0, 0.02, (4, u.size))
    got = curve.log_density(residuals, sigma, amplitude, length)
    scale = 3 * u.size / 200
    for i in range(4):
        ell = max(length[i], curve.floor)
        cov = amplitude[i] ** 2 * np.exp(-np.subtract.outer(u, u) ** 2 / (2.0 * ell**2))
        cov += (sigma[i] ** 2 * scale + 1e-10 * amplitude[i] ** 2) * np.eye(u.size)
        expected = multivariate_normal(np.zeros(u.size), cov).logpdf(residuals[i]) + 0.5 * u.size * math.log(scale)
        assert got[i] == pytest.approx(expected, rel=1e-9)
    residuals[1, 7] = np.nan
    again = curve.log_density(residuals, sigma, amplitude, length)
    assert np.isnan(again[1])
    assert again[[0, 2, 3]].tolist() == got[[0, 2, 3]].tolist()
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        curve.log_density(residuals[:1], np.zeros(1), np.zeros(1), np.full(1, 0.3))


def test_refusals_name_the_parameter_or_curve():
    obs = observations()
    like = Likelihood(obs, forward, discrepancy=Discrepancy())
    with pytest.raises(ValueError, match="delta_length"):
        like.bind(["a", "sigma_eps", "delta_q", "delta_e"])
    with pytest.raises(ValueError, match="names no recorded curve"):
        Likelihood(obs, forward, discrepancy=Discrepancy(groups={"stress": ["p"]}))
    with pytest.raises(ValueError, match="in no discrepancy group"):
        Likelihood(obs, forward, discrepancy=Discrepancy(groups={"stress": ["q"]}))
    with pytest.raises(ValueError, match="0 < lower < upper"):
        Discrepancy(amplitude=(0.1, 0.01))


def test_time_records_over_decades_are_spaced_in_log_time():
    t = np.array([0.0, 6.0, 60.0, 600.0, 6000.0, 60000.0])
    u = normalized_abscissa(t, "time")
    assert u[0] == 0.0 and u[-1] == 1.0
    # log(t + 6 s): the decades after the first records are evenly spaced, ln(10) each
    steps = np.diff(np.log(t + 6.0))
    assert np.diff(u) == pytest.approx(steps / steps.sum(), rel=1e-12)
    assert np.diff(u)[2:] == pytest.approx(np.full(3, np.diff(u)[-1]), rel=0.05)
    assert normalized_abscissa(np.linspace(0, 5, 6), "axial_strain") == pytest.approx(np.linspace(0, 1, 6))


def _evidence(obs, fwd, discrepancy, seed=4):
    names = {"a": (0.8, 1.2), "sigma_eps": (0.001, 0.3)}
    like = Likelihood(obs, fwd, batch=True, discrepancy=discrepancy)
    bounds = dict(names)
    log_names = ["sigma_eps"]
    if discrepancy is not None:
        bounds.update({"delta_q": discrepancy.amplitude, "delta_length": discrepancy.length})
        log_names += ["delta_q", "delta_length"]
    prior = inference.Prior([inference.Bound(n, lo, hi, "log-uniform" if n in log_names else "uniform")
                             for n, (lo, hi) in bounds.items()])
    post = inference.tmcmc(like, prior, n_samples=300, seed=seed, progress=False,
                           executor=inference.SerialExecutor())
    return post.log_evidence


@pytest.mark.slow
def test_evidence_prefers_the_discrepancy_for_a_smooth_misfit_and_not_for_noise():
    """Data = linear model x (1 + smooth S-shaped misfit of 3 %) x noise 1 %: the discrepancy class wins clearly;
    data = linear model x noise 1 %: it does not (its extra parameters cost more than they explain)."""
    x = np.linspace(0.2, 10.0, 40)
    rng = np.random.default_rng(11)
    shape = 0.03 * np.tanh((x - 5.0) / 1.5)

    def fwd(plist):
        return [{"t": {"q": (x, p["a"] * (5.0 + 2.0 * x))}} for p in plist]

    noise = rng.normal(1.0, 0.01, x.size)
    smooth = Observations([Test("t", {"q": Curve(x, (5.0 + 2.0 * x) * (1 + shape) * noise)})])
    plain = Observations([Test("t", {"q": Curve(x, (5.0 + 2.0 * x) * noise)})])
    d = Discrepancy()
    gain_smooth = _evidence(smooth, fwd, d) - _evidence(smooth, fwd, None)
    gain_plain = _evidence(plain, fwd, d) - _evidence(plain, fwd, None)
    assert gain_smooth > 10.0
    assert gain_plain < 1.0


def test_the_discrepancys_posterior_mean_is_the_gaussian_conditional_mean_written_here():
    """E[delta | r] = a^2 K (a^2 K + s^2 I)^-1 r (the conditional mean of (D1)), with K, the length floor and the
    noise's scale written in the test; zero amplitude gives zero."""
    rng = np.random.default_rng(6)
    u = np.sort(rng.uniform(0.0, 1.0, 40))
    curve = CurveDiscrepancy(u, n_curves=2, n_test=80, min_spacings=3.0)
    r = 0.03 * np.sin(6.0 * u) + rng.normal(0.0, 0.01, u.size)
    sigma, amplitude, length = 0.01, 0.04, 0.2
    k = amplitude**2 * np.exp(-np.subtract.outer(u, u) ** 2 / (2.0 * max(length, curve.floor) ** 2))
    noise = (sigma**2 * 2 * u.size / 80 + 1e-10 * amplitude**2) * np.eye(u.size)
    expected = k @ np.linalg.solve(k + noise, r)
    assert curve.posterior_mean(r, sigma, amplitude, length) == pytest.approx(expected, rel=1e-9, abs=1e-12)
    assert np.abs(curve.posterior_mean(r, sigma, 0.0, length)).max() == 0.0


def _long_curve(n, seed):
    rng = np.random.default_rng(seed)
    u = np.sort(rng.uniform(0.0, 1.0, n))
    return (u - u[0]) / (u[-1] - u[0]), rng


def test_a_long_curve_by_the_reduced_rank_expansion_equals_a_dense_normal_density():
    """(D2) of curves of 400 and 700 irregular records, where the reduced-rank expansion (D3) is taken (its basis at
    most a quarter of the records: checked), at the corners of the default priors (length 0.05-1, amplitude 0.1-5 %,
    noise 0.2-5 %) with a smooth misfit on top of draws of (D1), against scipy's multivariate normal on the exact
    covariance written here: within 1e-5 nats (the expansion's truncation and boundary errors; they reach 7e-3 nats
    with the boundary 2 l_j from the records instead of 6.8 l_j)."""
    for n, seed in ((400, 8), (700, 9)):
        u, rng = _long_curve(n, seed)
        curve = CurveDiscrepancy(u, n_curves=1, n_test=n, min_spacings=3.0)
        for length in (0.05, 0.3, 1.0):
            assert reduced_rank_basis(length, n)[1] > 0
            k = np.exp(-np.subtract.outer(u, u) ** 2 / (2.0 * length**2))
            for amplitude in (0.001, 0.05):
                for sigma in (0.002, 0.05):
                    cov = amplitude**2 * k + (sigma**2 + 1e-10 * amplitude**2) * np.eye(n)
                    r = np.linalg.cholesky(cov) @ rng.normal(size=n) + 0.03 * np.sin(7.0 * u)
                    got = curve.log_density(r[None], np.array([sigma]), np.array([amplitude]), np.array([length]))
                    expected = multivariate_normal(np.zeros(n), cov).logpdf(r)
                    assert abs(got[0] - expected) < 1e-5, (n, length, amplitude, sigma)


def test_a_long_curves_posterior_mean_by_the_reduced_rank_expansion_is_the_conditional_mean():
    """E[delta | r] of a 500-record curve with (D3) against a^2 K (a^2 K + s^2 I)^-1 r written here, at a short and a
    long length scale."""
    u, rng = _long_curve(500, 10)
    curve = CurveDiscrepancy(u, n_curves=1, n_test=500, min_spacings=3.0)
    r = 0.03 * np.sin(6.0 * u) + rng.normal(0.0, 0.01, u.size)
    sigma, amplitude = 0.01, 0.04
    for length in (0.05, 0.8):
        k = amplitude**2 * np.exp(-np.subtract.outer(u, u) ** 2 / (2.0 * length**2))
        expected = k @ np.linalg.solve(k + (sigma**2 + 1e-10 * amplitude**2) * np.eye(u.size), r)
        got = curve.posterior_mean(r, sigma, amplitude, length)
        assert np.abs(got - expected).max() < 1e-7 * np.abs(expected).max()
