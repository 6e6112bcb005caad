"""Likelihood Eqs. (3)-(6), priors, observations and their errors."""
import math

import numpy as np
import pytest

from inference import Curve, DataError, Likelihood, LogUniformPrior, Observations, PriorError, Test, UniformPrior, tmcmc


def _obs():
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    return Observations([
        Test("t1", {"q": Curve(x, [0.0, 10.0, 20.0, 30.0, 40.0]), "e": Curve(x, [0.8, 0.79, 0.78, 0.77, 0.76])}),
        Test("t2", {"q": Curve(x, [0.0, 5.0, 10.0, 15.0, 20.0])}),
    ])


def forward(p):
    x = np.arange(5.0)
    return {"t1": {"q": p["a"] * 10 * x, "e": 0.8 - 0.01 * x},
            "t2": {"q": (np.linspace(0, 4, 9), p["a"] * 5 * np.linspace(0, 4, 9))}}


def test_goodness_of_fit_and_log_likelihood_by_hand():
    like = Likelihood(_obs(), forward, weights={"t2": 2.0}).bind(("a", "sigma_eps"))
    a, s = 1.1, 0.2
    # Eq. (5) by hand: the q = 0 origin points are below the 1 % floor and excluded
    jg1 = 0.5 * (4 * (0.1**2) / 4 + 0.0)
    jg2 = 0.1**2
    n1, n2 = 4 + 5, 4
    expect = (-n1 / 2 * math.log(2 * math.pi * s**2) - n1 / (2 * s**2) * jg1
              + 2.0 * (-n2 / 2 * math.log(2 * math.pi * s**2) - n2 / (2 * s**2) * jg2))
    assert like([a, s]) == pytest.approx(expect, rel=1e-12)
    assert like.excluded[("t1", "q")] == 1 and like.excluded[("t1", "e")] == 0


def test_a_curve_that_changes_sign_leaves_out_the_points_near_its_zero_crossing():
    """A curve whose records change sign (an excess pore pressure of a dense clay, 30 kPa down to -5 kPa) leaves out
    of Eq. (5) the points within ``crossing_floor`` (10 %) of its largest |U_obs| = 30 kPa, at both sides of the
    crossing, and the log-likelihood is Eq. (5) by hand over the others; a curve of one sign (q, from its origin)
    keeps the floor of 1 %; a curve that only touches zero from one side does not count as crossing. The
    fingerprint names the crossing floor only where a curve crosses (a checkpoint of a study without one stays
    valid)."""
    x = np.arange(8.0)
    u = np.array([0.0, 12.0, 30.0, 20.0, 2.5, 0.2, -2.9, -5.0])   # |u| <= 3 kPa out: 0, 2.5, 0.2, -2.9
    q = np.array([0.0, 0.2, 20.0, 40.0, 50.0, 55.0, 57.0, 58.0])  # one sign: only the origin (<= 0.58 kPa) out
    obs = Observations([Test("t", {"u": Curve(x, u), "q": Curve(x, q)})])
    sim = {"u": u * 1.1, "q": q * 0.9}
    like = Likelihood(obs, lambda p: {"t": sim}).bind(("sigma_eps",))
    assert like.crossing == [("t", "u")]
    assert like.masks["t", "u"].tolist() == [False, True, True, True, False, False, False, True]
    assert like.masks["t", "q"].tolist() == [False, False] + [True] * 6
    s = 0.05
    jg = 0.5 * (0.1**2 + 0.1**2)                  # (U_obs - U_num)/U_obs = -0.1 and +0.1 at every point used
    n = 4 + 6
    expect = -n / 2 * math.log(2 * math.pi * s**2) - n / (2 * s**2) * jg
    assert like([s]) == pytest.approx(expect, rel=1e-12)
    assert "crossing=0.1" in like.fingerprint()
    touching = Observations([Test("t", {"q": Curve(x, np.abs(u))})])
    assert Likelihood(touching, lambda p: {}).crossing == []
    assert "crossing" not in Likelihood(touching, lambda p: {}).fingerprint()
    with pytest.raises(ValueError, match="crossing_floor"):
        Likelihood(obs, lambda p: {}, floor=0.05, crossing_floor=0.02)


def test_pointwise_log_likelihood_by_hand_sums_to_the_log_likelihood():
    """Each point's term of Eq. (4): -ln(2 pi s^2)/2 - N_i/(N_0 N_j) r^2/(2 s^2), times the test's weight; the
    excluded origin 0; summed, the log-likelihood of the same parameter sets."""
    like = Likelihood(_obs(), forward, weights={"t2": 2.0}).bind(("a", "sigma_eps"))
    thetas = np.array([[1.1, 0.2], [0.95, 0.05]])
    terms = like.pointwise_log_likelihood(like.simulated_many(thetas), thetas)
    a, s = thetas[0]
    # t1, q: r = 1 - a at the four used points, N_1 = 9 over N_0 = 2 curves, N_j = 4
    expect_q = -0.5 * math.log(2 * math.pi * s**2) - 9 / (2 * 4) * (1 - a) ** 2 / (2 * s**2)
    np.testing.assert_allclose(terms["t1", "q"][0], [0.0] + [expect_q] * 4, rtol=1e-12)
    # t2, q (weight 2): r = 1 - a, N_2 = 4 over one curve of 4 points
    expect_t2 = 2.0 * (-0.5 * math.log(2 * math.pi * s**2) - (1 - a) ** 2 / (2 * s**2))
    np.testing.assert_allclose(terms["t2", "q"][0], [0.0] + [expect_t2] * 4, rtol=1e-12)
    for i, theta in enumerate(thetas):
        assert sum(v[i].sum() for v in terms.values()) == pytest.approx(like(theta), rel=1e-12)


def test_forward_failures_are_errors_with_reasons():
    like = Likelihood(_obs(), lambda p: {"t1": {"q": np.full(5, np.nan), "e": np.zeros(5)}, "t2": {"q": np.ones(5)}})
    like.bind(("a", "sigma_eps"))
    values, reasons = like.evaluate_many(np.array([[1.0, 0.1]]))
    assert values[0] == -np.inf and "NaN" in reasons[0]
    short = Likelihood(_obs(), lambda p: {"t1": {"q": np.zeros(5), "e": np.ones(5)},
                                          "t2": {"q": (np.array([0.0, 2.0]), np.array([0.0, 1.0]))}})
    short.bind(("a", "sigma_eps"))
    values, reasons = short.evaluate_many(np.array([[1.0, 0.1]]))
    assert values[0] == -np.inf and "covers" in reasons[0]


def test_unknown_sigma_and_weights_are_refused():
    with pytest.raises(ValueError, match="sigma_eps"):
        Likelihood(_obs(), forward).bind(("a",))
    with pytest.raises(ValueError, match="unknown tests"):
        Likelihood(_obs(), forward, weights={"t9": 1.0})


def test_prior_errors_name_the_parameter():
    with pytest.raises(PriorError, match="M.*lower bound 2 must be < upper bound 1"):
        UniformPrior({"M": (2.0, 1.0)})
    with pytest.raises(PriorError, match="C_ae.*> 0"):
        LogUniformPrior({"C_ae": (0.0, 1.0)})
    with pytest.raises(PriorError, match="unknown parameter name 'K'"):
        UniformPrior({"M": (0, 1)}).index("K")
    with pytest.raises(ValueError, match="n_samples"):
        tmcmc(lambda t: 0.0, UniformPrior({"M": (0, 1)}), n_samples=1)


def test_prior_densities_integrate_to_one():
    prior = UniformPrior({"a": (-1, 3)}) & LogUniformPrior({"b": (1e-3, 1e-1)})
    rng = np.random.default_rng(0)
    # importance check: E_uniform-box[p(theta)] * volume = 1
    box = rng.uniform([-1, 1e-3], [3, 1e-1], size=(400000, 2))
    vol = 4 * (1e-1 - 1e-3)
    assert np.mean(np.exp(prior.logpdf(box))) * vol == pytest.approx(1.0, rel=0.02)
    s = prior.sample(rng, 20000)
    # log-uniform: log10 b uniform on [-3, -1]
    assert np.mean(np.log10(s[:, 1]) < -2) == pytest.approx(0.5, abs=0.015)
    assert np.all(prior.logpdf([[4.0, 0.01]]) == -np.inf)


def test_csv_reading_units_and_errors(tmp_path):
    good = tmp_path / "t.csv"
    good.write_text("# synthetic: true\n# e0: 0.7\neps_a_pct,q_MPa,e\n0,0,0.7\n1,0.1,0.69\n2,0.15,0.68\n")
    obs = Observations.from_csv({"T": good}, x="eps_a", curves=["q", "e"], units={"q": "kPa"})
    np.testing.assert_allclose(obs["T"].curves["q"].y, [0, 100, 150])
    assert obs["T"].conditions["synthetic"] == "true"
    with pytest.raises(DataError, match=r"t.csv: missing column 'u'"):
        Observations.from_csv({"T": good}, x="eps_a", curves=["u"])
    with pytest.raises(DataError, match=r"column 'eps_a' is in unit 'pct', expected 's'"):
        Observations.from_csv({"T": good}, x="eps_a", curves=["q"], units={"eps_a": "s"})
    bad = tmp_path / "bad.csv"
    bad.write_text("eps_a_pct,q_kPa\n0,0\n1,abc\n")
    with pytest.raises(DataError, match=r"bad.csv, line 3, column 'q_kPa': value 'abc'"):
        Observations.from_csv({"T": bad}, x="eps_a", curves=["q"])
    nan = tmp_path / "nan.csv"
    nan.write_text("eps_a [%],q [kPa]\n0,0\n1,nan\n")
    with pytest.raises(DataError, match="nan.csv, line 3"):
        Observations.from_csv({"T": nan}, x="eps_a", curves=["q"])
