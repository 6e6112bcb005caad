"""Time of a residual screening on synthetic data (forward solves excluded); prints one JSON line.

    python -m inference.diagnosis.bench [--curves 10] [--points 100] [--samples 300]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from ..likelihood import Likelihood
from ..observations import Curve, Observations, Test
from .screening import screen
from .structure import _SCAN_NULL, _scan_null

__all__ = ["benchmark", "main"]


def benchmark(n_curves=10, n_points=100, n_samples=300, seed=0) -> dict:
    """Screening time on synthetic data (forward solves excluded): one test per curve, a planted bump in one curve."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.1, 10.0, n_points)
    sim = {(f"T{j}", "q"): 100.0 * (1 - np.exp(-x / (2 + j))) for j in range(n_curves)}
    sigma = 0.02
    obs = {k: v * (1 + sigma * rng.standard_normal(n_points)) for k, v in sim.items()}
    obs["T0", "q"] *= 1 + 3 * sigma * np.exp(-0.5 * ((x - 5) / 0.8) ** 2)
    data = Observations([Test(t, {"q": Curve(x, obs[t, "q"])}) for t, _ in sim])
    like = Likelihood(data, lambda p: {}, sigma=sigma)
    samples = {k: v[None, :] * (1 + 0.005 * rng.standard_normal((n_samples, 1))) for k, v in sim.items()}
    sample_sigma = sigma * (1 + 0.05 * rng.standard_normal(n_samples))
    covariates = {"strain": {k: x for k in sim}, "rate": {f"T{j}": 10.0 ** (j % 4) for j in range(n_curves)},
                  "phase": {k: np.where(x < 7, "load", "hold") for k in sim}}
    t0 = time.perf_counter()  # the once-per-process null table of the scan test, timed separately
    _SCAN_NULL.clear()
    _scan_null(n_points, 3)
    null_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    report = screen(like, sim, sigma, samples, sample_sigma, covariates)
    wall = time.perf_counter() - t0
    return {"benchmark": "screen", "curves": n_curves, "points_per_curve": n_points, "posterior_samples": n_samples,
            "covariates": len(covariates) + 1, "wall_s": round(wall, 4), "scan_null_table_s": round(null_s, 4),
            "verdict": report.verdict, "regions": len(report.regions)}


def main(argv=None):
    parser = argparse.ArgumentParser(description="Residual screening benchmark (prints one JSON line)")
    parser.add_argument("--curves", type=int, default=10)
    parser.add_argument("--points", type=int, default=100)
    parser.add_argument("--samples", type=int, default=300)
    args = parser.parse_args(argv)
    print(json.dumps(benchmark(args.curves, args.points, args.samples)))


if __name__ == "__main__":
    main()
