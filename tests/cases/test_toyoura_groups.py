"""The Toyoura case's error groups (Eq. (6g), docs/reference.md section 1) on the shipped measured data: the groups
route (cases/examples/toyoura_groups.toml through the study library's error model) against Eq. (5) and Eq. (6g)
written out by hand from the forward model's curves, and one group against the single-sigma likelihood bit for bit.
"""
import math

import numpy as np
import pytest

import inference
from cases import toyoura
from cases.study.reading.schema import load_study
from cases.study.routes import sand as sand_route

STUDY = load_study(toyoura.STUDY)
SOIL = dict(STUDY.references["paper_reference"].values)
ERROR_GROUPS = STUDY.path.parent / STUDY.runner["error_groups"]


def _route(built):
    return built.cal_obs, built.all_obs, built.forward, built.forward_all, built.like, built.prior


@pytest.fixture(scope="module")
def routes():
    single = _route(sand_route.build(STUDY))
    groups = _route(sand_route.build(STUDY, error_model=sand_route.read_error_groups(ERROR_GROUPS)))
    return single, groups


def _hand_curve_means(like, forward):
    """Eq. (5)'s inner mean per (test, curve) at SOIL, by np.interp of the forward model's simulated curve and the
    1 % floor, independent of the likelihood's interpolation."""
    names = tuple(SOIL)
    curves, reasons = forward.simulate_batch(names, np.array([[SOIL[n] for n in names]]))
    assert reasons == [None]
    out = {}
    for t in like.observations:
        for c, rec in t.curves.items():
            x_sim, y_sim = curves[t.name][c]
            sim = np.interp(rec.x, np.asarray(x_sim), np.asarray(y_sim).reshape(-1))
            used = np.abs(rec.y) > 0.01 * np.max(np.abs(rec.y))
            rel = (rec.y[used] - sim[used]) / rec.y[used]
            out[t.name, c] = (float(np.mean(rel * rel)), int(used.sum()))
    return out


def test_groups_route_parameters(routes):
    (_, _, _, _, like1, prior1), (_, _, _, _, like2, prior2) = routes
    assert like1.sigma_names == ("sigma_eps",) and prior1.names[-1] == "sigma_eps"
    assert like2.sigma_names == ("sigma_eps_stress", "sigma_eps_volume")
    assert prior2.names[-2:] == ("sigma_eps_stress", "sigma_eps_volume")
    assert prior2.names[:-2] == prior1.names[:-1]
    assert {key: g for key, g in like2.group_of.items()} == {
        ("test2", "q"): "stress", ("test2", "e"): "volume", ("test6", "q"): "stress", ("test6", "e"): "volume"}
    assert sand_route.curve_sigmas(like2) == {"q": "sigma_eps_stress", "e": "sigma_eps_volume"}
    assert sand_route.curve_sigmas(like1) == {}


def test_same_jg_per_curve_and_eq_6g_by_hand(routes):
    (_, _, fwd1, _, like1, prior1), (_, _, fwd2, _, like2, prior2) = routes
    hand = _hand_curve_means(like1, fwd1)
    assert hand == _hand_curve_means(like2, fwd2)
    s_stress, s_volume = 0.08, 0.004
    theta1 = np.array([SOIL[n] for n in prior1.names[:-1]] + [s_stress])
    theta2 = np.array([SOIL[n] for n in prior2.names[:-2]] + [s_stress, s_volume])
    like1.bind(prior1.names)
    like2.bind(prior2.names)
    jg1 = like1.summary_goodness(theta1)
    jg2 = like2.summary_goodness(theta2)
    expected = 0.0
    for t in ("test2", "test6"):
        n_test = sum(hand[t, c][1] for c in ("q", "e"))
        jg_hand = (hand[t, "q"][0] + hand[t, "e"][0]) / 2
        assert jg1[t] == pytest.approx(jg_hand, rel=1e-10)
        assert jg2[t] == pytest.approx(jg_hand, rel=1e-10)
        for c, s in (("q", s_stress), ("e", s_volume)):
            j_group, n_group = hand[t, c][0] / 2, hand[t, c][1]
            expected += -0.5 * n_group * math.log(2 * math.pi * s * s) - n_test * j_group / (2 * s * s)
    values, reasons = like2.evaluate_many(theta2[None, :])
    assert reasons == [None]
    assert values[0] == pytest.approx(expected, rel=1e-10)
    # equal sigmas in both groups: Eq. (4)
    equal = theta2.copy()
    equal[-1] = s_stress
    assert like2.evaluate_many(equal[None, :])[0][0] == pytest.approx(like1.evaluate_many(theta1[None, :])[0][0],
                                                                      rel=1e-12)


def test_one_group_is_the_single_sigma_bit_for_bit(routes):
    (cal_obs, _, forward, _, like, prior), _ = routes
    paper = inference.Likelihood(cal_obs, forward, batch=True, sigma="sigma_eps")   # the case's single sigma
    one = inference.Likelihood(cal_obs, forward, batch=True, sigma="sigma_eps", groups={"all": ["q", "e"]})
    assert one.sigma_names == ("sigma_eps",)
    thetas = prior.sample(np.random.default_rng(3), 24)
    a, ra = like.bind(prior.names).evaluate_many(thetas)
    b, rb = paper.bind(prior.names).evaluate_many(thetas)
    c, rc = one.bind(prior.names).evaluate_many(thetas)
    assert np.isfinite(a).sum() >= 12
    assert ra == rb == rc
    assert np.array_equal(a, b) and np.array_equal(a, c)
