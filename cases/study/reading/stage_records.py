"""The records of a stage programme (a test with ``type = "programme"``): each record assigned to a stage, each
stage's curves against its abscissa.

A programme's CSV has the columns of its apparatus (:data:`COLUMNS`, units as in the flat types' files, converted
when the dimension agrees), an empty cell (or ``nan``) where a quantity was not recorded at that point, and:
- ``stage``: the 1-based stage number or the stage's name; without it, records are assigned by ``time_s`` (s since
  the start of the test) to the stage time ranges of the programme (:func:`cases.study.stages.sequence.stage_times`),
  a record at a boundary to the stage that ends there, a record at 0 to the first stage; a one-stage programme needs
  neither;
- ``stage_time_s`` (optional): s since the start of the record's stage.
Any stage may be recorded, each at its own points. Strains: ``axial_strain`` is the axial strain since the start of
the test, except in a shear stage where it is the strain since the stage start (zeroed at the start of shear, as
triaxial reports give it); ``cavity_strain`` since the start of the test.

The abscissa of a stage's records: the stage's ``abscissa`` when the study file gives it (``Stage.chosen_abscissa``),
else its control variable (``StageKind.control_variable`` of its kind, :mod:`cases.study.stages`) when recorded at
every record of the stage (shear, crs: axial strain in %; consolidation: p' or sigma'_v in kPa; expansion,
unloading: cavity strain in %), else the time since the stage start (``stage_time_s``, or ``time_s`` minus the
stage's start; holds, creep, relaxation and load stages always use it). An abscissa other than time must be recorded
at every record of the stage and increase or decrease strictly there: a noisy record of it is refused, naming the
line, never replaced by the time unasked. The other recorded quantities of the stage that its kind does not hold
(``StageKind.held_quantities``) are its curves, keyed by :func:`cases.study.programme.curve_key`; a stage's
``curves`` (``Stage.chosen_curves``) keeps those it names, each of which must be recorded in the stage.

A record within :data:`END_TOLERANCE` (1e-6) of its stage's range beyond an end of the stage known at load (its
duration, its to_axial_strain or to_cavity_strain, a consolidation's target stress:
:func:`cases.study.stages.sequence.stage_spans`) is taken at that end; one further out is refused at load, naming
the line, the test, the stage and the value.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

import inference
from cases.study.checks import did_you_mean
from cases.study.programme import curve_key, split_key
from cases.study.stages.sequence import stage_spans, stage_times
from inference import DataError
from inference.observations import converted, read_csv_rows, split_unit

__all__ = ["COLUMNS", "END_TOLERANCE", "load_programme_test", "recorded_programme"]

#: columns of a programme's CSV per apparatus: quantity -> unit (besides ``stage``)
COLUMNS = {
    "triaxial": {"time": "s", "stage_time": "s", "axial_strain": "%", "q": "kPa", "p": "kPa", "sigma_v": "kPa",
                 "sigma_r": "kPa", "excess_pore_pressure": "kPa", "volumetric_strain": "%", "void_ratio": "-"},
    "oedometer": {"time": "s", "stage_time": "s", "axial_strain": "%", "sigma_v": "kPa", "void_ratio": "-"},
    "sbp": {"time": "s", "stage_time": "s", "cavity_strain": "%", "cavity_pressure": "kPa", "pore_pressure": "kPa"},
}
#: CSV quantity -> curve name (sigma'_v is the catalog's "axial_stress", sigma'_r its "radial_stress")
CURVE_OF = {"sigma_v": "axial_stress", "sigma_r": "radial_stress"}


def _column(path, col, apparatus):
    """(quantity, unit) of a header cell ``q_kPa`` / ``q [MPa]`` / ``void_ratio`` among the apparatus's columns."""
    known = COLUMNS[apparatus]
    q, unit = split_unit(col)
    if q in known:
        return q, unit
    names = ["stage"] + [q if u == "-" else f"{q}_{'pct' if u == '%' else u}" for q, u in known.items()]
    hint = did_you_mean(col, names) or did_you_mean(q, known)
    raise DataError(f"{path}: column {col!r} is not a column of an {apparatus} programme; {hint}known: "
                    f"{', '.join(names)}")


def _read(spec):
    """(metadata, {quantity: values with NaN where empty}, stage cells or None, line numbers) of a programme CSV."""
    path = spec.file
    meta, header, rows = read_csv_rows(path)
    lines = [n for n, _ in rows]
    values, stage = {}, None
    for j, col in enumerate(header):
        cells = [c[j].strip() for _, c in rows]
        if col == "stage":
            stage = cells
            continue
        q, unit = _column(path, col, spec.apparatus)
        v = np.full(len(rows), np.nan)
        for i, raw in enumerate(cells):
            if raw and raw.lower() != "nan":
                try:
                    v[i] = float(raw)
                except ValueError:
                    v[i] = np.nan
                if not np.isfinite(v[i]):
                    raise DataError(f"{path}, line {lines[i]}, column {col!r}: value {raw!r} is not a finite number "
                                    "(an empty cell or nan: not recorded at that point)")
        v = converted(path, q, unit, v, COLUMNS[spec.apparatus][q])
        if q in ("time", "stage_time") and np.any(v < 0):
            i = int(np.argmax(v < 0))
            raise DataError(f"{path}, line {lines[i]}, column {col!r}: value {cells[i]} must be >= 0 s")
        if q in ("p", "sigma_v", "sigma_r", "void_ratio", "cavity_pressure") and np.any(v <= 0):
            i = int(np.argmax(v <= 0))
            raise DataError(f"{path}, line {lines[i]}, column {col!r}: value {cells[i]} must be > 0")
        if COLUMNS[spec.apparatus][q] == "%" and np.any(np.abs(v) > 100.0):
            i = int(np.argmax(np.abs(v) > 100.0))
            raise DataError(f"{path}, line {lines[i]}, column {col!r}: value {cells[i]} % exceeds 100 %")
        values[q] = v
    return meta, values, stage, lines


def _assign(spec, values, stage_cells, lines):
    """0-based stage index of every record: from the stage column, else by time, else the only stage."""
    path, stages = spec.file, spec.stages
    names = {s.name: k for k, s in enumerate(stages)}
    if stage_cells is not None:
        index = np.empty(len(stage_cells), dtype=int)
        for i, c in enumerate(stage_cells):
            k = int(c) - 1 if c.isdigit() else names.get(c, -1)
            if not 0 <= k < len(stages):
                raise DataError(f"{path}, line {lines[i]}, column 'stage': value {c!r} is not a stage of "
                                f"{spec.name} (1-{len(stages)} or {', '.join(names)})")
            index[i] = k
    elif len(stages) == 1:
        return np.zeros(len(lines), dtype=int)
    elif "time" not in values or np.any(np.isnan(values["time"])):
        i = 0 if "time" not in values else int(np.argmax(np.isnan(values["time"])))
        raise DataError(f"{path}, line {lines[i]}: a record of the {len(stages)}-stage test {spec.name} needs a "
                        "'stage' column (stage number or name) or a time_s (s since the test start) to be assigned "
                        "to its stage")
    else:
        index = np.empty(len(lines), dtype=int)
        ranges = stage_times(spec)
        for i, t in enumerate(values["time"]):
            k = next((k for k, (a, b) in enumerate(ranges) if a is not None and b is not None
                      and (a < t <= b or (k == 0 and t == 0.0))), None)
            if k is None:
                k_open = next(k for k, (_, b) in enumerate(ranges) if b is None)
                raise DataError(f"{path}, line {lines[i]}, column 'time': value {t:g} s is after the start of stage "
                                f"{stages[k_open].name!r} ({ranges[k_open][0]:g} s), whose end follows from the "
                                "material's response: give a 'stage' column (stage number or name)")
            index[i] = k
    back = np.diff(index) < 0
    if np.any(back):
        i = int(np.argmax(back)) + 1
        raise DataError(f"{path}, line {lines[i]}, column 'stage': stage {stages[index[i]].name!r} after stage "
                        f"{stages[index[i - 1]].name!r}: records are in the order of the stages")
    return index


def _abscissa(spec, k, values, rows, lines):
    """(abscissa name, unit, values) of stage k's records ``rows`` (see the module docstring)."""
    s, path = spec.stages[k], spec.file
    control = None if s.chosen_abscissa == "time" else s.procedure.control_variable(s)
    x = values[control][rows] if control in values else np.array([])
    recorded = x.size and not np.any(np.isnan(x))
    if s.chosen_abscissa is not None and control is not None and not recorded:
        i = rows[int(np.argmax(np.isnan(x)))] if x.size else rows[0]
        raise DataError(f"{path}, line {lines[i]}: stage {s.name!r} of {spec.name} is recorded against "
                        f"{s.chosen_abscissa} (its abscissa), which this record lacks")
    if recorded and control is not None:
        steps = np.diff(x)
        if x.size == 1 or np.all(steps > 0) or np.all(steps < 0):
            return control, COLUMNS[spec.apparatus][control], x
        i = int(np.argmax(steps * np.sign(x[-1] - x[0]) <= 0)) + 1
        raise DataError(f"{path}, line {lines[rows[i]]}, column {control!r}: value {x[i]:g} after {x[i - 1]:g}: "
                        f"stage {s.name!r} of {spec.name} is recorded against {control}, which must increase or "
                        "decrease strictly from record to record (a noisy record of a held or slow quantity: give "
                        "the stage abscissa = \"time\")")
    if "stage_time" in values and not np.any(np.isnan(values["stage_time"][rows])):
        x = values["stage_time"][rows]
    else:
        start = stage_times(spec)[k][0]
        if "time" not in values or np.any(np.isnan(values["time"][rows])) or start is None:
            why = ("no stage_time_s or time_s at every record" if start is not None else
                   "the stage's start follows from the material's response (give stage_time_s)")
            raise DataError(f"{path}, line {lines[rows[0]]}: stage {s.name!r} ({s.kind}) of {spec.name} has records "
                            f"but no abscissa: {control or 'its control variable'} not recorded monotone, and {why}")
        x = values["time"][rows] - start
    bad = np.diff(x) <= 0
    if np.any(bad) or x[0] < -1e-9 * max(1.0, abs(x[-1])):
        i = rows[int(np.argmax(bad)) + 1] if np.any(bad) else rows[0]
        raise DataError(f"{path}, line {lines[i]}: stage {s.name!r} of {spec.name}: the time since the stage start "
                        "must be >= 0 and increase from record to record")
    return "time", "s", x


#: how far (a fraction of the stage's range) a record may lie beyond an end of its stage and be taken at that end: a
#: value written with 7 significant digits or more is rounded by less than 5e-7 of itself, hence by less than 1e-6 of
#: the range of a stage that starts from zero or goes to at least half its end value
END_TOLERANCE = 1e-6


def _within_stage(spec, k, span, x_name, unit, x, rows, lines):
    """The abscissae ``x`` of stage k's records with those within END_TOLERANCE of the stage's range beyond one of
    its ends (``span``: (start, end, words) of :func:`cases.study.stages.sequence.stage_spans`, None: not known at
    load) taken at that end; a record further out is a DataError naming the file, the line, the test, the stage and
    the value (a shear stage's axial strain is compared by its magnitude)."""
    if span is None:
        return x
    s = spec.stages[k]
    magnitude = s.procedure.shearing and x_name == "axial_strain"
    v = np.abs(x) if magnitude else x
    lo, hi = sorted(span[:2])
    tol = END_TOLERANCE * max(hi - lo, np.finfo(float).tiny)
    out = (v < lo - tol) | (v > hi + tol)
    if np.any(out):
        i = int(np.argmax(out))
        raise DataError(f"{spec.file}, line {lines[rows[i]]}: test {spec.name!r}, stage {s.name!r}: record "
                        f"{x_name} = {x[i]:g} {unit} lies outside the stage, {lo:g} to {hi:g} {unit} ({span[2]}), by "
                        f"more than the rounding tolerance {tol:.3g} {unit} ({END_TOLERANCE:g} of its range)")
    snapped = np.clip(v, lo, hi)
    return np.sign(x) * snapped if magnitude else snapped


def load_programme_test(spec) -> tuple:
    """(inference.Test, {curve key: record times since the test start (s), or None}) of a programme's CSV: every
    record assigned to its stage, each stage's curves against its abscissa. Errors name the file, the line and the
    stage."""
    meta, values, stage_cells, lines = _read(spec)
    index = _assign(spec, values, stage_cells, lines)
    spans = stage_spans(spec)
    curves, times = {}, {}
    for k, s in enumerate(spec.stages):
        rows = np.flatnonzero(index == k)
        if rows.size == 0:
            continue
        x_name, x_unit, x = _abscissa(spec, k, values, rows, lines)
        x = _within_stage(spec, k, spans[k].get(x_name), x_name, x_unit, x, rows, lines)
        held = s.procedure.held_quantities(s)
        for c in s.chosen_curves or ():
            quantity = next(q for q in COLUMNS[spec.apparatus] if CURVE_OF.get(q, q) == c)
            if quantity not in values or np.all(np.isnan(values[quantity][rows])):
                raise DataError(f"{spec.file}: curve {c!r} of stage {s.name!r} of {spec.name} (its curves) is not "
                                f"recorded in the stage (columns {', '.join(values)})")
        for q, v in values.items():
            if q in ("time", "stage_time", x_name) or q in held:
                continue
            if s.chosen_curves is not None and CURVE_OF.get(q, q) not in s.chosen_curves:
                continue
            keep = ~np.isnan(v[rows])
            if np.any(keep):
                key = curve_key(spec, CURVE_OF.get(q, q), s)
                unit = COLUMNS[spec.apparatus][q]
                curves[key] = inference.Curve(x[keep], v[rows][keep], x_name, q, x_unit, unit)
                times[key] = values["time"][rows][keep] if "time" in values else None
    if not curves:
        raise DataError(f"{spec.file}: no curve recorded for {spec.name} (stage kinds "
                        f"{', '.join(s.kind for s in spec.stages)}; columns {', '.join(values)})")
    conditions = {**meta, "test_type": spec.type, "apparatus": spec.apparatus,
                  **{k: v for k, v in spec.conditions().items() if isinstance(v, (str, int, float))}}
    return inference.Test(spec.name, curves, conditions, str(spec.file)), times


def recorded_programme(spec, test):
    """``spec`` with each stage's ``abscissa`` and ``curves`` (recorded quantities) set from its records ``test``
    (an inference.Test of :func:`load_programme_test`); a flat type is returned as it is."""
    if not spec.staged:
        return spec
    stages = []
    for s in spec.stages:
        mine = [(split_key(k)[0], c) for k, c in test.curves.items()
                if split_key(k)[1] == s.name or (len(spec.stages) == 1 and split_key(k)[1] is None)]
        stages.append(replace(s, abscissa=mine[0][1].x_name if mine else s.abscissa,
                              curves=tuple(q for q, _ in mine)))
    return replace(spec, stages=tuple(stages))
