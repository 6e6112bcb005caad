"""Independent priors over named parameters: uniform (the paper) and log-uniform (scale parameters).

A :class:`Prior` is an ordered list of named bounds; a parameter vector ``theta`` is in the prior's order.
``UniformPrior({"M": (0.5, 2.0)})`` and ``LogUniformPrior({"C_ae": (1e-3, 5e-2)})`` build priors; ``&`` joins them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PriorError", "Bound", "Prior", "UniformPrior", "LogUniformPrior"]


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
    """Product of independent one-dimensional priors with bounded support."""

    def __init__(self, bounds):
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

    @property
    def dim(self) -> int:
        return len(self.names)

    def __and__(self, other: "Prior") -> "Prior":
        return Prior(self.bounds + other.bounds)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise PriorError(f"unknown parameter name {name!r}; the prior has {list(self.names)}") from None

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """n independent draws, shape (n, dim)."""
        u = rng.random((n, self.dim))
        lo, hi = self.lower, self.upper
        lin = lo + u * (hi - lo)
        safe_lo = np.where(self._log, lo, 1.0)
        log = np.exp(np.log(safe_lo) + u * np.log(np.where(self._log, hi, 1.0) / safe_lo))
        return np.where(self._log, log, lin)

    def in_support(self, theta) -> np.ndarray:
        theta = np.atleast_2d(theta)
        return np.all((theta >= self.lower) & (theta <= self.upper), axis=1)

    def logpdf(self, theta) -> np.ndarray:
        """Log prior density, -inf outside the support; shape (n,)."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        inside = self.in_support(theta)
        safe = np.where(inside[:, None], theta, self.lower + 0.5 * (self.upper - self.lower))
        val = self._log_norm - np.sum(np.log(np.where(self._log, safe, 1.0)), axis=1)
        return np.where(inside, val, -np.inf)

    def as_dict(self, theta) -> dict:
        return {n: float(v) for n, v in zip(self.names, np.asarray(theta, dtype=float))}

    def describe(self) -> list:
        return [{"name": b.name, "lower": b.lower, "upper": b.upper, "kind": b.kind} for b in self.bounds]

    def __repr__(self):
        return "Prior(" + ", ".join(f"{b.name}~{b.kind}[{b.lower:g}, {b.upper:g}]" for b in self.bounds) + ")"


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
