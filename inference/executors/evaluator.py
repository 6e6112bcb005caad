"""The evaluator: a log-likelihood made robust for batches (exceptions, NaN and time-outs become -inf with a reason).

The policy for a batch that raises (each evaluation alone) is :func:`inference.forward.batch_or_each`; the
evaluator adds the time limits and turns NaN and +inf into -inf.
"""
from __future__ import annotations

import signal
import threading

import numpy as np

from ..forward import batch_or_each
from ..likelihood import Likelihood

__all__ = ["EvaluationTimeout", "Evaluator"]


class EvaluationTimeout(RuntimeError):
    """A forward evaluation ran past the executor's per-evaluation time limit."""


def _alarm(signum, frame):
    raise EvaluationTimeout("forward evaluation exceeded its time limit")


class Evaluator:
    """Wraps a log-likelihood into a robust batch function: thetas (m, d) -> (values (m,), reasons).

    ``loglike`` is a :class:`inference.Likelihood`, a callable theta (d,) -> float, or with ``vectorized=True`` a
    callable thetas (m, d) -> (m,). Exceptions, NaN/+inf and time-outs become -inf with a reason; NaN never leaves.
    """

    def __init__(self, loglike, vectorized=False, timeout=None):
        self.loglike = loglike
        self.vectorized = bool(vectorized)
        self.timeout = timeout

    def _timer(self, seconds):
        if not seconds or threading.current_thread() is not threading.main_thread():
            return None
        previous = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, seconds)
        return previous

    @staticmethod
    def _cancel(previous):
        if previous is not None:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)

    def _timed(self, call, m):
        """``call`` under the time limit of m evaluations."""
        def timed():
            previous = self._timer(self.timeout * m if self.timeout else None)
            try:
                return call()
            finally:
                self._cancel(previous)
        return timed

    def _one(self, theta):
        previous = self._timer(self.timeout)
        try:
            if self.vectorized:
                return float(np.asarray(self.loglike(theta[None, :]), dtype=float).ravel()[0])
            return float(self.loglike(theta))
        finally:
            self._cancel(previous)

    def __call__(self, thetas):
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        m = len(thetas)
        whole = None
        if isinstance(self.loglike, Likelihood):
            whole = self._timed(lambda: self.loglike.evaluate_many(thetas), m)
        elif self.vectorized and m > 1:
            whole = self._timed(lambda: (np.asarray(self.loglike(thetas), dtype=float).reshape(m), [None] * m), m)
        values, reasons = batch_or_each(whole, lambda i: (self._one(thetas[i]), None), m)
        bad = np.isnan(values) | (values == np.inf)
        for i in np.flatnonzero(bad):
            reasons[i] = f"log-likelihood evaluated to {values[i]}"
        values = np.where(bad, -np.inf, values)
        for i in np.flatnonzero(np.isneginf(values)):
            if reasons[i] is None:
                reasons[i] = "log-likelihood is -inf (zero likelihood)"
        return values, list(reasons)
