"""Predictions of tests the calibration never saw: the predictive band with a model-error term, the model-error
amplitude from held-out residuals, and the scores of a band (docs/reference.md section 10, Eqs. (P1)-(P4)).

The predictive of a recorded value U of a test without data in the calibration (P1) is the equal-weight mixture over
posterior draws s of N(U_s, U_s^2 (sigma_s^2 + a_k^2)): U_s the simulated value of draw s (parameter uncertainty),
sigma_s its error parameter of Eq. (1) (noise; its error group's with Eq. (6g)) and a_k the model-form discrepancy
of the curve's quantity k, the Gaussian process of (D1) at a curve that has no data (its prior, variance a_k^2),
which grows with the test's distance from the calibrated tests in the space of their conditions (P2).
Relative quantities (sigma, a_k, residuals) are dimensionless; U, band widths and scores are in the curve's unit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from .diagnosis.bands import predictive_bands

__all__ = ["StateSpace", "ModelError", "prediction_bands", "interval_score", "crps_normal_mixture", "band_scores"]

#: columns of the CRPS double sum evaluated at once (memory: draws^2 x columns floats)
_CRPS_COLUMNS = 64


class StateSpace:
    """The distance between tests in the space of their conditions (P2): ``states`` {test: {feature: value}}, a
    number (a void ratio, the logarithm of a stress or a rate) or a text (the apparatus, the drainage). Gower's (1971)
    scaling: a numeric feature's difference divided by its range over every test given (calibrated and predicted),
    a text feature's 0 when equal and 1 when not, a feature given for one test of a pair and not the other 1; the
    distance is the Euclidean norm of these differences (dimensionless; 0 for tests in the same conditions)."""

    def __init__(self, states: dict):
        self.states = {name: dict(features) for name, features in states.items()}
        features = {f for s in self.states.values() for f in s}
        self.scale = {}
        for f in sorted(features):
            values = [s[f] for s in self.states.values() if f in s]
            if all(isinstance(v, str) for v in values):
                self.scale[f] = None
            else:
                span = float(np.ptp(np.asarray(values, dtype=float)))
                self.scale[f] = span if span > 0 else math.inf

    def distance(self, a: str, b: str) -> float:
        """The distance between tests ``a`` and ``b``."""
        sa, sb = self.states[a], self.states[b]
        total = 0.0
        for f, scale in self.scale.items():
            if f not in sa and f not in sb:
                continue
            if f not in sa or f not in sb:
                total += 1.0
            elif scale is None:
                total += float(sa[f] != sb[f])
            else:
                total += ((float(sa[f]) - float(sb[f])) / scale) ** 2
        return math.sqrt(total)

    def nearest(self, name: str, others) -> float:
        """The distance from test ``name`` to the nearest of ``others`` (at least one)."""
        return min(self.distance(name, o) for o in others)


@dataclass(frozen=True)
class ModelError:
    """(P2) the model-error amplitude a_k of each quantity k at a distance d from the calibrated tests
    (:class:`StateSpace`): a_k^2(d) = excess_k d / distance_k, the held-out excess variance growing linearly with the
    distance (a linear variogram). ``excess`` {k: the mean over the left-out curves of quantity k of [mean square
    relative residual - the relative variance the curve's calibration already predicts], at least 0};
    ``distance`` {k: the mean distance of those left-out tests to the nearest test of their calibration}. Where every
    left-out test had a test in its own conditions (distance_k 0) the amplitude is sqrt(excess_k) at any distance."""

    excess: dict
    distance: dict

    @classmethod
    def from_held_out(cls, curves: dict) -> "ModelError":
        """From the held-out curves {k: [(residuals, explained_variance, distance), ...]}: ``residuals`` one array of
        relative residuals (U_obs - U_num)/U_obs of a curve of quantity k of a left-out test (NaN points, below the
        floor of Eq. (5), left out); ``explained_variance`` the noise variance sigma^2 of its error group plus the
        variance of the relative prediction over the posterior draws, both of the calibration that did not see it;
        ``distance`` that test's distance to the nearest test of that calibration."""
        excess, distance = {}, {}
        for k, terms in curves.items():
            if not terms:
                raise ValueError(f"quantity {k!r}: the model-error amplitude needs at least one held-out curve")
            excess[k] = max(0.0, float(np.mean([np.nanmean(np.asarray(r, dtype=float) ** 2) - float(v)
                                                for r, v, _ in terms])))
            distance[k] = float(np.mean([d for _, _, d in terms]))
        return cls(excess, distance)

    def amplitude(self, quantity: str, distance: float) -> float:
        """a_k at ``distance`` from the calibrated tests (0 for a quantity no left-out test recorded)."""
        if quantity not in self.excess:
            return 0.0
        reach = self.distance[quantity]
        return math.sqrt(self.excess[quantity] * (distance / reach if reach > 0 else 1.0))


def prediction_bands(likelihood, sample_simulated: dict, sample_sigma, amplitude: dict, level=0.95) -> dict:
    """(P1) bands {(test, curve): PredictiveBand} of the likelihood's curves (:func:`inference.diagnosis.bands.
    predictive_bands`) with each curve's relative standard deviation sqrt(sigma_s^2 + a_k^2): ``sample_sigma`` as
    there ((n_s,) or (n_s, n_curves) in the likelihood's curve order), ``amplitude`` {(test, curve): a_k} (a curve
    not named: no model error)."""
    keys = [(t.name, c) for t in likelihood.observations for c in t.curves]
    n_s = np.atleast_2d(np.asarray(sample_simulated[keys[0]])).shape[0]
    sigma = np.asarray(sample_sigma, dtype=float)
    sigma = sigma if sigma.ndim == 2 else np.repeat(np.broadcast_to(sigma.ravel(), (n_s,))[:, None], len(keys), 1)
    a = np.array([amplitude.get(key, 0.0) for key in keys])
    return predictive_bands(likelihood, sample_simulated, np.sqrt(sigma**2 + a**2), level=level)


def interval_score(lower, upper, observed, level=0.95) -> np.ndarray:
    """The interval score of a central (level) prediction interval [lower, upper] (Gneiting & Raftery 2007, Eq. 43,
    written as a penalty: lower is better; in the unit of the values), per point:
    (upper - lower) + (2/alpha)(lower - y) 1{y < lower} + (2/alpha)(y - upper) 1{y > upper}, alpha = 1 - level."""
    lower, upper, y = (np.asarray(v, dtype=float) for v in (lower, upper, observed))
    alpha = 1.0 - level
    return (upper - lower) + 2.0 / alpha * (np.maximum(lower - y, 0.0) + np.maximum(y - upper, 0.0))


def _a(mu, var):
    """A(mu, s^2) = 2 s phi(mu/s) + mu (2 Phi(mu/s) - 1), the expectation E|X| of X ~ N(mu, s^2)."""
    s = np.sqrt(var)
    z = mu / s
    return 2.0 * s * np.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi) + mu * (2.0 * special.ndtr(z) - 1.0)


def crps_normal_mixture(observed, mean, sd) -> np.ndarray:
    """(P4) the continuous ranked probability score of the equal-weight mixture of N(mean[s], sd[s]^2) at the
    observed values (Grimit et al. 2006; a penalty in the unit of the values, lower is better):
    CRPS = E|X - y| - E|X - X'|/2 = (1/n) sum_s A(y - mu_s, sd_s^2) - (1/2n^2) sum_s,t A(mu_s - mu_t, sd_s^2 + sd_t^2).
    ``observed`` (N,), ``mean`` and ``sd`` (n_s, N); returns (N,)."""
    y = np.asarray(observed, dtype=float)
    mean, sd = (np.atleast_2d(np.asarray(v, dtype=float)) for v in (mean, sd))
    var = sd * sd
    out = np.empty(y.size)
    for start in range(0, y.size, _CRPS_COLUMNS):
        cols = slice(start, min(y.size, start + _CRPS_COLUMNS))
        m, v = mean[:, cols], var[:, cols]
        first = _a(y[cols] - m, v).mean(axis=0)
        pair = _a(m[:, None, :] - m[None, :, :], v[:, None, :] + v[None, :, :]).mean(axis=(0, 1))
        out[cols] = first - 0.5 * pair
    return out


def band_scores(band, mean, sd, used) -> dict:
    """The scores of one curve's band (:class:`inference.diagnosis.bands.PredictiveBand`) at its ``used`` points
    (boolean, the likelihood's mask: outside the floor of Eq. (5)): coverage (fraction of the recorded values inside
    the band), mean_width (mean upper - lower, the curve's unit), relative_width (mean of (upper - lower)/|recorded
    value|), interval_score and crps (means of (P3) and (P4), the curve's unit), n (points); ``mean``, ``sd`` (n_s, N)
    the mixture of (P1) at the curve's recorded points."""
    y, lower, upper = band.observed[used], band.lower[used], band.upper[used]
    return {"coverage": float(np.mean((y >= lower) & (y <= upper))), "mean_width": float(np.mean(upper - lower)),
            "relative_width": float(np.mean((upper - lower) / np.abs(y))),
            "interval_score": float(interval_score(lower, upper, y, band.level).mean()),
            "crps": float(crps_normal_mixture(y, mean[:, used], sd[:, used]).mean()), "n": int(used.sum())}
