"""Where log-likelihood evaluations run: serially, in a local process pool, or on MPI ranks.

Every evaluation of one parameter vector runs whole on one process (one forward solve per particle, as the paper's
SPMD scheme). The sampler hands an executor a batch of parameter vectors and gets back, for each, the
log-likelihood (or -inf), the failure reason (or None) and the rank that computed it. Results are stored by particle
index, so the order in which workers finish never changes the answer. A likelihood whose forward model takes
batches (``Likelihood.batch``) is handed chunks of up to ``local.BATCH_CHUNK`` vectors in one call, which carries the
forward model's per-call work once for the chunk; a batched forward model gives each vector the bits it gives it
alone, so the chunking never changes the answer either.

MPI (mpi4py, chosen automatically under ``mpirun -n K`` with K > 1):
- ``dynamic`` (default): rank 0 hands out one parameter vector at a time and keeps four in flight per worker, and
  computes vectors itself between polls, so every rank is busy even when forward-solve times differ (a likelihood
  whose forward model takes batches: chunks of up to ``local.BATCH_CHUNK`` vectors, two per rank, two in flight);
- ``spmd``: static round-robin, rank r evaluates particles k with k % K == r (the paper's ``labindex`` scheme).
Every rank calls :func:`inference.tmcmc`; rank 0 runs the sampler, the others serve evaluations and receive the
final posterior. The sampler sees only :meth:`Executor.run` (its whole run, on the root rank), ``evaluate`` (one
batch) and ``close``; every executor has them, so the sampler never asks which kind it has.
"""
from __future__ import annotations

import os

from .evaluator import EvaluationTimeout, Evaluator
from .local import Executor, PoolExecutor, SerialExecutor
from .mpi import MPIExecutor, RootRankError, mpi_world
from .side_by_side import SharedCoresExecutor, side_by_side

__all__ = ["EvaluationTimeout", "RootRankError", "Evaluator", "Executor", "SerialExecutor", "PoolExecutor",
           "MPIExecutor", "SharedCoresExecutor", "default_executor", "mpi_world", "side_by_side"]


def default_executor(dispatch="dynamic", processes=None):
    """MPI under mpirun with more than one rank, else the local process pool (one process per core), or serial
    on a one-core machine."""
    comm = mpi_world()
    if comm is not None:
        return MPIExecutor(comm, mode=dispatch)
    n = processes or os.cpu_count() or 1
    return PoolExecutor(n) if n > 1 else SerialExecutor()
