"""The loop's refined evidence (cases.study.loop.evidence.refined_evidence) solves each set of soil parameters of
a finite-difference stencil once: the same estimate, to the bit, as the plain evaluation of every set, with the
forward model given only the distinct sets. A toy forward model and two error groups, no soil code."""
from types import SimpleNamespace

import numpy as np

import inference
from cases.study.loop.evidence import refined_evidence
from inference import Bound, Curve, ForwardModel, Likelihood, Observations, Prior, Test

X = np.linspace(1.0, 3.0, 12)
NOISE = np.random.default_rng(4).standard_normal((2, len(X)))


class Counted(ForwardModel):
    """q = 10 a x and u = 5 b x; counts the parameter sets it is given."""

    def __init__(self):
        self.rows = 0

    def simulate_batch(self, names, values):
        self.rows += len(values)
        a, b = values[:, names.index("a")], values[:, names.index("b")]
        return {"t": {"q": 10.0 * a[:, None] * X, "u": 5.0 * b[:, None] * X}}, [None] * len(values)


def _likelihood(forward):
    obs = Observations([Test("t", {"q": Curve(X, 10.0 * X * (1 + 0.02 * NOISE[0])),
                                   "u": Curve(X, 5.0 * X * (1 + 0.05 * NOISE[1]))})])
    names = ("a", "b", "sigma_eps_q", "sigma_eps_u")
    return Likelihood(obs, forward, groups={"q": ["q"], "u": ["u"]}).bind(names)


def test_the_stencil_shares_its_solves_and_the_estimate_is_unchanged():
    prior = Prior([Bound("a", 0.5, 1.5), Bound("b", 0.5, 1.5), Bound("sigma_eps_q", 0.005, 0.2, "log-uniform"),
                   Bound("sigma_eps_u", 0.005, 0.2, "log-uniform")])
    rng = np.random.default_rng(1)
    samples = np.column_stack([1 + 0.02 * rng.standard_normal(64), 1 + 0.03 * rng.standard_normal(64),
                               np.full(64, 0.03), np.full(64, 0.06)])
    counted = Counted()
    like = _likelihood(counted)
    post = SimpleNamespace(samples=samples, log_like=like.evaluate_many(samples)[0], names=prior.names)
    counted.rows = 0
    shared = refined_evidence(like, prior, post, 3, None, inference.SerialExecutor)

    plain = Counted()
    reference = _likelihood(plain)
    single = inference.Evaluator(lambda theta: reference(theta))     # one set per call: every set solved
    with inference.SerialExecutor() as pool:
        expected = inference.mode_evidence(lambda t: pool.evaluate(single, t)[0], prior, samples,
                                           log_values=post.log_like, seed=3)
    assert shared.to_dict() == expected.to_dict()
    assert plain.rows == expected.n_solves
    # a stencil of d = 4 parameters has d^2 + d + 1 = 21 sets, of which p^2 + p + 1 = 7 hold distinct soil
    # parameters (p = 2): 14 fewer solves per stencil; the trial steps and importance draws share none
    saved = plain.rows - counted.rows
    assert saved > 0 and saved % 14 == 0
