"""Where log-likelihood evaluations run: serially, in a local process pool, or on MPI ranks.

Every evaluation of one parameter vector runs whole on one process (one forward solve per particle, as the paper's
SPMD scheme). The sampler hands an executor a batch of parameter vectors and gets back, for each, the
log-likelihood (or -inf), the failure reason (or None) and the rank that computed it. Results are stored by particle
index, so the order in which workers finish never changes the answer.

MPI (mpi4py, chosen automatically under ``mpirun -n K`` with K > 1):
- ``dynamic`` (default): rank 0 hands out one parameter vector at a time and keeps four in flight per worker, and
  computes vectors itself between polls, so every rank is busy even when forward-solve times differ;
- ``spmd``: static round-robin, rank r evaluates particles k with k % K == r (the paper's ``labindex`` scheme).
Every rank calls :func:`inference.tmcmc`; rank 0 runs the sampler, the others serve evaluations and receive the
final posterior. The sampler sees only :meth:`Executor.run` (its whole run, on the root rank), ``evaluate`` (one
batch) and ``close``; every executor has them, so the sampler never asks which kind it has.
"""
from __future__ import annotations

import math
import os
import signal
import sys
import threading
import traceback

import numpy as np

__all__ = ["EvaluationTimeout", "RootRankError", "Evaluator", "Executor", "SerialExecutor", "PoolExecutor",
           "MPIExecutor", "default_executor", "mpi_world"]


class EvaluationTimeout(RuntimeError):
    """A forward evaluation ran past the executor's per-evaluation time limit."""


class RootRankError(RuntimeError):
    """Raised on the other ranks when the root rank's run stopped with an error."""


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


# ------------------------------------------------------------------------------------------------ process pool
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


# ------------------------------------------------------------------------------------------------ MPI
_TAG_TASK, _TAG_RESULT, _TAG_STOP = 11, 12, 13


def mpi_world():
    """The MPI world communicator when running under mpirun with more than one rank, else None.

    mpi4py is imported only when an MPI launcher's environment is present, so serial runs never load MPI.
    """
    launched = any(k in os.environ for k in ("PMI_RANK", "PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "PMIX_RANK",
                                             "HYDRA_CONTROL_FD", "MPI_LOCALNRANKS", "SLURM_STEP_ID"))
    if not launched and "mpi4py" not in sys.modules:
        return None
    try:
        from mpi4py import MPI
    except Exception:  # pragma: no cover - mpi4py missing or broken
        return None
    comm = MPI.COMM_WORLD
    return comm if comm.Get_size() > 1 else None


class MPIExecutor(Executor):
    """Evaluations on MPI ranks; ``mode`` is "dynamic" (master/worker, default) or "spmd" (static round-robin)."""

    name = "mpi"

    def __init__(self, comm=None, mode="dynamic", depth=4):
        if mode not in ("dynamic", "spmd"):
            raise ValueError(f"MPI dispatch mode {mode!r}: use 'dynamic' or 'spmd'")
        self.comm = comm if comm is not None else mpi_world()
        if self.comm is None:
            raise RuntimeError("MPIExecutor needs mpirun with more than one rank")
        self.mode = mode
        self.depth = depth
        self.rank = self.comm.Get_rank()
        self.ranks = self.comm.Get_size()
        self.is_root = self.rank == 0
        self.name = f"mpi-{mode}"

    # ---- root side
    def evaluate(self, evaluator, thetas, callback=None, stop=None):
        m = len(thetas)
        values = np.full(m, np.nan)
        reasons = [None] * m
        ranks = np.zeros(m, dtype=int)

        def store(idx, v, r, rank):
            idx = np.atleast_1d(idx)
            values[idx] = v
            ranks[idx] = rank
            for i, reason in zip(idx, r):
                reasons[i] = reason
            if callback is not None:
                callback(idx, np.asarray(v), r, ranks[idx])

        if self.mode == "spmd":
            self.comm.bcast(("eval", thetas), root=0)
            mine = np.arange(0, m, self.ranks)
            v, r = evaluator(thetas[mine]) if mine.size else (np.empty(0), [])
            gathered = self.comm.gather((mine, v, r), root=0)
            for rank, (idx, vv, rr) in enumerate(gathered):
                store(idx, vv, rr, rank)
            return values, reasons, ranks

        comm = self.comm
        queue = list(range(m))
        queue.reverse()  # pop() hands out particle 0 first
        inflight = {w: 0 for w in range(1, self.ranks)}
        outstanding = 0
        stopping = False

        def send_next(worker):
            nonlocal outstanding
            if queue and not stopping:
                k = queue.pop()
                comm.send((k, thetas[k]), dest=worker, tag=_TAG_TASK)
                inflight[worker] += 1
                outstanding += 1

        def receive(block):
            nonlocal outstanding
            from mpi4py import MPI

            status = MPI.Status()
            while block or comm.Iprobe(source=MPI.ANY_SOURCE, tag=_TAG_RESULT, status=status):
                msg = comm.recv(source=MPI.ANY_SOURCE, tag=_TAG_RESULT, status=status)
                worker = status.Get_source()
                if msg[0] == "error":
                    raise RuntimeError(f"MPI rank {worker} failed outside a forward evaluation:\n{msg[1]}")
                _, k, v, r = msg
                inflight[worker] -= 1
                outstanding -= 1
                store([k], [v], [r], worker)
                send_next(worker)
                block = False

        for w in inflight:
            for _ in range(self.depth):
                send_next(w)
        while queue or outstanding:
            if stop is not None and stop():
                stopping = True
            if queue and not stopping:
                k = queue.pop()
                v, r = evaluator(thetas[k:k + 1])
                store([k], v, r, 0)
                receive(block=False)
            else:
                if outstanding == 0:
                    break
                receive(block=True)
        return values, reasons, ranks

    def run(self, evaluator, main):
        """Rank 0 calls ``main()`` and hands its result (or how it stopped) to the workers, which serve ``evaluator``
        meanwhile: a result is returned on every rank, SystemExit raises SystemExit with the same code on every
        rank, another exception raises :class:`RootRankError` on the workers."""
        if not self.is_root:
            kind, value = self.serve(evaluator)
            if kind == "exit":
                raise SystemExit(value)
            if kind == "error":
                raise RootRankError(f"rank 0 stopped: {value}")
            return value
        try:
            value = main()
        except SystemExit as exc:
            self.finish(("exit", exc.code))
            raise
        except BaseException as exc:
            self.finish(("error", f"{type(exc).__name__}: {exc}"))
            raise
        self.finish(("ok", value))
        return value

    def finish(self, payload):
        """Release the workers and hand them ``payload``: ("ok", result), ("exit", status) or ("error", message)."""
        if self.mode == "spmd":
            self.comm.bcast(("stop", None), root=0)
        else:
            for w in range(1, self.ranks):
                self.comm.send(None, dest=w, tag=_TAG_STOP)
        return self.comm.bcast(payload, root=0)

    # ---- worker side
    def serve(self, evaluator):
        """Worker loop on ranks > 0: evaluate what rank 0 sends until told to stop; returns rank 0's payload."""
        comm = self.comm
        flags = {"signal": None}

        def note(signum, frame):  # rank 0 decides what to do on SIGTERM/SIGUSR1; keep serving until told
            flags["signal"] = signum

        for sig in (signal.SIGTERM, signal.SIGUSR1):
            signal.signal(sig, note)
        if self.mode == "spmd":
            while True:
                kind, thetas = comm.bcast(None, root=0)
                if kind == "stop":
                    break
                mine = np.arange(self.rank, len(thetas), self.ranks)
                try:
                    v, r = evaluator(thetas[mine]) if mine.size else (np.empty(0), [])
                except Exception:  # pragma: no cover - Evaluator catches forward errors itself
                    v, r = np.full(mine.size, -np.inf), [traceback.format_exc()] * mine.size
                comm.gather((mine, v, r), root=0)
        else:
            from mpi4py import MPI

            status = MPI.Status()
            while True:
                msg = comm.recv(source=0, tag=MPI.ANY_TAG, status=status)
                if status.Get_tag() == _TAG_STOP:
                    break
                try:
                    k, theta = msg
                    v, r = evaluator(np.asarray(theta)[None, :])
                    comm.send(("ok", k, float(v[0]), r[0]), dest=0, tag=_TAG_RESULT)
                except Exception:
                    comm.send(("error", traceback.format_exc()), dest=0, tag=_TAG_RESULT)
        return comm.bcast(None, root=0)


def default_executor(dispatch="dynamic", processes=None):
    """MPI under mpirun with more than one rank, else the local process pool (one process per core), or serial
    on a one-core machine."""
    comm = mpi_world()
    if comm is not None:
        return MPIExecutor(comm, mode=dispatch)
    n = processes or os.cpu_count() or 1
    return PoolExecutor(n) if n > 1 else SerialExecutor()
