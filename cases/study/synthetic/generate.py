"""SYNTHETIC recordings of a study: this project's forward model at stated parameter values, times independent
multiplicative noise c ~ N(1, noise^2) per point and curve (Eq. 1), written with the same record writer and header
lines (``# synthetic: NOT MEASURED DATA ...``) for every entry point."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

import inference
from cases.study.checks import Checker, StudyError
from cases.study.forward.study import StudyForward
from cases.study.programme import TestSpec
from cases.study.reading.presets import FE_FIELDS
from cases.study.reading.records import CURVE_OF, SBP_MAX_STRAIN_PCT, X_COLUMN, column_name, write_records
from cases.study.reading.schema import Study, load_study
from cases.study.synthetic.logging_plan import logged_stages, programme_columns
from constitutive.registry import class_name

__all__ = ["SYNTHETIC_DEFAULTS", "generated_quantities", "synthetic_settings", "synthetic_abscissae", "generate",
           "generate_sbp"]


SYNTHETIC_DEFAULTS = {"noise": 0.02, "seed": 1, "points": 25}
#: default largest strain of a generated record (%), per test type
MAX_STRAIN_PCT = {"triaxial": 15.0, "oedometer_crs": 20.0, "sbp": SBP_MAX_STRAIN_PCT}
#: CSV quantities generated for a test without a ``curves`` field, per (type, drainage)
GENERATED = {("triaxial", "drained"): ("q", "void_ratio"), ("triaxial", "undrained"): ("q", "excess_pore_pressure"),
             ("oedometer_crs", None): ("sigma_v",), ("oedometer_creep", None): ("axial_strain",),
             ("sbp", None): ("cavity_pressure", "pore_pressure")}
QUANTITY_OF = {c: q for q, c in CURVE_OF.items()}


def generated_quantities(spec: TestSpec) -> tuple:
    """The CSV quantities the generator writes for a test: its ``curves`` field, else :data:`GENERATED`."""
    if spec.curves is not None:
        return tuple(QUANTITY_OF.get(c, c) for c in spec.curves)
    return GENERATED[spec.type, spec.drainage]


def synthetic_settings(study: Study, noise=None, seed=None) -> dict:
    """The study's [synthetic] table, checked: generating parameters (every free one, plus those the generating
    switches need), switches, noise, seed, points, max_strain_pct."""
    ck = Checker(study.path)
    s = study.synthetic
    params = ck.table(s.get("parameters", {}), "synthetic.parameters")
    switches = {**study.switches, **ck.table(s.get("switches", {}), "synthetic.switches", tuple(study.switches))}
    for k, v in switches.items():
        ck.flag(v, f"synthetic.switches.{k}")
    values = {k: ck.number(v, f"synthetic.parameters.{k}") for k, v in params.items()}
    for k in study.free:
        if k not in values:
            raise StudyError(f"{study.path}: synthetic.parameters.{k} is missing: the generator needs a value for "
                             "every free parameter")
    for k in values:
        if k not in study.spec.parameters:
            ck.fail(f"synthetic.parameters.{k}", params[k], f"unknown parameter of {study.model}")
    out = {"parameters": values, "switches": switches,
           "noise": ck.number(s.get("noise", SYNTHETIC_DEFAULTS["noise"]) if noise is None else noise,
                              "synthetic.noise", non_negative=True),
           "seed": ck.integer(s.get("seed", SYNTHETIC_DEFAULTS["seed"]) if seed is None else seed, "synthetic.seed", 0),
           "points": ck.integer(s.get("points", SYNTHETIC_DEFAULTS["points"]), "synthetic.points", 3),
           "max_strain_pct": s.get("max_strain_pct")}
    if out["max_strain_pct"] is not None:
        ck.number(out["max_strain_pct"], "synthetic.max_strain_pct", positive=True)
    return out


def synthetic_abscissae(spec: TestSpec, settings: dict):
    """Recorded abscissae of a generated test: axial or cavity strain (%) evenly spaced to the largest strain, or
    the driver's own log-spaced hold times (s since the test start) of an incremental oedometer."""
    if spec.type == "oedometer_creep":
        hold = np.geomspace(spec.load_time, spec.stage_duration, spec.n_times)
        return np.concatenate([k * spec.stage_duration + hold for k in range(len(spec.stage_stress))])
    top = min(settings["max_strain_pct"] or MAX_STRAIN_PCT[spec.type], MAX_STRAIN_PCT[spec.type])
    n = settings["points"]
    x = np.linspace(top / n, top, n)
    return -x if spec.type == "triaxial" and spec.direction == "extension" else x


def generate(path, noise=None, seed=None, directory=None) -> dict:
    """Write SYNTHETIC recordings of every test of the study file ``path`` from its [synthetic] table: this project's
    forward model (the lab drivers or the SBP FE at the study's FE settings, full preset) at the stated parameter
    values, times independent multiplicative noise c ~ N(1, noise^2) per point and curve (Eq. 1). A stage programme
    is recorded in every stage at the logging points of :func:`cases.study.synthetic.logging_plan.logged_stages`. Files
    go to the paths the study names (or into ``directory`` with the same file names). Returns {test: path}."""
    study = load_study(path, check_files=False)
    settings = synthetic_settings(study, noise, seed)
    fake, logs = {}, {}
    for i, spec in enumerate(study.tests):
        if spec.staged:
            logs[spec.name] = logged_stages(spec, settings, i)
            fake[spec.name] = inference.Test(spec.name, {k: inference.Curve(x, np.ones_like(x), x_name)
                                                         for k, (x_name, x, *_) in logs[spec.name].items()})
            continue
        x = synthetic_abscissae(spec, settings)
        quantities = generated_quantities(spec)
        fake[spec.name] = inference.Test(spec.name, {CURVE_OF.get(q, q): inference.Curve(x, np.ones_like(x))
                                                     for q in quantities})
    observations = inference.Observations(list(fake.values()))
    forward = StudyForward(replace(study, fixed={**study.fixed, **{k: v for k, v in settings["parameters"].items()
                                                                   if k not in study.free}}),
                           observations, settings["switches"])
    free = {k: v for k, v in settings["parameters"].items() if k in study.free}
    try:
        result = forward([free])[0]
    except inference.ForwardModelError as exc:  # the model refuses the values
        result = exc
    if isinstance(result, Exception):
        raise StudyError(f"{study.path}: synthetic.parameters = {settings['parameters']}: the generating model failed: "
                         f"{result}")
    rng = np.random.default_rng(settings["seed"])
    paths = {}
    for spec in study.tests:
        if spec.staged:
            columns, exact = programme_columns(spec, logs[spec.name], result[spec.name], rng, settings["noise"])
        else:
            t = fake[spec.name]
            x = next(iter(t.curves.values())).x
            x_name = X_COLUMN[spec.type]
            columns, exact = {column_name(x_name, spec.type): x}, (column_name(x_name, spec.type),)
            for q in generated_quantities(spec):
                sim = result[spec.name][CURVE_OF.get(q, q)]
                y = np.interp(x, *sim) if isinstance(sim, tuple) else np.asarray(sim)
                columns[column_name(q, spec.type)] = y * rng.normal(1.0, settings["noise"], y.size)
            if spec.type == "sbp":
                columns["time_s"] = x / 100.0 / spec.strain_rate
        header = [f"synthetic: NOT MEASURED DATA. Generated by python -m cases.calibrate {Path(path).name} "
                  "--generate with "
                  f"this project's forward model {class_name(settings['switches'], study.model)}",
                  f"synthetic_parameters: {json.dumps(free)}",
                  f"synthetic_fixed: {json.dumps(forward.fixed)}",
                  f"synthetic_noise: multiplicative c ~ N(1, {settings['noise']:g}^2) per point on every value column "
                  f"(Eq. 1), seed {settings['seed']}",
                  f"test: {spec.name}", f"test_type: {spec.type}: {spec.describe()}"]
        if spec.type == "sbp" or spec.apparatus == "sbp":
            fe = {k: getattr(forward.sbp[spec.name].preset, k) for k in FE_FIELDS}
            header.append(f"synthetic_fe: {json.dumps(fe)}")
        target = Path(directory) / spec.file.name if directory else spec.file
        target.parent.mkdir(parents=True, exist_ok=True)
        paths[spec.name] = write_records(target, header, columns, exact=exact)
    return paths


def generate_sbp(directory, forward, params: dict, noise: float, seed: int, n_points: int, source: str,
                 note: str = "", extra_header=()) -> dict:
    """Write SYNTHETIC pressuremeter recordings, one CSV per test of ``forward`` (an SBP forward model with
    ``results``, ``fixed``, ``site``, ``rates`` and ``preset``), from the FE at ``params``: ``n_points`` cavity
    strains evenly spaced to 10 %, multiplicative noise c ~ N(1, noise^2) on pressure and pore pressure (Eq. 1).
    ``source`` names the generator in the header, ``note`` follows the parameters there. Returns {test: path}."""
    results = forward.results(params)
    rng = np.random.default_rng(seed)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, res in results.items():
        strain = np.linspace(0.0, 10.0, n_points + 1)[1:]
        columns = {"time_s": np.interp(strain, 100 * res.cavity_strain, res.time),
                   "cavity_strain_pct": strain,
                   "cavity_pressure_kPa": np.interp(strain, 100 * res.cavity_strain, res.cavity_pressure),
                   "pore_pressure_kPa": np.interp(strain, 100 * res.cavity_strain, res.cavity_pore_pressure)}
        for c in ("cavity_pressure_kPa", "pore_pressure_kPa"):
            columns[c] = columns[c] * rng.normal(1.0, noise, strain.size)
        header = [
            f"synthetic: NOT MEASURED DATA. Generated by {source} with this project's FE",
            f"synthetic_parameters: {json.dumps(params)}" + note,
            f"synthetic_fixed: {json.dumps(forward.fixed)}; site: {json.dumps(forward.site)}",
            f"synthetic_fe: {json.dumps({k: getattr(forward.preset, k) for k in FE_FIELDS})}",
            f"synthetic_noise: multiplicative c ~ N(1, {noise}^2) per point on pressures (Eq. 1), seed {seed}",
            f"test: {name}", f"strain_rate_per_s: {forward.rates[name]}", *extra_header]
        paths[name] = write_records(directory / f"sbp_{name}.csv", header, columns)
    return paths
