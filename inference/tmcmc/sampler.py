"""The front of the sampler: :func:`tmcmc` turns its options into one :class:`TMCMCSettings` record, builds the move,
the evaluator and the executor, and runs (or resumes) the run on the root rank.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..checkpoint import CheckpointError, load_checkpoint
from ..executors import Evaluator, Executor, RootRankError, default_executor
from ..likelihood import Likelihood
from ..priors import Prior
from ..results import Posterior, RunProgress
from .moves import make_move
from .run import Interrupted, Run
from .settings import TMCMCSettings
from .stage import SamplerError
from .state import STATE_TYPES, RunState

__all__ = ["tmcmc", "EXIT_CHECKPOINTED", "RunStopped", "Checkpointed"]

#: exit status after a SIGTERM/SIGUSR1 was turned into a checkpoint (EX_TEMPFAIL: "try again")
EXIT_CHECKPOINTED = 75


class RunStopped(SamplerError):
    """The run stopped without a posterior: too many failed forward solves, no convergence to beta = 1, or no particle
    with a finite likelihood. ``progress`` (:class:`inference.results.RunProgress`) is what it did."""

    def __init__(self, message, progress: RunProgress):
        super().__init__(message)
        self.progress = progress


class Checkpointed(SystemExit):
    """SIGTERM or SIGUSR1 stopped the run after its checkpoint was written; uncaught, the process exits with
    :data:`EXIT_CHECKPOINTED`. ``progress`` (:class:`inference.results.RunProgress`) is what it did."""

    def __init__(self, progress: RunProgress):
        super().__init__(EXIT_CHECKPOINTED)
        self.progress = progress


def tmcmc(loglike, prior: Prior, settings: TMCMCSettings | None = None, *, executor=None, checkpoint=None,
          resume=False, progress=True, log=None, **options) -> Posterior:
    """Sample the posterior p(theta | D) ∝ pi(theta) L(theta) by TMCMC and estimate the log-evidence.

    loglike: an :class:`inference.Likelihood` (Eqs. (3)-(6), bound to the prior's parameter order here), a callable
        theta (d,) -> ln L, or with ``vectorized=True`` thetas (m, d) -> (m,).
    prior: :class:`inference.Prior` (``UniformPrior``/``LogUniformPrior``); theta is in its order.
    settings: a :class:`TMCMCSettings`; ``options`` are its fields by name (n_samples, proposal, de_variant, chains,
        n_steps, covariance, seed, ...), on their own or replacing those of ``settings``.
    executor: None chooses MPI under mpirun (``dispatch`` "dynamic" or "spmd"), else a local process pool.
    checkpoint / resume: a file written atomically after every stage and every ``checkpoint_every`` seconds (or
        ``checkpoint_evals`` evaluations) inside a stage; SIGTERM/SIGUSR1 write it and raise :class:`Checkpointed`
        (a ``SystemExit`` with status 75, :data:`EXIT_CHECKPOINTED`); ``resume=True`` continues from it when it
        exists.
    progress: one line per stage on stderr (the tempering exponent as ``p=``, the ETA of
        :func:`inference.tmcmc.run.eta_text`); log: a file the lines are appended to.
    Returns a :class:`inference.Posterior` on every rank. A run that stops before beta = 1 raises :class:`RunStopped`
    (a :class:`SamplerError`) or :class:`Checkpointed` on the root rank, both carrying ``progress``, what the run did
    (``progress.save(out)`` writes progress.json and failed_solves.jsonl); other ranks get a plain SamplerError.
    """
    if not isinstance(prior, Prior):
        raise TypeError("prior must be an inference.Prior (UniformPrior / LogUniformPrior)")
    if settings is None:
        settings = TMCMCSettings(**options)
    elif isinstance(settings, TMCMCSettings):
        settings = dataclasses.replace(settings, **options)
    else:
        raise TypeError(f"settings = {settings!r}: pass an inference.tmcmc.TMCMCSettings or the options by name")
    settings = settings.resolved(prior.dim)
    if isinstance(loglike, Likelihood):
        loglike.bind(prior.names)
    evaluator = Evaluator(loglike, vectorized=settings.vectorized, timeout=settings.timeout)
    if not (executor is None or isinstance(executor, Executor)):
        raise TypeError(f"executor = {executor!r}: pass None (MPI under mpirun, else a process pool) or an instance "
                        "of inference.SerialExecutor, PoolExecutor or MPIExecutor")
    own_executor = executor is None
    if own_executor:
        executor = default_executor(settings.dispatch)

    def sample():
        fingerprint = _fingerprint(loglike, prior, settings)
        run = Run(evaluator, prior, executor, settings, make_move(settings, prior), checkpoint, fingerprint,
                  progress, log)
        if resume and checkpoint is not None and Path(checkpoint).exists():
            st = load_checkpoint(checkpoint, fingerprint, STATE_TYPES)
            check_resumable(st, prior, checkpoint)
            run.say(f"resuming from {checkpoint}: stage {st.stage}, phase {st.phase.value}, "
                    f"{st.n_evals} evaluations done")
        else:
            st = RunState()

        def progress_of(reason):
            return RunProgress.from_state(st, prior, reason, *run.walls(st), checkpoint)

        try:
            st = run.run(st)
        except Interrupted as intr:
            run.say(f"signal {intr.signum} received: checkpoint written to {checkpoint}; rerun the same command "
                    "with --resume (resume=True in Python) to continue")
            raise Checkpointed(progress_of(f"signal {intr.signum}; resume from {checkpoint}")) from None
        except SamplerError as exc:
            raise RunStopped(str(exc), progress_of(str(exc).splitlines()[0])) from exc
        return Posterior.from_state(st, prior, settings.as_dict(), executor, *run.walls(st))

    try:
        return executor.run(evaluator, sample)
    except RootRankError as exc:
        raise SamplerError(str(exc)) from None
    finally:
        if own_executor:
            executor.close()


def _fingerprint(loglike, prior, settings: TMCMCSettings) -> dict:
    """What a checkpoint must match to be resumed: the likelihood's fingerprint (or its name), the prior and the
    settings that decide the numbers."""
    if isinstance(loglike, Likelihood):
        fp = loglike.fingerprint()
    else:
        fp = getattr(loglike, "__qualname__", type(loglike).__qualname__)
    return {"likelihood": str(fp), "prior": str(prior.describe()), **settings.sampling()}


def check_resumable(st, prior: Prior, path) -> None:
    """Refuse a checkpoint whose state contradicts the prior it was written for (a file altered and re-checksummed):
    every population and stage sample must lie in the prior's support, the exponent in [0, 1] and the evidence so far
    be finite. Raises :class:`CheckpointError` naming the file and the first contradiction."""
    if not (0.0 <= st.exponent <= 1.0 and np.isfinite(st.log_evidence)):
        raise CheckpointError(f"{path}: exponent {st.exponent} or ln Z {st.log_evidence} out of range: not a state "
                              "this sampler writes")
    populations = ([] if st.theta is None else [("population", st.theta)])
    populations += [(f"stage {j} samples", t) for j, t in enumerate(st.stage_theta)]
    for what, theta in populations:
        theta = np.asarray(theta, dtype=float)
        if theta.ndim != 2 or theta.shape[1] != prior.dim:
            raise CheckpointError(f"{path}: {what} has shape {theta.shape}, the prior has {prior.dim} parameters")
        outside = ~prior.in_support(theta)
        if np.any(outside):
            k = int(np.flatnonzero(outside)[0])
            raise CheckpointError(f"{path}: {what} particle {k} = {dict(zip(prior.names, theta[k].tolist()))} lies "
                                  "outside the prior: the checkpoint was altered")

