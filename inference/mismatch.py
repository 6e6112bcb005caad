"""Locate the mismatch between simulated and recorded curves after a calibration (issue 6, "locate").

Generic statistics on the relative residuals of the error model of Eq. (1) (REFERENCE section 1):
U_obs = U_sim (1 + eps), eps ~ N(0, sigma_eps^2), so under a correct model the relative residual
r_i = U_obs_i / U_sim_i - 1 is exactly N(0, sigma_eps^2) and independent from point to point. (The likelihood's
Eq. (5) uses (U_obs - U_sim)/U_obs = r/(1 + r), equal to r to first order.) Points below the likelihood's
near-zero floor are left out (NaN), as in Eq. (5).

What is computed
- Posterior predictive band of U_obs per point: the mixture over posterior samples s of N(U_sim_s, (sigma_s U_sim_s)^2),
  its quantiles solved exactly (safeguarded Newton on the mixture CDF), the predictive tail probability (PIT) of each
  recorded value, the points outside the band and the coverage per curve (`predictive_bands`).
- Per curve, four tests of "structure versus noise" on the MAP residuals in recorded order (the abscissa order for a
  monotone loading; for a record with holds or unloading the time order, in which misfit is contiguous):
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
- Family-wise error: Holm's step-down over all 4 x (number of curves) p-values (valid under any dependence between
  the tests); the verdict is "structured mismatch" when any adjusted p-value is <= alpha.
- Mismatch regions: binary segmentation with the scan statistic: the best interval of a curve is a region when the
  curve's scan test is rejected by Holm; the pieces left and right of it are scanned again and give further regions at
  the Bonferroni level alpha/m (m = family size). Under noise alone no region is reported with probability >= 1 - alpha.

Fitted residuals. At the MAP the parameters were adjusted to these same residuals: to first order r = (I - H) eps,
H the projection onto the columns of the (relative) sensitivity matrix. That removes p directions, which for
physical parameters are smooth along a curve, so the fitted residuals have less scatter (E sum r^2 = (n - p) sigma^2)
and a negative lag-1 bias (about -p/(n - p)); all four tests are one-sided against too much scatter or too much
smoothness, so fitting makes them conservative. sigma_eps at the MAP is fitted to the pooled residuals too: a curve
that holds all the points then has S = n and p about 0.5 (never a false alarm). Verified by Monte Carlo with
least-squares polynomial fits in tests/test_inference_mismatch.py.

Covariate attribution (which per-point quantity explains the structured residual) is in `covariates.py`;
`screen` runs everything and returns a `ScreenReport` (JSON and Markdown).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import special

from .covariates import Attribution, attribute, holm

__all__ = ["PredictiveBand", "CurveStatistics", "Region", "ScreenReport", "relative_residuals", "simulate_samples",
           "predictive_bands", "runs_test", "lag1_test", "scale_test", "scan_test", "holm", "segment", "curve_statistics",
           "screen", "benchmark"]

#: the tests run on every curve, in the order of the Holm family
TESTS = ("runs", "lag1", "scale", "scan")
SCAN_DRAWS = 2000
_SCAN_NULL: dict = {}


# ================================================================ residuals and posterior predictive
def _simulated_by_curve(likelihood, simulated) -> dict:
    """Accept {(test, curve): values} or a forward result {test: {curve: values | (x, y)}}."""
    if simulated and all(isinstance(k, tuple) for k in simulated):
        return {k: np.asarray(v, dtype=float) for k, v in simulated.items()}
    return likelihood.simulated_at_observations(simulated)


def relative_residuals(likelihood, simulated) -> dict:
    """r = U_obs / U_sim - 1 per (test, curve), Eq. (1); NaN below the likelihood's floor or where U_sim = 0.

    likelihood: the calibration's Likelihood (observations and near-zero masks); simulated: the simulated values at
    the recorded abscissae, {(test, curve): values} or a forward result {test: {curve: values or (x, y)}}.
    """
    sim = _simulated_by_curve(likelihood, simulated)
    out = {}
    for t in likelihood.observations:
        for c, curve in t.curves.items():
            s = sim[t.name, c]
            if s.shape != curve.y.shape:
                raise ValueError(f"test {t.name}, curve {c}: {s.size} simulated values for {curve.y.size} points")
            with np.errstate(divide="ignore", invalid="ignore"):
                r = curve.y / s - 1.0
            r[~likelihood.masks[t.name, c] | (s == 0) | ~np.isfinite(r)] = np.nan
            out[t.name, c] = r
    return out


def simulate_samples(likelihood, thetas):
    """Forward solves for posterior samples (rows of thetas in the prior's order, sigma_eps included).

    Returns ({(test, curve): (n_samples, n_points) simulated values}, sigma_eps (n_samples,)). A failed solve raises:
    posterior samples were all solved once already, so a failure here is an error of the caller.
    """
    split = [likelihood.split(th) for th in np.atleast_2d(thetas)]
    params = [p for p, _ in split]
    results = likelihood.forward(params) if likelihood.batch else [likelihood.forward(p) for p in params]
    per_sample = [likelihood.simulated_at_observations(res) for res in results]
    sims = {k: np.stack([ps[k] for ps in per_sample]) for k in per_sample[0]}
    return sims, np.array([s for _, s in split])


@dataclass
class PredictiveBand:
    """Posterior predictive of U_obs at the recorded points of one curve.

    lower, upper: quantiles (1-level)/2 and (1+level)/2 of U_sim(1 + eps) over posterior samples; mean: its mean
    (the mean simulated curve);
    pit: predictive probability P(U_obs_rep <= recorded value); outside: recorded value outside the band (NaN points
    below the floor are never outside); coverage: fraction of used points inside the band (expected about `level`).
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
    coverage: float
    level: float

    def to_dict(self) -> dict:
        d = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(self).items()}
        d["n_outside"] = int(self.outside.sum())
        return d


def _mixture_cdf_pdf(u, mean, sd):
    """CDF and density at u (N,) of the equal-weight mixture of N(mean[s], sd[s]^2), mean and sd (n_s, N)."""
    z = (u - mean) / sd
    return special.ndtr(z).mean(axis=0), (np.exp(-0.5 * z * z) / sd).mean(axis=0) / math.sqrt(2 * math.pi)


def _mixture_quantile(q, mean, sd, tol=1e-9, max_iter=50):
    """Quantile q of the normal mixture per column: Newton steps from the moment-matched normal's quantile, kept
    inside a shrinking bracket (bisection when a step leaves it); typically three iterations."""
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

    sample_simulated: {(test, curve): (n_samples, n_points)} simulated values at the recorded abscissae (e.g. from
    `simulate_samples`, or reused from the case's own solves); sample_sigma: sigma_eps of each sample (n_samples,) or
    one float. The band is exact for the mixture (no Monte Carlo draws of eps).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level = {level} must be in (0, 1)")
    keys = [(t.name, c) for t in likelihood.observations for c in t.curves]
    missing = [k for k in keys if k not in sample_simulated]
    if missing:
        raise ValueError(f"sample_simulated has no curves {missing}")
    sims = [np.atleast_2d(np.asarray(sample_simulated[k], dtype=float)) for k in keys]
    n_s = sims[0].shape[0]
    sigma = np.broadcast_to(np.asarray(sample_sigma, dtype=float).ravel(), (n_s,))
    if not np.all(sigma > 0):
        raise ValueError(f"sample_sigma must be > 0, got min {sigma.min()}")
    for k, s in zip(keys, sims):
        c = likelihood.observations[k[0]].curves[k[1]]
        if s.shape != (n_s, c.y.size):
            raise ValueError(f"sample_simulated[{k}] has shape {s.shape}, expected ({n_s}, {c.y.size})")
    mean = np.concatenate(sims, axis=1)
    sd = np.maximum(np.abs(mean) * sigma[:, None], 1e-300)
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
                                   outside, float(1.0 - outside.sum() / used.sum()), float(level))
    return out


# ================================================================ tests of structure versus noise
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


# ================================================================ regions
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


# ================================================================ screening report
@dataclass
class CurveStatistics:
    """Residual statistics of one curve at the MAP.

    n_points: points used; mean, rms: mean and root mean square of r = U_obs/U_sim - 1; runs, runs_expected: observed
    and expected number of sign runs; lag1: lag-1 autocorrelation; scale: sum r^2 / sigma_eps^2; scan: best interval
    statistic; p: raw p-values {test: p} of TESTS; p_adjusted: Holm over the whole family; structured: any adjusted
    p <= alpha; coverage, n_outside: posterior predictive coverage and points outside the band (None without samples).
    """

    test: str
    curve: str
    n_points: int
    mean: float
    rms: float
    runs: int
    runs_expected: float
    lag1: float
    scale: float
    scan: float
    p: dict
    p_adjusted: dict = field(default_factory=dict)
    structured: bool = False
    coverage: float | None = None
    n_outside: int | None = None

    def to_dict(self) -> dict:
        return asdict(self)


def curve_statistics(test, curve, r, sigma_eps, min_points=3) -> CurveStatistics:
    """The four structure tests of one curve's residuals r (recorded order, NaN skipped)."""
    x = _finite(r)
    runs, expected, p_runs = runs_test(x)
    rho, p_lag = lag1_test(x)
    s, _, p_scale = scale_test(x, sigma_eps)
    scan, _, p_scan = scan_test(x, sigma_eps, min_points)
    return CurveStatistics(test, curve, int(x.size), float(x.mean()) if x.size else 0.0,
                           float(np.sqrt(np.mean(x**2))) if x.size else 0.0, int(runs), expected, rho, s, scan,
                           {"runs": p_runs, "lag1": p_lag, "scale": p_scale, "scan": p_scan})


@dataclass
class ScreenReport:
    """Result of `screen`: per-curve statistics, mismatch regions, covariate ranking and the verdict."""

    verdict: str                  # "structured mismatch" or "consistent with noise"
    alpha: float                  # family-wise false-alarm level
    correction: str
    family_size: int
    sigma_eps: float
    curves: list
    tests: list                   # per test: {test, curves, structured_curves, min_p_adjusted, regions}
    regions: list
    attribution: list
    predictive_level: float | None = None
    wall_s: float = 0.0

    def to_dict(self) -> dict:
        d = {k: v for k, v in asdict(self).items() if k not in ("curves", "regions", "attribution")}
        d["curves"] = [c.to_dict() for c in self.curves]
        d["regions"] = [r.to_dict() for r in self.regions]
        d["attribution"] = [a.to_dict() for a in self.attribution]
        return d

    def to_json(self, path=None) -> str:
        text = json.dumps(self.to_dict(), indent=2)
        if path is not None:
            with open(path, "w") as fh:
                fh.write(text + "\n")
        return text

    def to_markdown(self) -> str:
        lines = [f"## Residual screening: {self.verdict}", "",
                 f"Relative residuals r = U_obs/U_sim - 1 at the MAP, sigma_eps = {self.sigma_eps:.4g}. "
                 f"False-alarm level {self.alpha:g} for the whole screening ({self.correction}, "
                 f"{self.family_size} tests).", "",
                 "| test | curve | n | mean r | rms r | runs p | lag-1 p | scale p | scan p | adj. p | coverage |",
                 "|---|---|---|---|---|---|---|---|---|---|---|"]
        for c in self.curves:
            cov = "-" if c.coverage is None else f"{100 * c.coverage:.0f} % ({c.n_outside} out)"
            flag = " **structured**" if c.structured else ""
            lines.append(f"| {c.test} | {c.curve} | {c.n_points} | {100 * c.mean:+.2f} % | {100 * c.rms:.2f} % | "
                         + " | ".join(f"{c.p[t]:.3g}" for t in TESTS)
                         + f" | {min(c.p_adjusted.values()):.3g}{flag} | {cov} |")
        lines += ["", "### Mismatch regions", ""]
        if self.regions:
            lines += ["| test | curve | abscissa range | points | sign | mean r | p (adjusted) |", "|---|---|---|---|---|---|---|"]
            for r in self.regions:
                what = "recorded above simulated" if r.sign == "+" else "recorded below simulated"
                lines.append(f"| {r.test} | {r.curve} | {r.x_start:.4g} to {r.x_end:.4g} | {r.n_points} | {what} | "
                             f"{100 * r.mean_relative:+.2f} % | {r.p_adjusted:.3g} |")
        else:
            lines.append("None at this false-alarm level.")
        if self.attribution:
            lines += ["", "### Covariates ranked by explained residual variance", "",
                      "| covariate | kind | R^2 | p | p (Holm) | null |", "|---|---|---|---|---|---|"]
            lines += [f"| {a.name} | {a.kind} | {a.r2:.3f} | {a.p_value:.3g} | {a.p_adjusted:.3g} | {a.null} |"
                      for a in self.attribution]
        return "\n".join(lines) + "\n"


POSITION = "position along curve"


def screen(likelihood, map_simulated, sigma_eps, sample_simulated=None, sample_sigma=None, covariates=None,
           alpha=0.05, level=0.95, min_points=3, n_shifts=1000, seed=0) -> ScreenReport:
    """Locate the mismatch of a finished calibration.

    likelihood: the calibration's Likelihood; map_simulated: simulated values at the MAP ({(test, curve): values} or a
    forward result); sigma_eps: sigma_eps at the MAP; sample_simulated, sample_sigma: posterior sample curves and their
    sigma_eps for the predictive bands (optional, see `predictive_bands`); covariates: per-point covariates for
    `covariates.attribute` (optional; the position along each curve is added as a reference); alpha: family-wise
    false-alarm level; level: predictive band level; min_points: shortest region.
    """
    import time

    t0 = time.perf_counter()
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha = {alpha} must be in (0, 1)")
    if not sigma_eps > 0:
        raise ValueError(f"sigma_eps = {sigma_eps} must be > 0")
    residuals = relative_residuals(likelihood, map_simulated)
    curves = [curve_statistics(t, c, r, sigma_eps, min_points) for (t, c), r in residuals.items()]
    family = np.array([cs.p[name] for cs in curves for name in TESTS])
    adjusted = holm(family).reshape(len(curves), len(TESTS))
    for cs, adj in zip(curves, adjusted):
        cs.p_adjusted = {name: float(a) for name, a in zip(TESTS, adj)}
        cs.structured = bool(np.any(adj <= alpha))
    if sample_simulated is not None:
        bands = predictive_bands(likelihood, sample_simulated, sample_sigma, level)
        for cs in curves:
            band = bands[cs.test, cs.curve]
            cs.coverage, cs.n_outside = band.coverage, int(band.outside.sum())
    regions = []
    for cs in curves:
        if cs.p_adjusted["scan"] <= alpha:
            x = likelihood.observations[cs.test].curves[cs.curve].x
            regions += segment(cs.test, cs.curve, x, residuals[cs.test, cs.curve], sigma_eps, alpha, family.size,
                               first_level=1.0, min_points=min_points)
    attribution = []
    if covariates:
        reference = {k: np.linspace(0.0, 1.0, r.size) for k, r in residuals.items()}
        attribution = attribute(residuals, {**covariates, POSITION: reference}, n_shifts=n_shifts, seed=seed)
    tests = [{"test": t.name, "curves": len(t.curves),
              "structured_curves": sum(cs.structured for cs in curves if cs.test == t.name),
              "min_p_adjusted": float(min(min(cs.p_adjusted.values()) for cs in curves if cs.test == t.name)),
              "regions": sum(r.test == t.name for r in regions)} for t in likelihood.observations]
    structured = bool(np.any(adjusted <= alpha))
    return ScreenReport("structured mismatch" if structured else "consistent with noise", float(alpha),
                        f"Holm over {len(TESTS)} tests x {len(curves)} curves", int(family.size), float(sigma_eps),
                        curves, tests, regions, attribution, float(level) if sample_simulated is not None else None,
                        time.perf_counter() - t0)


# ================================================================ benchmark
def benchmark(n_curves=10, n_points=100, n_samples=300, seed=0) -> dict:
    """Screening time on synthetic data (forward solves excluded): one test per curve, a planted bump in one curve."""
    import time

    from .likelihood import Likelihood
    from .observations import Curve, Observations, Test

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
    import argparse

    parser = argparse.ArgumentParser(description="Residual screening benchmark (prints one JSON line)")
    parser.add_argument("--curves", type=int, default=10)
    parser.add_argument("--points", type=int, default=100)
    parser.add_argument("--samples", type=int, default=300)
    args = parser.parse_args(argv)
    print(json.dumps(benchmark(args.curves, args.points, args.samples)))


if __name__ == "__main__":
    main()
