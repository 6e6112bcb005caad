"""Recording files: the CSV columns of each test type, the one reader that checks and converts them into
``inference`` observations (every entry point: study files and the pressuremeter's ``--recordings``), and the
writer of synthetic records.

A recording CSV has ``#`` header lines (``key: value`` pairs become the test's conditions), a row of column names with
units, then the rows (the forms ``inference.observations`` reads: ',' or ';' separated, decimal commas in a ';' file).
A column is named as :data:`COLUMNS` spells it, with its unit as a suffix (``axial_strain_pct``, ``q_kPa``,
``time_s``) or in brackets or parentheses with blanks for ``_`` (``axial strain (%)``, ``q [MPa]``: converted when
the dimension agrees); names are case-sensitive, and the stresses p and sigma_v are effective, named without a prime
(``p'`` is refused with the hint ``p_kPa``). Errors name the file, the column and the line.
"""
from __future__ import annotations

import difflib
import json
from pathlib import Path

import numpy as np

import inference
from cases.study.programme import TestSpec
from cases.study.reading.stage_records import load_programme_test
from cases.study.stages.pressuremeter import MAX_CAVITY_STRAIN
from inference import DataError
from inference.observations import converted, read_csv_rows, read_csv_table

__all__ = ["COLUMNS", "X_COLUMN", "CURVE_OF", "DRAINED_ONLY", "UNDRAINED_ONLY", "SBP_MAX_STRAIN_PCT",
           "column_name", "data_lines", "check_table", "creep_stage", "load_test", "load_observations",
           "load_sbp_recordings", "has_pore_pressure", "write_records", "generating_values"]

#: CSV columns per test type: quantity -> (unit, role); role "x" (abscissa), "curve" (calibrated when present),
#: "required curve", "time" (optional record time)
COLUMNS = {
    "triaxial": {"axial_strain": ("%", "x"), "q": ("kPa", "required curve"), "p": ("kPa", "curve"),
                 "excess_pore_pressure": ("kPa", "curve"), "volumetric_strain": ("%", "curve"),
                 "void_ratio": ("-", "curve"), "time": ("s", "time")},
    "oedometer_crs": {"axial_strain": ("%", "x"), "sigma_v": ("kPa", "required curve"), "time": ("s", "time")},
    "oedometer_creep": {"time": ("s", "x"), "axial_strain": ("%", "required curve")},
    "sbp": {"cavity_strain": ("%", "x"), "cavity_pressure": ("kPa", "required curve"),
            "pore_pressure": ("kPa", "curve"), "time": ("s", "time")},
}
#: the abscissa quantity of each test type
X_COLUMN = {kind: next(q for q, (_, role) in cols.items() if role == "x") for kind, cols in COLUMNS.items()}
#: CSV quantity -> curve name (the catalog's stress-curve names: sigma'_v is "axial_stress")
CURVE_OF = {"sigma_v": "axial_stress"}
DRAINED_ONLY = ("volumetric_strain", "void_ratio")
UNDRAINED_ONLY = ("excess_pore_pressure",)
#: largest cavity strain of the pressuremeter FE expansion, %
SBP_MAX_STRAIN_PCT = 100.0 * MAX_CAVITY_STRAIN


def column_name(quantity: str, test_type: str) -> str:
    """The CSV column name of ``quantity`` in a ``test_type`` file, with its unit (``q_kPa``, ``axial_strain_pct``)."""
    unit = COLUMNS[test_type][quantity][0]
    return quantity if unit == "-" else f"{quantity}_{'pct' if unit == '%' else unit}"


def data_lines(path) -> list:
    """File line numbers of the data rows of a CSV read by ``read_csv_table``."""
    return [lineno for lineno, _ in read_csv_rows(path)[2]]


def _unknown_column(path, quantity, unit, test_type):
    """The DataError of a column that is not one of ``test_type``'s: the near-miss known name when there is one (a
    typo in an optional column is refused, never dropped), and the known names."""
    names = [column_name(q, test_type) for q in COLUMNS[test_type]]
    given = quantity if unit == "-" else f"{quantity}_{'pct' if unit == '%' else unit}"
    lower = {n.lower(): n for n in names} | {q.lower(): column_name(q, test_type) for q in COLUMNS[test_type]}
    close = (difflib.get_close_matches(given.lower(), lower, n=1, cutoff=0.75)
             or difflib.get_close_matches(quantity.lower(), lower, n=1, cutoff=0.75))
    hint = f"did you mean {lower[close[0]]!r}? " if close else ""
    unprimed = quantity.replace("'", "").replace("\u2019", "").strip("_")
    if unprimed != quantity and unprimed in COLUMNS[test_type]:
        hint = (f"did you mean {column_name(unprimed, test_type)!r}? (p and sigma_v are effective stresses, named "
                "without the prime) ")
    raise DataError(f"{path}: column {quantity!r} (unit {unit!r}) is not a column of a {test_type} test; {hint}"
                    f"known: {', '.join(names)} (or as 'name (unit)', e.g. 'axial strain (%)')")


def _monotone(path, column, values, lines, decreasing=False, strict=True, what="increase"):
    steps = -np.diff(values) if decreasing else np.diff(values)
    bad = steps <= 0 if strict else steps < 0
    if np.any(bad):
        i = int(np.argmax(bad)) + 1
        raise DataError(f"{path}, line {lines[i]}, column {column!r}: value {values[i]:g} does not "
                        f"{what} (previous {values[i - 1]:g})")


def check_table(spec, table: dict):
    """Columns known for the test type and in convertible units, the abscissa monotone and in range, positive
    stresses; returns the converted {quantity: values}. Errors name the file, the column and the line."""
    path, columns = spec.file, COLUMNS[spec.type]
    lines = data_lines(path)
    for q, (unit, _) in table.items():
        if q not in columns:
            _unknown_column(path, q, unit, spec.type)
    for q, (unit, role) in columns.items():
        if role in ("x", "required curve") and q not in table:
            raise DataError(f"{path}: missing column {q!r} ({unit}) of a {spec.type} test; found {list(table)}")
    values = {q: converted(path, q, u, v, columns[q][0]) for q, (u, v) in table.items()}
    x_name = X_COLUMN[spec.type]
    x = values[x_name]
    extension = spec.type == "triaxial" and spec.direction == "extension"
    if extension and x[0] > 0:
        raise DataError(f"{path}, line {lines[0]}, column {x_name!r}: value {x[0]:g}: an extension test has axial "
                        "strains <= 0 (compression positive)")
    if not extension and x[0] < 0:
        raise DataError(f"{path}, line {lines[0]}, column {x_name!r}: value {x[0]:g} must be >= 0"
                        + (" (compression positive; an extension test says direction = \"extension\")"
                           if spec.type == "triaxial" else ""))
    _monotone(path, x_name, x, lines, decreasing=extension, what="decrease" if extension else "increase")
    limit = SBP_MAX_STRAIN_PCT if spec.type == "sbp" else (None if x_name == "time" else 100.0)
    if limit is not None and np.max(np.abs(x)) > limit:
        i = int(np.argmax(np.abs(x) > limit))
        raise DataError(f"{path}, line {lines[i]}, column {x_name!r}: value {x[i]:g} % exceeds {limit:g} %"
                        + (" (the pressuremeter FE expands the cavity to 10 %)" if spec.type == "sbp" else ""))
    if "time" in values and x_name != "time":
        _monotone(path, "time", values["time"], lines, strict=False, what="increase or stay")
    for q in ("p", "sigma_v", "void_ratio", "cavity_pressure"):
        if q in values and np.any(values[q] <= 0):
            i = int(np.argmax(values[q] <= 0))
            raise DataError(f"{path}, line {lines[i]}, column {q!r}: value {values[q][i]:g} must be > 0")
    if spec.type == "triaxial":
        wrong = DRAINED_ONLY if spec.drainage == "undrained" else UNDRAINED_ONLY
        for q in wrong:
            if q in values:
                raise DataError(f"{path}: column {q!r} is not recorded in a {spec.drainage} test ({spec.where})")
    if spec.type == "oedometer_creep":
        creep_stage(spec, x, path, lines)
    return values


def creep_stage(spec, t, path=None, lines=None):
    """Stage index and time since the stage start (``TestSpec.hold_stage``) of records at times ``t`` (s since the
    test start) of an incremental oedometer; with ``path``, a record outside the holds of the stages is a DataError
    naming the file and the line."""
    stage, local = spec.hold_stage(t)
    bad = (stage >= len(spec.stage_stress)) | (local < spec.load_time * (1 - 1e-9))
    if path is not None and np.any(bad):
        i = int(np.argmax(bad))
        raise DataError(f"{path}, line {lines[i]}, column 'time': value {t[i]:g} s is not in a hold of the "
                        f"{len(spec.stage_stress)} stages of {spec.stage_duration:g} s (each loaded during its first "
                        f"{spec.load_time:g} s)")
    return stage, local


def load_test(spec) -> tuple:
    """(inference.Test, record times in s or None) of one test's CSV, checked (:func:`check_table`): the curves
    of the file's columns for the test type, or those ``spec.curves`` names; conditions from the file's header
    and the test record. A stage programme's records: :func:`cases.study.reading.stage_records.load_programme_test`."""
    if spec.staged:
        return load_programme_test(spec)
    meta, table = read_csv_table(spec.file)
    values = check_table(spec, table)
    cols = COLUMNS[spec.type]
    x_name = X_COLUMN[spec.type]
    present = [q for q, (_, role) in cols.items() if "curve" in role and q in values]
    if spec.curves is not None:
        for c in spec.curves:
            if c not in [CURVE_OF.get(q, q) for q in present]:
                raise DataError(f"{spec.file}: curve {c!r} requested by {spec.where}.curves has no column in the file "
                                f"(found {list(table)})")
        present = [q for q in present if CURVE_OF.get(q, q) in spec.curves]
    conditions = {**meta, "test_type": spec.type, **{k: v for k, v in spec.conditions().items()
                                                     if isinstance(v, (str, int, float))}}
    curves = {CURVE_OF.get(q, q): inference.Curve(values[x_name], values[q], x_name, q, cols[x_name][0], cols[q][0])
              for q in present}
    test = inference.Test(spec.name, curves, conditions, str(spec.file))
    times = values[x_name] if x_name == "time" else values.get("time")
    return test, times


def load_observations(tests) -> tuple:
    """(Observations, {test: record times or None}) of the test records ``tests`` (a study's ``tests``)."""
    loaded = [load_test(t) for t in tests]
    return inference.Observations([t for t, _ in loaded]), {t.name: times for t, (_, times) in zip(tests, loaded)}


def load_sbp_recordings(files: dict, pore_pressure=False) -> inference.Observations:
    """Pressuremeter records {test: CSV path} -> Observations of the total cavity pressure (and, with
    ``pore_pressure``, the total pore pressure at the wall) against cavity strain (%), read and checked as the
    ``sbp`` test type of a study (:func:`load_test`)."""
    curves = ("cavity_pressure", "pore_pressure") if pore_pressure else ("cavity_pressure",)
    specs = [TestSpec(name, "sbp", file=Path(path), where=f"recordings {name}", curves=curves)
             for name, path in files.items()]
    return load_observations(specs)[0]


def has_pore_pressure(path) -> bool:
    """Whether a recording file has a pore-pressure column."""
    return "pore_pressure" in read_csv_table(path)[1]


def write_records(path, header, columns: dict, exact=()) -> Path:
    """One CSV of records: ``# `` header lines, the column names, then the rows, 9 significant digits except the
    columns named in ``exact`` (shortest round trip); written to ``<path>.tmp`` and moved into place."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    shortest = [c in exact for c in columns]
    with tmp.open("w") as fh:
        fh.writelines(f"# {h}\n" for h in header)
        fh.write(",".join(columns) + "\n")
        for row in zip(*columns.values()):
            fh.write(",".join(repr(float(v)) if s else f"{v:.9g}" for s, v in zip(shortest, row)) + "\n")
    tmp.replace(path)
    return path


def generating_values(observations, names=None):
    """The parameters synthetic records were generated from: the JSON object at the start of their
    ``# synthetic_parameters:`` header (text after it is a note), equal in every test, or None (no such header,
    tests that disagree, unreadable JSON, or other names than ``names`` when given)."""
    found = {t.conditions.get("synthetic_parameters") for t in observations}
    if len(found) != 1 or None in found:
        return None
    try:
        values, _ = json.JSONDecoder().raw_decode(next(iter(found)).strip())
    except json.JSONDecodeError:
        return None
    if not isinstance(values, dict) or (names is not None and set(values) != set(names)):
        return None
    return values
