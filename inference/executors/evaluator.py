"""The evaluator: a log-likelihood made robust for batches (exceptions, NaN and time-outs become -inf with a reason).
"""
from __future__ import annotations

import signal
import threading

import numpy as np

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
        values = np.full(m, -np.inf)
        reasons = [None] * m
        done = False
        if hasattr(self.loglike, "evaluate_many"):
            previous = self._timer(self.timeout * m if self.timeout else None)
            try:
                values, reasons = self.loglike.evaluate_many(thetas)
                values = np.array(values, dtype=float)
                done = True
            except Exception:
                done = False
            finally:
                self._cancel(previous)
        elif self.vectorized and m > 1:
            previous = self._timer(self.timeout * m if self.timeout else None)
            try:
                values = np.asarray(self.loglike(thetas), dtype=float).reshape(m)
                done = True
            except Exception:
                done = False  # evaluate one by one to attribute the failure
            finally:
                self._cancel(previous)
        if not done:
            for i, th in enumerate(thetas):
                try:
                    values[i] = self._one(th)
                except Exception as exc:
                    values[i] = -np.inf
                    reasons[i] = f"{type(exc).__name__}: {exc}"
        bad = np.isnan(values) | (values == np.inf)
        for i in np.flatnonzero(bad):
            reasons[i] = f"log-likelihood evaluated to {values[i]}"
        values = np.where(bad, -np.inf, values)
        for i in np.flatnonzero(np.isneginf(values)):
            if reasons[i] is None:
                reasons[i] = "log-likelihood is -inf (zero likelihood)"
        return values, list(reasons)
