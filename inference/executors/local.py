"""Executors in one process or a local process pool, and the :class:`Executor` interface every executor has.
"""
from __future__ import annotations

import math
import os
import signal

import numpy as np

__all__ = ["Executor", "SerialExecutor", "PoolExecutor"]


class Executor:
    """Where evaluations run. ``run(evaluator, main)`` calls ``main()`` on the root rank and returns its result on
    every rank (other ranks serve ``evaluator`` meanwhile); ``evaluate`` evaluates one batch on the root rank."""

    name = "base"
    ranks = 1
    is_root = True

    def run(self, evaluator, main):
        """``main()`` (which calls ``evaluate``) on the root rank; its result, returned on every rank."""
        return main()

    def evaluate(self, evaluator, thetas, callback=None, stop=None):
        """Evaluate every row of thetas. ``callback(indices, values, reasons, ranks)`` is called as results arrive;
        ``stop()`` returning True asks to stop early (rows not evaluated are returned as NaN with reason None).
        Returns (values, reasons, ranks)."""
        raise NotImplementedError

    def finish(self, payload):
        """Release the other ranks, handing them ``payload``; returns it (nothing to release in one process)."""
        return payload

    def serve(self, evaluator):
        """Serve evaluations on a rank other than the root until released (only MPI has such ranks)."""
        raise RuntimeError(f"the {self.name} executor has no ranks other than the root")

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class SerialExecutor(Executor):
    """Evaluates in this process, in chunks (a vectorized log-likelihood gets the whole chunk at once)."""

    name = "serial"

    def __init__(self, chunk=None):
        self.chunk = chunk

    def evaluate(self, evaluator, thetas, callback=None, stop=None):
        m = len(thetas)
        values = np.full(m, np.nan)
        reasons = [None] * m
        ranks = np.zeros(m, dtype=int)
        chunk = self.chunk or (m if (evaluator.vectorized or getattr(evaluator.loglike, "batch", False)) else 1)
        for start in range(0, m, chunk):
            if stop is not None and stop():
                break
            idx = np.arange(start, min(m, start + chunk))
            v, r = evaluator(thetas[idx])
            values[idx] = v
            for i, reason in zip(idx, r):
                reasons[i] = reason
            if callback is not None:
                callback(idx, v, r, ranks[idx])
        return values, reasons, ranks


_POOL_EVALUATOR = None


def _pool_init(evaluator):
    global _POOL_EVALUATOR
    if evaluator is not None:
        _POOL_EVALUATOR = evaluator
    # the parent handles SIGTERM/SIGINT (checkpoint and exit); workers must not die half-way through a task
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGUSR1, signal.SIG_IGN)


def _pool_task(args):
    idx, thetas = args
    values, reasons = _POOL_EVALUATOR(thetas)
    return idx, values, reasons, os.getpid()


class PoolExecutor(Executor):
    """A local process pool (the embedded default on a laptop or workstation without mpirun).

    Workers are forked with the evaluator already in memory (nothing but parameter vectors crosses processes);
    where fork is unavailable the evaluator is pickled once per worker. Workers ignore SIGTERM/SIGINT so that a
    signal sent to the whole process group (Slurm) reaches only the parent, which checkpoints; the pool is shut down
    with sentinels (running evaluations finish, queued ones are cancelled), never with signals.
    """

    name = "pool"

    def __init__(self, processes=None, chunk=None):
        self.processes = processes or os.cpu_count() or 1
        self.ranks = self.processes
        self.chunk = chunk
        self._pool = None
        self._evaluator = None
        self._pids = {}

    def _ensure(self, evaluator):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        if self._pool is not None and self._evaluator is evaluator:
            return
        self.close()
        global _POOL_EVALUATOR
        if "fork" in mp.get_all_start_methods():
            _POOL_EVALUATOR = evaluator
            ctx, initarg = mp.get_context("fork"), None
        else:  # pragma: no cover - not on Linux
            ctx, initarg = mp.get_context("spawn"), evaluator
        self._pool = ProcessPoolExecutor(self.processes, mp_context=ctx, initializer=_pool_init, initargs=(initarg,))
        self._evaluator = evaluator

    def evaluate(self, evaluator, thetas, callback=None, stop=None):
        from concurrent.futures import as_completed

        self._ensure(evaluator)
        m = len(thetas)
        values = np.full(m, np.nan)
        reasons = [None] * m
        ranks = np.zeros(m, dtype=int)
        vec = evaluator.vectorized or getattr(evaluator.loglike, "batch", False)
        chunk = self.chunk or (math.ceil(m / self.processes) if vec else max(1, m // (8 * self.processes)))
        futures = [self._pool.submit(_pool_task, (np.arange(s, min(m, s + chunk)), thetas[s:s + chunk]))
                   for s in range(0, m, chunk)]
        try:
            for fut in as_completed(futures):
                idx, v, r, pid = fut.result()
                rank = self._pids.setdefault(pid, len(self._pids))
                values[idx] = v
                ranks[idx] = rank
                for i, reason in zip(idx, r):
                    reasons[i] = reason
                if callback is not None:
                    callback(idx, v, r, ranks[idx])
                if stop is not None and stop():
                    break
        finally:
            for fut in futures:
                fut.cancel()
        return values, reasons, ranks

    def close(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            self._evaluator = None
