"""Chunks the executors hand a likelihood: a batched forward model gets up to BATCH_CHUNK parameter sets in one call
(serially; in the pool one chunk per worker at most that size), any other one set at a time, and the values are
those of each set evaluated alone, bit for bit."""
import math

import numpy as np
import pytest

from inference import Curve, ForwardModel, Likelihood, Observations, PoolExecutor, SerialExecutor, Test
from inference.executors import Evaluator
from inference.executors.local import BATCH_CHUNK

X = np.linspace(1.0, 5.0, 9)


class Quadratic(ForwardModel):
    """q = a x + b x^2, a batch of parameter sets in one call; records the size of every batch it is given."""

    def __init__(self):
        self.sizes = []

    def simulate_batch(self, names, values):
        self.sizes.append(len(values))
        a, b = values[:, [names.index("a")]], values[:, [names.index("b")]]
        return {"T": {"q": (X, a * X + b * X ** 2)}}, [None] * len(values)


def _likelihood(forward):
    obs = Observations([Test("T", {"q": Curve(X, 2.0 * X + 0.1 * X ** 2)})])
    return Likelihood(obs, forward, sigma="sigma_eps").bind(("a", "b", "sigma_eps"))


def _thetas(m):
    rng = np.random.default_rng(3)
    return np.column_stack([rng.uniform(1.5, 2.5, m), rng.uniform(0.0, 0.2, m), rng.uniform(0.01, 0.1, m)])


def test_a_batched_forward_model_gets_chunks_of_at_most_batch_chunk_sets_with_the_bits_of_each_alone():
    forward = Quadratic()
    like = _likelihood(forward)
    assert like.batch
    thetas = _thetas(2 * BATCH_CHUNK + 22)
    chunks = []
    values, reasons, _ = SerialExecutor().evaluate(Evaluator(like), thetas,
                                                   callback=lambda idx, v, r, ranks: chunks.append(len(idx)))
    assert chunks == [BATCH_CHUNK, BATCH_CHUNK, 22] and forward.sizes == chunks
    alone = np.array([like.evaluate_many(t[None, :])[0][0] for t in thetas])
    assert np.array_equal(values, alone) and np.all(np.isfinite(values)) and reasons == [None] * len(thetas)


def test_the_pool_hands_a_batched_likelihood_a_chunk_per_worker_of_at_most_batch_chunk_sets():
    like = _likelihood(Quadratic())
    for m in (40, 3 * BATCH_CHUNK + 5):
        thetas = _thetas(m)
        chunks = []
        with PoolExecutor(2) as pool:
            values, _, _ = pool.evaluate(Evaluator(like), thetas,
                                         callback=lambda idx, v, r, ranks: chunks.append(len(idx)))
        expected = min(BATCH_CHUNK, math.ceil(m / 2))
        assert max(chunks) == expected and sum(chunks) == m
        assert np.array_equal(values, SerialExecutor().evaluate(Evaluator(like), thetas)[0])


@pytest.mark.parametrize("m", [1, 7])
def test_a_forward_model_of_one_set_at_a_time_is_given_one_set_a_call(m):
    seen = []

    def one(p):
        seen.append(p["a"])
        return {"T": {"q": (X, p["a"] * X + p["b"] * X ** 2)}}

    like = _likelihood(one)
    assert not like.batch
    chunks = []
    SerialExecutor().evaluate(Evaluator(like), _thetas(m), callback=lambda idx, v, r, ranks: chunks.append(len(idx)))
    assert chunks == [1] * m and len(seen) == m
