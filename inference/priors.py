"""Independent priors over named parameters: uniform (the paper) and log-uniform (scale parameters), optionally
restricted by constraints between parameters.

A :class:`Prior` is an ordered list of named bounds; a parameter vector ``theta`` is in the prior's order.
``UniformPrior({"M": (0.5, 2.0)})`` and ``LogUniformPrior({"C_ae": (1e-3, 5e-2)})`` build priors; ``&`` joins them;
``Prior(bounds, constraints=["kappa < lambda_"])`` restricts the box (:class:`Constraint`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constraints import Constraint, constraint_of

__all__ = ["PriorError", "Bound", "Prior", "UniformPrior", "LogUniformPrior", "Constraint",
           "FRACTION_DRAWS", "MIN_ACCEPTED_FRACTION"]

#: box draws (fixed stream, seed 0) from which a constrained prior's accepted fraction is estimated
FRACTION_DRAWS = 1 << 16
#: a constrained prior accepting less of its box than this is refused (rejection sampling would be hopeless)
MIN_ACCEPTED_FRACTION = 1e-3


class PriorError(ValueError):
    """Invalid prior specification (names the parameter and the value)."""


@dataclass(frozen=True)
class Bound:
    """One parameter: ``kind`` is "uniform" (density 1/(hi - lo)) or "log-uniform" (density 1/(x ln(hi/lo)))."""

    name: str
    lower: float
    upper: float
    kind: str = "uniform"

    def __post_init__(self):
        if self.kind not in ("uniform", "log-uniform"):
            raise PriorError(f"parameter {self.name}: unknown prior kind {self.kind!r} (uniform or log-uniform)")
        for label, v in (("lower", self.lower), ("upper", self.upper)):
            if not np.isfinite(v):
                raise PriorError(f"parameter {self.name}: {label} bound {v} is not finite")
        if not self.lower < self.upper:
            raise PriorError(f"parameter {self.name}: lower bound {self.lower:g} must be < upper bound {self.upper:g}")
        if self.kind == "log-uniform" and self.lower <= 0:
            raise PriorError(f"parameter {self.name}: log-uniform lower bound {self.lower:g} must be > 0")


class Prior:
    """Product of independent one-dimensional priors with bounded support, optionally restricted by constraints.

    constraints: :class:`Constraint` instances, expressions such as ``"kappa < lambda_"`` or callables
    ``{name: values (n,)} -> bool (n,)``. A constrained prior is the box prior restricted to the region where every
    constraint holds and renormalized: density pi_box(theta) / f there, 0 elsewhere, f the box prior's probability
    of the region. f is estimated once, deterministically, from ``FRACTION_DRAWS`` box draws of a fixed stream
    (seed 0), and the prior is refused (PriorError naming the constraint that rejects most) when f <
    ``MIN_ACCEPTED_FRACTION``. :meth:`sample` draws from the restricted prior by rejection from the box, so a
    TMCMC run's stage 0 starts from it and its evidence sum_j ln S_j is the evidence under the renormalized prior;
    no correction by f is needed, which enters only the density's normalization (``logpdf``).
    """

    def __init__(self, bounds, constraints=()):
        bounds = list(bounds)
        if not bounds:
            raise PriorError("a prior needs at least one parameter")
        names = [b.name for b in bounds]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise PriorError(f"parameter names repeated in the prior: {sorted(dup)}")
        self.bounds = tuple(bounds)
        self.names = tuple(names)
        self.lower = np.array([b.lower for b in bounds])
        self.upper = np.array([b.upper for b in bounds])
        self._log = np.array([b.kind == "log-uniform" for b in bounds])
        width = np.where(self._log, np.log(self.upper / np.where(self._log, self.lower, 1.0)), self.upper - self.lower)
        self._log_norm = -np.sum(np.log(width))
        try:
            self.constraints = tuple(constraint_of(c, self.names) for c in constraints)
        except ValueError as exc:
            raise PriorError(str(exc)) from None
        self.accepted_fraction = 1.0
        if self.constraints:
            draws = self._box_sample(np.random.default_rng(0), FRACTION_DRAWS)
            holds = np.array([c.holds(draws, self.names) for c in self.constraints])
            self.accepted_fraction = float(np.all(holds, axis=0).mean())
            if self.accepted_fraction < MIN_ACCEPTED_FRACTION:
                worst = self.constraints[int(np.argmin(holds.mean(axis=1)))]
                raise PriorError(f"constraint {worst.text}: only {self.accepted_fraction:.2g} of the prior box "
                                 f"satisfies the constraints (< {MIN_ACCEPTED_FRACTION:g}); change the bounds of "
                                 f"{', '.join(worst.names)}")
            self._log_norm = self._log_norm - np.log(self.accepted_fraction)

    @property
    def dim(self) -> int:
        return len(self.names)

    def __and__(self, other: "Prior") -> "Prior":
        return Prior(self.bounds + other.bounds, self.constraints + other.constraints)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise PriorError(f"unknown parameter name {name!r}; the prior has {list(self.names)}") from None

    def _box_sample(self, rng, n):
        u = rng.random((n, self.dim))
        lo, hi = self.lower, self.upper
        lin = lo + u * (hi - lo)
        safe_lo = np.where(self._log, lo, 1.0)
        log = np.exp(np.log(safe_lo) + u * np.log(np.where(self._log, hi, 1.0) / safe_lo))
        return np.where(self._log, log, lin)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n independent draws, shape (n, dim); with constraints by rejection from the box (batches of box draws
        from ``rng``, the accepted ones kept in order: deterministic for a seed)."""
        if not self.constraints:
            return self._box_sample(rng, n)
        kept, total = [], 0
        batch = int(np.ceil(1.2 * n / self.accepted_fraction)) + 16
        while total < n:
            draws = self._box_sample(rng, batch)
            draws = draws[self.satisfies(draws)]
            kept.append(draws)
            total += len(draws)
        return np.concatenate(kept)[:n]

    def satisfies(self, theta) -> np.ndarray:
        """True where every constraint holds, shape (n,)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        ok = np.ones(len(theta), dtype=bool)
        for c in self.constraints:
            ok &= c.holds(theta, self.names)
        return ok

    def in_support(self, theta) -> np.ndarray:
        theta = np.atleast_2d(theta)
        inside = np.all((theta >= self.lower) & (theta <= self.upper), axis=1)
        return inside & self.satisfies(theta) if self.constraints else inside

    def logpdf(self, theta) -> np.ndarray:
        """Log prior density, -inf outside the support (the box and the constraints); shape (n,)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        inside = self.in_support(theta)
        safe = np.where(inside[:, None], theta, self.lower + 0.5 * (self.upper - self.lower))
        val = self._log_norm - np.sum(np.log(np.where(self._log, safe, 1.0)), axis=1)
        return np.where(inside, val, -np.inf)

    def as_dict(self, theta) -> dict:
        return {n: float(v) for n, v in zip(self.names, np.asarray(theta, dtype=float))}

    def describe(self) -> list:
        """The bounds, then one entry per constraint with the accepted fraction of the box."""
        return ([{"name": b.name, "lower": b.lower, "upper": b.upper, "kind": b.kind} for b in self.bounds]
                + [{"constraint": c.text, "accepted_fraction": self.accepted_fraction} for c in self.constraints])

    def __repr__(self):
        return "Prior(" + ", ".join([f"{b.name}~{b.kind}[{b.lower:g}, {b.upper:g}]" for b in self.bounds]
                                    + [c.text for c in self.constraints]) + ")"


def _from_mapping(bounds: dict, kind: str) -> Prior:
    if not isinstance(bounds, dict) or not bounds:
        raise PriorError(f"expected a non-empty mapping name -> (lower, upper), got {bounds!r}")
    out = []
    for name, lohi in bounds.items():
        try:
            lo, hi = (float(v) for v in lohi)
        except (TypeError, ValueError):
            raise PriorError(f"parameter {name}: bounds must be two numbers (lower, upper), got {lohi!r}") from None
        out.append(Bound(str(name), lo, hi, kind))
    return Prior(out)


def UniformPrior(bounds: dict) -> Prior:
    """Independent uniform priors, ``{name: (lower, upper)}`` in parameter order (the paper's choice)."""
    return _from_mapping(bounds, "uniform")


def LogUniformPrior(bounds: dict) -> Prior:
    """Independent log-uniform priors (for scale parameters such as k_p or C_alpha_e)."""
    return _from_mapping(bounds, "log-uniform")
