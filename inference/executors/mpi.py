"""Evaluations on MPI ranks (mpi4py): dynamic master/worker or static round-robin (spmd); rank 0 runs the sampler.

The ranks are processes of the MPI launcher, which ends the whole job when one rank dies; unlike the local pool's
workers (:class:`inference.executors.PoolExecutor`), no rank here watches for its parent's death, and a lost rank
cannot be replaced. Where the MPI library reports the loss to rank 0 as an error instead, rank 0 prints one line
(:func:`rank_lost_message`: rerun with --resume) and aborts the job with status 75 (EX_TEMPFAIL, "try again"):
the other ranks wait for messages that will never come, so nothing but an abort ends them.
"""
from __future__ import annotations

import math
import os
import signal
import sys
import traceback

import numpy as np

from .local import BATCH_CHUNK, Executor, batch_capable

__all__ = ["RootRankError", "RankLost", "MPIExecutor", "mpi_world", "rank_lost_message", "EXIT_RANK_LOST"]


class RootRankError(RuntimeError):
    """Raised on the other ranks when the root rank's run stopped with an error."""


class RankLost(RuntimeError):
    """Rank 0 lost contact with another rank (an MPI error during a batch): the job cannot continue."""


#: status of a job aborted after a lost rank (EX_TEMPFAIL: rerun with --resume)
EXIT_RANK_LOST = 75

_TAG_TASK, _TAG_RESULT, _TAG_STOP = 11, 12, 13


def rank_lost_message(detail):
    """The one line printed when a rank is lost: what MPI said, and rerun with --resume."""
    detail = " ".join(str(detail).split())
    return (f"error: an MPI rank was lost ({detail}); a rank cannot be replaced under mpirun: rerun the same command "
            "with --resume (resume=True in Python) to continue from the last checkpoint")


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
    def evaluate(self, evaluator, thetas, callback=None, stop=None, note=None):
        from mpi4py import MPI

        try:
            return self._evaluate(evaluator, thetas, callback, stop)
        except MPI.Exception as exc:
            raise RankLost(str(exc)) from exc

    def _evaluate(self, evaluator, thetas, callback, stop):
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
        # a likelihood whose forward model takes batches: chunks of up to BATCH_CHUNK sets, two per rank, and two in
        # flight per worker (a chunk outlasts a message's round trip); else one set a message, ``depth`` in flight
        chunk = min(BATCH_CHUNK, math.ceil(m / (2 * self.ranks))) if batch_capable(evaluator) else 1
        depth = 2 if chunk > 1 else self.depth
        queue = [np.arange(s, min(m, s + chunk)) for s in range(0, m, chunk)]
        queue.reverse()  # pop() hands out particle 0 first
        inflight = {w: 0 for w in range(1, self.ranks)}
        outstanding = 0
        stopping = False

        def send_next(worker):
            nonlocal outstanding
            if queue and not stopping:
                idx = queue.pop()
                comm.send((idx, thetas[idx]), dest=worker, tag=_TAG_TASK)
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
                _, idx, v, r = msg
                inflight[worker] -= 1
                outstanding -= 1
                store(idx, v, r, worker)
                send_next(worker)
                block = False

        for w in inflight:
            for _ in range(depth):
                send_next(w)
        while queue or outstanding:
            if stop is not None and stop():
                stopping = True
            if queue and not stopping:
                idx = queue.pop()
                v, r = evaluator(thetas[idx])
                store(idx, v, r, 0)
                receive(block=False)
            else:
                if outstanding == 0:
                    break
                receive(block=True)
        return values, reasons, ranks

    def run(self, evaluator, main):
        """Rank 0 calls ``main()`` and hands its result (or how it stopped) to the workers, which serve ``evaluator``
        meanwhile: a result is returned on every rank, SystemExit raises SystemExit with the same code on every
        rank, another exception raises :class:`RootRankError` on the workers; a lost rank (:class:`RankLost`)
        prints :func:`rank_lost_message` and aborts the job with :data:`EXIT_RANK_LOST`."""
        if not self.is_root:
            kind, value = self.serve(evaluator)
            if kind == "exit":
                raise SystemExit(value)
            if kind == "error":
                raise RootRankError(f"rank 0 stopped: {value}")
            return value
        try:
            value = main()
        except RankLost as exc:  # releasing the ranks would wait for the lost one
            print(rank_lost_message(exc), file=sys.stderr, flush=True)
            self.comm.Abort(EXIT_RANK_LOST)
            raise
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
                    idx, chunk = msg
                    v, r = evaluator(np.atleast_2d(np.asarray(chunk, dtype=float)))
                    comm.send(("ok", idx, np.asarray(v, dtype=float), list(r)), dest=0, tag=_TAG_RESULT)
                except Exception:
                    comm.send(("error", traceback.format_exc()), dest=0, tag=_TAG_RESULT)
        return comm.bcast(None, root=0)
