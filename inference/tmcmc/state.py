"""Typed state of a TMCMC run: the run, the stage record being written, the chains of the stage under way.

Everything here is plain data (numbers, strings, arrays, lists), so a checkpoint stores it without pickling
(:mod:`inference.checkpoint`) and a resumed run continues from exactly these values.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from .mixture import GaussianMixture

__all__ = ["Phase", "StageRecord", "MapPoint", "ChainState", "RunState", "STATE_TYPES"]


class Phase(enum.Enum):
    """Where a run stands: stage 0 to draw from the prior, a stage to select (steps 1-4 of docs/reference.md
    section 2), its Metropolis sweeps under way (steps 5-6), or finished at beta = 1 (step 7). A checkpoint stores the
    value string."""

    PRIOR = "prior"
    SELECT = "select"
    MCMC = "mcmc"
    DONE = "done"


@dataclass
class StageRecord:
    """What one stage did; ``as_dict`` gives the record of ``Posterior.stages`` (key "beta": the exponent beta_j)."""

    stage: int
    exponent: float                  # tempering exponent beta_j of f_j ∝ pi(theta) L^beta_j
    beta2: float                     # random-walk scale beta^2 of Eq. (11)
    log_S: float = 0.0               # ln S_j, Eq. (10)
    acceptance: float = float("nan")
    n_evals: int = 0
    n_failed: int = 0
    sweeps: int = 0
    wall_s: float = 0.0
    wall_at_start: float = 0.0       # run wall time when the stage began (s)
    components: list | None = None   # mixture components of the two cross-fitted mixtures ("mixture" move)

    def as_dict(self) -> dict:
        out = {"stage": self.stage, "beta": self.exponent, "log_S": self.log_S, "acceptance": self.acceptance,
               "n_evals": self.n_evals, "n_failed": self.n_failed, "sweeps": self.sweeps, "wall_s": self.wall_s,
               "beta2": self.beta2}
        if self.components is not None:
            out["components"] = self.components
        return out


@dataclass
class MapPoint:
    """The evaluated sample of largest prior x likelihood so far, Eq. (7)."""

    theta: np.ndarray
    log_posterior: float
    log_like: float


@dataclass
class ChainState:
    """The Metropolis chains of one stage (steps 5-6), from the resampled starts to the current positions.

    With chains "particles" there is one chain per particle; with "ching-chen" one per distinct resampled point,
    ``length`` its multiplicity, and every chain state after each sweep is kept in ``samples``. The move's per-stage
    data: ``chol`` (Cholesky factor of Sigma_j, Eqs. (11)-(12)), ``best`` (theta_best of Eq. (14)) or ``mixtures``
    (two cross-fitted Gaussian mixtures, ``fit_of`` the one each chain moves with, ``resp`` their cached
    log-responsibilities (ln r, ln g) of the current positions)."""

    exponent: float                  # beta_{j+1}, the exponent the moves target
    log_S: float
    start: np.ndarray                # (C, d) chain starts
    pos: np.ndarray                  # (C, d) current positions
    log_like: np.ndarray
    log_prior: np.ndarray
    scale: float                     # proposal scale factor (steered when scale_adapt)
    length: np.ndarray | None = None
    sweep: int = 0
    move: int = 0
    accepted: int = 0
    proposed: int = 0
    samples: list | None = None      # [(active chains, positions, ln L, ln prior)] per sweep ("ching-chen")
    chol: np.ndarray | None = None
    best: np.ndarray | None = None
    mixtures: list | None = None
    fit_of: np.ndarray | None = None
    resp: list | None = None


@dataclass
class RunState:
    """A whole run: the :class:`Phase` it is in, the current population, the evidence so far (ln Z = sum_j ln S_j),
    the stage records and every stage's samples, failures, the MAP and the batch of evaluations under way
    (``partial``: particle -> (ln L, failure reason, rank), kept across a checkpoint). ``phase`` is also accepted as
    its value string (a checkpoint may hold the bare string)."""

    phase: Phase = Phase.PRIOR
    stage: int = 0
    exponent: float = 0.0
    log_evidence: float = 0.0
    theta: np.ndarray | None = None
    log_like: np.ndarray | None = None
    log_prior: np.ndarray | None = None
    records: list = field(default_factory=list)
    stage_theta: list = field(default_factory=list)
    stage_log_like: list = field(default_factory=list)
    failures: list = field(default_factory=list)
    n_evals: int = 0
    map: MapPoint | None = None
    current: StageRecord | None = None
    chain: ChainState | None = None
    partial: dict = field(default_factory=dict)
    wall_before: float = 0.0
    scale: float = 1.0

    def __post_init__(self):
        self.phase = Phase(self.phase)


#: the classes a checkpoint may rebuild (and no others)
STATE_TYPES = {cls.__name__: cls for cls in (Phase, StageRecord, MapPoint, ChainState, RunState, GaussianMixture)}
