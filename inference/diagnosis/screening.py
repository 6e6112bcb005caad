"""Screen a finished calibration: where do the recorded curves depart from the model beyond the noise?

Generic statistics on the relative residuals of the error model of Eq. (1) (docs/reference.md section 1):
U_obs = U_sim (1 + eps), eps ~ N(0, sigma_eps^2), so under a correct model the relative residual
r_i = U_obs_i / U_sim_i - 1 is exactly N(0, sigma_eps^2) and independent from point to point. (The likelihood's
Eq. (5) uses (U_obs - U_sim)/U_obs = r/(1 + r), equal to r to first order.) Points below the likelihood's
near-zero floor are left out (NaN), as in Eq. (5).

`screen` runs, per curve, the four tests of structure versus noise of `structure` (runs, lag-1, scale, scan) on the
MAP residuals; the posterior predictive bands of `bands` when posterior-sample curves are given; the mismatch regions
(`structure.segment`); and the covariate attribution of `attribution`.
- Family-wise error: Holm's step-down over all 4 x (number of curves) p-values (valid under any dependence between
  the tests); the verdict is "structured mismatch" when any adjusted p-value is <= alpha.
- Mismatch regions: the best scan interval of a curve is a region when the curve's scan test is rejected by Holm;
  further regions at the Bonferroni level alpha/m (m = family size). Under noise alone no region is reported with
  probability >= 1 - alpha.

Fitted residuals. At the MAP the parameters were adjusted to these same residuals: to first order r = (I - H) eps,
H the projection onto the columns of the (relative) sensitivity matrix. That removes p directions, which for
physical parameters are smooth along a curve, so the fitted residuals have less scatter (E sum r^2 = (n - p) sigma^2)
and a negative lag-1 bias (about -p/(n - p)); all four tests are one-sided against too much scatter or too much
smoothness, so fitting makes them conservative. sigma_eps at the MAP is fitted to the pooled residuals too: a curve
that holds all the points then has S = n and p about 0.5 (never a false alarm). Verified by Monte Carlo with
least-squares polynomial fits in tests/inference/test_inference_mismatch.py.
"""
from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from .attribution import Attribution, attribute, holm
from .bands import predictive_bands
from .structure import Region, _finite, lag1_test, runs_test, scale_test, scan_test, segment

__all__ = ["TESTS", "POSITION", "CurveStatistics", "ScreenReport", "relative_residuals", "simulate_samples",
           "curve_statistics", "screen"]

#: the tests run on every curve, in the order of the Holm family
TESTS = ("runs", "lag1", "scale", "scan")
#: the reference covariate `screen` adds to the attribution: the position along each curve, 0 to 1
POSITION = "position along curve"


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

    Returns ({(test, curve): (n_samples, n_points) simulated values}, sigma_eps (n_samples,), or with error groups
    each curve's sigma (n_samples, n_curves) in the likelihood's curve order). A failed solve raises: posterior
    samples were all solved once already, so a failure here is an error of the caller.
    """
    return likelihood.simulated_many(thetas), likelihood.curve_sigmas(thetas)


def sigma_text(sigma_eps) -> str:
    """sigma_eps as reported: one value, or the distinct per-curve values of error groups."""
    if np.ndim(sigma_eps) == 0:
        return f"{sigma_eps:.4g}"
    return "per curve " + " / ".join(f"{s:.4g}" for s in dict.fromkeys(sigma_eps))


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
    sigma_eps: float | list       # at the MAP; with error groups each curve's, in the likelihood's curve order
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

    @classmethod
    def from_dict(cls, d: dict) -> "ScreenReport":
        """A ScreenReport back from its ``to_dict()``."""
        return cls(**{**d, "curves": [CurveStatistics(**c) for c in d["curves"]],
                      "regions": [Region(**r) for r in d["regions"]],
                      "attribution": [Attribution(**a) for a in d["attribution"]]})

    def to_json(self, path=None) -> str:
        text = json.dumps(self.to_dict(), indent=2)
        if path is not None:
            with open(path, "w") as fh:
                fh.write(text + "\n")
        return text

    def to_markdown(self) -> str:
        lines = [f"## Residual screening: {self.verdict}", "",
                 f"Relative residuals r = U_obs/U_sim - 1 at the MAP, sigma_eps = {sigma_text(self.sigma_eps)}. "
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
            lines += ["| test | curve | abscissa range | points | sign | mean r | p (adjusted) |",
                      "|---|---|---|---|---|---|---|"]
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


def screen(likelihood, map_simulated, sigma_eps, sample_simulated=None, sample_sigma=None, covariates=None,
           alpha=0.05, level=0.95, min_points=3, n_shifts=1000, seed=0) -> ScreenReport:
    """Locate the mismatch of a finished calibration.

    likelihood: the calibration's Likelihood; map_simulated: simulated values at the MAP ({(test, curve): values} or a
    forward result); sigma_eps: sigma_eps at the MAP (with error groups each curve's sigma, a sequence in the
    likelihood's curve order); sample_simulated, sample_sigma: posterior sample curves and their
    sigma_eps for the predictive bands (optional, see `predictive_bands`); covariates: per-point covariates for
    `attribution.attribute` (optional; the position along each curve is added as a reference); alpha: family-wise
    false-alarm level; level: predictive band level; min_points: shortest region.
    """
    t0 = time.perf_counter()
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha = {alpha} must be in (0, 1)")
    per_curve = np.ndim(sigma_eps) > 0
    keys = [(t.name, c) for t in likelihood.observations for c in t.curves]
    sigma_of = dict(zip(keys, np.broadcast_to(np.asarray(sigma_eps, dtype=float), (len(keys),)).tolist()))
    if not all(s > 0 for s in sigma_of.values()):
        raise ValueError(f"sigma_eps = {sigma_eps} must be > 0")
    residuals = relative_residuals(likelihood, map_simulated)
    curves = [curve_statistics(t, c, r, sigma_of[t, c], min_points) for (t, c), r in residuals.items()]
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
            regions += segment(cs.test, cs.curve, x, residuals[cs.test, cs.curve], sigma_of[cs.test, cs.curve], alpha,
                               family.size, first_level=1.0, min_points=min_points)
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
                        f"Holm over {len(TESTS)} tests x {len(curves)} curves", int(family.size),
                        [sigma_of[k] for k in keys] if per_curve else float(sigma_eps),
                        curves, tests, regions, attribution, float(level) if sample_simulated is not None else None,
                        time.perf_counter() - t0)
