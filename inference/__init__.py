"""Bayesian identification: the paper's likelihood, O-TMCMC and DE-TMCMC, evidence, MAP, parallel dispatch.

Generic: knows nothing of soil. A forward model maps parameter sets to simulated curves (:mod:`inference.forward`).
"""
from .checkpoint import CheckpointError
from .diagnosis import ScreenReport, screen
from .discrepancy import Discrepancy
from .evidence import EvidenceEstimate, mode_evidence
from .executors import Evaluator, Executor, MPIExecutor, PoolExecutor, SerialExecutor, default_executor, side_by_side
from .forward import ForwardModel, ForwardModelError, ListForward, ParticleForward, distinct_rows
from .goodness import goodness_of_fit
from .likelihood import Likelihood
from .observations import Curve, DataError, Observations, Test
from .priors import Bound, Constraint, LogUniformPrior, Prior, PriorError, UniformPrior
from .results import Posterior, RunProgress, write_failures
from .tmcmc import EXIT_CHECKPOINTED, Checkpointed, RunStopped, SamplerError, TMCMCSettings, tmcmc

__all__ = [
    "CheckpointError", "Discrepancy", "Evaluator", "Executor", "MPIExecutor", "PoolExecutor", "SerialExecutor",
    "side_by_side", "default_executor", "ForwardModel", "ForwardModelError", "ListForward", "ParticleForward",
    "Likelihood", "distinct_rows",
    "goodness_of_fit", "Curve", "DataError", "Observations", "Test",
    "Bound", "Constraint", "LogUniformPrior", "Prior", "PriorError", "UniformPrior", "Posterior", "RunProgress",
    "write_failures",
    "EXIT_CHECKPOINTED", "SamplerError", "RunStopped", "Checkpointed", "TMCMCSettings", "tmcmc", "ScreenReport",
    "screen", "EvidenceEstimate", "mode_evidence",
]
