"""Sampler benchmarks: posteriors with known log-evidence (docs/reference.md section 8, B1-B6), as vectorized
log-likelihoods, used by the evidence tests; ``python -m inference.bench`` (``__main__``) runs the samplers on them
and measures the dispatch overheads.

Each problem gives a prior, a log-likelihood over (m, d) arrays, the exact ln Z and, where known, the exact
posterior mean and standard deviation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from ..priors import Prior, UniformPrior

__all__ = ["Problem", "linear_gaussian", "gaussian_mixture", "twin_gaussian", "gaussian_shells", "eggbox",
           "rosenbrock", "PROBLEMS"]


@dataclass
class Problem:
    name: str
    prior: Prior
    log_like: callable
    log_evidence: float
    mean: np.ndarray | None = None
    std: np.ndarray | None = None
    minor_mode: callable | None = None  # samples -> fraction in the minor mode (B2)
    minor_weight: float | None = None


def _box(d, lo, hi):
    return UniformPrior({f"x{i}": (lo, hi) for i in range(d)})


def linear_gaussian(d=4, seed=0):
    """B1: y = G theta + e with a Gaussian prior folded into the likelihood, uniform box wide enough to be
    immaterial. The box prior has density 1/V, so Z = (1/V) integral N(y; G theta, Se) N(theta; m0, S0)/N(...)...

    To keep an exact answer with a uniform prior we write L(theta) = N(y; G theta, Se) N(theta; m0, S0) (the Gaussian
    prior is part of the likelihood) and the box [-10, 10]^d holds all but ~1e-20 of its mass, so
    ln Z = ln N(y; G m0, G S0 G^T + Se) - d ln 20.
    """
    rng = np.random.default_rng(seed)
    n_obs = d + 2
    G = rng.normal(size=(n_obs, d))
    m0 = np.zeros(d)
    S0 = np.eye(d)
    Se = 0.5**2 * np.eye(n_obs)
    theta_true = rng.normal(size=d)
    y = G @ theta_true + rng.normal(scale=0.5, size=n_obs)
    Se_inv = np.linalg.inv(Se)
    S0_inv = np.linalg.inv(S0)
    cov_y = G @ S0 @ G.T + Se

    def log_norm(x, mean, cov):
        diff = x - mean
        sign, logdet = np.linalg.slogdet(cov)
        return -0.5 * (diff @ np.linalg.solve(cov, diff) + logdet + len(x) * math.log(2 * math.pi))

    ln_z = log_norm(y, G @ m0, cov_y) - d * math.log(20.0)
    post_cov = np.linalg.inv(G.T @ Se_inv @ G + S0_inv)
    post_mean = post_cov @ (G.T @ Se_inv @ y + S0_inv @ m0)
    c_e = -0.5 * (np.linalg.slogdet(Se)[1] + n_obs * math.log(2 * math.pi))
    c_0 = -0.5 * (np.linalg.slogdet(S0)[1] + d * math.log(2 * math.pi))

    def log_like(theta):
        theta = np.atleast_2d(theta)
        r = y[None, :] - theta @ G.T
        t = theta - m0
        return (c_e - 0.5 * np.einsum("ni,ij,nj->n", r, Se_inv, r)
                + c_0 - 0.5 * np.einsum("ni,ij,nj->n", t, S0_inv, t))

    return Problem(f"B1_linear_gaussian_d{d}", _box(d, -10, 10), log_like, ln_z, post_mean,
                   np.sqrt(np.diag(post_cov)))


def gaussian_mixture(d=10):
    """B2: L = 0.1 N(+0.5 1, 0.1^2 I) + 0.9 N(-0.5 1, 0.1^2 I), prior U[-2, 2]^d; ln Z = -d ln 4, minor weight 0.1."""
    s = 0.1
    c = -d * math.log(s * math.sqrt(2 * math.pi))

    def log_like(theta):
        theta = np.atleast_2d(theta)
        a = math.log(0.1) - 0.5 * np.sum((theta - 0.5) ** 2, axis=1) / s**2
        b = math.log(0.9) - 0.5 * np.sum((theta + 0.5) ** 2, axis=1) / s**2
        return c + np.logaddexp(a, b)

    mean = np.full(d, 0.1 * 0.5 - 0.9 * 0.5)
    second = 0.1 * (0.25 + s**2) + 0.9 * (0.25 + s**2)
    std = np.sqrt(second - mean**2)
    return Problem(f"B2_mixture_d{d}", _box(d, -2, 2), log_like, -d * math.log(4.0), mean, std,
                   minor_mode=lambda x: float(np.mean(np.sum(x, axis=1) > 0)), minor_weight=0.1)


def twin_gaussian(d=2):
    """B3: L = N(-5 1, I) + N(+5 1, I), prior U[-15, 15]^d; ln Z = ln 2 - d ln 30."""
    c = -0.5 * d * math.log(2 * math.pi)

    def log_like(theta):
        theta = np.atleast_2d(theta)
        return c + np.logaddexp(-0.5 * np.sum((theta + 5) ** 2, axis=1), -0.5 * np.sum((theta - 5) ** 2, axis=1))

    return Problem(f"B3_twin_gaussian_d{d}", _box(d, -15, 15), log_like, math.log(2) - d * math.log(30),
                   np.zeros(d), np.sqrt(np.full(d, 26.0)),
                   minor_mode=lambda x: float(np.mean(np.sum(x, axis=1) > 0)), minor_weight=0.5)


_SHELL_LN_Z = {2: -1.746, 5: -5.674, 10: -14.590, 20: -36.087}


def gaussian_shells(d=2):
    """B4: two Gaussian shells of radius 2, width 0.1, centres (+-3.5, 0, ...), prior U[-6, 6]^d."""
    r, w = 2.0, 0.1
    c1 = np.zeros(d)
    c1[0] = -3.5
    c2 = -c1
    norm = -0.5 * math.log(2 * math.pi * w**2)

    def log_like(theta):
        theta = np.atleast_2d(theta)
        d1 = np.linalg.norm(theta - c1, axis=1)
        d2 = np.linalg.norm(theta - c2, axis=1)
        return np.logaddexp(norm - (d1 - r) ** 2 / (2 * w**2), norm - (d2 - r) ** 2 / (2 * w**2))

    return Problem(f"B4_shells_d{d}", _box(d, -6, 6), log_like, _SHELL_LN_Z[d],
                   minor_mode=lambda x: float(np.mean(x[:, 0] > 0)), minor_weight=0.5)


def eggbox():
    """B5: L = exp[(2 + cos(t1/2) cos(t2/2))^5], prior U[0, 10 pi]^2; ln Z = 235.856."""

    def log_like(theta):
        theta = np.atleast_2d(theta)
        return (2.0 + np.cos(theta[:, 0] / 2) * np.cos(theta[:, 1] / 2)) ** 5

    return Problem("B5_eggbox", _box(2, 0, 10 * math.pi), log_like, 235.856)


def rosenbrock():
    """B6: L = exp(-[(1 - x)^2 + 100 (y - x^2)^2]), prior U[-5, 5]^2; ln Z = -5.8041."""

    def log_like(theta):
        theta = np.atleast_2d(theta)
        x, y = theta[:, 0], theta[:, 1]
        return -((1 - x) ** 2 + 100 * (y - x**2) ** 2)

    return Problem("B6_rosenbrock", _box(2, -5, 5), log_like, -5.8041)


PROBLEMS = {
    "B1": linear_gaussian, "B2": gaussian_mixture, "B3": twin_gaussian, "B4": gaussian_shells, "B5": eggbox,
    "B6": rosenbrock,
}


def reference_evidence_by_quadrature(problem: Problem, n=2001):
    """Brute-force ln Z on a grid for 2-D problems (an independent check of the constants above)."""
    lo, hi = problem.prior.lower, problem.prior.upper
    xs = [np.linspace(lo[i], hi[i], n) for i in range(2)]
    X, Y = np.meshgrid(*xs, indexing="ij")
    ll = problem.log_like(np.column_stack([X.ravel(), Y.ravel()])).reshape(n, n)
    cell = (xs[0][1] - xs[0][0]) * (xs[1][1] - xs[1][0])
    wts = np.ones(n)
    wts[0] = wts[-1] = 0.5
    W = np.log(np.outer(wts, wts))
    return float(logsumexp(ll + W) + math.log(cell) - math.log(np.prod(hi - lo)))
