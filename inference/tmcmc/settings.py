"""The options of one TMCMC run as one frozen, validated record (docs/reference.md section 2)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

__all__ = ["TMCMCSettings"]

#: options that choose how evaluations run, not which numbers come out (left out of ``as_dict``)
EXECUTION = ("dispatch", "vectorized", "timeout")

#: options that decide the samples, MAP and evidence: a checkpoint resumes only with the same values
SAMPLING = ("n_samples", "proposal", "de_variant", "chains", "n_steps", "min_steps", "max_steps", "corr_threshold",
            "beta2", "cov_target", "seed", "de_c", "de_c_star", "de_delta", "de_cr", "resampling", "scale_adapt",
            "target_acceptance", "covariance", "max_components", "independence")


@dataclass(frozen=True)
class TMCMCSettings:
    """Every option of :func:`inference.tmcmc` except where its output goes (executor, checkpoint, progress, log).

    n_samples: particles per stage N_s (>= 2; >= 5 for DE-TMCMC).
    proposal: "gaussian" (O-TMCMC, step 5.2) or "de" (DE-TMCMC, Eqs. (13)-(15)); ``de_variant`` "paper" (Eq. (14)
        with the theta_best pull), "symmetric" (pull off) or "redblue" (pull off, halves moved in turn).
    chains: "particles" (``n_steps`` sweeps per stage: "adaptive" between ``min_steps`` and ``max_steps``, stopped
        when the start correlation falls below ``corr_threshold``, or a positive integer) or "ching-chen" (one chain
        per distinct resampled point, as long as its multiplicity).
    beta2: random-walk scale beta^2 of Eq. (11); None gives 0.04 (the paper) with covariance "global" and
        2.38^2 / d with "mixture" (resolved by :meth:`resolved`).
    cov_target: target coefficient of variation of the stage weights (step 1).
    covariance: O-TMCMC proposal covariance, "global" (Eqs. (11)-(12)) or "mixture" (a Gaussian mixture of at most
        ``max_components`` components per stage, a fraction ``independence`` of independence proposals).
    de_c, de_c_star, de_delta, de_cr: c, c*, delta and CR of Eqs. (13)-(15).
    dispatch: MPI mode under mpirun ("dynamic" or "spmd") when no executor is given.
    seed: root of every random stream (keyed by seed, stage, sweep, move).
    checkpoint_every (s) / checkpoint_evals: checkpoint inside a stage after this time or this many evaluations.
    progress_every: seconds between progress lines inside a batch.
    vectorized: the log-likelihood takes (m, d) arrays; timeout: seconds per forward evaluation.
    max_failure_fraction: stop when more than this fraction of a stage's evaluations failed.
    max_stages: stop when the exponent has not reached 1 after this many stages.
    resampling: "systematic" or "multinomial" (step 4).
    scale_adapt / target_acceptance: steer the proposal scale toward the target acceptance between moves.
    """

    n_samples: int = 2000
    proposal: str = "de"
    de_variant: str | None = "redblue"
    chains: str = "particles"
    n_steps: int | str = "adaptive"
    min_steps: int = 2
    max_steps: int = 25
    corr_threshold: float = 0.3
    beta2: float | None = None
    cov_target: float = 1.0
    de_c: float = 0.1
    de_c_star: float = 1e-12
    de_delta: float = 3.0
    de_cr: float = 0.9
    seed: int = 0
    checkpoint_every: float = 60.0
    checkpoint_evals: int | None = None
    progress_every: float = 10.0
    max_failure_fraction: float = 0.1
    max_stages: int = 200
    resampling: str = "systematic"
    scale_adapt: bool = False
    target_acceptance: float = 0.25
    covariance: str = "global"
    max_components: int = 5
    independence: float = 0.8
    dispatch: str = "dynamic"
    vectorized: bool = False
    timeout: float | None = None

    def __post_init__(self):
        n, proposal = self.n_samples, self.proposal
        if int(n) != n or n < 2:
            raise ValueError(f"n_samples = {n}: need an integer >= 2")
        if proposal not in ("gaussian", "de"):
            raise ValueError(f"proposal = {proposal!r}: use 'gaussian' (O-TMCMC) or 'de' (DE-TMCMC)")
        if self.de_variant not in ("paper", "symmetric", "redblue") and not (proposal == "gaussian"
                                                                              and self.de_variant is None):
            raise ValueError(f"de_variant = {self.de_variant!r}: use 'paper', 'symmetric' or 'redblue'")
        if self.chains not in ("particles", "ching-chen"):
            raise ValueError(f"chains = {self.chains!r}: use 'particles' or 'ching-chen'")
        if self.n_steps != "adaptive" and (int(self.n_steps) != self.n_steps or self.n_steps < 1):
            raise ValueError(f"n_steps = {self.n_steps!r}: use 'adaptive' or a positive integer")
        if proposal == "de" and n < 5:
            raise ValueError("DE-TMCMC needs n_samples >= 5 (three distinct partners per move)")
        if self.covariance not in ("global", "mixture"):
            raise ValueError(f"covariance = {self.covariance!r}: use 'global' (Eqs. 11-12) or 'mixture'")
        if self.covariance == "mixture" and proposal != "gaussian":
            raise ValueError("covariance = 'mixture' is a move of O-TMCMC: use it with proposal = 'gaussian'")
        if self.covariance == "mixture" and self.scale_adapt:
            raise ValueError("covariance = 'mixture' keeps its proposal fixed within a stage: scale_adapt must be "
                             "False")
        if not (0.0 <= self.independence <= 1.0) or int(self.max_components) != self.max_components \
                or self.max_components < 1:
            raise ValueError("independence must be in [0, 1] and max_components a positive integer")
        if not ((self.beta2 is None or self.beta2 > 0) and self.cov_target > 0):
            raise ValueError("beta2 and cov_target must be > 0")
        # normal form: integers and floats as such, no DE variant for O-TMCMC
        normal = dict(n_samples=int(n), de_variant=self.de_variant if proposal == "de" else None,
                      min_steps=int(self.min_steps), max_steps=int(self.max_steps),
                      corr_threshold=float(self.corr_threshold), cov_target=float(self.cov_target),
                      seed=int(self.seed), checkpoint_every=float(self.checkpoint_every),
                      progress_every=float(self.progress_every),
                      max_failure_fraction=float(self.max_failure_fraction), max_stages=int(self.max_stages),
                      scale_adapt=bool(self.scale_adapt), target_acceptance=float(self.target_acceptance),
                      max_components=int(self.max_components), independence=float(self.independence),
                      vectorized=bool(self.vectorized))
        if self.beta2 is not None:
            normal["beta2"] = float(self.beta2)
        for name, value in normal.items():
            object.__setattr__(self, name, value)

    def resolved(self, dim: int) -> TMCMCSettings:
        """These settings with beta^2 fixed for a d-dimensional problem (see ``beta2``)."""
        if self.beta2 is not None:
            return self
        return dataclasses.replace(self, beta2=2.38**2 / dim if self.covariance == "mixture" else 0.04)

    def as_dict(self) -> dict:
        """The sampling and bookkeeping options by name (the ``settings`` of a Posterior and its summary.json)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in EXECUTION}

    def sampling(self) -> dict:
        """The options that decide the numbers (part of a checkpoint's fingerprint)."""
        return {name: getattr(self, name) for name in SAMPLING}
