"""Executors in one process or a local process pool, and the :class:`Executor` interface every executor has.
"""
from __future__ import annotations

import atexit
import ctypes
import math
import multiprocessing as mp
import os
import signal
import sys
import threading
import time
import traceback
import weakref
from collections import deque
from multiprocessing.connection import wait

import numpy as np

__all__ = ["Executor", "SerialExecutor", "PoolExecutor", "WATCHDOG_INTERVAL_S", "MAX_WORKER_DEATHS", "BATCH_CHUNK",
           "batch_capable", "child_start", "close_at_exit", "closed", "how_it_ended"]

#: the most parameter sets handed at once to a likelihood whose forward model takes batches (``loglike.batch``):
#: one call then carries the per-call work (the drivers' set-up, the Python around the compiled loops) for up to this
#: many sets, while a chunk stays short enough for progress lines, a prompt stop and a pool's redone chunk
BATCH_CHUNK = 64


def batch_capable(evaluator) -> bool:
    """The evaluator's log-likelihood takes a batch of parameter sets in one forward call (``inference.Likelihood``
    with a batched forward model)."""
    return bool(getattr(evaluator.loglike, "batch", False))


class Executor:
    """Where evaluations run. ``run(evaluator, main)`` calls ``main()`` on the root rank and returns its result on
    every rank (other ranks serve ``evaluator`` meanwhile); ``evaluate`` evaluates one batch on the root rank."""

    name = "base"
    ranks = 1
    is_root = True

    def run(self, evaluator, main):
        """``main()`` (which calls ``evaluate``) on the root rank; its result, returned on every rank."""
        return main()

    def evaluate(self, evaluator, thetas, callback=None, stop=None, note=None):
        """Evaluate every row of thetas. ``callback(indices, values, reasons, ranks)`` is called as results arrive;
        ``stop()`` returning True asks to stop early (rows not evaluated are returned as NaN with reason None);
        ``note(line)`` receives one line per event the run should log (a pool worker lost and replaced).
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
    """Evaluates in this process, in chunks: a vectorized log-likelihood gets the whole batch at once, a likelihood
    whose forward model takes batches up to :data:`BATCH_CHUNK` sets at once, any other one set at a time."""

    name = "serial"

    def __init__(self, chunk=None):
        self.chunk = chunk

    def evaluate(self, evaluator, thetas, callback=None, stop=None, note=None):
        m = len(thetas)
        values = np.full(m, np.nan)
        reasons = [None] * m
        ranks = np.zeros(m, dtype=int)
        chunk = self.chunk or (m if evaluator.vectorized else min(m, BATCH_CHUNK) if batch_capable(evaluator)
                               else 1)
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


#: how often a pool worker's watchdog compares its parent process id with the pool owner's (s)
WATCHDOG_INTERVAL_S = 0.5

#: how many times one evaluation may take its pool worker down before it counts as a failed forward solve
MAX_WORKER_DEATHS = 3

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>

#: owners of live helper processes (pools, a figure drawer) not closed yet: held (a pool's workers inherit each
#: other's pipes, so they would not see the end of a pool that is collected) or, where the helper ends with its
#: owner's pipe, weakly
_LIVE_OWNERS, _LIVE_WEAK_OWNERS = set(), weakref.WeakSet()


def child_start(owner_pid, death_signal):
    """Start-up of a forked helper process (a pool worker, the figures' background drawer): signals, and death with
    its owner ``owner_pid``.

    The parent handles SIGTERM/SIGINT (checkpoint and exit), so helpers ignore them and never die half-way through a
    task. Because they ignore SIGTERM, a helper must notice by itself that its parent is gone (SIGKILL, a crash):
    the kernel's death signal (``death_signal``, Linux; ask it only for a helper forked from the main thread) and a
    watchdog thread, see :class:`PoolExecutor`. The check after the request closes the race of an owner that died
    before the request was made.
    """
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


def _serve(conn, evaluator, owner_pid, death_signal):
    """A worker's loop: evaluate the (batch, indices, thetas) tasks read from ``conn`` until None or the pipe closes;
    answer (batch, indices, values, reasons, None), or a traceback in place of the results for an error outside
    the forward evaluations (which the evaluator turns into -inf itself)."""
    child_start(owner_pid, death_signal)
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        if task is None:
            return
        batch, idx, thetas = task
        try:
            values, reasons = evaluator(thetas)
        except Exception:
            conn.send((batch, idx, None, None, traceback.format_exc()))
        else:
            conn.send((batch, idx, values, reasons, None))


def close_at_exit(owner, weak: bool = False):
    """Have ``owner.close()`` called at interpreter exit unless :func:`closed` says it was closed before. ``owner``
    holds helper processes started with :func:`child_start`: they ignore SIGTERM, so multiprocessing's own exit
    handler, which sends SIGTERM to its daemonic children and then joins every child, would wait for them forever.
    ``weak``: ``owner`` is not kept alive for this (its helpers end when it is collected). The handler is registered
    after multiprocessing's (anew whenever the first owner of a round comes), so it runs first (atexit runs the last
    registered first)."""
    if not _LIVE_OWNERS and not _LIVE_WEAK_OWNERS:
        atexit.unregister(_close_live_owners)
        atexit.register(_close_live_owners)
    (_LIVE_WEAK_OWNERS if weak else _LIVE_OWNERS).add(owner)


def closed(owner):
    """``owner`` has closed its helper processes (:func:`close_at_exit`)."""
    _LIVE_OWNERS.discard(owner)
    _LIVE_WEAK_OWNERS.discard(owner)


def _close_live_owners():
    for owner in [*_LIVE_OWNERS, *_LIVE_WEAK_OWNERS]:
        owner.close()


def how_it_ended(exitcode) -> str:
    """How a process ended, in words, from its exit code (a signal's name, or the exit status)."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by signal {-exitcode} ({signal.Signals(-exitcode).name})"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exited with status {exitcode}"


class _Worker:
    """One worker process of the pool: its end of the pipe and the task it runs, (batch, indices) or None."""

    def __init__(self, ctx, evaluator):
        conn, child = ctx.Pipe()
        death_signal = threading.current_thread() is threading.main_thread()
        self.process = ctx.Process(target=_serve, args=(child, evaluator, os.getpid(), death_signal),
                                   name="inference-pool-worker")
        self.process.start()
        child.close()
        self.conn = conn
        self.task = None

    def end(self):
        """Wait for the process to exit, answers it still sends read and dropped (a full pipe never blocks it)."""
        while True:
            ready = wait([self.conn, self.process.sentinel])
            if self.process.sentinel in ready:
                break
            try:
                self.conn.recv()
            except (EOFError, OSError):
                break
        self.process.join()
        self.conn.close()


class PoolExecutor(Executor):
    """A local process pool (the embedded default on a laptop or workstation without mpirun).

    Workers are forked with the evaluator already in memory (nothing but parameter vectors crosses processes);
    where fork is unavailable the evaluator is pickled once per worker. Each worker has its own pipe and runs one
    chunk of a batch at a time, so the pool always knows which evaluations each worker has in flight. Workers ignore
    SIGTERM/SIGINT so that a signal sent to the whole process group (Slurm) reaches only the parent, which
    checkpoints; the pool is shut down with sentinels (running evaluations finish, queued ones are dropped), never
    with signals.

    Self-healing: a worker that dies (killed, out of memory, a segfault in compiled code) is replaced by a new
    process in its rank, and the chunk it was evaluating is put back at the head of the queue, so the batch ends
    with exactly the values of an uninterrupted one (evaluations are deterministic; results are stored by index).
    Each loss is reported in one line, to ``note`` (the run's progress log) or else stderr: the worker's pid, the
    signal or exit status, and how many evaluations are redone. A chunk that takes a worker down a second time is
    redone one evaluation per task, to find the culprit (a vectorized log-likelihood then sees single rows); an
    evaluation that has taken workers down ``max_deaths`` times (:data:`MAX_WORKER_DEATHS`, counting the deaths of
    the chunks it was in) is given up as a failed forward solve (-inf with the reason), so the sampler's failed-solve
    policy applies instead of a crash loop. Workers that die with nothing of the batch in flight, more than
    ``max_deaths`` times per worker in one batch, stop the batch with an error.

    Workers die with their parent, even when it is killed with SIGKILL (no clean shut-down): on Linux the kernel
    sends them SIGKILL (prctl PR_SET_PDEATHSIG); everywhere a watchdog thread in each worker exits it within
    :data:`WATCHDOG_INTERVAL_S` once its parent process id changes (the watchdog needs the GIL, so a worker inside
    a long compiled call exits when the call returns). The kernel's signal follows the *thread* that started the
    worker, so it is requested only for workers started from the main thread; from any other thread the watchdog
    alone applies (a pool started in a thread that ends would otherwise lose its workers).
    """

    name = "pool"

    def __init__(self, processes=None, chunk=None, max_deaths=MAX_WORKER_DEATHS):
        self.processes = processes or os.cpu_count() or 1
        self.ranks = self.processes
        self.chunk = chunk
        self.max_deaths = max(1, int(max_deaths))
        self._workers = []
        self._evaluator = None
        self._ctx = None
        self._batch = 0

    def _ensure(self, evaluator):
        if self._workers and self._evaluator is evaluator:
            return
        self.close()
        method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
        self._ctx = mp.get_context(method)
        self._evaluator = evaluator
        self._workers = [_Worker(self._ctx, evaluator) for _ in range(self.processes)]
        close_at_exit(self)

    def evaluate(self, evaluator, thetas, callback=None, stop=None, note=None):
        self._ensure(evaluator)
        self._batch += 1
        batch = _Batch(self, self._batch, thetas, callback, note)
        while batch.unfinished():
            if stop is not None and stop():
                break
            for rank, worker in enumerate(self._workers):
                if worker.task is None and batch.queue:
                    batch.send(rank)
            conns = {w.conn: rank for rank, w in enumerate(self._workers)}
            sentinels = {w.process.sentinel: rank for rank, w in enumerate(self._workers)}
            for ready in wait(list(conns) + list(sentinels), timeout=1.0):
                rank = conns.get(ready, sentinels.get(ready))
                if self._workers[rank].conn is not ready and self._workers[rank].process.sentinel is not ready:
                    continue  # this worker was replaced while handling an earlier ready object
                batch.receive(rank)
        return batch.values, batch.reasons, batch.ranks

    def _replace(self, rank):
        """Start a new worker in ``rank`` in place of the dead one; returns (old pid, how it ended, new pid)."""
        old = self._workers[rank]
        old.process.join()
        old.conn.close()
        self._workers[rank] = _Worker(self._ctx, self._evaluator)
        return old.process.pid, how_it_ended(old.process.exitcode), self._workers[rank].process.pid

    def close(self):
        for worker in self._workers:
            try:
                worker.conn.send(None)
            except OSError:
                pass
        for worker in self._workers:
            worker.end()
        self._workers = []
        self._evaluator = None
        closed(self)


class _Batch:
    """One batch on a :class:`PoolExecutor`: the chunks still to send, the results, and the workers' deaths."""

    def __init__(self, pool, batch_id, thetas, callback, note):
        self.pool = pool
        self.id = batch_id
        self.thetas = thetas
        self.callback = callback
        self.note = note
        m = len(thetas)
        self.values = np.full(m, np.nan)
        self.reasons = [None] * m
        self.ranks = np.zeros(m, dtype=int)
        self.deaths = np.zeros(m, dtype=int)
        self.idle_deaths = 0
        ev = pool._evaluator
        n = pool.processes
        # a vectorized log-likelihood: one chunk per worker; a batched forward model: one per worker as well, at most
        # BATCH_CHUNK (a large batch is then spread in chunks of that size); else small chunks that keep every worker
        # busy to the end
        chunk = pool.chunk or (math.ceil(m / n) if ev.vectorized else
                               min(BATCH_CHUNK, math.ceil(m / n)) if batch_capable(ev) else
                               max(1, m // (8 * n)))
        self.queue = deque(np.arange(s, min(m, s + chunk)) for s in range(0, m, chunk))

    def unfinished(self):
        return bool(self.queue) or any(w.task is not None and w.task[0] == self.id for w in self.pool._workers)

    def send(self, rank):
        worker = self.pool._workers[rank]
        idx = self.queue.popleft()
        try:
            worker.conn.send((self.id, idx, self.thetas[idx]))
        except OSError:  # it died while idle: the chunk never reached it
            self.queue.appendleft(idx)
            self.lost(rank)
            return
        worker.task = (self.id, idx)

    def receive(self, rank):
        """Read what ``rank`` answered, or handle its death."""
        worker = self.pool._workers[rank]
        answer = None
        if worker.conn.poll():
            try:
                answer = worker.conn.recv()
            except (EOFError, OSError):
                answer = None
        if answer is None:
            if not worker.process.is_alive():
                self.lost(rank)
            return
        batch, idx, v, r, error = answer
        worker.task = None
        if error is not None:
            raise RuntimeError(f"pool worker {worker.process.pid} failed outside a forward evaluation:\n{error}")
        if batch == self.id:
            self.store(idx, v, r, rank)

    def store(self, idx, v, r, rank):
        self.values[idx] = v
        self.ranks[idx] = rank
        for i, reason in zip(idx, r):
            self.reasons[i] = reason
        if self.callback is not None:
            self.callback(idx, np.asarray(v), r, self.ranks[idx])

    def lost(self, rank):
        """The worker of ``rank`` died: replace it, and redo its chunk or give the culprit up."""
        task = self.pool._workers[rank].task
        pid, how, new_pid = self.pool._replace(rank)
        line = f"pool worker {pid} (rank {rank}) {how}; replaced by worker {new_pid}"
        if task is None or task[0] != self.id:
            self.idle_deaths += 1
            if self.idle_deaths > self.pool.max_deaths * self.pool.processes:
                raise RuntimeError(f"{line}: pool workers keep dying without evaluating anything")
            self.say(f"{line}; no evaluation of this batch was in flight")
            return
        idx = task[1]
        self.deaths[idx] += 1
        limit = self.pool.max_deaths
        if len(idx) == 1 and self.deaths[idx[0]] >= limit:
            reason = (f"the forward evaluation took its pool worker down {self.deaths[idx[0]]} times (last: {how}); "
                      "counted as a failed solve")
            self.say(f"{line}; 1 evaluation given up after {self.deaths[idx[0]]} worker deaths (-inf, a failed solve)")
            self.store(idx, np.array([-np.inf]), [reason], rank)
        elif len(idx) > 1 and self.deaths[idx].max() >= limit - 1:
            self.queue.extendleft(np.array([k]) for k in reversed(idx))
            self.say(f"{line}; {len(idx)} evaluations redone one at a time (the chunk took workers down "
                     f"{self.deaths[idx].max()} times)")
        else:
            self.queue.appendleft(idx)
            self.say(f"{line}; {len(idx)} evaluation{'s' if len(idx) != 1 else ''} redone")

    def say(self, line):
        if self.note is not None:
            self.note(line)
        else:
            print(line, file=sys.stderr, flush=True)
