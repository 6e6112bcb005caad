"""The likelihood of the paper: normalized relative-error goodness of fit with an identified error sigma.

Eq. (1): U_obs = c U_num(b), c ~ N(1, sigma_eps^2).
Eq. (5): J_g = 1/N_0 sum_j [1/N_j sum_i ((U_obs_i - U_num_i)/U_obs_i)^2] over the N_0 curves of one test.
Eq. (4): ln p(D|theta) = -N/2 ln(2 pi sigma_eps^2) - N/(2 sigma_eps^2) J_g, N = number of points used.
Eq. (6): ln p(D|theta) = sum_i w_i ln p(D_i|theta) over tests, w_i = 1 by default.

Near-zero recorded values (the origin of a stress-strain curve) make relative errors explode; the paper is silent.
Points with |U_obs| below ``floor`` times the curve's max |U_obs| (default 1 %) are excluded and counted
(REFERENCE section 1).

A forward model maps a parameter dict (soil parameters, without sigma_eps) to simulated curves:
``{test: {curve: y_at_observed_x}}`` or ``{test: {curve: (x_sim, y_sim)}}``, the latter interpolated linearly to the
recorded abscissae (the simulation must cover them). With ``batch=True`` the forward model takes a list of parameter
dicts and returns a list of such results (an Exception instance in place of a failed one).
"""
from __future__ import annotations

import numpy as np

from .observations import Observations

__all__ = ["ForwardModelError", "Likelihood", "goodness_of_fit", "log_likelihood_test"]


class ForwardModelError(RuntimeError):
    """The forward model gave no usable curves for this parameter vector (reason in the message)."""


def goodness_of_fit(observed, simulated) -> float:
    """Eq. (5): mean over curves of the mean squared relative error; arguments are lists of equal-length arrays."""
    total = 0.0
    for o, s in zip(observed, simulated):
        rel = (o - s) / o
        total += float(rel @ rel) / rel.size
    return total / len(observed)


def log_likelihood_test(j_g, n_points, sigma_eps):
    """Eq. (4) for one test with N points (vectorizes over sigma_eps and j_g)."""
    return -0.5 * n_points * np.log(2.0 * np.pi * sigma_eps**2) - n_points * j_g / (2.0 * sigma_eps**2)


class Likelihood:
    """ln p(D | theta) of Eqs. (3)-(6) for observations and a forward model.

    Parameters
    ----------
    observations: Observations
    forward: callable, params dict -> {test: {curve: values or (x, y)}} (or a list -> list with batch=True)
    weights: {test: w_i} of Eq. (6), default 1 for every test
    sigma: name of the error parameter in the prior ("sigma_eps"), or a fixed float
    floor: relative near-zero floor of Eq. (5) (fraction of the curve's max |U_obs|)
    batch: the forward model is vectorized over parameter sets
    """

    def __init__(self, observations: Observations, forward, weights=None, sigma="sigma_eps", floor=0.01,
                 batch=False):
        if not isinstance(observations, Observations):
            raise TypeError("observations must be an inference.Observations")
        self.observations = observations
        self.forward = forward
        self.batch = bool(batch)
        self.sigma = sigma
        self.floor = float(floor)
        if not 0.0 <= self.floor < 1.0:
            raise ValueError(f"floor = {floor} must be in [0, 1)")
        weights = dict(weights or {})
        unknown = set(weights) - set(observations.tests)
        if unknown:
            raise ValueError(f"weights name unknown tests {sorted(unknown)}; tests are {list(observations.tests)}")
        self.weights = {t: float(weights.get(t, 1.0)) for t in observations.tests}
        # points used per curve (Eq. 5 floor)
        self.masks, self.excluded, self._span, self._used = {}, {}, {}, {}
        for t in observations:
            for cname, c in t.curves.items():
                ymax = np.max(np.abs(c.y))
                mask = np.abs(c.y) > self.floor * ymax if ymax > 0 else np.zeros(c.y.size, bool)
                if not mask.any():
                    raise ValueError(f"test {t.name}, curve {cname}: every recorded value is below the floor")
                self.masks[t.name, cname] = mask
                self.excluded[t.name, cname] = int(c.y.size - mask.sum())
                # per-evaluation constants: recorded span with its coverage tolerance, the used recorded values
                self._span[t.name, cname] = (c.x.min(), c.x.max(), 1e-9 * max(1.0, np.max(np.abs(c.x))))
                self._used[t.name, cname] = c.y[mask]
        self.n_points = {t.name: int(sum(self.masks[t.name, c].sum() for c in t.curves)) for t in observations}
        self.names = None

    # ----------------------------------------------------------------- binding to a prior's parameter order
    def bind(self, names):
        """Fix the parameter order (the prior's). Returns self."""
        names = tuple(names)
        if isinstance(self.sigma, str) and self.sigma not in names:
            raise ValueError(f"the prior has no error parameter {self.sigma!r}: add it or pass sigma=<float>")
        self.names = names
        return self

    def split(self, theta):
        """theta (prior order) -> (soil parameter dict, sigma_eps)."""
        if self.names is None:
            raise RuntimeError("Likelihood.bind(prior.names) must be called before evaluation")
        params = {n: float(v) for n, v in zip(self.names, theta)}
        sigma = params.pop(self.sigma) if isinstance(self.sigma, str) else float(self.sigma)
        return params, sigma

    def fingerprint(self) -> str:
        return f"{self.observations.fingerprint()}|w={sorted(self.weights.items())}|floor={self.floor}|s={self.sigma}"

    # ----------------------------------------------------------------- evaluation
    def simulated_at_observations(self, result) -> dict:
        """Forward result -> {(test, curve): simulated values at the recorded abscissae}; ForwardModelError if unusable."""
        if isinstance(result, Exception):
            raise result
        out = {}
        for t in self.observations:
            if t.name not in result:
                raise ForwardModelError(f"forward model returned no test {t.name!r}")
            for cname, c in t.curves.items():
                sim = result[t.name].get(cname) if hasattr(result[t.name], "get") else None
                if sim is None:
                    raise ForwardModelError(f"forward model returned no curve {cname!r} for test {t.name!r}")
                if isinstance(sim, tuple):
                    xs, ys = (np.asarray(v, dtype=float) for v in sim)
                    if xs.size < 2 or not (np.isfinite(xs).all() and np.isfinite(ys).all()):
                        raise ForwardModelError(f"test {t.name}, curve {cname}: simulated curve has NaN/inf")
                    lo, hi, tol = self._span[t.name, cname]
                    order = np.argsort(xs, kind="stable")
                    xs, ys = xs[order], ys[order]
                    if xs[0] > lo + tol or xs[-1] < hi - tol:
                        raise ForwardModelError(
                            f"test {t.name}, curve {cname}: simulation covers {c.x_name} in [{xs[0]:g}, {xs[-1]:g}]"
                            f" but the record spans [{lo:g}, {hi:g}]")
                    values = np.interp(c.x, xs, ys)
                else:
                    values = np.asarray(sim, dtype=float).ravel()
                    if values.shape != c.y.shape:
                        raise ForwardModelError(f"test {t.name}, curve {cname}: {values.size} simulated values for "
                                                f"{c.y.size} recorded points")
                if not np.isfinite(values).all():
                    raise ForwardModelError(f"test {t.name}, curve {cname}: simulated values contain NaN/inf")
                out[t.name, cname] = values
        return out

    def goodness_of_fit(self, simulated: dict) -> dict:
        """Eq. (5) per test from {(test, curve): values}."""
        return {t.name: goodness_of_fit([self._used[t.name, c] for c in t.curves],
                                        [simulated[t.name, c][self.masks[t.name, c]] for c in t.curves])
                for t in self.observations}

    def log_likelihood_from(self, result, sigma) -> float:
        """Eqs. (4) and (6) from one forward result."""
        if not sigma > 0:
            raise ForwardModelError(f"sigma_eps = {sigma} must be > 0")
        jg = self.goodness_of_fit(self.simulated_at_observations(result))
        return float(sum(self.weights[t] * log_likelihood_test(jg[t], self.n_points[t], sigma) for t in jg))

    def _forward_one(self, params):
        return self.forward([params])[0] if self.batch else self.forward(params)

    def __call__(self, theta) -> float:
        params, sigma = self.split(theta)
        return self.log_likelihood_from(self._forward_one(params), sigma)

    def evaluate_many(self, thetas):
        """Batch evaluation: (values (m,), reasons list) with -inf and a reason for each failed parameter set."""
        thetas = np.atleast_2d(thetas)
        split = [self.split(th) for th in thetas]
        values = np.full(len(thetas), -np.inf)
        reasons = [None] * len(thetas)
        results = None
        if self.batch:
            try:
                results = self.forward([p for p, _ in split])
            except Exception:  # the batch failed as a whole: evaluate one by one to find the culprits
                results = None
        for i, (params, sigma) in enumerate(split):
            try:
                if results is not None:
                    res = results[i]
                else:
                    res = self._forward_one(params)
                values[i] = self.log_likelihood_from(res, sigma)
            except Exception as exc:
                reasons[i] = f"{type(exc).__name__}: {exc}"
        return values, reasons

    # ----------------------------------------------------------------- diagnostics
    def residuals(self, theta) -> dict:
        """Relative residuals (U_obs - U_num)/U_obs per (test, curve) at theta (excluded points as NaN)."""
        params, _ = self.split(theta)
        result = self._forward_one(params)
        sim = self.simulated_at_observations(result)
        out = {}
        for t in self.observations:
            for c, curve in t.curves.items():
                r = (curve.y - sim[t.name, c]) / np.where(curve.y == 0, np.nan, curve.y)
                r[~self.masks[t.name, c]] = np.nan
                out[t.name, c] = r
        return out

    def summary_goodness(self, theta) -> dict:
        params, _ = self.split(theta)
        result = self._forward_one(params)
        return self.goodness_of_fit(self.simulated_at_observations(result))
