"""The likelihood's array path (forward models whose ``simulate_batch`` gives a table of curves): Eq. (5) over a
whole batch in numpy.

Checked against (1) a hand-computed Eq. (5) on a toy forward model, (2) a reference written here as the per-particle
code was before the array path (np.interp per particle and curve, ``rel @ rel`` per curve), on random parameter sets of
both SIMSAND studies, and (3) the per-particle path of the same Likelihood, bit for bit, whatever the batch size.
"""
import math

import numpy as np
import pytest

from cases import simsand_synthetic, toyoura
from cases.study.reading.schema import load_study
from cases.study.routes import sand as sand_route
from inference import Curve, ForwardModel, ForwardModelError, Likelihood, Observations, Test
from inference.curve_reading import CurveReader


# ----------------------------------------------------------------------------------------------- a toy forward model
def _toy_obs():
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    return Observations([
        Test("t1", {"q": Curve(x, [0.0, 10.0, 20.0, 30.0, 40.0]), "e": Curve(x, [0.8, 0.79, 0.78, 0.77, 0.76])}),
        Test("t2", {"q": Curve([0.5, 1.5, 2.5], [5.0, 15.0, 25.0])}),
    ])


class Toy(ForwardModel):
    """q = 10 a x on a grid (interpolated to the records), e at the recorded strains; a < 0 fails (a reason),
    a > 100 gives a NaN q curve without a reason."""

    grid = np.array([0.0, 2.0, 1.0, 3.0, 4.0])  # unsorted on purpose

    def simulate_batch(self, names, values):
        a = values[:, names.index("a")]
        q = 10.0 * a[:, None] * self.grid ** 2 / np.where(self.grid > 0, self.grid, 1.0)  # 10 a x, x = 0 -> 0
        q[a > 100] = np.nan
        e = np.broadcast_to(0.8 - 0.01 * np.arange(5.0), (len(a), 5))
        curves = {"t1": {"q": (self.grid, q), "e": e}, "t2": {"q": (self.grid, q)}}
        return curves, [ForwardModelError(f"a = {v} < 0") if v < 0 else None for v in a]

    def __call__(self, batch):
        curves, reasons = self.simulate_batch(("a",), np.array([[p["a"]] for p in batch]))
        return [r if r is not None else {t: {c: (v[0], v[1][i]) if isinstance(v, tuple) else v[i]
                                                    for c, v in cs.items()} for t, cs in curves.items()}
                for i, r in enumerate(reasons)]


def test_batch_eq5_by_hand():
    """Eq. (5) and Eq. (4) by hand for the toy: t1 q has relative error (10 - 11)/10 = -0.1 at every used point
    (the origin is under the 1 % floor), e is exact; t2 q (interpolated between grid nodes) also -0.1."""
    like = Likelihood(_toy_obs(), Toy(), weights={"t2": 2.0}, batch=True).bind(("a", "sigma_eps"))
    a, s = 1.1, 0.2
    jg1 = 0.5 * (4 * 0.1**2 / 4 + 0.0)
    jg2 = 3 * 0.1**2 / 3
    n1, n2 = 4 + 5, 3
    expect = (-n1 / 2 * math.log(2 * math.pi * s**2) - n1 / (2 * s**2) * jg1
              + 2.0 * (-n2 / 2 * math.log(2 * math.pi * s**2) - n2 / (2 * s**2) * jg2))
    values, reasons = like.evaluate_many(np.array([[a, s], [1.0, s], [-1.0, s], [200.0, s], [a, -0.1]]))
    assert values[0] == pytest.approx(expect, rel=1e-12)
    assert values[1] == pytest.approx(-(n1 + 2 * n2) / 2 * math.log(2 * math.pi * s**2), rel=1e-12)  # J_g = 0
    assert values[2] == -np.inf and reasons[2] == "ForwardModelError: a = -1.0 < 0"
    assert values[3] == -np.inf and reasons[3] == "ForwardModelError: test t1, curve q: simulated curve has NaN/inf"
    assert values[4] == -np.inf and "sigma_eps = -0.1 must be > 0" in reasons[4]
    assert reasons[:2] == [None, None]
    jg = like.goodness_of_fit(like.simulated_at_observations(Toy()([{"a": a}])[0]))
    assert jg["t1"] == pytest.approx(jg1, rel=1e-12) and jg["t2"] == pytest.approx(jg2, rel=1e-12)


def test_batch_path_equals_the_per_particle_path_for_the_toy():
    like = Likelihood(_toy_obs(), Toy(), batch=True).bind(("a", "sigma_eps"))
    thetas = np.column_stack([np.random.default_rng(1).uniform(-0.5, 3.0, 40), np.full(40, 0.05)])
    thetas[7, 0] = 150.0
    whole, reasons = like.evaluate_many(thetas)
    one_by_one = [like.evaluate_many(th[None]) for th in thetas]
    np.testing.assert_array_equal(whole, [v[0] for v, _ in one_by_one])
    assert reasons == [r[0] for _, r in one_by_one]
    plain = Likelihood(_toy_obs(), lambda b: Toy()(b), batch=True).bind(("a", "sigma_eps"))  # a list callable
    values, plain_reasons = plain.evaluate_many(thetas)
    np.testing.assert_array_equal(whole, values)
    assert reasons == plain_reasons


def test_a_grid_that_does_not_cover_the_record_fails_every_particle():
    class Short(Toy):
        grid = np.array([0.0, 1.0, 2.0, 3.0])

        def simulate_batch(self, names, values):
            curves, reasons = super().simulate_batch(names, values)
            return {t: {c: (v[0][:4], v[1][:, :4]) if isinstance(v, tuple) else v for c, v in cs.items()}
                    for t, cs in curves.items()}, reasons

    like = Likelihood(_toy_obs(), Short(), batch=True).bind(("a", "sigma_eps"))
    values, reasons = like.evaluate_many(np.array([[1.0, 0.1], [-1.0, 0.1]]))
    assert (values == -np.inf).all()
    assert "covers" in reasons[0] and reasons[1] == "ForwardModelError: a = -1.0 < 0"


def test_interpolation_is_np_interp_bit_for_bit():
    """Random unsorted grids with repeated nodes, records on nodes, between nodes and at the ends."""
    rng = np.random.default_rng(7)
    x_rec = np.concatenate([[0.0], np.sort(rng.uniform(0, 10, 30)), [2.0, 5.0, 10.0]])
    obs = Observations([Test("t", {"y": Curve(x_rec, rng.uniform(1, 2, x_rec.size))})])
    reader = CurveReader(obs)
    for _ in range(20):
        xs = np.concatenate([[0.0, 10.0, 2.0, 5.0, 5.0], rng.uniform(0, 10, 12)])
        rng.shuffle(xs)
        ys = rng.normal(size=(3, xs.size))
        values, bad, _ = reader.at_records("t", "y", (xs, ys), 3)
        order = np.argsort(xs, kind="stable")
        for row, y in zip(values, ys):
            np.testing.assert_array_equal(row, np.interp(x_rec, xs[order], y[order]))
        assert not bad.any()


# ----------------------------------------------------------------------------------------------- the SIMSAND studies
def _reference_log_likelihood(like, result, sigma):
    """The per-particle code as it was before the array path: np.interp per curve, ``rel @ rel`` per curve."""
    total = 0.0
    for t in like.observations:
        terms = []
        for c, curve in t.curves.items():
            xs, ys = result[t.name][c]
            order = np.argsort(xs, kind="stable")
            sim = np.interp(curve.x, xs[order], ys[order])
            mask = np.abs(curve.y) > like.floor * np.max(np.abs(curve.y))
            rel = (curve.y[mask] - sim[mask]) / curve.y[mask]
            terms.append(float(rel @ rel) / rel.size)
        jg = sum(terms) / len(terms)
        n = sum(int((np.abs(cv.y) > like.floor * np.max(np.abs(cv.y))).sum()) for cv in t.curves.values())
        total += like.weights[t.name] * (-0.5 * n * np.log(2 * np.pi * sigma**2) - n * jg / (2 * sigma**2))
    return total


def _random_thetas(prior, samples_near, rng, n):
    near = samples_near * rng.uniform(0.98, 1.02, (n, samples_near.size))
    return np.vstack([prior.sample(rng, n), np.clip(near, prior.lower, prior.upper)])


@pytest.mark.parametrize("study", ["synthetic", "toyoura"])
def test_simsand_batch_equals_reference_and_per_particle_path(study):
    path, centre_key, sigma = ((simsand_synthetic.STUDY, "generating", 0.02) if study == "synthetic" else
                               (toyoura.STUDY, "paper_reference", 0.05))
    loaded = load_study(path)
    built = sand_route.build(loaded)
    forward, like, prior = built.forward, built.like, built.prior
    centre = np.array([loaded.references[centre_key].values.get(n, sigma) for n in prior.names])
    like.bind(prior.names)
    thetas = _random_thetas(prior, centre, np.random.default_rng(11), 12)
    values, reasons = like.evaluate_many(thetas)
    results = forward([like.split(th)[0] for th in thetas])
    assert np.isfinite(values[12:]).all()
    for i, (th, res) in enumerate(zip(thetas, results)):
        if isinstance(res, Exception):
            assert values[i] == -np.inf and reasons[i] == f"ForwardModelError: {res}"
            continue
        assert reasons[i] is None
        assert values[i] == pytest.approx(_reference_log_likelihood(like, res, th[-1]), rel=1e-12, abs=0)
        assert values[i] == like(th)  # the per-particle path: same bits
    singles = np.concatenate([like.evaluate_many(thetas[i:i + 1])[0] for i in range(len(thetas))])
    np.testing.assert_array_equal(values, singles)
