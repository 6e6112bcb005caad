"""Transitional Markov chain Monte Carlo: O-TMCMC (Ching & Chen 2007) and DE-TMCMC (Jin, Yin et al. 2019).

docs/reference.md section 2. Modules:
- :mod:`.settings`: :class:`TMCMCSettings`, every option of a run in one validated record;
- :mod:`.stage`: next tempering exponent, weights Eq. (9), S_j Eq. (10) and ln Z, weighted covariance
  Eqs. (11)-(12), resampling, random streams, the adaptive-sweep statistic;
- :mod:`.mixture`: Gaussian mixtures and their EM fit (the O-TMCMC mixture move);
- :mod:`.moves`: the Metropolis-Hastings moves, one class each (Gaussian, mixture, DE Eqs. (13)-(15));
- :mod:`.state`: typed run, stage and chain state and the run's :class:`Phase`;
- :mod:`.steps`: the steps of a run as functions of its state (stage 0, steps 1-4, steps 5-6), free of I/O;
- :mod:`.run`: the driver that loops the steps, with evaluations, checkpoints, signals and progress;
- :mod:`.sampler`: :func:`tmcmc`.

Random numbers: each move draws its arrays from a stream keyed by (seed, stage, sweep, move), row k belonging to
chain k. Samples, MAP and evidence therefore do not depend on the executor or the number of MPI ranks, and a run
resumed from a checkpoint continues with exactly the numbers it would have drawn.
"""
from .mixture import GaussianMixture, fit_gaussian_mixture
from .moves import (
                    DEMove,
                    GaussianMove,
                    MixtureMove,
                    Move,
                    Proposal,
                    RedBlueDEMove,
                    SymmetricDEMove,
                    de_proposal,
                    make_move,
                    mixture_proposal,
)
from .sampler import EXIT_CHECKPOINTED, Checkpointed, RunStopped, tmcmc
from .settings import TMCMCSettings
from .stage import SamplerError, choose_next_exponent, resample, stage_weights, start_correlation, weighted_covariance

__all__ = ["tmcmc", "TMCMCSettings", "SamplerError", "RunStopped", "Checkpointed", "EXIT_CHECKPOINTED",
           "choose_next_exponent", "stage_weights", "weighted_covariance", "resample", "start_correlation",
           "GaussianMixture", "fit_gaussian_mixture",
           "Move", "Proposal", "GaussianMove", "MixtureMove", "DEMove", "SymmetricDEMove", "RedBlueDEMove",
           "make_move", "de_proposal", "mixture_proposal"]
