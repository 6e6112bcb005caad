"""The likelihood of the paper: normalized relative-error goodness of fit with an identified error sigma, Eqs. (1),
(4)-(6) and (6g) with error groups (their terms: :mod:`inference.goodness`), over a study's tests and curves.

Near-zero recorded values (the origin of a stress-strain curve) make relative errors explode; the paper is silent.
Points with |U_obs| below ``floor`` times the curve's max |U_obs| (default 1 %) are excluded and counted
(REFERENCE section 1). A curve whose records change sign (an excess pore pressure that turns negative as an
overconsolidated clay dilates, q into extension) has a second origin in mid-curve, where a fit whose absolute
error is small everywhere has relative errors of tens of per cent: its floor is ``crossing_floor`` (default 10 %).

The forward model is an :class:`inference.forward.ForwardModel` (``simulate_batch(names, values) -> (curves,
failed)``), or a callable adapted to one: params dict -> ``{test: {curve: y_at_observed_x}}`` or ``{test: {curve:
(x_sim, y_sim)}}``, or with ``batch=True`` a list of parameter dicts -> a list of such results (an Exception
instance in place of a failed one). Simulated curves given on their own abscissae are interpolated linearly to the
recorded ones (the simulation must cover them). A batch table of curves is interpolated and scored by Eq. (5) in
numpy expressions over the batch; a list of per-particle results runs through the same interpolation, its usable
results stacked and scored the same way: both give each parameter set the bits it gets alone. The failure policy
(:func:`inference.forward.batch_or_each`): a batch that raises is evaluated particle by particle; a particle that
fails gets -inf and the reason ``"<exception class>: <message>"``.

A model-form discrepancy (:class:`inference.Discrepancy`, Eqs. (D1)-(D2) of :mod:`inference.discrepancy`) replaces
each curve's independent errors by errors plus a smooth Gaussian process marginalized exactly; its parameters
(``delta_<group>`` amplitudes and ``delta_length``) are then part of the prior like the error parameters.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .curve_reading import CurveReader
from .discrepancy import CurveDiscrepancy, Discrepancy, normalized_abscissa
from .forward import (
    ForwardModelError,
    as_forward_model,
    batch_or_each,
    distinct_rows,
    particle_result,
    reason_of,
    simulate_distinct,
    stacked_results,
)
from .goodness import curve_mean_squares, goodness_of_fit, log_likelihood_test
from .observations import Observations

__all__ = ["ForwardModelError", "Likelihood"]


#: the near-zero floor of Eq. (5) for a curve whose records change sign (fraction of its max |U_obs|): a fit whose
#: absolute error is 1-2 % of the curve's range has relative errors of 10-20 % at a tenth of it, a few times a
#: typical sigma_eps, and above it every point is judged by its relative error as the paper's are
CROSSING_FLOOR = 0.1


class Likelihood:
    """ln p(D | theta) of Eqs. (3)-(6) for observations and a forward model.

    Parameters
    ----------
    observations: Observations
    forward: an inference.forward.ForwardModel, or a callable params dict -> {test: {curve: values or (x, y)}} (or
        a list -> list with batch=True) adapted to one (inference.forward.as_forward_model)
    weights: {test: w_i} of Eq. (6), default 1 for every test (w_i multiplies the test's log-likelihood: give a test
        recorded much more densely than the others less weight, or a test repeated n times 1/n)
    sigma: name of the error parameter in the prior ("sigma_eps"), or a fixed float (every group)
    floor: relative near-zero floor of Eq. (5) (fraction of the curve's max |U_obs|)
    crossing_floor: the floor of a curve whose records change sign (values beyond ``floor`` of both signs): a
        fraction of its max |U_obs| as well, at least ``floor``
    batch: a callable ``forward`` takes a list of parameter sets (ignored for a ForwardModel)
    groups: None (one error parameter for every curve, the paper's setting) or {group: [curve name or (test, curve)
        key, ...]}, Eq. (6g): a curve name stands for that curve of every test; every curve falls in exactly one
        group. With two or more groups the error parameters are ``<sigma>_<group>`` (e.g. sigma_eps_volume) in the
        prior, in the order of ``groups``; with one group the name stays ``sigma``.
    discrepancy: None (the paper's independent errors) or an :class:`inference.Discrepancy`: a model-form
        discrepancy per curve (Eqs. (D1)-(D2)), whose parameters must be in the prior (:attr:`discrepancy_names`).
    """

    def __init__(self, observations: Observations, forward, weights=None, sigma="sigma_eps", floor=0.01,
                 batch=False, groups=None, discrepancy: Discrepancy | None = None, crossing_floor=CROSSING_FLOOR):
        if not isinstance(observations, Observations):
            raise TypeError("observations must be an inference.Observations")
        self.observations = observations
        self.forward = as_forward_model(forward, batch)
        self.sigma = sigma
        self.floor = float(floor)
        if not 0.0 <= self.floor < 1.0:
            raise ValueError(f"floor = {floor} must be in [0, 1)")
        self.crossing_floor = float(crossing_floor)
        if not self.floor <= self.crossing_floor < 1.0:
            raise ValueError(f"crossing_floor = {crossing_floor} must be in [floor = {self.floor}, 1)")
        weights = dict(weights or {})
        unknown = set(weights) - set(observations.tests)
        if unknown:
            raise ValueError(f"weights name unknown tests {sorted(unknown)}; tests are {list(observations.tests)}")
        self.weights = {t: float(weights.get(t, 1.0)) for t in observations.tests}
        # points used per curve (Eq. 5 floor; the crossing curves' floor for the curves that change sign)
        self.masks, self.excluded, self._used, self._kept = {}, {}, {}, {}
        self.crossing = []
        for t in observations:
            for cname, c in t.curves.items():
                ymax = np.max(np.abs(c.y))
                beyond = np.abs(c.y) > self.floor * ymax
                if np.any(beyond & (c.y > 0.0)) and np.any(beyond & (c.y < 0.0)):
                    self.crossing.append((t.name, cname))
                    beyond = np.abs(c.y) > self.crossing_floor * ymax
                mask = beyond if ymax > 0 else np.zeros(c.y.size, bool)
                if not mask.any():
                    raise ValueError(f"test {t.name}, curve {cname}: every recorded value is below the floor")
                self.masks[t.name, cname] = mask
                self.excluded[t.name, cname] = int(c.y.size - mask.sum())
                # per-evaluation constants: the used recorded values and their columns (a slice when every point is
                # used)
                self._used[t.name, cname] = c.y[mask]
                self._kept[t.name, cname] = slice(None) if mask.all() else np.flatnonzero(mask)
        self.n_points = {t.name: int(sum(self.masks[t.name, c].sum() for c in t.curves)) for t in observations}
        self.curve_keys = tuple((t.name, c) for t in observations for c in t.curves)
        self.group_of = self._resolve_groups(groups)
        self.groups = tuple(groups) if groups and len(groups) > 1 else tuple(dict.fromkeys(self.group_of.values()))
        if isinstance(sigma, str):
            self.sigma_names = ((sigma,) if len(self.groups) == 1 else
                                tuple(f"{sigma}_{g}" for g in self.groups))
        else:
            self.sigma_names = ()
        # per test: (group column, the group's curve indices in the test, its points N_ig) of Eq. (6g)
        self._test_groups = {}
        for t in observations:
            names = list(t.curves)
            self._test_groups[t.name] = [
                (k, [i for i, c in enumerate(names) if self.group_of[t.name, c] == g],
                 int(sum(self.masks[t.name, c].sum() for c in names if self.group_of[t.name, c] == g)))
                for k, g in enumerate(self.groups) if any(self.group_of[t.name, c] == g for c in names)]
        self._reader = CurveReader(observations)
        self.discrepancy = discrepancy
        self.discrepancy_names, self._curve_discrepancy, self._discrepancy_column = (), {}, {}
        if discrepancy is not None:
            group_of = discrepancy.group_of(self.curve_keys)
            groups = tuple(dict.fromkeys(group_of.values()))
            self.discrepancy_names = discrepancy.parameter_names(groups)
            self._discrepancy_column = {k: groups.index(g) for k, g in group_of.items()}
            for t in observations:
                for cname, c in t.curves.items():
                    u = normalized_abscissa(c.x[self.masks[t.name, cname]], c.x_name)
                    self._curve_discrepancy[t.name, cname] = CurveDiscrepancy(
                        u, len(t.curves), self.n_points[t.name], discrepancy.min_spacings)
        self.names = None
        self._soil_names, self._soil_columns, self._sigma_columns = None, None, None
        self._discrepancy_columns = []

    def _resolve_groups(self, groups) -> dict:
        """{(test, curve): group} from ``groups`` (see the class docstring); ValueError naming the curve or entry."""
        if groups is None or len(groups) <= 1:
            name = next(iter(groups)) if groups else "all"
            return {k: name for k in self.curve_keys}
        out = {}
        for g, members in groups.items():
            if not isinstance(g, str) or not g.isidentifier():
                raise ValueError(f"error group name {g!r} must be an identifier (it names sigma_eps_<group>)")
            if isinstance(members, (str, tuple)):
                members = [members]
            if not members:
                raise ValueError(f"error group {g} has no curves")
            for entry in members:
                keys = ([entry] if isinstance(entry, tuple) and entry in self.curve_keys else
                        [k for k in self.curve_keys if k[1] == entry])
                if not keys:
                    raise ValueError(f"error group {g}: {entry!r} names no recorded curve; curves are "
                                     f"{sorted({c for _, c in self.curve_keys})}")
                for k in keys:
                    if out.get(k, g) != g:
                        raise ValueError(f"test {k[0]}, curve {k[1]} is in two error groups: {out[k]} and {g}")
                    out[k] = g
        missing = [k for k in self.curve_keys if k not in out]
        if missing:
            raise ValueError(f"test {missing[0][0]}, curve {missing[0][1]} is in no error group; every curve must "
                             f"be in exactly one of {list(groups)}")
        return {k: out[k] for k in self.curve_keys}

    @property
    def batch(self) -> bool:
        """True when the forward model takes a batch of parameter sets in one call: the executors then hand the
        likelihood whole chunks of a batch instead of one set at a time (``inference.executors``); a batched
        forward model gives every set the bits it gives it alone."""
        return bool(self.forward.batched)

    # ----------------------------------------------------------------- binding to a prior's parameter order
    def bind(self, names):
        """Fix the parameter order (the prior's). Returns self."""
        names = tuple(names)
        for n in self.sigma_names:
            if n not in names:
                raise ValueError(f"the prior has no error parameter {n!r}: add it or pass sigma=<float>")
        for n in self.discrepancy_names:
            if n not in names:
                raise ValueError(f"the prior has no discrepancy parameter {n!r}")
        self.names = names
        self._soil_columns = [k for k, n in enumerate(names)
                              if n not in self.sigma_names and n not in self.discrepancy_names]
        self._soil_names = tuple(names[k] for k in self._soil_columns)
        self._sigma_columns = [names.index(n) for n in self.sigma_names]
        self._discrepancy_columns = [names.index(n) for n in self.discrepancy_names]
        return self

    def split(self, theta):
        """theta (prior order) -> (soil parameter dict, sigma_eps): a float with one error group, else
        {group: sigma_g}."""
        if self.names is None:
            raise RuntimeError("Likelihood.bind(prior.names) must be called before evaluation")
        params = {n: float(v) for n, v in zip(self.names, theta)}
        for n in self.discrepancy_names:
            params.pop(n)
        if not self.sigma_names:
            sigma = float(self.sigma)
            return params, sigma if len(self.groups) == 1 else {g: sigma for g in self.groups}
        sigmas = [params.pop(n) for n in self.sigma_names]
        return params, sigmas[0] if len(self.groups) == 1 else dict(zip(self.groups, sigmas))

    def sigma_arrays(self, thetas):
        """The error parameters of m parameter sets (rows of ``thetas`` in the prior's order): (m,) with one group,
        else (m, number of groups) in the order of ``groups``."""
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        if self.names is None:
            raise RuntimeError("Likelihood.bind(prior.names) must be called before evaluation")
        if self.sigma_names:
            sigma = thetas[:, self._sigma_columns]
        else:
            sigma = np.full((len(thetas), len(self.groups)), float(self.sigma))
        return sigma[:, 0] if len(self.groups) == 1 else sigma

    def discrepancy_arrays(self, thetas):
        """The discrepancy parameters of m parameter sets: (amplitudes (m, number of groups), length (m,)), or None
        without a discrepancy."""
        if self.discrepancy is None:
            return None
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        if self.names is None:
            raise RuntimeError("Likelihood.bind(prior.names) must be called before evaluation")
        values = thetas[:, self._discrepancy_columns]
        return values[:, :-1], values[:, -1]

    def curve_sigmas(self, thetas):
        """Each curve's sigma (of its group) for m parameter sets: (m,) with one group (every curve's), else
        (m, number of curves) in the order of ``curve_keys``."""
        sigma = self.sigma_arrays(thetas)
        if sigma.ndim == 1:
            return sigma
        column = {g: k for k, g in enumerate(self.groups)}
        return sigma[:, [column[self.group_of[key]] for key in self.curve_keys]]

    def fingerprint(self) -> str:
        groups = "" if len(self.groups) == 1 else f"|groups={sorted(self.group_of.items())}"
        crossing = f"|crossing={self.crossing_floor}" if self.crossing else ""
        return (f"{self.observations.fingerprint()}|w={sorted(self.weights.items())}|floor={self.floor}{crossing}"
                f"|s={self.sigma}{groups}{'' if self.discrepancy is None else f'|delta={self.discrepancy}'}")

    # ----------------------------------------------------------------- simulated curves at the recorded abscissae
    def _simulated_batch(self, result, m):
        """{test: {curve: ...}} of m parameter sets -> ({(test, curve): (m, n_recorded)}, [(bad rows, reason)])."""
        out, failures = {}, []
        for t in self.observations:
            if t.name not in result:
                raise ForwardModelError(f"forward model returned no test {t.name!r}")
            curves = result[t.name]
            for cname in t.curves:
                sim = curves.get(cname) if isinstance(curves, Mapping) else None
                out[t.name, cname], bad, message = self._reader.at_records(t.name, cname, sim, m)
                if bad.any():
                    failures.append((bad, message))
        return out, failures

    def _simulated_one(self, result) -> dict:
        """One forward result -> {(test, curve): (1, n_recorded)}; ForwardModelError if unusable."""
        if isinstance(result, Exception):
            raise result
        out, failures = self._simulated_batch(result, 1)
        if failures:
            raise ForwardModelError(failures[0][1])
        return out

    def simulated_at_observations(self, result) -> dict:
        """Forward result -> {(test, curve): simulated values at the recorded abscissae}; ForwardModelError if
        unusable."""
        return {key: values[0] for key, values in self._simulated_one(result).items()}

    # ----------------------------------------------------------------- evaluation
    def goodness_of_fit(self, simulated: dict) -> dict:
        """Eq. (5) per test from {(test, curve): values}, values (n_recorded,) or (m, n_recorded) for m parameter
        sets (J_g then (m,) per test)."""
        return {t.name: goodness_of_fit([self._used[t.name, c] for c in t.curves],
                                        [simulated[t.name, c][..., self._kept[t.name, c]] for c in t.curves])
                for t in self.observations}

    def _log_likelihood(self, simulated, sigma, delta=None):
        """Eqs. (4)-(6) for m parameter sets from {(test, curve): (m, n_recorded)} and sigma (m,), or Eq. (6g) with
        sigma (m, number of groups); with a discrepancy, (D2) summed over curves and tests, ``delta`` the
        :meth:`discrepancy_arrays` of the rows."""
        if self.discrepancy is not None:
            return self._log_likelihood_discrepancy(simulated, sigma, delta)
        if sigma.ndim == 1:
            jg = self.goodness_of_fit(simulated)
            return sum(self.weights[t] * log_likelihood_test(jg[t], self.n_points[t], sigma) for t in jg)
        total = 0.0
        for t in self.observations:
            names = list(t.curves)
            mean_squares = curve_mean_squares([self._used[t.name, c] for c in names],
                                              [simulated[t.name, c][..., self._kept[t.name, c]] for c in names])
            term = 0.0
            for column, members, n_group in self._test_groups[t.name]:
                j_group = sum(mean_squares[i] for i in members) / len(names)
                term = term + log_likelihood_test(j_group, n_group, sigma[:, column], self.n_points[t.name])
            total = total + self.weights[t.name] * term
        return total

    def _log_likelihood_discrepancy(self, simulated, sigma, delta):
        """(D2) summed over the curves of each test, times the test's weight."""
        amplitudes, length = delta
        sigmas = dict(zip(self.curve_keys, self.curve_sigmas_from(sigma)))
        total = 0.0
        for t in self.observations:
            term = 0.0
            for cname in t.curves:
                key = (t.name, cname)
                used = self._used[key]
                residuals = (used - simulated[key][..., self._kept[key]]) / used
                term = term + self._curve_discrepancy[key].log_density(
                    residuals, sigmas[key], amplitudes[:, self._discrepancy_column[key]], length)
            total = total + self.weights[t.name] * term
        return total

    def pointwise_log_likelihood(self, simulated, thetas) -> dict:
        """Each recorded point's term of Eqs. (4)-(6) (Eq. (6g) with error groups) for the m parameter sets
        ``thetas`` (prior order) and their curves ``simulated`` {(test, curve): (m, n_recorded)}
        (:meth:`simulated_many`): {(test, curve): (m, n_recorded)},
            w_i [-ln(2 pi sigma_g^2)/2 - N_i / (N_0 N_j) r_k^2 / (2 sigma_g^2)],
        r_k = (U_obs - U_num)/U_obs at point k, N_i the points the test uses, N_0 its curves, N_j the points the curve
        uses, sigma_g the curve's error parameter; a point below the floor (not used) is 0. Summed over every point,
        the log-likelihood. Refused (ValueError) with a discrepancy, which couples the points of a curve."""
        if self.discrepancy is not None:
            raise ValueError("a model-form discrepancy couples the points of a curve: no pointwise log-likelihood")
        sigmas = dict(zip(self.curve_keys, self.curve_sigmas_from(self.sigma_arrays(thetas))))
        out = {}
        for t in self.observations:
            for cname, curve in t.curves.items():
                key = (t.name, cname)
                used, s = self.masks[key], sigmas[key][:, None]
                r = (curve.y - simulated[key]) / np.where(used, curve.y, 1.0)
                share = self.n_points[t.name] / (len(t.curves) * used.sum())
                terms = -0.5 * np.log(2.0 * np.pi * s**2) - share * r**2 / (2.0 * s**2)
                out[key] = self.weights[t.name] * np.where(used, terms, 0.0)
        return out

    def curve_sigmas_from(self, sigma) -> list:
        """Each curve's sigma_g (m,) in the order of ``curve_keys`` from :meth:`sigma_arrays`' value."""
        if sigma.ndim == 1:
            return [sigma] * len(self.curve_keys)
        column = {g: k for k, g in enumerate(self.groups)}
        return [sigma[:, column[self.group_of[key]]] for key in self.curve_keys]

    def discrepancy_mean(self, theta, simulated=None) -> dict:
        """The posterior mean of the discrepancy delta (relative, as the residuals) per (test, curve) at theta, at the
        recorded points (excluded points NaN); {} without a discrepancy. ``simulated``: the curves at theta when at
        hand (:meth:`residuals`)."""
        if self.discrepancy is None:
            return {}
        residuals = self.residuals(theta, simulated)
        sigmas = self.curve_sigmas_from(self.sigma_arrays(theta))
        amplitudes, length = self.discrepancy_arrays(theta)
        out = {}
        for i, key in enumerate(self.curve_keys):
            mask = self.masks[key]
            mean = np.full(mask.size, np.nan)
            mean[mask] = self._curve_discrepancy[key].posterior_mean(
                residuals[key][mask], float(sigmas[i][0]), float(amplitudes[0, self._discrepancy_column[key]]),
                float(length[0]))
            out[key] = mean
        return out

    def _sigma_reason(self, sigma):
        """The reason a parameter set's error parameters are refused (one row of :meth:`sigma_arrays`), or None."""
        if np.ndim(sigma) == 0:
            return None if sigma > 0 else f"sigma_eps = {sigma} must be > 0"
        for name, s in zip(self.sigma_names or [f"sigma_eps_{g}" for g in self.groups], sigma.tolist()):
            if not s > 0:
                return f"{name} = {s} must be > 0"
        return None

    def log_likelihood_from(self, result, sigma, delta=None) -> float:
        """Eqs. (4) and (6) (Eq. (6g) with ``sigma`` {group: sigma_g}) from one forward result (computed as a batch
        of one: the same bits as in any batch); with a discrepancy, ``delta`` is the parameter set's
        :meth:`discrepancy_arrays` (one row)."""
        if isinstance(sigma, dict):
            sigma = np.array([[float(sigma[g]) for g in self.groups]])
        else:
            sigma = np.array([float(sigma)])
            if len(self.groups) > 1:
                sigma = np.repeat(sigma[:, None], len(self.groups), axis=1)
        reason = self._sigma_reason(sigma[0])
        if reason:
            raise ForwardModelError(reason)
        return float(self._log_likelihood(self._simulated_one(result), sigma, delta)[0])

    def soil_parameters(self, thetas):
        """The forward model's parameters (m, k) of m parameter sets (rows in the prior's order): every column but
        the error and discrepancy parameters, in the prior's order."""
        if self.names is None:
            raise RuntimeError("Likelihood.bind(prior.names) must be called before evaluation")
        return np.atleast_2d(np.asarray(thetas, dtype=float))[:, self._soil_columns]

    def _simulate(self, thetas) -> tuple:
        """The forward model's (curves, failed) for the parameter sets ``thetas`` (rows in the prior's order); sets
        that differ only in their error or discrepancy parameters share one solve (``forward.simulate_distinct``)."""
        return simulate_distinct(self.forward, self._soil_names, self.soil_parameters(thetas))

    def _forward_one(self, theta):
        """The forward result of one parameter set (prior order); raises what the forward model raises."""
        return particle_result(*self._simulate(np.asarray(theta, dtype=float)[None, :]), 0)

    def __call__(self, theta) -> float:
        return self.log_likelihood_from(self._forward_one(theta), self.split(theta)[1], self.discrepancy_arrays(theta))

    def simulated_many(self, thetas) -> dict:
        """{(test, curve): (m, n_recorded)} simulated values at the recorded abscissae of the parameter sets
        ``thetas`` (rows in the prior's order; sets sharing their soil parameters are solved once); raises the first
        failed set's exception (ForwardModelError for unusable curves)."""
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        if self.forward.batched:
            curves, failed = self._simulate(thetas)
            results = [particle_result(curves, failed, i) for i in range(len(thetas))]
        else:
            first, inverse = distinct_rows(self.soil_parameters(thetas))
            solved = [self._forward_one(thetas[i]) for i in first]
            results = [solved[k] for k in inverse]
        per_set = [self.simulated_at_observations(result) for result in results]
        return {key: np.stack([values[key] for values in per_set]) for key in per_set[0]}

    def evaluate_many(self, thetas):
        """Batch evaluation: (values (m,), reasons list) with -inf and a reason for each failed parameter set.

        A batched forward model is given the whole batch; should that call fail as a whole, or for a model that
        takes one particle at a time, every parameter set is evaluated on its own
        (:func:`inference.forward.batch_or_each`)."""
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        if self.names is None:
            raise RuntimeError("Likelihood.bind(prior.names) must be called before evaluation")
        m = len(thetas)
        whole = (lambda: self._evaluate_batch(thetas)) if self.forward.batched and m > 1 else None
        solved = {}   # one forward solve (or its exception) per distinct row of soil parameters

        def alone(i):
            k = self.soil_parameters(thetas[i]).tobytes()
            if k not in solved:
                try:
                    solved[k] = self._simulate(thetas[i:i + 1])
                except Exception as exc:  # noqa: BLE001 - raised again for every set that shares this solve
                    solved[k] = exc
            if isinstance(solved[k], Exception):
                raise solved[k]
            values, reasons = self._evaluate_solved(thetas[i:i + 1], *solved[k])
            return values[0], reasons[0]

        return batch_or_each(whole, alone, m)

    def _evaluate_batch(self, thetas):
        """(values (m,), reasons) of one forward call over ``thetas``; raises what the forward model raises."""
        return self._evaluate_solved(thetas, *self._simulate(thetas))

    def _evaluate_solved(self, thetas, curves, failed):
        """(values (m,), reasons) of the parameter sets ``thetas`` from their forward model's (curves, failed)."""
        if isinstance(curves, Mapping):
            return self._evaluate_arrays(thetas, curves, failed)
        values = np.full(len(thetas), -np.inf)
        reasons = [None] * len(thetas)
        # the usable sets' curves stacked, then Eqs. (4)-(6) (or (D2)) once for them: the same bits as one set at a
        # time (each row's arithmetic is the same whatever the batch), without the per-set Python of the curves'
        # terms; the reasons in the per-set precedence (sigma_eps, the forward model's failure, an unusable curve)
        sigma, candidates = self.sigma_arrays(thetas), []
        for i in range(len(thetas)):
            bad = self._sigma_reason(sigma[i])
            if bad or failed[i] is not None:
                reasons[i] = reason_of(ForwardModelError(bad) if bad else failed[i])
            else:
                candidates.append(i)
        rows, simulated = self._usable_rows(curves, candidates, reasons)
        if not rows:
            return values, reasons
        delta = self.discrepancy_arrays(thetas[rows])
        try:
            values[rows] = self._log_likelihood(simulated, sigma[rows], delta)
            return values, reasons
        except Exception:  # noqa: BLE001 - one set's failure (a covariance not positive definite) is its own
            pass
        for i in rows:
            try:
                values[i] = self.log_likelihood_from(particle_result(curves, failed, i), self.split(thetas[i])[1],
                                                     self.discrepancy_arrays(thetas[i]))
            except Exception as exc:  # noqa: BLE001 - an unusable result is this particle's zero likelihood
                reasons[i] = reason_of(exc)
        return values, reasons

    def _usable_rows(self, curves, candidates, reasons) -> tuple:
        """(rows, {(test, curve): (len(rows), n_recorded)}) of the sets ``candidates`` of per-set results ``curves``
        whose curves are usable (the others' reasons in ``reasons``): as one batch where they stack, else set by set."""
        stacked = stacked_results([curves[i] for i in candidates], {t.name: t.curves for t in self.observations})
        if stacked is not None:
            try:
                simulated, failures = self._simulated_batch(stacked, len(candidates))
            except ForwardModelError:  # a size or curve that no set can use: each set names it itself, below
                stacked = None
        if stacked is None:
            rows, usable = [], []
            for i in candidates:
                try:
                    usable.append(self._simulated_one(curves[i]))
                    rows.append(i)
                except Exception as exc:  # noqa: BLE001 - an unusable result is this particle's zero likelihood
                    reasons[i] = reason_of(exc)
            return rows, ({key: np.concatenate([u[key] for u in usable]) for key in usable[0]} if usable else {})
        keep = np.ones(len(candidates), dtype=bool)
        for bad, message in failures:
            for j in np.flatnonzero(bad & keep):
                reasons[candidates[j]] = f"{ForwardModelError.__name__}: {message}"
            keep &= ~bad
        return [i for i, k in zip(candidates, keep) if k], {key: v[keep] for key, v in simulated.items()}

    def _evaluate_arrays(self, thetas, curves, failed):
        """Eqs. (4)-(6) for a batch from a table of curves: the same reasons, in the same precedence, as the
        per-particle path (sigma_eps, then the forward model's failure, then the first unusable curve)."""
        m = len(thetas)
        sigma = self.sigma_arrays(thetas)
        error = ForwardModelError.__name__
        reasons = []
        for s, r in zip(sigma, failed):
            bad = self._sigma_reason(s)
            reasons.append(f"{error}: {bad}" if bad else (None if r is None else reason_of(r)))
        try:
            simulated, failures = self._simulated_batch(curves, m)
        except ForwardModelError as exc:  # unusable for every parameter set
            return np.full(m, -np.inf), [r or f"{error}: {exc}" for r in reasons]
        for bad, message in failures:
            for i in np.flatnonzero(bad):
                reasons[i] = reasons[i] or f"{error}: {message}"
        with np.errstate(all="ignore"):  # failed rows are computed with their NaNs and then discarded
            values = self._log_likelihood(simulated, sigma, self.discrepancy_arrays(thetas))
        values[[r is not None for r in reasons]] = -np.inf
        return values, reasons

    # ----------------------------------------------------------------- diagnostics
    def residuals(self, theta, simulated=None) -> dict:
        """Relative residuals (U_obs - U_num)/U_obs per (test, curve) at theta (excluded points as NaN); ``simulated``
        {(test, curve): values at the recorded abscissae} the curves at theta when at hand (else solved)."""
        sim = self.simulated_at_observations(self._forward_one(theta)) if simulated is None else simulated
        out = {}
        for t in self.observations:
            for c, curve in t.curves.items():
                r = (curve.y - sim[t.name, c]) / np.where(curve.y == 0, np.nan, curve.y)
                r[~self.masks[t.name, c]] = np.nan
                out[t.name, c] = r
        return out

    def summary_goodness(self, theta) -> dict:
        return self.goodness_of_fit(self.simulated_at_observations(self._forward_one(theta)))
