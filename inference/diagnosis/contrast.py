"""Few-test contrasts: does a between-test condition explain the residual when there are only 2 to 4 tests?

A permutation null over k tests has at most k! distinct values (p >= 1/2 for 2 tests, docs/reference.md section 9),
so with fewer than 5 tests the between-test attribution (`attribution`) uses the residual scatter within the tests
instead. For one curve name, the tests' relative residuals r = U_obs/U_sim - 1 are put on a common abscissa
(`common_grid`), combined point by point into a contrast sequence b_i, and mean(b) = 0 is tested against the noise
of b (`mean_test`).

Common abscissa (`common_grid`): when the curves are recorded at the same abscissae (same number of points, equal
values to round-off, or no abscissa given and the same number of points), they are paired point by point and the
points where any residual is NaN are dropped. Otherwise, when every curve's abscissa is strictly monotone, each
curve's residuals (NaN points dropped) are interpolated linearly onto the recorded points of the sparsest curve inside
the range that all curves cover (the overlap); outside the overlap nothing is compared. Curves of different lengths
without a monotone abscissa are not compared (no pairing by index).

Contrasts on the grid (R_t,i: residual of test t at grid point i):
- numeric or ordinal condition (rate, confining stress, OCR): the trend over the ranks of the levels,
  b_i = sum_t w_t R_t,i, w_t = (rank_t - mean rank) / sum_t (rank_t - mean rank)^2 (two tests: the higher level's
  residual minus the lower's); z > 0: the residual rises with the condition;
- categorical condition (compression/extension, K0/isotropic): for every pair of levels (a, b), in sorted order or
  the order given, b_i = mean over the tests at level b of R_t,i - mean over those at level a; z > 0: the residual of
  level b is above that of level a.
Null hypothesis: r_t,i = f_i + e_t,i with any common shape f (it cancels in b) and noise e independent between tests
and stationary along each curve (autocorrelated allowed).

`mean_test`: z = mean(b) / SE, with the noise of b estimated about a straight line fitted to b along the grid (so a
difference that grows along the curve, the usual alternative, is not mistaken for autocorrelation), or about a line
plus one step when the best step removes at least STEP_REDUCTION = 75 % of the line's residual sum of squares (a
difference over part of the range: without it the step's remainder reads as lag-1 0.9 and the contrast loses all
power; the threshold keeps the step out of AR(1) noise, measured rates in the `attribution` docstring): e = b - fit;
rho = lag-1 autocorrelation of e plus its O(1/n) bias correction (3 + 6 rho)/n, clipped to [0, 0.9]; effective
sample size n_eff = n (1 - rho)/(1 + rho) (AR(1), at least 4); noise variance sum e^2 / (n - m n/n_eff) (m = 2 or 3
fitted coefficients each take about n/n_eff of it); SE^2 = variance / n_eff; p from Student's t with n_eff - 2
degrees of freedom, two-sided (one-sided when a candidate states the direction: `one_sided`).
"""
from __future__ import annotations

import itertools
import math

import numpy as np
from scipy import stats

__all__ = ["MIN_CONTRAST_POINTS", "MIN_EFFECTIVE_POINTS", "common_grid", "mean_test", "trend_contrast",
           "level_contrasts", "one_sided"]

#: shortest contrast sequence tested, and the smallest effective sample size credited
MIN_CONTRAST_POINTS = 8
MIN_EFFECTIVE_POINTS = 4.0
#: a step is fitted to a contrast's noise estimate when it removes this fraction of the line's residual sum of
#: squares, at least MIN_STEP_POINTS from either end (`mean_test`)
STEP_REDUCTION = 0.75
MIN_STEP_POINTS = 4


def _monotone(x):
    d = np.diff(x)
    return x.size >= 2 and (np.all(d > 0) or np.all(d < 0))


def common_grid(residuals: dict, keys: list, abscissae: dict | None = None):
    """(grid abscissa or None, residual matrix (len(keys), n_grid), how: "paired" | "interpolated") of the curves
    ``keys`` on a common abscissa (module docstring), or None when they cannot be compared.

    residuals: {(test, curve): r}; abscissae: {(test, curve): recorded abscissa} or None."""
    rs = [np.asarray(residuals[k], dtype=float) for k in keys]
    xs = None if abscissae is None or any(k not in abscissae for k in keys) else \
        [np.asarray(abscissae[k], dtype=float).ravel() for k in keys]
    same_size = len({r.size for r in rs}) == 1
    if same_size and (xs is None or all(np.allclose(x, xs[0], rtol=1e-12, atol=0.0) for x in xs)):
        r = np.vstack(rs)
        keep = np.all(np.isfinite(r), axis=0)
        return (None if xs is None else xs[0][keep]), r[:, keep], "paired"
    if xs is None:
        return None
    pieces = []
    for x, r in zip(xs, rs):
        ok = np.isfinite(x) & np.isfinite(r)
        x, r = x[ok], r[ok]
        if not _monotone(x):
            return None
        order = np.argsort(x)
        pieces.append((x[order], r[order]))
    lo, hi = max(x[0] for x, _ in pieces), min(x[-1] for x, _ in pieces)
    if not hi > lo:
        return None
    inside = [x[(x >= lo) & (x <= hi)] for x, _ in pieces]
    grid = min(inside, key=lambda g: g.size)
    return grid, np.vstack([np.interp(grid, x, r) for x, r in pieces]), "interpolated"


def _detrended(b):
    """(b minus its fitted smooth part, number of fitted coefficients): a straight line, or a line plus one step
    (a change of level at the break that minimizes the residual sum of squares, at least MIN_STEP_POINTS from either
    end) when the step removes at least STEP_REDUCTION of the line's residual sum of squares (a level change over
    part of the range, far beyond what autocorrelated noise produces)."""
    n = b.size
    line = np.column_stack([np.ones(n), np.arange(n) - (n - 1) / 2.0])
    e_line = b - line @ np.linalg.lstsq(line, b, rcond=None)[0]
    best, ss_line = e_line, float(e_line @ e_line)
    for k in range(MIN_STEP_POINTS, n - MIN_STEP_POINTS + 1):
        x = np.column_stack([line, (np.arange(n) >= k).astype(float)])
        e = b - x @ np.linalg.lstsq(x, b, rcond=None)[0]
        if float(e @ e) < float(best @ best):
            best = e
    if float(best @ best) <= (1.0 - STEP_REDUCTION) * ss_line:
        return best, 3
    return e_line, 2


def mean_test(b):
    """(z, degrees of freedom, n_eff, lag-1) of mean(b) = 0 for a stationary, possibly autocorrelated sequence b
    (module docstring); None when b is shorter than MIN_CONTRAST_POINTS or has no scatter about a straight line."""
    b = np.asarray(b, dtype=float)
    n = b.size
    if n < MIN_CONTRAST_POINTS:
        return None
    e, n_fitted = _detrended(b)
    ss = float(e @ e)
    if not ss > 1e-24 * max(float(b @ b), 1e-300):
        return None
    rho = float(e[1:] @ e[:-1]) / ss
    rho = min(max(rho + (3.0 + 6.0 * rho) / n, 0.0), 0.9)
    n_eff = max(n * (1.0 - rho) / (1.0 + rho), MIN_EFFECTIVE_POINTS)
    variance = ss / (n - n_fitted * n / n_eff)
    return float(b.mean() / math.sqrt(variance / n_eff)), n_eff - 2.0, n_eff, rho


def _details(b, grid, how, **extra):
    result = mean_test(b)
    if result is None:
        return None
    z, df, n_eff, rho = result
    out = {"z": z, "p": float(2.0 * stats.t.sf(abs(z), df)), "df": df, "n_eff": n_eff, "lag1": rho,
           "mean": float(b.mean()), "points": int(b.size), "grid": how}
    if grid is not None and grid.size:
        out["range"] = [float(grid[0]), float(grid[-1])]
    return {**out, **extra}


def trend_contrast(residuals: dict, keys: list, levels, abscissae=None):
    """Rank trend of the residual over a numeric or ordinal condition (module docstring) for the curves ``keys`` of
    one curve name at condition ``levels`` (numbers, one per key); the details dict or None."""
    level = np.asarray(levels, dtype=float)
    if np.unique(level).size < 2:
        return None
    common = common_grid(residuals, keys, abscissae)
    if common is None:
        return None
    grid, r, how = common
    rank = stats.rankdata(level) - (len(keys) + 1) / 2.0
    return _details((rank / (rank @ rank)) @ r, grid, how)


def level_contrasts(residuals: dict, keys: list, levels, order=None, abscissae=None) -> dict:
    """Pairwise contrasts of a categorical condition (module docstring) for the curves ``keys`` of one curve name at
    levels ``levels`` (one per key): {"b - a": details with "levels": [a, b]} (empty when fewer than 2 levels or the
    curves cannot be compared). order: the levels in the order pairs are formed (default sorted)."""
    labels = [str(v) for v in levels]
    present = sorted(set(labels)) if order is None else [str(v) for v in order if str(v) in set(labels)]
    if len(present) < 2:
        return {}
    common = common_grid(residuals, keys, abscissae)
    if common is None:
        return {}
    grid, r, how = common
    lab = np.array(labels)
    out = {}
    for a, b in itertools.combinations(present, 2):
        d = _details(r[lab == b].mean(axis=0) - r[lab == a].mean(axis=0), grid, how, levels=[a, b])
        if d is not None:
            out[f"{b} - {a}"] = d
    return out


def one_sided(details: dict, direction: int) -> float:
    """One-sided p of a contrast's details for the stated direction (+1: z > 0 expected, -1: z < 0)."""
    return float(stats.t.sf(direction * details["z"], details["df"]))
