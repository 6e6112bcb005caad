"""The failure policy of the likelihood (inference.forward.batch_or_each) with toy forward models, no soil code:
a batch that raises is evaluated particle by particle; a particle that still fails gets -inf and its reason."""
import numpy as np
import pytest

from inference import Curve, ForwardModel, ForwardModelError, Likelihood, Observations, Test

X = np.array([1.0, 2.0, 3.0])


def _obs():
    return Observations([Test("t", {"q": Curve(X, 10.0 * X)})])


class Linear(ForwardModel):
    """q = 10 a x at the records; raises for the whole batch when a batch of more than one holds a >= ``batch_bad``;
    a particle with a >= ``always_bad`` raises even alone."""

    def __init__(self, batch_bad=np.inf, always_bad=np.inf):
        self.batch_bad, self.always_bad = batch_bad, always_bad
        self.calls = []

    def simulate_batch(self, names, values):
        a = values[:, names.index("a")]
        self.calls.append(len(a))
        if (a >= self.always_bad).any():
            raise ValueError(f"a = {a[a >= self.always_bad][0]} is refused")
        if len(a) > 1 and (a >= self.batch_bad).any():
            raise RuntimeError("the batch cannot be solved together")
        return {"t": {"q": 10.0 * a[:, None] * X}}, [None] * len(a)


THETAS = np.array([[1.0, 0.1], [2.0, 0.1], [1.5, 0.1]])


def test_a_batch_that_fails_as_a_whole_is_retried_particle_by_particle():
    reference = Likelihood(_obs(), Linear()).bind(("a", "sigma_eps")).evaluate_many(THETAS)
    forward = Linear(batch_bad=2.0)
    values, reasons = Likelihood(_obs(), forward).bind(("a", "sigma_eps")).evaluate_many(THETAS)
    assert forward.calls == [3, 1, 1, 1]
    np.testing.assert_array_equal(values, reference[0])
    assert reasons == [None, None, None] and np.isfinite(values).all()


def test_a_particle_that_fails_alone_gets_minus_inf_with_its_reason():
    forward = Linear(always_bad=2.0)
    values, reasons = Likelihood(_obs(), forward).bind(("a", "sigma_eps")).evaluate_many(THETAS)
    assert forward.calls == [3, 1, 1, 1]
    assert values[1] == -np.inf and reasons[1] == "ValueError: a = 2.0 is refused"
    assert np.isfinite(values[[0, 2]]).all() and reasons[0] is None and reasons[2] is None


def test_a_failed_record_and_the_single_particle_adapter():
    class Recorded(Linear):
        def simulate_batch(self, names, values):
            curves, _ = super().simulate_batch(names, values)
            return curves, [ForwardModelError("no curve") if v > 1.8 else None for v in values[:, 0]]

    values, reasons = Likelihood(_obs(), Recorded()).bind(("a", "sigma_eps")).evaluate_many(THETAS)
    assert values[1] == -np.inf and reasons == [None, "ForwardModelError: no curve", None]

    seen = []

    def one(params):  # a single-particle callable: given one parameter set at a time
        seen.append(params)
        if params["a"] > 1.8:
            raise ArithmeticError("diverged")
        return {"t": {"q": 10.0 * params["a"] * X}}

    like = Likelihood(_obs(), one).bind(("a", "sigma_eps"))
    values, reasons = like.evaluate_many(THETAS)
    assert seen == [{"a": 1.0}, {"a": 2.0}, {"a": 1.5}]
    assert reasons == [None, "ArithmeticError: diverged", None]
    assert values[0] == pytest.approx(like(THETAS[0])) and values[0] > values[2]
    with pytest.raises(ArithmeticError):
        like(THETAS[1])


SHARED = np.array([[1.0, 0.1], [2.0, 0.1], [1.0, 0.3], [1.5, 0.1], [2.0, 0.05], [1.0, 0.1]])


def test_sets_differing_only_in_their_error_parameter_share_one_solve():
    """A batch (a finite-difference stencil moving sigma_eps) gives the forward model each distinct set of soil
    parameters once, and each set the value it has alone: Eq. (4) at its own sigma_eps on the shared curves."""
    forward = Linear()
    like = Likelihood(_obs(), forward).bind(("a", "sigma_eps"))
    values, reasons = like.evaluate_many(SHARED)
    assert forward.calls == [3] and reasons == [None] * 6
    alone = [like(theta) for theta in SHARED]
    np.testing.assert_array_equal(values, alone)
    # Eq. (4) by hand: q = 10 a x against 10 x, every point used
    j = (1.0 - SHARED[:, 0]) ** 2
    n = len(X)
    expected = -n / 2 * np.log(2 * np.pi * SHARED[:, 1] ** 2) - n * j / (2 * SHARED[:, 1] ** 2)
    np.testing.assert_allclose(values, expected, rtol=1e-12)


def test_a_shared_solve_that_fails_fails_every_set_sharing_it_and_one_at_a_time_forwards_solve_once():
    forward = Linear(always_bad=2.0)
    values, reasons = Likelihood(_obs(), forward).bind(("a", "sigma_eps")).evaluate_many(SHARED)
    assert forward.calls == [3, 1, 1, 1]   # the batch of the 3 distinct sets fails, then each distinct set alone
    assert reasons[1] == reasons[4] == "ValueError: a = 2.0 is refused"
    assert values[1] == values[4] == -np.inf and np.isfinite(values[[0, 2, 3, 5]]).all()

    seen = []

    def one(params):  # a single-particle callable
        seen.append(params["a"])
        return {"t": {"q": 10.0 * params["a"] * X}}

    like = Likelihood(_obs(), one).bind(("a", "sigma_eps"))
    values, _ = like.evaluate_many(SHARED)
    assert seen == [1.0, 2.0, 1.5]
    np.testing.assert_array_equal(values, [like(theta) for theta in SHARED])


def test_simulated_curves_of_sets_sharing_their_soil_parameters_are_solved_once():
    seen = []

    def one(params):
        seen.append(params["a"])
        return {"t": {"q": 10.0 * params["a"] * X}}

    simulated = Likelihood(_obs(), one).bind(("a", "sigma_eps")).simulated_many(SHARED)
    assert seen == [1.0, 2.0, 1.5]
    np.testing.assert_array_equal(simulated["t", "q"], 10.0 * SHARED[:, :1] * X)


def test_a_list_of_results_is_scored_at_once_with_the_bits_and_reasons_of_each_set_alone():
    """A forward model returning one result per set (a list: a laboratory study's): the usable sets' terms are taken
    in one batch; each value is the bits of the set's own ``like(theta)`` and each refusal the reason and precedence
    of the set alone (sigma_eps first, then the forward model's failure, then an unusable curve); with a model-form
    discrepancy too. Oracle: each set evaluated by itself."""
    from inference import Discrepancy

    def forward(plist):
        out = []
        for p in plist:
            if p["a"] > 2.5:
                out.append(ForwardModelError("a refused"))
            else:
                q = 10.0 * p["a"] * X * (1.0 + 0.01 * X ** 2)
                out.append({"t": {"q": np.where(p["a"] > 2.2, np.nan, q)}})
        return out

    rng = np.random.default_rng(5)
    a = np.concatenate([rng.uniform(0.9, 1.1, 9), [2.6, 2.3, 1.0, 2.6]])
    sigma = np.concatenate([rng.uniform(0.01, 0.05, 11), [-0.1, -0.1]])
    for discrepancy, names, extra in ((None, ("a", "sigma_eps"), []),
                                      (Discrepancy(), ("a", "sigma_eps", "delta_q", "delta_length"),
                                       [rng.uniform(0.001, 0.05, a.size), rng.uniform(0.05, 1.0, a.size)])):
        like = Likelihood(_obs(), forward, batch=True, discrepancy=discrepancy).bind(names)
        thetas = np.column_stack([a, sigma, *extra])
        values, reasons = like.evaluate_many(thetas)
        assert reasons[9] == "ForwardModelError: a refused" and "NaN" in reasons[10]
        assert reasons[11] == reasons[12] == "ForwardModelError: sigma_eps = -0.1 must be > 0"
        for i, theta in enumerate(thetas):
            alone, why = like.evaluate_many(theta[None, :])
            assert why[0] == reasons[i]
            if reasons[i] is None:
                assert values[i] == like(theta) == alone[0]
            else:
                assert values[i] == -np.inf


@pytest.mark.parametrize("odd", ["short", "interpolated", "missing"])
def test_a_list_whose_sets_give_curves_of_other_forms_is_scored_set_by_set(odd):
    """One set of a list gives its curve with a value short, as (x, y) to interpolate, or not at all: the sets
    cannot be taken as one batch of values, so each is scored as alone, its own reason for an unusable curve and
    the bits of ``like(theta)`` for the others. Oracle: each set evaluated by itself."""
    def forward(plist):
        out = []
        for p in plist:
            q = 10.0 * p["a"] * X
            if p["a"] == 1.5:
                q = {"short": q[:2], "interpolated": (X, q), "missing": None}[odd]
            out.append({"t": {} if q is None else {"q": q}})
        return out

    like = Likelihood(_obs(), forward, batch=True).bind(("a", "sigma_eps"))
    values, reasons = like.evaluate_many(THETAS)
    for i, theta in enumerate(THETAS):
        alone, why = like.evaluate_many(theta[None, :])
        assert why[0] == reasons[i]
        assert values[i] == alone[0]
    assert (reasons[2] is None) == (odd == "interpolated")
    assert reasons[0] is None and values[0] == like(THETAS[0])


def test_a_batch_whose_terms_raise_is_scored_set_by_set(monkeypatch):
    """Should the batched terms of a list of results raise (a covariance not positive definite for one set), every
    set is scored alone from the batch's one forward call (not solved again): the values are each set's own."""
    calls = []

    def forward(plist):
        calls.append(len(plist))
        return [{"t": {"q": 10.0 * p["a"] * X}} for p in plist]

    like = Likelihood(_obs(), forward, batch=True).bind(("a", "sigma_eps"))
    expected = np.array([like(theta) for theta in THETAS])
    batched = like._log_likelihood

    def refuse_batches(simulated, sigma, delta=None):
        if len(sigma) > 1:
            raise np.linalg.LinAlgError("not positive definite")
        return batched(simulated, sigma, delta)

    monkeypatch.setattr(like, "_log_likelihood", refuse_batches)
    calls.clear()
    values, reasons = like.evaluate_many(THETAS)
    assert calls == [len(THETAS)] and reasons == [None] * len(THETAS)
    np.testing.assert_array_equal(values, expected)
