"""Per-point covariates of a programme of tests for the diagnosis' attribution (names from
``constitutive.physics_catalog.COVARIATES``), in the form ``inference.diagnosis`` takes: {name: {(test, curve): array
aligned with the recorded points, or a scalar for a condition of the test}}, or the declared form {"values": ...,
"kind": ..., "scope": ...} (``inference.diagnosis.attribution``, covariate specs).

Along a curve: time since the start of the stage (s; of the test for a one-stage test), strain level |eps| (-), and
(flat types) the MAP simulation's stress ratio q/p' and mean effective stress p' (kPa). Between tests (conditions of
a test or stage): strain rate (1/s, magnitude), loading phase, stress path direction, consolidation and, for a model
with a critical state line, the initial state parameter psi_0 = e_0 - e_c(p'_0) of the MAP. A between-test covariate
is kept only when it takes at least two values.

Within a test (``within_test=True``, the study path; each declared kind/scope, kept only where defined and varying):
- post-peak strain (numeric, within): |strain| beyond the peak of the recorded |q| of a shear stage (or of a flat
  triaxial test), NaN before it (:func:`post_peak_strain`);
- hold time after loading / after unloading (numeric, within): time since the start of a hold (creep, relaxation,
  SBP hold, a load stage after its ramp) following a loading or an unloading, NaN elsewhere;
- consolidation compression (numeric, within): -de/dln sigma' of the recorded void ratio over the MAP's, between
  neighbouring records of a consolidation stage recorded against its stress;
- loading phase (categorical): "loading", "unloading" or "hold" of each point's stage (a load stage: its ramp, then
  hold);
- overconsolidation (numeric; per stage, so it may differ between the stages of one test): the stress history's
  largest stress over the stage's starting stress (from the test's ``ocr`` / ``preconsolidation`` and its
  consolidation targets; 1 without either).
Staged curves are keyed "<quantity>@<stage>" (``cases.study.programme.curve_key``); their stage comes from the key.
Further covariates of particular programmes: :func:`drainage_time_factor`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cases.study.programme import split_key
from cases.study.stages.sequence import stage_times
from fem.oracles import consolidation_coefficient

__all__ = ["programme_covariates", "BETWEEN", "post_peak_strain", "drainage_time_factor", "StagePhase",
           "stage_phases"]

BETWEEN = ("strain rate", "loading phase", "stress path direction", "consolidation", "initial state parameter",
           "overconsolidation")
ORDER = ("strain rate", "time", "strain level", "stress ratio", "mean effective stress", "loading phase",
         "stress path direction", "consolidation", "initial state parameter")
WITHIN = ("post-peak strain", "hold time after loading", "hold time after unloading", "consolidation compression")


@dataclass(frozen=True)
class StagePhase:
    """What a stage does in its test's history: ``phase`` "loading" | "unloading" | "hold" (a load stage: its ramp's
    phase, held after ``ramp_time``); ``after`` the last loading/unloading phase before a hold ("loading" at the
    start); ``ocr`` the largest stress of the history over the stress at the stage's start; ``consolidation``
    "isotropic" | "K0" of the last consolidation (or of the initial state); ``start`` s since the test start or
    None."""

    phase: str
    after: str
    ocr: float
    consolidation: str
    start: float | None


def stage_phases(spec) -> list:
    """[StagePhase] of every stage of ``spec`` (a TestSpec with its stages, ``programme_of``)."""
    init = spec.initial
    current = init.vertical if init.vertical is not None else 1.0
    pre = init.preconsolidation if init.preconsolidation is not None else (
        init.ocr * current if init.ocr is not None else current)
    consolidation = "isotropic" if init.p0 is not None else "K0"
    after, out = "loading", []
    times = stage_times(spec) if spec.stages else []
    for k, st in enumerate(spec.stages):
        ocr = max(pre, current) / current
        kind = st.procedure
        phase = kind.loading_phase(st, current)
        target = kind.stress_target(st)
        if target is not None:
            consolidation = kind.consolidation_path(st) or consolidation
            pre, current = max(pre, current, target), target
        out.append(StagePhase(phase, after, ocr, consolidation, times[k][0] if k < len(times) else None))
        after = after if phase == "hold" else phase
    return out


def _stage_of(spec, key):
    """(stage index, Stage) of a curve key of ``spec``."""
    _, name = split_key(key)
    if name is None:
        return 0, spec.stages[0]
    names = [s.name for s in spec.stages]
    return names.index(name), spec.stages[names.index(name)]


def _stage_time(spec, stage, phase: StagePhase, curve, recorded):
    """Time since the stage start (s) of a staged curve's records: the recorded times when the file gives any,
    else, for a rate-controlled stage, its strain over its rate; None when neither gives a finite time (the
    screening refuses a covariate defined on no point)."""
    recorded = None if recorded is None else np.asarray(recorded, dtype=float)
    if curve.x_name == "time":
        t = np.asarray(curve.x, dtype=float)
    elif recorded is not None and np.isfinite(recorded).any():
        t = recorded - (phase.start if phase.start is not None else recorded[0])
    elif stage.procedure.rate_controlled and stage.strain_rate:
        x = np.asarray(curve.x, dtype=float) / 100.0
        t = np.abs(x - (0.0 if stage.procedure.shearing else x[0])) / abs(stage.strain_rate)
    else:
        return None
    return t if np.isfinite(t).any() else None


def _deviator(test, keys):
    """{key: recorded |q| at the curve's points} for the curves ``keys`` of one stage, from the q curve (or 3(p' -
    sigma'_r), or sigma'_a - sigma'_r, recorded at the same points)."""
    by = {split_key(k)[0]: k for k in keys}
    c = test.curves
    if "q" in by:
        q, x = c[by["q"]].y, c[by["q"]].x
    elif "p" in by and "radial_stress" in by and np.array_equal(c[by["p"]].x, c[by["radial_stress"]].x):
        q, x = 3.0 * (c[by["p"]].y - c[by["radial_stress"]].y), c[by["p"]].x
    else:
        return None
    return np.abs(np.asarray(x, dtype=float)) / 100.0, np.abs(np.asarray(q, dtype=float))


def _within_test(spec, test, map_curves, times, out):
    """The within-test covariates of one test (module docstring) into ``out`` {name: {(test, key): values}}."""
    phases = stage_phases(spec)
    stages = {}
    for key in test.curves:
        stages.setdefault(_stage_of(spec, key)[0], []).append(key)
    for k, keys in stages.items():
        stage, phase = spec.stages[k], phases[k]
        if stage.procedure.shearing:
            peak = _deviator(test, keys)
            if peak is not None:
                strain, q = peak
                i = int(np.nanargmax(q))
                for key in keys:
                    s = np.abs(np.asarray(test.curves[key].x, dtype=float)) / 100.0
                    out["post-peak strain"][spec.name, key] = np.where(s > strain[i], s - strain[i], np.nan)
        for key in keys:
            curve = test.curves[key]
            n = curve.y.size
            kind = np.full(n, phase.phase, dtype=object)
            if stage.procedure.ramped_hold:
                t = np.asarray(curve.x, dtype=float) if curve.x_name == "time" else None
                if t is not None and stage.ramp_time is not None:
                    kind = np.where(t > stage.ramp_time, "hold", phase.phase).astype(object)
                    held = np.where(t > stage.ramp_time, t - stage.ramp_time, np.nan)
                    out[f"hold time after {phase.phase}"][spec.name, key] = held
            elif phase.phase == "hold":
                t = _stage_time(spec, stage, phase, curve, times.get(key))
                if t is not None:
                    out[f"hold time after {phase.after}"][spec.name, key] = t
            out["loading phase"][spec.name, key] = kind.astype(str)
            out["overconsolidation"][spec.name, key] = phase.ocr
            quantity = split_key(key)[0]
            if stage.procedure.consolidates and quantity == "void_ratio" and curve.x_name in ("p", "sigma_v"):
                sim = np.asarray(map_curves.get(key, np.full(n, np.nan)), dtype=float)
                ln_s = np.log(np.asarray(curve.x, dtype=float))
                if n >= 3 and np.ptp(ln_s) > 0:
                    rec = -np.gradient(curve.y, ln_s)
                    mod = -np.gradient(sim, ln_s)
                    out["consolidation compression"][spec.name, key] = np.where(np.abs(mod) > 0, rec / mod, np.nan)


def _staged_along(spec, test, times, cov):
    """The along-curve and condition covariates of a staged test (time since the stage start, strain level, strain
    rate, stress path direction, consolidation)."""
    phases = stage_phases(spec)
    for key, curve in test.curves.items():
        k, stage = _stage_of(spec, key)
        t = _stage_time(spec, stage, phases[k], curve, times.get(key))
        if t is not None:
            cov["time"][spec.name, key] = t
        if curve.x_name in ("axial_strain", "cavity_strain"):
            cov["strain level"][spec.name, key] = np.abs(np.asarray(curve.x, dtype=float)) / 100.0
        if stage.procedure.rate_controlled and stage.strain_rate:
            cov["strain rate"][spec.name, key] = abs(stage.strain_rate)
        if stage.procedure.shearing:
            cov["stress path direction"][spec.name, key] = stage.direction
            cov["consolidation"][spec.name, key] = phases[k].consolidation


def _flat_along(spec, test, sim, strains, times, cov):
    """The covariates of a flat-type test (time since its start, strain level, strain rate, loading phase, the
    MAP's stress ratio and p', stress path direction, consolidation, initial state parameter)."""
    for c, curve in test.curves.items():
        k = (spec.name, c)
        if spec.type == "oedometer_creep":
            cov["time"][k] = curve.x
            cov["strain level"][k] = np.abs(np.asarray(sim["axial_strain"])) / 100.0
        else:
            level = np.abs(strains[spec.name]) if spec.name in strains else np.abs(curve.x) / 100.0
            cov["strain rate"][k] = spec.strain_rate
            cov["strain level"][k] = level
            recorded = times.get(spec.name)
            cov["time"][k] = recorded if recorded is not None else level / spec.strain_rate
        if "stress_ratio" in sim:
            cov["stress ratio"][k] = np.asarray(sim["stress_ratio"])
            cov["mean effective stress"][k] = np.asarray(sim["mean_stress"])
        if "initial_state_parameter" in sim:
            cov["initial state parameter"][k] = float(sim["initial_state_parameter"][0])
        cov["loading phase"][k] = "hold" if spec.type == "oedometer_creep" else "loading"
        if spec.type == "triaxial":
            cov["stress path direction"][k] = spec.direction
            cov["consolidation"][k] = spec.consolidation


def _varies(values: dict) -> bool:
    """Whether a within-test covariate takes at least two finite values along some curve."""
    return any(np.unique(np.asarray(v, dtype=float)[np.isfinite(v)]).size > 1 for v in values.values())


def programme_covariates(tests, observations, map_curves: dict, strains=None, times=None,
                         within_test=False) -> dict:
    """Covariates of every recorded curve of the ``tests`` (TestSpec) from the base class's MAP curves
    ``map_curves`` {test: {curve or quantity: values}} (``stress_ratio``, ``mean_stress``,
    ``initial_state_parameter`` and, for an incremental oedometer, ``axial_strain`` in %, where the forward model
    reports them; a staged test's MAP curves by curve key).

    strains: {test: axial or cavity strains (-) of the records} (default: the recorded abscissae in % / 100); times:
    {test: record times (s) or None} for a flat test, {test: {curve key: record times since the test start or None}}
    for a staged one (default: strain / strain rate; an incremental oedometer's abscissa is its time).
    within_test: add the within-test covariates and the per-stage loading phase and overconsolidation (module
    docstring; the study path), each in its declared form, for staged and one-stage tests (a flat incremental
    oedometer's records of several load stages share one curve: left out)."""
    strains, times = strains or {}, times or {}
    cov = {k: {} for k in ORDER}
    within = {k: {} for k in WITHIN + ("loading phase", "overconsolidation")}
    for spec in tests:
        test = observations[spec.name]
        recorded = times.get(spec.name)
        if spec.staged:
            _staged_along(spec, test, recorded if isinstance(recorded, dict) else {}, cov)
        else:
            _flat_along(spec, test, map_curves[spec.name], strains, times, cov)
        if within_test and (spec.staged or len(spec.stages) == 1):
            _within_test(spec, test, map_curves.get(spec.name, {}),
                         recorded if isinstance(recorded, dict) else {}, within)
    out = {k: v for k, v in cov.items() if v and (k not in BETWEEN or len({str(x) for x in v.values()}) > 1)}
    if within_test:
        for name in WITHIN:
            if _varies(within[name]):
                out[name] = {"values": within[name], "kind": "numeric", "scope": "within"}
        phases = {**cov["loading phase"], **within["loading phase"]}
        if len({x for v in phases.values() for x in np.atleast_1d(v)}) > 1:
            out["loading phase"] = {"values": phases, "kind": "categorical"}
        ocr = within["overconsolidation"]
        if len(set(ocr.values())) > 1:
            out["overconsolidation"] = {"values": ocr, "kind": "numeric"}  # per stage: may vary inside a test
        if "stress path direction" in out:
            # compression and extension are compared at equal strain magnitude: extension strains are negative
            # (compression positive), so on the signed abscissa the two tests' ranges would not overlap
            direction = out["stress path direction"]
            out["stress path direction"] = {"values": direction, "kind": "categorical", "abscissa": {
                (t, c): np.abs(np.asarray(observations[t].curves[c].x, dtype=float)) for t, c in direction}}
    return out


def post_peak_strain(strain, deviator):
    """|strain| beyond the strain of the largest recorded |q| (``deviator``), NaN up to that point (and everywhere
    when the record peaks at its last point): the covariate is defined on the softening branch only."""
    k = int(np.argmax(deviator))
    return np.where(np.arange(strain.size) > k, strain - strain[k], np.nan)


def drainage_time_factor(time, permeability: float, shear_modulus: float, nu: float, a0: float):
    """T = c_h t / a0^2 of a cavity expansion (Randolph & Wroth's c_h from the permeability k (m/s), the elastic
    shear modulus G (kPa) and Poisson's ratio; ``fem.oracles.consolidation_coefficient``); t in s, a0 in m."""
    return consolidation_coefficient(permeability, shear_modulus, nu) * time / a0 ** 2
