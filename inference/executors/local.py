"""Executors in one process or a local process pool, and the :class:`Executor` interface every executor has.
"""
from __future__ import annotations

import ctypes
import math
import os
import signal
import sys
import threading
import time

import numpy as np

__all__ = ["Executor", "SerialExecutor", "PoolExecutor", "WATCHDOG_INTERVAL_S"]


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

#: how often a pool worker's watchdog compares its parent process id with the pool owner's (s)
WATCHDOG_INTERVAL_S = 0.5

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _pool_init(evaluator, owner_pid, death_signal):
    """Worker start-up: the evaluator (spawn start method only), signals, and death with the pool's owner.

    The parent handles SIGTERM/SIGINT (checkpoint and exit), so workers ignore them and never die half-way through a
    task. Because they ignore SIGTERM, a worker must notice by itself that its parent is gone (SIGKILL, a crash):
    the kernel's death signal (``death_signal``, Linux) and a watchdog thread, see :class:`PoolExecutor`. The check
    after the request closes the race of an owner that died before the request was made.
    """
    global _POOL_EVALUATOR
    if evaluator is not None:
        _POOL_EVALUATOR = evaluator
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGUSR1, signal.SIG_IGN)
    if death_signal:
        _request_parent_death_signal()
    if os.getppid() != owner_pid:  # the owner died before (or while) this worker started
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(owner_pid,), name="pool-parent-watchdog", daemon=True).start()


def _request_parent_death_signal():
    """Linux: ask the kernel for SIGKILL when the parent dies (prctl PR_SET_PDEATHSIG); elsewhere nothing."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - no usable libc: the watchdog alone
        pass


def _watch_parent(owner_pid):
    """The portable fallback: exit as soon as the parent process is no longer the pool's owner (re-parented)."""
    while os.getppid() == owner_pid:
        time.sleep(WATCHDOG_INTERVAL_S)
    os._exit(1)


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

    Workers die with their parent, even when it is killed with SIGKILL (no clean shut-down): on Linux the kernel
    sends them SIGKILL (prctl PR_SET_PDEATHSIG); everywhere a watchdog thread in each worker exits it within
    :data:`WATCHDOG_INTERVAL_S` once its parent process id changes (the watchdog needs the GIL, so a worker inside
    a long compiled call exits when the call returns). The kernel's signal follows the *thread* that started the
    workers, so it is requested only when the pool is started from the main thread; from any other thread the
    watchdog alone applies (a pool started in a thread that ends would otherwise lose its workers).
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
        death_signal = threading.current_thread() is threading.main_thread()
        self._pool = ProcessPoolExecutor(self.processes, mp_context=ctx, initializer=_pool_init,
                                         initargs=(initarg, os.getpid(), death_signal))
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
