"""Logging points of SYNTHETIC stage-programme records: where a laboratory would log each stage (every stage
recorded, ramps and holds included, each test at its own points), and the CSV columns of the records
(:mod:`cases.study.reading.stage_records` reads them back).

Each stage is logged where its kind says (``StageKind.logged``, :mod:`cases.study.stages`), at ``n`` = the
[synthetic] ``points`` plus 0, 2 or 4 points for successive tests (different tests are logged at different points).
"""
from __future__ import annotations

import numpy as np

from cases.study.programme import curve_key
from cases.study.reading.stage_records import COLUMNS, CURVE_OF
from cases.study.stages.sequence import stage_times

__all__ = ["logged_stages", "programme_columns"]


def logged_stages(spec, settings: dict, index: int) -> dict:
    """{curve key: (abscissa name, abscissae in the file's units, stage index, CSV quantity, time since the stage
    start in s)} of the synthetic records of programme ``spec``, the ``index``-th test of its study."""
    n = settings["points"] + 2 * (index % 3)
    init = spec.initial
    now = {"p": init.p, "sigma_v": init.vertical, "strain": 0.0, "cavity": 0.0}
    logs = {}
    for k, s in enumerate(spec.stages):
        x_name, x, t, quantities = s.procedure.logged(s, spec.apparatus, n, now, settings,
                                                      f"{spec.where}: stages[{k}] ({s.name})")
        for q in quantities:
            logs[curve_key(spec, CURVE_OF.get(q, q), s)] = (x_name, x, k, q, x if t is None else t)
    return logs


def _column(q, apparatus):
    unit = COLUMNS[apparatus][q]
    return q if unit == "-" else f"{q}_{'pct' if unit == '%' else unit}"


def _at(x, sim):
    """Simulated values at the abscissae ``x``: an array at them, or (abscissae, values) interpolated."""
    if not isinstance(sim, tuple):
        return np.asarray(sim, dtype=float)
    xp, yp = (np.asarray(v, dtype=float) for v in sim)
    order = np.argsort(xp, kind="stable")
    return np.interp(x, xp[order], yp[order])


def programme_columns(spec, logs: dict, sim: dict, rng, noise: float) -> tuple:
    """({CSV column: values}, exact columns) of a programme's synthetic records: ``stage`` (number), ``time_s`` (s
    since the test start; ``stage_time_s`` when a stage's start follows from the material's response), each stage's
    abscissa, and its quantities at the simulated values ``sim`` {curve key: values} times the noise c ~ N(1,
    noise^2) (Eq. 1); a cell that a stage does not record is NaN (not recorded)."""
    starts = [a for a, _ in stage_times(spec)]
    known = all(starts[k] is not None for _, _, k, _, _ in logs.values())
    rows = {}  # (stage, abscissa) -> row
    for key, (x_name, x, k, q, t) in logs.items():
        y = _at(x, sim[key]) * rng.normal(1.0, noise, len(x))
        for j, xj in enumerate(x):
            row = rows.setdefault((k, float(xj)), {"stage": k + 1.0, x_name: xj,
                                                   "time" if known else "stage_time": (starts[k] if known else 0.0)
                                                   + t[j]})
            row[q] = y[j]
    order = sorted(rows, key=lambda r: (r[0], rows[r]["time" if known else "stage_time"]))
    names = ["stage"] + [q for q in COLUMNS[spec.apparatus] if any(q in rows[r] for r in order)]
    columns = {("stage" if q == "stage" else _column(q, spec.apparatus)): np.array([rows[r].get(q, np.nan)
                                                                                    for r in order])
               for q in names}
    return columns, ()
