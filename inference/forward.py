"""The forward-model protocol of :class:`inference.Likelihood`, its adapters for plain callables, the failure
policy of a batch of evaluations (written once here, applied by the likelihood and the executors' evaluator), one
solve per distinct parameter set of a batch (:func:`simulate_distinct`), and a batch's results per particle
(:func:`particle_result`) or as one table (:func:`stacked_results`).

A forward model maps m parameter sets to simulated curves:

    simulate_batch(names, values) -> (curves, failed)

``names``: the parameter names (a tuple: the prior's order without the error parameters); ``values``: (m, k) array
of their values, one row per particle (parameter set), in the units of the model's parameters. ``curves`` is either

* a table for the whole batch, ``{test: {curve: y (m, n_recorded)}}`` at the recorded abscissae or
  ``{test: {curve: (x_sim (n,), y (m, n))}}`` on one simulated abscissa for every particle (the likelihood
  interpolates linearly to the recorded abscissae; the simulation must cover them), or
* a list of m per-particle results ``{test: {curve: y (n_recorded,) or (x_sim (n,), y (n,))}}`` (None for a failed
  particle);

``failed`` is a list of m entries: None, or the exception that explains why that particle has no usable curves (its
rows or result are then ignored; the reason recorded is the exception's class and message). Abscissae and values are
in the units of the recorded curves.

A model whose values the whole batch cannot be simulated with raises; the failure policy (:func:`batch_or_each`)
then evaluates each particle alone, and a particle that still raises gets log-likelihood -inf with the reason
``"<exception class>: <message>"``. A model with ``batched = False`` is only ever given one particle at a time.

Parameter sets of a batch that differ only in what the forward model does not take (a likelihood's error or
discrepancy parameters: a finite-difference stencil moves them about one set of soil parameters) share one solve.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping

import numpy as np

__all__ = ["ForwardModelError", "ForwardModel", "ParticleForward", "ListForward", "as_forward_model", "batch_or_each",
           "particle_dicts", "reason_of", "distinct_rows", "simulate_distinct", "particle_result",
           "stacked_results"]


class ForwardModelError(RuntimeError):
    """The forward model gave no usable curves for this parameter vector (reason in the message)."""


def reason_of(exc: BaseException) -> str:
    """The recorded reason of a failed evaluation: ``"<exception class>: <message>"``."""
    return f"{type(exc).__name__}: {exc}"


def batch_or_each(whole, alone, m: int):
    """The failure policy of m evaluations: ``whole()`` -> (values (m,), reasons) for the batch (None: no batch
    call); if it is None or raises, ``alone(i)`` -> (value, reason) for each i, and an i that raises gets -inf with
    :func:`reason_of` its exception. Returns (values (m,) float array, reasons list of m, None where fine)."""
    if whole is not None:
        try:
            values, reasons = whole()
        except Exception:  # noqa: BLE001 - the batch failed as a whole: each evaluation alone names the culprits
            pass
        else:
            return np.array(values, dtype=float), list(reasons)
    values = np.full(m, -np.inf)
    reasons = [None] * m
    for i in range(m):
        try:
            values[i], reasons[i] = alone(i)
        except Exception as exc:  # noqa: BLE001 - a failed evaluation is this particle's zero likelihood
            values[i], reasons[i] = -np.inf, reason_of(exc)
    return values, reasons


class ForwardModel(ABC):
    """The forward-model protocol (module docstring). ``batched``: :meth:`simulate_batch` accepts any number of
    particles (False: the likelihood gives it one at a time)."""

    batched = True

    @abstractmethod
    def simulate_batch(self, names, values) -> tuple:
        """(names (k,), values (m, k)) -> (curves, failed): see the module docstring."""


def particle_dicts(names, values) -> list:
    """One parameter dict {name: float} per row of ``values`` (m, k)."""
    return [{n: float(v) for n, v in zip(names, row)} for row in np.atleast_2d(values)]


class ParticleForward(ForwardModel):
    """A single-particle callable params dict -> {test: {curve: values or (x, y)}} as a :class:`ForwardModel`
    (``batched = False``; an exception of the callable is that particle's failure)."""

    batched = False

    def __init__(self, function):
        self.function = function

    def simulate_batch(self, names, values) -> tuple:
        return [self.function(p) for p in particle_dicts(names, values)], [None] * len(np.atleast_2d(values))


class ListForward(ForwardModel):
    """A forward model called on a list of parameter dicts that returns the list of per-particle results, an
    exception instance in place of a failed particle's (raising when the batch cannot be simulated as a whole).
    Subclasses define ``__call__``; :meth:`of` wraps a plain callable."""

    @abstractmethod
    def __call__(self, batch) -> list:
        """A list of m parameter dicts -> the list of m results (module docstring), an exception in place of a
        failed particle's."""

    @staticmethod
    def of(function) -> "ListForward":
        """A plain list callable as a :class:`ListForward`."""
        return _CallableList(function)

    def simulate_batch(self, names, values) -> tuple:
        results = self(particle_dicts(names, values))
        failed = [r if isinstance(r, Exception) else None for r in results]
        return [None if f is not None else r for r, f in zip(results, failed)], failed


class _CallableList(ListForward):
    """A plain list callable as a :class:`ListForward`."""

    def __init__(self, function):
        self.function = function

    def __call__(self, batch) -> list:
        return self.function(batch)


def as_forward_model(forward, batch: bool) -> ForwardModel:
    """``forward`` itself when it is a :class:`ForwardModel`, else the callable adapted: a list callable
    (``batch=True``) by :class:`ListForward`, a single-particle one by :class:`ParticleForward`."""
    if isinstance(forward, ForwardModel):
        return forward
    return ListForward.of(forward) if batch else ParticleForward(forward)


def distinct_rows(rows):
    """(first, inverse) of the rows of ``rows`` (m, k): ``first`` the index of each distinct row's first occurrence,
    in the order of occurrence; ``inverse`` (m,) the position in ``first`` of the row equal to each row (a row
    holding NaN equals no other)."""
    rows = np.ascontiguousarray(rows)
    _, index, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(index)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return index[order], rank[np.asarray(inverse).ravel()]


def simulate_distinct(forward: ForwardModel, names, values) -> tuple:
    """``forward.simulate_batch(names, values)`` (module docstring) with each distinct row of ``values`` (m, k)
    solved once, in the order of first occurrence, and its curves and failure handed to every row equal to it."""
    first, inverse = distinct_rows(values)
    if len(first) == len(values):
        return forward.simulate_batch(names, values)
    curves, failed = forward.simulate_batch(names, values[first])
    failed = [failed[k] for k in inverse]
    if not isinstance(curves, Mapping):
        return [curves[k] for k in inverse], failed
    return ({t: {c: (v[0], np.asarray(v[1])[inverse]) if isinstance(v, tuple) else np.asarray(v)[inverse]
                 for c, v in cs.items()} for t, cs in curves.items()}, failed)


def stacked_results(results, curves: dict):
    """A list of per-particle results (module docstring) as the table ``{test: {curve: y (m, n)}}`` of the curves
    ``curves`` ({test: curve names}) when each result gives each of them as values at the records of one size (not
    as (x, y)); else None."""
    out = {}
    for test, names in curves.items():
        out[test] = {}
        for name in names:
            parts = []
            for result in results:
                curves_of_test = result.get(test) if isinstance(result, Mapping) else None
                y = curves_of_test.get(name) if isinstance(curves_of_test, Mapping) else None
                if y is None or isinstance(y, tuple):
                    return None
                parts.append(np.asarray(y, dtype=float))
            if not parts or any(y.shape != parts[0].shape for y in parts):
                return None
            out[test][name] = np.stack(parts)
    return out


def particle_result(curves, failed, i):
    """Particle i's forward result from a batch's (curves, failed): its exception, or {test: {curve: values or
    (x, y)}}."""
    if failed[i] is not None:
        return failed[i]
    if isinstance(curves, Mapping):
        return {t: {c: (v[0], v[1][i]) if isinstance(v, tuple) else v[i] for c, v in cs.items()}
                for t, cs in curves.items()}
    return curves[i]
