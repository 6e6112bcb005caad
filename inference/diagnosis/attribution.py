"""Attribution: which per-point covariate explains the structured residual of a screened calibration.

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
  (all permutations when there are at most 7 tests, else n_shifts random ones), so with k tests p >= 1/k! (and
  p >= 2/k! for a numeric covariate: the reversed order fits as well), which cannot reach 0.05 with k <= 4: hence
  the few-test contrast below.
- few-test contrast (a between-test covariate with fewer than MIN_PERMUTATION_TESTS = 5 tests and at least two
  levels): the permutation null is replaced, for the p-value only, by a contrast that uses the within-test residual
  scatter (`contrast`): per curve name, the tests' residuals on a common abscissa (paired point by point when
  recorded at the same abscissae, else interpolated onto the sparsest curve's points over the overlapping range;
  never paired by index), then a numeric or ordinal covariate's rank trend, or a categorical covariate's difference
  between every pair of levels, tested for mean 0 against Student's t with the lag-1 effective sample size. Curve
  names (and level pairs) are combined by Bonferroni; ``Attribution.contrast`` holds per curve name {z, p, df,
  n_eff, lag1, mean, points, grid, range} (z > 0: the residual rises with the covariate, or level b of "levels"
  [a, b] is above level a; categorical: the most significant pair, all in "pairs"); `rank` makes the p-value of an
  item one-sided when the item states a direction.
  Measured false-alarm rates at alpha = 0.05, one curve name, 1000 simulated programmes of 40-point curves
  (2-4 tests; "different logging": each test its own range and 40 - 4 j points), white / AR(1) phi 0.5 noise:
  categorical, same logging: 2 tests 0.042 / 0.056, 3 tests 0.041 / 0.064, 4 tests 0.045 / 0.065; different
  logging: 0.052 / 0.053, 0.029 / 0.050, 0.051 / 0.044; numeric: 2 tests as categorical, 3 tests 0.030 / 0.045
  (same), 0.035 / 0.029 (different), 4 tests 0.045 / 0.056, 0.048 / 0.035 (binomial SE 0.007; the step of
  `contrast.mean_test` did not change one of these rates against the line alone: it stays out of noise).
  tests/inference/test_diagnosis_power.py checks 6 of them over 400 programmes at alpha + 3 SE. Earlier measurement for
  the rate trend, 2 tests x 40 points, 3000 pairs (tests/inference/test_covariates_contrast.py): white 0.036, AR(1) phi
  0.3 0.047, 0.5 0.057, 0.7 0.060; with 20 points 0.038, 0.061, 0.068, 0.091 (read the p-value as approximate below
  about 30 points). Power at 40 points: a 1-sigma offset in white noise 0.98, 2 sigma in AR(1) phi 0.5 0.90, a
  difference growing 0 -> 3 sigma 0.98; +9 % / -15 % offsets over the last 70 % of two tests logged at different points,
  noise 2 %: 20/20. With 5 or more tests nothing changes (permutation null).
- stage properties (numeric, constant along each stage's curve "<quantity>@<stage>" but changing between the stages
  of a test, e.g. a rate step): the between-stage contrast of `stage_contrast` (second differences of the
  stage-mean residuals against the property's, a permutation among the stages of each test); its per-quantity
  details fill ``Attribution.contrast`` like a few-test contrast's, so `rank` judges an item on them;
- within-test covariates declared with scope "within" (post-peak strain, unloading branch, hold time, stage kind):
  besides the pooled R^2 above, the p-value is one circular-shift test per curve, Bonferroni over the curves of a
  test (valid whatever their dependence), Stouffer over the tests (independent; weights sqrt(points), each z
  clipped to +-8), so one test can carry the evidence; per test p in ``Attribution.per_test``. Measured false-alarm
  rate on white noise, 1 and 2 tests x 2 curves, post-peak points only: at most 0.05 + 3 SE over 300 programmes
  (tests/inference/test_diagnosis_power.py).

Covariate specs. Plain form (as forward models have always given them): {(test, curve): array aligned with the
curve's points, or scalar} or {test: scalar or array}; numeric values are "numeric", strings "categorical", the
scope follows from whether the values vary along a curve. Declared form: {"values": <plain form>, "kind": "numeric"
| "ordinal" | "categorical", "scope": "within" | "between", "order": [levels, for ordinal text values or the order
of categorical pairs], "abscissa": {(test, curve): recorded abscissa} for the common grid}; every key but "values"
optional. A declared "between" that varies along a curve, or "within" that does not, is an error.

Within one curve, covariates that are monotone along it (strain level, time, p' in monotonic loading) cannot be told
apart; the pooled fit over tests run at other rates, pressures or drainage conditions is what separates them.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import special, stats

from . import contrast, stage_contrast

__all__ = ["Attribution", "attribute", "holm", "per_curve", "split_spec", "expand_covariates", "KINDS", "SCOPES",
           "SPEC_KEYS", "MIN_PERMUTATION_TESTS"]

MAX_EXACT_TESTS = 7
#: fewer tests than this: a between-test covariate is tested by the few-test contrast (module docstring)
MIN_PERMUTATION_TESTS = 5
#: a declared covariate spec: its keys, kinds and scopes (module docstring: covariate specs)
SPEC_KEYS = ("values", "kind", "scope", "order", "abscissa")
KINDS = ("numeric", "ordinal", "categorical")
SCOPES = ("within", "between")
#: |z| of one test's p-value in the Stouffer combination is clipped here (p = 1 after Bonferroni gives -inf)
STOUFFER_CLIP = 8.0


@dataclass
class Attribution:
    """How much of the residual one covariate explains.

    kind: "within" (varies along curves) or "between" (constant along every curve); r2: fraction of the residual
    variance about each curve name's mean explained by the fitted function of the covariate; p_value: against the
    null named in `null`; p_adjusted: Holm over the covariates screened; n_points, n_curves: data used.
    contrast: for a between-test covariate tested by the few-test contrast (module docstring), per curve name
    {z, p, df, n_eff, lag1, mean, points} (z > 0: the residual rises with the covariate; mean: mean of b), else None.
    """

    name: str
    kind: str
    r2: float
    p_value: float
    p_adjusted: float
    n_points: int
    n_curves: int
    null: str
    contrast: dict | None = None
    explained_rms: float | None = None
    per_test: dict | None = None

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


def split_spec(name, spec) -> tuple:
    """(values, meta) of a covariate spec: values keyed by (test, curve) or test; meta {kind, scope, order, abscissa}
    from the declared form {"values": ..., "kind": ..., "scope": ..., "order": ..., "abscissa": ...} (module
    docstring: covariate specs), empty for the plain form."""
    if not isinstance(spec, dict):
        raise TypeError(f"covariate {name!r}: expected a dict keyed by (test, curve) or test, "
                        f"got {type(spec).__name__}")
    if "values" not in spec or not set(spec) <= set(SPEC_KEYS):
        return spec, {}
    meta = {k: spec[k] for k in SPEC_KEYS[1:] if spec.get(k) is not None}
    if meta.get("kind", KINDS[0]) not in KINDS:
        raise ValueError(f"covariate {name!r}: kind {meta['kind']!r} must be one of {KINDS}")
    if meta.get("scope", SCOPES[0]) not in SCOPES:
        raise ValueError(f"covariate {name!r}: scope {meta['scope']!r} must be one of {SCOPES}")
    if meta.get("kind") == "ordinal" and "order" not in meta:
        meta["order"] = None
    return spec["values"], meta


def per_curve(name, spec, residuals):
    """Covariate spec -> {(test, curve): array aligned with the residual}; keys (test, curve) or test; scalars
    broadcast. The spec in its plain or declared form (`split_spec`)."""
    spec, _ = split_spec(name, spec)
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


def _coded(name, cov, meta):
    """The covariate's values as the analysis uses them, and its completed meta: categorical values as strings,
    ordinal levels as their position in ``order`` (numeric values keep their order)."""
    numeric = all(np.asarray(v).dtype.kind in "biuf" for v in cov.values())
    kind = meta.get("kind", "numeric" if numeric else "categorical")
    if kind == "categorical":
        cov = {k: np.asarray(v).astype(str) for k, v in cov.items()}
    elif not numeric:
        order = meta.get("order")
        if kind != "ordinal" or not order:
            raise ValueError(f"covariate {name!r}: text values need kind 'categorical', or 'ordinal' with 'order'")
        code = {str(v): float(i) for i, v in enumerate(order)}
        unknown = {str(x) for v in cov.values() for x in np.asarray(v).astype(str)} - set(code)
        if unknown:
            raise ValueError(f"covariate {name!r}: levels {sorted(unknown)} not in its order {list(order)}")
        cov = {k: np.array([code[str(x)] for x in np.asarray(v).astype(str)]) for k, v in cov.items()}
    return cov, {**meta, "kind": kind}


def expand_covariates(covariates: dict, curves: dict) -> dict:
    """Every covariate in its full form {name: {(test, curve): array aligned with the curve's points}} (the values
    only: a declared spec's meta is read with `split_spec`).

    covariates: in the form of ``attribute`` (keys (test, curve) or test; scalars broadcast); curves: {(test, curve):
    recorded values}, whose order the result follows (so the attribution's random draws do not depend on the order
    in which a caller listed the curves).
    """
    out = {}
    for name, spec in covariates.items():
        full = per_curve(name, spec, curves)
        out[name] = {k: full[k] for k in curves if k in full}
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


def _varies_within_tests(residuals, cov) -> bool:
    """Whether a covariate varies inside a test: along one of its curves, or from one of its curves to another (a
    stage property of a staged test, constant along each stage's curve). Such a covariate is tested within the tests
    (circular shifts); one constant over each test is a between-test condition."""
    seen = {}
    for (t, c), v in cov.items():
        values = np.unique(v[np.isfinite(residuals[t, c]) & _valid(v)])
        if values.size > 1:
            return True
        if values.size == 1 and seen.setdefault(t, values[0]) != values[0]:
            return True
    return False


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


def _contrast(residuals, cov, meta, abscissae):
    """Few-test contrast of a between-test covariate (module docstring, ``contrast``): (p, null description,
    {curve: details}) or None when it does not apply (5 or more tests, one level, or no curve name whose curves can
    be compared at two levels)."""
    keys = [k for k in cov if np.any(np.isfinite(residuals[k]) & _valid(cov[k]))]
    tests = set(t for t, _ in keys)
    if len(tests) >= MIN_PERMUTATION_TESTS:
        return None
    categorical = meta["kind"] == "categorical"
    details, tested = {}, 0
    for c in dict.fromkeys(c for _, c in keys):
        ck = [k for k in keys if k[1] == c]
        level = [cov[k][_valid(cov[k])][0] for k in ck]
        if categorical:
            pairs = contrast.level_contrasts(residuals, ck, level, meta.get("order"), abscissae)
            if not pairs:
                continue
            best = min(pairs.values(), key=lambda d: d["p"])
            tested += len(pairs)
            details[c] = {**best, "p": min(1.0, len(pairs) * best["p"]), "pairs": pairs}
        else:
            d = contrast.trend_contrast(residuals, ck, level, abscissae)
            if d is None:
                continue
            tested += 1
            details[c] = d
    if not details:
        return None
    p = min(1.0, len(details) * min(d["p"] for d in details.values()))
    what = ("pairwise differences of the paired residuals between the levels" if categorical else
            "mean trend of the paired residuals over the covariate's levels")
    return p, (f"few-test contrast over {len(tests)} tests: {what} vs Student's t with the lag-1 effective sample "
               f"size, Bonferroni over {len(details)} curve names" +
               (f" and {tested} level pairs" if categorical else "")), details


def _within_by_test(residuals, cov, degree, n_shifts, rng):
    """p-value of a declared within-test covariate (module docstring: within each test): one circular-shift test per
    curve, Bonferroni over the curves of a test, Stouffer over the tests (weights sqrt(points)); also
    {test: p}."""
    by_test = {}
    for k in cov:
        by_test.setdefault(k[0], []).append(k)
    per_test, z, w = {}, [], []
    for t, keys in by_test.items():
        ps, n_t = [], 0
        for k in keys:
            explained, total, null, n, _ = _within({k: residuals[k]}, {k: cov[k]}, degree, n_shifts, rng)
            if total > 0 and np.any(null > 0):
                ps.append((1 + np.count_nonzero(null >= explained * (1 - 1e-12))) / (1 + null.size))
                n_t += n
        if ps:
            per_test[t] = float(min(1.0, len(ps) * min(ps)))
            z.append(float(np.clip(stats.norm.isf(per_test[t]), -STOUFFER_CLIP, STOUFFER_CLIP)))
            w.append(math.sqrt(n_t))
    if not per_test:
        return 1.0, per_test
    w = np.array(w)
    return float(stats.norm.sf(float(w @ np.array(z)) / math.sqrt(float(w @ w)))), per_test


def attribute(residuals: dict, covariates: dict, degree=3, n_shifts=1000, seed=0, abscissae=None) -> list:
    """Rank covariates by the fraction of the residual they explain; returns [Attribution] by decreasing R^2.

    residuals: {(test, curve): r = U_obs/U_sim - 1 in recorded order, NaN for points not used}.
    covariates: {name: spec}, a spec in the plain form {(test, curve): array aligned with the curve's points, or
    scalar} or {test: scalar or array (applied to every curve of the test)}, numeric or categorical (strings), or in
    the declared form (module docstring: covariate specs). Curves without the covariate are left out of its fit.
    degree: Legendre degree in the rank for within-curve covariates; n_shifts: null draws; abscissae: {(test,
    curve): recorded abscissa} for the few-test contrasts' common abscissa (a spec's own "abscissa" comes first).
    """
    if n_shifts < 1:
        raise ValueError(f"n_shifts = {n_shifts} must be >= 1")
    results = []
    for name, spec in covariates.items():
        cov, meta = _coded(name, per_curve(name, spec, residuals), split_spec(name, spec)[1])
        rng = np.random.default_rng(seed)  # the same shifts for every covariate (common random numbers)
        varying = _varies_within_tests(residuals, cov)
        scope = meta.get("scope")
        if scope == "between" and varying:
            raise ValueError(f"covariate {name!r}: declared 'between' but varies inside a test")
        if scope == "within" and not varying:
            raise ValueError(f"covariate {name!r}: declared 'within' but constant along every curve")
        per_test = None
        staged = (stage_contrast.stage_trend(residuals, cov, n_shifts, rng)
                  if varying and meta["kind"] != "categorical" else None)
        if staged is not None:   # a stage property: constant along each stage's curve, changing between stages
            obs, total = staged["explained"], staged["total"]
            results.append(Attribution(name, "within", float(obs / total) if total > 0 else 0.0, staged["p"],
                                       staged["p"], staged["n_points"], staged["n_curves"], staged["null"],
                                       staged["details"], float(math.sqrt(max(obs, 0.0) / staged["n_points"]))))
            continue
        if varying:
            obs, total, null, n_points, n_curves = _within(residuals, cov, degree, n_shifts, rng)
            null_name = f"{n_shifts} independent circular shifts of each curve's residuals"
        else:
            obs, total, null, n_points, n_curves, null_name = _between(residuals, cov, n_shifts, rng)
        if n_points == 0:
            raise ValueError(f"covariate {name!r}: no residual on the points where it is defined")
        if not total > 0:  # residuals constant where the covariate is defined (an exact fit): nothing to explain
            results.append(Attribution(name, "within" if varying else "between", 0.0, 1.0, 1.0, int(n_points),
                                       int(n_curves), "no residual variance", None, 0.0, None))
            continue
        p = (1 + np.count_nonzero(null >= obs * (1 - 1e-12))) / (1 + null.size) if varying else \
            np.count_nonzero(null >= obs * (1 - 1e-12)) / null.size
        if scope == "within":
            p, per_test = _within_by_test(residuals, cov, degree, n_shifts, np.random.default_rng(seed))
            null_name = (f"{n_shifts} circular shifts of each curve's residuals, one test per curve, Bonferroni over "
                         f"the curves of a test, Stouffer over {len(per_test)} tests")
        few = None if varying else _contrast(residuals, cov, meta, meta.get("abscissa", abscissae))
        if few is not None:
            p, null_name, few = few
        results.append(Attribution(name, "within" if varying else "between", float(obs / total), float(p),
                                   float(p), int(n_points), int(n_curves), null_name, few,
                                   float(math.sqrt(max(obs, 0.0) / n_points)), per_test))
    for a, adj in zip(results, holm([a.p_value for a in results])):
        a.p_adjusted = float(adj)
    return sorted(results, key=lambda a: -a.r2)
