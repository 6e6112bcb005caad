"""Stage mathematics of TMCMC (docs/reference.md section 2): the next tempering exponent, the weights and evidence,
the weighted covariance, resampling, the random streams and the adaptive-sweep statistic.

Stages beta_0 = 0 < beta_1 < ... < beta_m = 1 with f_j ∝ pi(theta) L(theta)^beta_j, pi the prior (the tempering
exponent is the paper's q_j; here beta, since q is the deviator stress in soil mechanics; the code's variables write
it p, the random-walk scale of step 3 is beta2 = beta^2 of Eq. (11)):
1. beta_{j+1} by bisection so that the coefficient of variation of w_k = L_k^(beta_{j+1} - beta_j) equals 1 (log
   space);
2. weights Eq. (9), S_j = mean(w) Eq. (10), ln Z = sum_j ln S_j;
3. proposal covariance Sigma_j = beta^2 * weighted covariance, Eqs. (11)-(12);
4. resampling with probabilities w_k / sum w (step 5.1).
"""
from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

__all__ = ["SamplerError", "choose_next_exponent", "stage_weights", "weighted_covariance", "resample",
           "random_stream", "start_correlation", "SIBLING_FRACTION"]

#: the adaptive-sweep rule uses siblings of one parent when at least this fraction of the particles are extra copies
SIBLING_FRACTION = 0.1


class SamplerError(RuntimeError):
    """The sampler cannot continue (too many failed forward solves, invalid settings)."""


def choose_next_exponent(log_like, p, cov_target=1.0, tol=1e-10):
    """Step 1: the next tempering exponent p' in (p, 1] such that COV(L^(p' - p)) = cov_target (bisection in
    log space, shifted by max ln L). -inf entries (failed particles) have zero weight. Returns 1 if the COV
    stays below the target up to p' = 1."""
    finite = np.isfinite(log_like)
    if not finite.any():
        raise SamplerError("every particle has zero likelihood: cannot choose the next stage")
    shifted = np.where(finite, log_like - np.max(log_like[finite]), -np.inf)

    def cov(dp):
        w = np.exp(dp * shifted)
        m = w.mean()
        return w.std() / m

    hi = 1.0 - p
    if cov(hi) <= cov_target:
        return 1.0
    lo = hi
    while cov(lo) > cov_target:
        lo *= 0.1
        if lo < 1e-300:
            raise SamplerError(f"the fraction of zero-likelihood particles ({1 - finite.mean():.0%}) alone gives "
                               f"a weight COV above {cov_target}: cannot temper")
    hi = min(hi, lo * 10.0)
    while hi - lo > tol * hi:  # COV grows monotonically with the exponent step
        mid = 0.5 * (lo + hi)
        if cov(mid) > cov_target:
            hi = mid
        else:
            lo = mid
    return p + lo


def stage_weights(log_like, dp):
    """Eqs. (9)-(10): returns (normalized weights, ln S_j) with w_k = L_k^dp, dp = beta_{j+1} - beta_j; -inf gives
    weight 0."""
    lw = np.where(np.isfinite(log_like), dp * log_like, -np.inf)
    log_sum = logsumexp(lw)
    return np.exp(lw - log_sum), float(log_sum - np.log(len(log_like)))


def weighted_covariance(theta, weights):
    """Eq. (12): sum_k w_k (theta_k - mean)(theta_k - mean)^T with normalized weights."""
    mean = weights @ theta
    dev = theta - mean
    return (weights[:, None] * dev).T @ dev


def resample(weights, rng, method="systematic"):
    """Step 4 (5.1): N indices drawn with probabilities ``weights``, sorted. "multinomial" is Ching & Chen's;
    "systematic" (one uniform, N evenly spaced points on the cumulative weights) has lower variance."""
    n = len(weights)
    if method == "multinomial":
        return np.sort(rng.choice(n, size=n, p=weights))
    if method != "systematic":
        raise ValueError(f"resampling = {method!r}: use 'systematic' or 'multinomial'")
    cum = np.cumsum(weights)
    cum[-1] = 1.0
    return np.searchsorted(cum, (rng.random() + np.arange(n)) / n, side="right").clip(0, n - 1)


def random_stream(seed, *key):
    """The generator of the stream keyed by (seed, stage, sweep, move): the same numbers on any executor, rank count
    or resume."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), *[int(k) for k in key]]))


def start_correlation(start, pos):
    """Correlation between the particles' start and current positions, mean over dimensions: the smaller of the
    plain correlation over the population and a within-mode estimate from siblings.

    Siblings (copies of one resampled parent, hence one start x0) move independently given x0. For a mode of
    variance s^2 and a lag correlation rho, the mean squared displacement is D = E(x - x0)^2 = 2 s^2 (1 - rho)
    and the spread among siblings is W = E Var(x | x0) = s^2 (1 - rho^2) (exact for Gaussian modes), so
    rho = 2 W / D - 1 with W and D taken over the siblings. Both are local, so the spread between modes, which
    keeps the plain correlation near 1 on a multimodal posterior, drops out. Each estimate errs high in its own
    case: the plain one through the spread between modes, the sibling one because copies come from high-weight
    starts near a mode's centre, which move less (on unimodal problems it exceeds the plain one); hence the
    minimum. The sibling estimate needs at least ``SIBLING_FRACTION`` of the population to be extra copies."""
    a, b = start, pos
    da, db = a - a.mean(0), b - b.mean(0)
    den = np.sqrt((da * da).sum(0) * (db * db).sum(0))
    plain = float(np.where(den > 0, (da * db).sum(0) / np.where(den > 0, den, 1.0), 0.0).mean())
    _, group, counts = np.unique(a, axis=0, return_inverse=True, return_counts=True)
    group = group.ravel()
    dof = int(np.sum(counts[counts > 1] - 1))
    if dof < SIBLING_FRACTION * len(a):
        return plain
    in_group = counts[group] > 1
    g, x = group[in_group], b[in_group]
    sums = np.zeros((counts.size, x.shape[1]))
    np.add.at(sums, g, x)
    within = ((x - sums[g] / counts[g][:, None]) ** 2).sum(0) / dof
    disp = ((x - a[in_group]) ** 2).mean(0)
    rho = np.where(disp > 0, 2.0 * within / np.where(disp > 0, disp, 1.0) - 1.0, 1.0)
    return min(plain, float(np.clip(rho, -1.0, 1.0).mean()))

