"""Size of a pressuremeter study: the FE discretization of the cavity expansion and the sampler settings that go
with it, the paper's and the quick one."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Preset", "PRESETS", "FE_FIELDS"]


@dataclass(frozen=True)
class Preset:
    """FE discretization and sampler size. The cavity problem is one-dimensional in r (plane strain, top and bottom
    fixed vertically), so ``layers`` = 1 gives the same answer as the paper's 4 layers at a quarter of the cost.
    ``sweeps``: MCMC sweeps per stage, 1 = the paper's one Metropolis step per resampled particle (docs/reference.md
    section 2, step 4), None = adaptive (inference.tmcmc), between 2 and ``max_steps``."""

    radial_cells: int = 60
    layers: int = 4
    increments: int = 100
    outer: str = "fixed"
    outer_radius_a0: float = 3200.0
    n_samples: int = 2000
    sweeps: int | None = 1
    max_steps: int = 25


FE_FIELDS = ("radial_cells", "layers", "increments", "outer", "outer_radius_a0")
PRESETS = {
    "paper": Preset(),
    "quick": Preset(layers=1, n_samples=64, sweeps=None, max_steps=4),
}
