"""Structure versus noise in one curve's relative residuals, and the mismatch regions found by the scan statistic.

The residuals r_i = U_obs_i / U_sim_i - 1 of the error model of Eq. (1) (docs/reference.md section 1) are, under a
correct model, independent N(0, sigma_eps^2). Each test below is one-sided against structure, on the residuals in
recorded order (the abscissa order for a monotone loading; for a record with holds or unloading the time order, in
which misfit is contiguous):
  runs: Wald-Wolfowitz runs test on the signs, one-sided (too few runs), exact conditional p-value given the numbers
  of positive and negative signs; discrete, so its size is at most alpha (measured: 0.021 at n = 20, 0.033 at 50,
  0.042 at 200 for alpha = 0.05);
  lag1: lag-1 autocorrelation about zero rho = sum r_i r_{i+1} / sum r_i^2, one-sided (positive), against the
  symmetric beta law on [-cos(pi/(n+1)), cos(pi/(n+1))] with the exact null variance (n-1)/(n(n+2)) of iid normal
  residuals (size within 0.003 of alpha for n >= 20);
  scale: S = sum r_i^2 / sigma_eps^2 against chi-square(n), one-sided (too much scatter);
  scan: the largest standardized interval mean |sum_{i in I} r_i| / (sigma_eps sqrt(|I|)) over intervals of at least
  `min_points` points, against its null law for iid N(0, 1) computed once by Monte Carlo (2000 draws, fixed seed),
  p = (1 + #exceedances)/(1 + 2000), so p >= 5e-4.
Mismatch regions (`segment`): binary segmentation with the scan statistic; the pieces left and right of a region are
scanned again and give further regions at the Bonferroni level alpha/m (m = family size).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import special

__all__ = ["SCAN_DRAWS", "Region", "runs_test", "lag1_test", "scale_test", "scan_test", "segment"]

SCAN_DRAWS = 2000
_SCAN_NULL: dict = {}


def _finite(r):
    r = np.asarray(r, dtype=float).ravel()
    return r[np.isfinite(r)]


def runs_test(r):
    """Wald-Wolfowitz runs test on the signs of r (zeros and NaN dropped), one-sided: too few runs.

    Returns (number of runs, expected number, exact p = P(R <= observed | n+, n-)). p = 1 when all signs agree
    (nothing to test) or fewer than 2 points.
    """
    s = _finite(r)
    s = s[s != 0] > 0
    n1, n = int(s.sum()), s.size
    n2 = n - n1
    if n1 == 0 or n2 == 0:
        return 1 if n else 0, float(1 if n else 0), 1.0
    runs = 1 + int(np.count_nonzero(s[1:] != s[:-1]))
    expected = 1.0 + 2.0 * n1 * n2 / n
    # P(R = 2k) = 2 C(n1-1,k-1) C(n2-1,k-1) / C(n,n1); P(R = 2k+1) = [C(n1-1,k-1) C(n2-1,k) + C(n1-1,k) C(n2-1,k-1)] / C
    k = np.arange(1, runs // 2 + 2, dtype=float)
    c1, c2 = _log_comb(n1 - 1, k - 1), _log_comb(n2 - 1, k - 1)       # C(n1-1, k-1), C(n2-1, k-1)
    d1, d2 = _log_comb(n1 - 1, k), _log_comb(n2 - 1, k)               # C(n1-1, k),   C(n2-1, k)
    log_total = _log_comb(n, np.array([float(n1)]))[0]
    even = 2.0 * np.exp(c1 + c2 - log_total)
    odd = np.exp(c1 + d2 - log_total) + np.exp(d1 + c2 - log_total)
    p = even[2 * k <= runs].sum() + odd[2 * k + 1 <= runs].sum()
    return runs, float(expected), float(min(1.0, p))


def _log_comb(a, b):
    """ln C(a, b) for an array b (-inf where b < 0 or b > a)."""
    ok = (b >= 0) & (b <= a)
    bb = np.where(ok, b, 0.0)
    return np.where(ok, special.gammaln(a + 1.0) - special.gammaln(bb + 1.0) - special.gammaln(a - bb + 1.0), -np.inf)


def lag1_test(r):
    """Lag-1 autocorrelation about zero, rho = sum r_i r_(i+1) / sum r_i^2, one-sided (positive).

    Null law for iid N(0, s^2): rho lies in [-a, a], a = cos(pi/(n+1)) (extreme eigenvalues of the lag matrix),
    mean 0, variance (n-1)/(n(n+2)); approximated by the symmetric beta law on [-a, a] with that variance.
    Returns (rho, p); p = 1 for fewer than 3 points.
    """
    x = _finite(r)
    n = x.size
    ss = float(x @ x)
    if n < 3 or ss == 0:
        return 0.0, 1.0
    rho = float(x[1:] @ x[:-1]) / ss
    a = math.cos(math.pi / (n + 1))
    shape = 0.5 * (a * a * n * (n + 2) / (n - 1) - 1.0)
    return rho, float(special.betainc(shape, shape, (a - rho) / (2 * a)))  # beta survival, by symmetry


def scale_test(r, sigma_eps):
    """S = sum r^2 / sigma_eps^2 against chi-square(n), one-sided (too much scatter). Returns (S, n, p)."""
    x = _finite(r)
    if not sigma_eps > 0:
        raise ValueError(f"sigma_eps = {sigma_eps} must be > 0")
    s = float(x @ x) / sigma_eps**2
    return s, int(x.size), float(special.chdtrc(x.size, s)) if x.size else 1.0


def _scan_lengths(n, min_points):
    """Interval lengths scanned: every length up to 50, then a geometric grid of ratio 1.05 (fewer for long curves)."""
    full = np.arange(min_points, min(n, 50) + 1)
    if n <= 50:
        return full
    geo = np.unique(np.round(50 * 1.05 ** np.arange(1, 1 + math.ceil(math.log(n / 50) / math.log(1.05)))).astype(int))
    return np.concatenate([full, geo[(geo > 50) & (geo <= n)]])


def _scan_null(n, min_points):
    """Sorted null draws (SCAN_DRAWS,) of the scan statistic for iid N(0, 1) sequences of length n (cached).

    One simulation at length n_max gives every n <= n_max: the maximum over intervals inside the first n points is the
    running maximum over end points of the best interval ending there.
    """
    cached = _SCAN_NULL.get((n, min_points))
    if cached is not None:
        return cached
    table = _SCAN_NULL.get(min_points)
    if table is None or table.shape[1] < n + 1:
        n_max = max(n, 2 * (table.shape[1] - 1) if table is not None else 200)
        # drawn point by point (n_max, draws): the first n points of every draw do not depend on n_max, so p-values
        # do not depend on which curves were screened before in this process
        z = np.random.default_rng(np.random.SeedSequence([20240601, min_points])).standard_normal((n_max, SCAN_DRAWS)).T
        csum = np.concatenate([np.zeros((SCAN_DRAWS, 1)), np.cumsum(z, axis=1)], axis=1)
        best_ending = np.zeros((SCAN_DRAWS, n_max + 1))
        for length in _scan_lengths(n_max, min_points):
            stat = np.abs(csum[:, length:] - csum[:, :-length]) / math.sqrt(length)
            np.maximum(best_ending[:, length:], stat, out=best_ending[:, length:])
        table = np.maximum.accumulate(best_ending, axis=1)  # column n: maximum over intervals within the first n
        _SCAN_NULL[min_points] = table
    _SCAN_NULL[n, min_points] = np.sort(table[:, n])
    return _SCAN_NULL[n, min_points]


def scan_test(r, sigma_eps, min_points=3):
    """Best interval of one-signed misfit: max over intervals I (|I| >= min_points) of |sum r_I|/(sigma_eps sqrt|I|).

    r: residuals in recorded order (NaN allowed, skipped: intervals are over the finite points).
    Returns (statistic, (start, stop) indices into the finite points, Monte Carlo p-value). p = 1 when the curve has
    fewer than min_points points.
    """
    x = _finite(r)
    n = x.size
    if not sigma_eps > 0:
        raise ValueError(f"sigma_eps = {sigma_eps} must be > 0")
    if n < min_points:
        return 0.0, (0, n), 1.0
    csum = np.concatenate([[0.0], np.cumsum(x / sigma_eps)])
    lengths = _scan_lengths(n, min_points)
    start = np.arange(n)
    stop = np.minimum(start[None, :] + lengths[:, None], n)            # (lengths, starts); past the end -> empty
    stat = np.where(start[None, :] + lengths[:, None] <= n, np.abs(csum[stop] - csum[start]), -1.0) \
        / np.sqrt(lengths)[:, None]
    li, i = np.unravel_index(int(np.argmax(stat)), stat.shape)
    best = float(stat[li, i])
    null = _scan_null(n, min_points)
    exceed = null.size - np.searchsorted(null, best, side="left")
    return best, (int(i), int(i + lengths[li])), float((1 + exceed) / (1 + null.size))


@dataclass
class Region:
    """A contiguous abscissa range of one curve where the residual is systematically of one sign.

    sign: "+" when |recorded| exceeds |simulated| (U_obs/U_sim > 1: the model under-predicts), "-" otherwise;
    mean_relative: mean of r = U_obs/U_sim - 1 over the region; i_start, i_stop: indices into the curve's points
    (stop exclusive); p_value: scan p-value of the piece in which it was found; p_adjusted: Bonferroni over the family.
    """

    test: str
    curve: str
    x_start: float
    x_end: float
    i_start: int
    i_stop: int
    sign: str
    mean_relative: float
    n_points: int
    statistic: float
    p_value: float
    p_adjusted: float

    def to_dict(self) -> dict:
        return asdict(self)


def segment(test, curve, x, r, sigma_eps, alpha=0.05, family_size=1, first_level=None, min_points=3):
    """Binary segmentation of one curve's residuals into mismatch regions.

    x, r: abscissa and residuals r = U_obs/U_sim - 1 in recorded order (NaN residuals are skipped); sigma_eps: the
    error sigma of Eq. (1). The curve's best scan interval is a region when its p-value is <= first_level (default
    alpha/family_size; `screen` passes the Holm decision); the pieces left and right of a region are scanned with
    their own null law and give regions at p <= alpha/family_size (Bonferroni), recursively.
    Returns the regions sorted by abscissa; p_adjusted = min(1, family_size * p_value).
    """
    level = alpha / family_size
    first_level = level if first_level is None else first_level
    x = np.asarray(x, dtype=float)
    used = np.flatnonzero(np.isfinite(r))
    rr = np.asarray(r, dtype=float)[used]
    regions, pieces = [], [(0, used.size, first_level)]
    while pieces:
        lo, hi, threshold = pieces.pop()
        if hi - lo < min_points:
            continue
        stat, (i, j), p = scan_test(rr[lo:hi], sigma_eps, min_points)
        if p > threshold:
            continue
        i, j = lo + i, lo + j
        mean = float(np.mean(rr[i:j]))
        regions.append(Region(test, curve, float(x[used[i]]), float(x[used[j - 1]]), int(used[i]),
                              int(used[j - 1]) + 1, "+" if mean > 0 else "-", mean, j - i, stat, p,
                              min(1.0, family_size * p)))
        pieces += [(lo, i, level), (j, hi, level)]
    return sorted(regions, key=lambda reg: reg.i_start)
