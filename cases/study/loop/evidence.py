"""The refined evidence of one calibrated model class in the diagnosis loop: ln Z and MAP from the posterior mode
(``inference.mode_evidence``), climbed from the best of the TMCMC sample and, for an enriched class, from the base
class's mode with the added parameters at their prior's lower end and at mid-prior."""
from __future__ import annotations

import numpy as np

import inference
from inference.executors import mpi_world

__all__ = ["refined_evidence"]


def refined_evidence(like, prior, post, seed, base_mode, executor):
    """ln Z and MAP from the refined posterior mode (``inference.mode_evidence``: TMCMC's estimate with few
    particles falls short by an amount growing with its stages, so classes would be compared by the sampler's lag),
    climbed from the best of the posterior sample and, for an enriched class (``base_mode`` {name: value} of the
    step's base, a subset of ``post.names``), the base class's mode with the added parameters at their prior's lower
    end (where the enriched class nests the base), and climbed again from the base mode with the added parameters at
    mid-prior (a sample of few particles may sit on a lesser mode of the enriched class), the higher mode kept. The
    batches of the refinement run on ``executor()`` (serially under MPI). None when no mode can be refined (the
    TMCMC values are then used)."""
    starts = climbs = None
    if base_mode is not None and set(base_mode) < set(post.names):
        levels = {}   # the added parameters' (lower end, mid-prior)
        for n, b in zip(post.names, prior.bounds):
            if n not in base_mode:
                middle = np.sqrt(b.lower * b.upper) if b.kind == "log-uniform" else 0.5 * (b.lower + b.upper)
                levels[n] = (b.lower + 1e-3 * (b.upper - b.lower), middle)
        starts, climbs = ([[base_mode[n] if n in base_mode else levels[n][level] for n in post.names]]
                          for level in (0, 1))
    evaluator = inference.Evaluator(like)
    # under MPI every rank holds the posterior and refines the same mode by itself
    pool = inference.SerialExecutor() if mpi_world() is not None else executor()

    def log_likelihood(thetas):
        # a finite-difference stencil moves the error and discrepancy parameters about one set of soil parameters:
        # the sets sharing their soil parameters go out side by side, so one chunk solves them once
        order = np.argsort(inference.distinct_rows(like.soil_parameters(thetas))[1], kind="stable")
        values = np.empty(len(thetas))
        values[order] = pool.evaluate(evaluator, thetas[order])[0]
        return values

    with pool:
        return inference.mode_evidence(log_likelihood, prior, post.samples, log_values=post.log_like,
                                       starts=starts, climbs=climbs, seed=seed)
