"""Posterior predictive bands of the recorded values: the exact quantiles of a normal mixture.

Under the error model of Eq. (1) (docs/reference.md section 1), U_obs = U_sim (1 + eps), eps ~ N(0, sigma_eps^2),
the posterior predictive of one recorded value is the equal-weight mixture over posterior samples s of
N(U_sim_s, (sigma_s U_sim_s)^2). Its quantiles are solved exactly (safeguarded Newton on the mixture CDF, no Monte
Carlo draws of eps); the predictive tail probability (PIT) of each recorded value, the points outside the band and
the coverage per curve follow.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import special

__all__ = ["PredictiveBand", "predictive_bands"]


@dataclass
class PredictiveBand:
    """Posterior predictive of U_obs at the recorded points of one curve.

    lower, upper: quantiles (1-level)/2 and (1+level)/2 of U_sim(1 + eps) over posterior samples; mean: its mean
    (the mean simulated curve);
    pit: predictive probability P(U_obs_rep <= recorded value); outside: recorded value outside the band (NaN points
    below the floor are never outside); n_used: the number of used points; coverage: fraction of them inside the
    band (expected about `level`).
    """

    test: str
    curve: str
    x: np.ndarray
    observed: np.ndarray
    lower: np.ndarray
    mean: np.ndarray
    upper: np.ndarray
    pit: np.ndarray
    outside: np.ndarray
    n_used: int
    coverage: float
    level: float

    def to_dict(self) -> dict:
        d = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(self).items()}
        d["n_outside"] = int(self.outside.sum())
        return d


def _mixture_cdf_pdf(u, mean, sd):
    """CDF and density at u (N,) of the equal-weight mixture of N(mean[s], sd[s]^2), mean and sd (n_s, N). A
    component of (near) zero spread, at a simulated value of zero (the start of a curve), is a point mass: its z is
    infinite away from it, its CDF 0 or 1 and its density 0 (the overflow there is expected, not reported)."""
    with np.errstate(over="ignore", divide="ignore"):
        z = (u - mean) / sd
        return special.ndtr(z).mean(axis=0), (np.exp(-0.5 * z * z) / sd).mean(axis=0) / math.sqrt(2 * math.pi)


def _mixture_quantile(q, mean, sd, tol=1e-9, max_iter=50):
    """Quantile q of the normal mixture per column (mean, sd: (n_s, N)): Newton steps from the moment-matched
    normal's quantile, kept inside a shrinking bracket (bisection when a step leaves it); typically three
    iterations. Converged when the mixture CDF is within ``tol`` of q at every column."""
    zq = special.ndtri(q)
    component = mean + zq * sd
    lo, hi = component.min(axis=0), component.max(axis=0)  # the mixture quantile lies between these
    m = mean.mean(axis=0)
    u = np.clip(m + zq * np.sqrt(np.mean(sd * sd, axis=0) + mean.var(axis=0)), lo, hi)
    for _ in range(max_iter):
        cdf, pdf = _mixture_cdf_pdf(u, mean, sd)
        err = cdf - q
        if np.all(np.abs(err) < tol):
            break
        hi, lo = np.where(err > 0, u, hi), np.where(err <= 0, u, lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = u - err / pdf
        u = np.where(np.isfinite(step) & (step > lo) & (step < hi), step, 0.5 * (lo + hi))
    return u


def predictive_bands(likelihood, sample_simulated: dict, sample_sigma, level=0.95) -> dict:
    """Posterior predictive bands {(test, curve): PredictiveBand} from precomputed sample curves.

    likelihood: the calibration's Likelihood (recorded curves and near-zero masks); sample_simulated:
    {(test, curve): (n_samples, n_points)} simulated values at the recorded abscissae (e.g. from
    ``simulate_samples``, or reused from the case's own solves); sample_sigma: sigma_eps of each sample (n_samples,)
    or one float, or with error groups each curve's sigma (n_samples, n_curves) in the likelihood's curve order;
    level: central probability of the band.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level = {level} must be in (0, 1)")
    keys = [(t.name, c) for t in likelihood.observations for c in t.curves]
    missing = [k for k in keys if k not in sample_simulated]
    if missing:
        raise ValueError(f"sample_simulated has no curves {missing}")
    sims = [np.atleast_2d(np.asarray(sample_simulated[k], dtype=float)) for k in keys]
    n_s = sims[0].shape[0]
    sigma = np.asarray(sample_sigma, dtype=float)
    per_curve = sigma.ndim == 2
    if per_curve:  # each curve's sigma, repeated over its points
        if sigma.shape != (n_s, len(keys)):
            raise ValueError(f"sample_sigma has shape {sigma.shape}, expected ({n_s},) or ({n_s}, {len(keys)})")
        sigma = np.repeat(sigma, [s.shape[1] for s in sims], axis=1)
    else:
        sigma = np.broadcast_to(sigma.ravel(), (n_s,))
    if not np.all(sigma > 0):
        raise ValueError(f"sample_sigma must be > 0, got min {sigma.min()}")
    for k, s in zip(keys, sims):
        c = likelihood.observations[k[0]].curves[k[1]]
        if s.shape != (n_s, c.y.size):
            raise ValueError(f"sample_simulated[{k}] has shape {s.shape}, expected ({n_s}, {c.y.size})")
    mean = np.concatenate(sims, axis=1)
    sd = np.maximum(np.abs(mean) * (sigma if per_curve else sigma[:, None]), 1e-300)
    obs = np.concatenate([likelihood.observations[t].curves[c].y for t, c in keys])
    lower_all, upper_all = (_mixture_quantile(q, mean, sd) for q in ((1 - level) / 2, (1 + level) / 2))
    mean_all = mean.mean(axis=0)
    pit = _mixture_cdf_pdf(obs, mean, sd)[0]
    out, start = {}, 0
    for (t, c), s in zip(keys, sims):
        sl = slice(start, start + s.shape[1])
        start = sl.stop
        used = likelihood.masks[t, c]
        lower, upper = lower_all[sl], upper_all[sl]
        y = likelihood.observations[t].curves[c].y
        outside = used & ((y < lower) | (y > upper))
        out[t, c] = PredictiveBand(t, c, likelihood.observations[t].curves[c].x, y, lower, mean_all[sl], upper, pit[sl],
                                   outside, int(used.sum()), float(1.0 - outside.sum() / used.sum()), float(level))
    return out
