"""Which per-point covariate explains the structured residual (issue 6, end of "locate", start of "explain").

Forward models report covariates alongside the curves (time, strain rate, strain level, stress ratio, p',
overconsolidation, drainage time factor, loading phase, test conditions ...). For each covariate this module fits the
relative residual r = U_obs/U_sim - 1 as a function of the covariate, pooled over every test, separately per curve
name (a q curve and a void-ratio curve may respond with opposite signs), and reports the fraction of the residual
variance it explains (R^2, about each curve name's mean) with a p-value from a null that keeps the residual's
autocorrelation:

- within-curve covariates (varying along at least one curve): f is a Legendre polynomial of degree <= 3 in the
  covariate's pooled rank (monotone transforms such as log rate give the same answer); categorical covariates
  (strings, e.g. the loading phase "load"/"hold"/"unload") use one indicator per level. Null: the residual sequence of
  every curve is circularly shifted by an independent random amount (n_shifts draws), which keeps its autocorrelation
  and breaks its alignment with the covariate; p = (1 + #{R^2_shift >= R^2})/(1 + n_shifts).
- between-test covariates (constant along every curve: test conditions such as strain rate or confining pressure):
  only the per-curve mean residuals carry information; f is linear in the covariate's rank among the curves (a
  monotone trend), or one mean per level for categories. Null: the covariate values are permuted among the tests
  (all permutations when there are at most 7 tests, else n_shifts random ones), so with k tests p >= 1/k!.

Within one curve, covariates that are monotone along it (strain level, time, p' in monotonic loading) cannot be told
apart; the pooled fit over tests run at other rates, pressures or drainage conditions is what separates them.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import special, stats

__all__ = ["Attribution", "attribute", "holm", "per_curve"]

MAX_EXACT_TESTS = 7


@dataclass
class Attribution:
    """How much of the residual one covariate explains.

    kind: "within" (varies along curves) or "between" (constant along every curve); r2: fraction of the residual
    variance about each curve name's mean explained by the fitted function of the covariate; p_value: against the
    null named in `null`; p_adjusted: Holm over the covariates screened; n_points, n_curves: data used.
    """

    name: str
    kind: str
    r2: float
    p_value: float
    p_adjusted: float
    n_points: int
    n_curves: int
    null: str

    def to_dict(self) -> dict:
        return asdict(self)


def holm(pvalues):
    """Holm's step-down adjusted p-values (family-wise error control under any dependence between the tests)."""
    p = np.asarray(pvalues, dtype=float)
    m = p.size
    order = np.argsort(p, kind="stable")
    adjusted = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adjusted
    return out


def per_curve(name, spec, residuals):
    """Covariate spec -> {(test, curve): array aligned with the residual}; keys (test, curve) or test; scalars broadcast."""
    if not isinstance(spec, dict):
        raise TypeError(f"covariate {name!r}: expected a dict keyed by (test, curve) or test, got {type(spec).__name__}")
    tests = {t for t, _ in residuals}
    out = {}
    for key, value in spec.items():
        if isinstance(key, tuple):
            if key not in residuals:
                raise ValueError(f"covariate {name!r}: unknown (test, curve) {key}")
            keys = [key]
        elif key in tests:
            keys = [k for k in residuals if k[0] == key]
        else:
            raise ValueError(f"covariate {name!r}: unknown test {key!r}; tests are {sorted(tests)}")
        for k in keys:
            arr = np.asarray(value)
            n = residuals[k].size
            arr = np.full(n, arr.item(), dtype=arr.dtype) if arr.ndim == 0 else arr.ravel()
            if arr.size != n:
                raise ValueError(f"covariate {name!r}, test {k[0]}, curve {k[1]}: {arr.size} values for {n} points")
            out[k] = arr
    kinds = {np.asarray(v).dtype.kind in "biuf" for v in out.values()}
    if len(kinds) > 1:
        raise ValueError(f"covariate {name!r}: mixes numeric and categorical values")
    return out


def _valid(arr):
    return np.isfinite(arr) if arr.dtype.kind in "biuf" else np.ones(arr.size, bool)


def _basis(values, degree):
    """Centered design of one curve name's pooled covariate values: Legendre in the rank, or level indicators."""
    if values.dtype.kind in "biuf":
        u = 2.0 * (stats.rankdata(values) - 0.5) / values.size - 1.0
        d = min(degree, np.unique(values).size - 1)
        cols = [special.eval_legendre(k, u) for k in range(1, d + 1)]
    else:
        levels = np.unique(values.astype(str))
        cols = [(values.astype(str) == lev).astype(float) for lev in levels[1:]]
    if not cols:
        return np.zeros((values.size, 0))
    x = np.column_stack(cols)
    return x - x.mean(axis=0)


def _within(residuals, cov, degree, n_shifts, rng):
    """Explained and total sums of squares, and the circular-shift null of the explained sum, for a covariate varying
    along curves. For every curve the projections of all its n circular shifts are formed at once (k x n x n), and each
    null draw sums the projections of one random shift per curve."""
    groups = {}
    for k in cov:
        groups.setdefault(k[1], []).append(k)
    explained = total = 0.0
    null = np.zeros(n_shifts)
    n_points = n_curves = 0
    for keys in groups.values():
        used = [np.isfinite(residuals[k]) & _valid(cov[k]) for k in keys]
        keys, used = [k for k, u in zip(keys, used) if u.any()], [u for u in used if u.any()]
        if not keys:
            continue
        r = np.concatenate([residuals[k][u] for k, u in zip(keys, used)])
        r = r - r.mean()
        x = _basis(np.concatenate([cov[k][u] for k, u in zip(keys, used)]), degree)
        n_points, n_curves, total = n_points + r.size, n_curves + len(keys), total + float(r @ r)
        if x.shape[1] == 0:
            continue
        u_, sv, _ = np.linalg.svd(x, full_matrices=False)
        q = u_[:, sv > 1e-10 * sv[0]]                                   # orthonormal basis of the fitted functions
        explained += float(np.sum((q.T @ r) ** 2))
        projection, start = np.zeros((q.shape[1], n_shifts)), 0
        for u in used:
            n = int(u.sum())
            seg = slice(start, start + n)
            start += n
            ring = (np.arange(n)[:, None] + np.arange(n)[None, :]) % n  # ring[i, s]: point i after a shift by s
            projection += (q[seg].T @ r[seg][ring])[:, rng.integers(0, n, n_shifts)]
        null += np.sum(projection**2, axis=0)
    return explained, total, null, n_points, n_curves


def _between(residuals, cov, n_shifts, rng):
    """R^2 and test-permutation p-value for a covariate constant along every curve."""
    keys = [k for k in cov if np.any(np.isfinite(residuals[k]) & _valid(cov[k]))]
    tests = list(dict.fromkeys(t for t, _ in keys))
    value = {}
    for t, c in keys:
        v = cov[t, c][np.isfinite(residuals[t, c]) & _valid(cov[t, c])][0]
        if value.setdefault(t, v) != v:
            raise ValueError(f"covariate constant along curves but not across the curves of test {t!r}: "
                             f"{value[t]!r} and {v!r}")
    categorical = np.asarray(list(value.values())).dtype.kind not in "biuf"
    levels = np.unique([str(value[t]) for t in tests]) if categorical else None
    if math.factorial(len(tests)) <= math.factorial(MAX_EXACT_TESTS):
        perms = np.array(list(itertools.permutations(range(len(tests)))))
        null_name = f"all {len(perms)} permutations of the covariate among {len(tests)} tests"
    else:
        perms = np.vstack([np.arange(len(tests)), np.argsort(rng.random((n_shifts, len(tests))), axis=1)])
        null_name = f"{n_shifts} random permutations of the covariate among {len(tests)} tests"
    test_values = np.array([value[t] for t in tests], dtype=object if categorical else float)
    explained = np.zeros(len(perms))
    total, n_points = 0.0, 0
    for c in dict.fromkeys(c for _, c in keys):
        ck = [k for k in keys if k[1] == c]
        means = np.array([np.nanmean(residuals[k]) for k in ck])
        w = np.array([np.count_nonzero(np.isfinite(residuals[k])) for k in ck], dtype=float)
        r_all = np.concatenate([residuals[k][np.isfinite(residuals[k])] for k in ck])
        grand = float(np.average(means, weights=w))
        total += float(np.sum((r_all - grand) ** 2))
        n_points += r_all.size
        vals = test_values[perms][:, [tests.index(t) for t, _ in ck]]           # (n_perm, curves of this name)
        if categorical:
            x = np.stack([(vals.astype(str) == lev).astype(float) for lev in levels[1:]], axis=2)
        else:
            x = stats.rankdata(vals.astype(float), axis=1)[:, :, None]
        xc = x - np.einsum("j,pjk->pk", w, x)[:, None, :] / w.sum()
        sw = np.sqrt(w)[None, :, None]
        xw = xc * sw                                                             # weighted, centered design
        mw = (means - grand) * np.sqrt(w)
        coef = np.einsum("pkl,pl->pk", np.linalg.pinv(np.einsum("pjk,pjl->pkl", xw, xw)),
                         np.einsum("pjk,j->pk", xw, mw))
        explained += np.einsum("pk,pjk,j->p", coef, xw, mw)
    return explained[0], total, explained, n_points, len(keys), null_name


def attribute(residuals: dict, covariates: dict, degree=3, n_shifts=1000, seed=0) -> list:
    """Rank covariates by the fraction of the residual they explain; returns [Attribution] by decreasing R^2.

    residuals: {(test, curve): r = U_obs/U_sim - 1 in recorded order, NaN for points not used}.
    covariates: {name: {(test, curve): array aligned with the curve's points, or scalar} or {test: scalar or array
    (applied to every curve of the test)}}; numeric or categorical (strings). Curves without the covariate are left
    out of its fit. degree: Legendre degree in the rank for within-curve covariates; n_shifts: null draws.
    """
    if n_shifts < 1:
        raise ValueError(f"n_shifts = {n_shifts} must be >= 1")
    results = []
    for name, spec in covariates.items():
        cov = per_curve(name, spec, residuals)
        rng = np.random.default_rng(seed)  # the same shifts for every covariate (common random numbers)
        varying = any(np.unique(v[np.isfinite(residuals[k]) & _valid(v)]).size > 1 for k, v in cov.items())
        if varying:
            obs, total, null, n_points, n_curves = _within(residuals, cov, degree, n_shifts, rng)
            null_name = f"{n_shifts} independent circular shifts of each curve's residuals"
        else:
            obs, total, null, n_points, n_curves, null_name = _between(residuals, cov, n_shifts, rng)
        if total <= 0 or n_points == 0:
            raise ValueError(f"covariate {name!r}: no residual variance on the points where it is defined")
        p = (1 + np.count_nonzero(null >= obs * (1 - 1e-12))) / (1 + null.size) if varying else \
            np.count_nonzero(null >= obs * (1 - 1e-12)) / null.size
        results.append(Attribution(name, "within" if varying else "between", float(obs / total), float(p),
                                   float(p), int(n_points), int(n_curves), null_name))
    for a, adj in zip(results, holm([a.p_value for a in results])):
        a.p_adjusted = float(adj)
    return sorted(results, key=lambda a: -a.r2)
