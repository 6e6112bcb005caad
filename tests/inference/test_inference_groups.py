"""Error groups and per-test weights of the likelihood, Eq. (6g) of docs/reference.md section 1.

Checked against the equation written out by hand on a toy whose relative errors are known exactly, against the
one-group likelihood (Eq. (4)) when every group has the same sigma, and the array path against the per-particle path.
"""
import math

import numpy as np
import pytest

from inference import Curve, ForwardModel, ForwardModelError, Likelihood, Observations, Test

X = np.array([0.0, 1.0, 2.0, 3.0, 4.0])


def _obs():
    return Observations([
        Test("t1", {"q": Curve(X, [0.0, 10.0, 20.0, 30.0, 40.0]), "e": Curve(X, [0.8, 0.79, 0.78, 0.77, 0.76])}),
        Test("t2", {"q": Curve([0.5, 1.5, 2.5], [5.0, 15.0, 25.0])}),
    ])


class Toy(ForwardModel):
    """q = 10 a x (relative error (1 - a) at every used point), e = b (0.8 - 0.01 x) (relative error (1 - b))."""

    def simulate_batch(self, names, values):
        a, b = values[:, names.index("a")], values[:, names.index("b")]
        q = 10.0 * a[:, None] * X
        e = b[:, None] * (0.8 - 0.01 * X)
        return {"t1": {"q": (X, q), "e": e}, "t2": {"q": (X, q)}}, [None] * len(a)

    def __call__(self, batch):
        curves, _ = self.simulate_batch(("a", "b"), np.array([[p["a"], p["b"]] for p in batch]))
        return [{t: {c: (v[0], v[1][i]) if isinstance(v, tuple) else v[i] for c, v in cs.items()}
                 for t, cs in curves.items()} for i in range(len(batch))]


GROUPS = {"stress": ["q"], "volume": ["e"]}
NAMES = ("a", "b", "sigma_eps_stress", "sigma_eps_volume")


def _by_hand(a, b, s_q, s_e, w2=1.0):
    """Eq. (6g): t1 has N = 4 (q, origin below the floor) + 5 (e) points over N_0 = 2 curves; t2 one q curve, 3."""
    rq, re = (1.0 - a) ** 2, (1.0 - b) ** 2  # (U_obs - U_num)/U_obs = 1 - a on q, 1 - b on e
    n1 = 9
    t1 = (-4 / 2 * math.log(2 * math.pi * s_q**2) - n1 * (rq / 2) / (2 * s_q**2)
          - 5 / 2 * math.log(2 * math.pi * s_e**2) - n1 * (re / 2) / (2 * s_e**2))
    t2 = -3 / 2 * math.log(2 * math.pi * s_q**2) - 3 * rq / (2 * s_q**2)
    return t1 + w2 * t2


def test_pointwise_terms_of_two_groups_sum_to_eq_6g():
    like = Likelihood(_obs(), Toy(), weights={"t2": 2.0}, batch=True, groups=GROUPS).bind(NAMES)
    theta = np.array([[1.1, 0.97, 0.05, 0.01], [0.9, 1.02, 0.2, 0.003]])
    terms = like.pointwise_log_likelihood(like.simulated_many(theta), theta)
    for i, th in enumerate(theta):
        assert sum(v[i].sum() for v in terms.values()) == pytest.approx(_by_hand(*th, w2=2.0), rel=1e-12)


def test_two_groups_against_the_equation_by_hand():
    like = Likelihood(_obs(), Toy(), weights={"t2": 2.0}, batch=True, groups=GROUPS).bind(NAMES)
    assert like.sigma_names == ("sigma_eps_stress", "sigma_eps_volume")
    theta = np.array([[1.1, 0.97, 0.05, 0.01], [0.9, 1.02, 0.2, 0.003]])
    values, reasons = like.evaluate_many(theta)
    assert reasons == [None, None]
    for v, th in zip(values, theta):
        assert v == pytest.approx(_by_hand(*th, w2=2.0), rel=1e-12)
    # the per-particle path gives the same bits as the array path
    per_particle = Likelihood(_obs(), lambda b: Toy()(b), batch=True, weights={"t2": 2.0}, groups=GROUPS).bind(NAMES)
    np.testing.assert_array_equal(per_particle.evaluate_many(theta)[0], values)
    assert like(theta[0]) == values[0]


def test_one_group_is_the_single_sigma_likelihood_bit_for_bit():
    single = Likelihood(_obs(), Toy(), batch=True).bind(("a", "b", "sigma_eps"))
    one = Likelihood(_obs(), Toy(), batch=True, groups={"all": ["q", "e"]}).bind(("a", "b", "sigma_eps"))
    assert one.sigma_names == ("sigma_eps",) and one.fingerprint() == single.fingerprint()
    thetas = np.column_stack([np.random.default_rng(3).uniform(0.8, 1.2, (30, 2)), np.full(30, 0.04)])
    np.testing.assert_array_equal(one.evaluate_many(thetas)[0], single.evaluate_many(thetas)[0])
    # and Eq. (4)-(6) by hand: both groups' formula with equal sigma
    a, b, s = thetas[0]
    assert single(thetas[0]) == pytest.approx(_by_hand(a, b, s, s), rel=1e-12)


def test_two_groups_with_equal_sigma_equal_one_group():
    single = Likelihood(_obs(), Toy(), batch=True, weights={"t1": 0.5}).bind(("a", "b", "sigma_eps"))
    two = Likelihood(_obs(), Toy(), batch=True, weights={"t1": 0.5}, groups=GROUPS).bind(NAMES)
    rng = np.random.default_rng(4)
    ab, s = rng.uniform(0.8, 1.2, (25, 2)), rng.uniform(0.01, 0.2, 25)
    np.testing.assert_allclose(two.evaluate_many(np.column_stack([ab, s, s]))[0],
                               single.evaluate_many(np.column_stack([ab, s]))[0], rtol=1e-13)


def test_weights_multiply_the_test_term():
    base = Likelihood(_obs(), Toy(), batch=True, groups=GROUPS).bind(NAMES)
    heavy = Likelihood(_obs(), Toy(), batch=True, groups=GROUPS, weights={"t2": 3.0}).bind(NAMES)
    th = np.array([1.05, 0.99, 0.03, 0.02])
    t2 = -3 / 2 * math.log(2 * math.pi * 0.03**2) - 3 * 0.05**2 / (2 * 0.03**2)
    assert heavy(th) - base(th) == pytest.approx(2.0 * t2, rel=1e-10)


def test_group_keys_curve_sigmas_and_refusals():
    keyed = Likelihood(_obs(), Toy(), batch=True, groups={"a": [("t1", "q"), "e"], "b": [("t2", "q")]})
    keyed.bind(("a", "b", "sigma_eps_a", "sigma_eps_b"))
    sig = keyed.curve_sigmas(np.array([[1.0, 1.0, 0.1, 0.2]]))
    assert keyed.curve_keys == (("t1", "q"), ("t1", "e"), ("t2", "q"))
    np.testing.assert_array_equal(sig, [[0.1, 0.1, 0.2]])
    assert keyed.split([1.0, 1.0, 0.1, 0.2])[1] == {"a": 0.1, "b": 0.2}
    with pytest.raises(ValueError, match="curve e is in no error group"):
        Likelihood(_obs(), Toy(), groups={"s": [("t1", "q")], "t": [("t2", "q")]})
    with pytest.raises(ValueError, match="two error groups"):
        Likelihood(_obs(), Toy(), groups={"s": ["q"], "v": ["e", "q"]})
    with pytest.raises(ValueError, match="'void' names no recorded curve"):
        Likelihood(_obs(), Toy(), groups={"s": ["q"], "v": ["e", "void"]})
    with pytest.raises(ValueError, match="sigma_eps_volume"):
        Likelihood(_obs(), Toy(), groups=GROUPS).bind(("a", "b", "sigma_eps_stress"))
    like = Likelihood(_obs(), Toy(), batch=True, groups=GROUPS).bind(NAMES)
    values, reasons = like.evaluate_many(np.array([[1.0, 1.0, 0.1, -0.1]]))
    assert values[0] == -np.inf and reasons[0] == f"{ForwardModelError.__name__}: sigma_eps_volume = -0.1 must be > 0"


def test_groups_keep_their_given_order():
    like = Likelihood(_obs(), Toy(), batch=True, groups={"volume": ["e"], "stress": ["q"]})
    assert like.groups == ("volume", "stress") and like.sigma_names == ("sigma_eps_volume", "sigma_eps_stress")
    like.bind(("a", "b", "sigma_eps_stress", "sigma_eps_volume"))
    np.testing.assert_array_equal(like.sigma_arrays([[1.0, 1.0, 0.1, 0.2]]), [[0.2, 0.1]])
    with pytest.raises(ValueError, match="error group v has no curves"):
        Likelihood(_obs(), Toy(), groups={"s": ["q", "e"], "v": []})
