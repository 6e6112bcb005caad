"""Logging points of SYNTHETIC stage-programme records: where a laboratory would log each stage (every stage
recorded, ramps and holds included, each test at its own points), and the CSV columns of the records
(:mod:`cases.study.reading.stage_records` reads them back).

Per stage kind, with ``n`` = the [synthetic] ``points`` plus 0, 2 or 4 for successive tests (different tests are
logged at different points):
- consolidation: n stresses spaced geometrically from the stage's start to its target (p' or sigma'_v, kPa; the
  ramp is linear in time), void ratio recorded; when the start stress is not known beforehand, n log-spaced times;
- shear: n axial strains evenly spaced to ``to_strain`` (else ``max_strain_pct``, else 15 %; the stage's own strain,
  signed by the direction), q and the void ratio (drained) or the excess pore pressure (undrained);
- creep, relaxation, hold: n times log-spaced from 1e-4 of the duration (at least 1 s; 0.1 s for a hold) to its
  end; creep: axial strain (and the volumetric strain or excess pore pressure in a triaxial cell); relaxation:
  sigma'_v (oedometer) or q (and the excess pore pressure when undrained); hold: cavity and pore pressure;
- crs: n total axial strains evenly spaced from the stage's start to ``to_strain``, sigma'_v recorded;
- load: 3 times during the ramp, then n log-spaced times to the stage's end, axial strain recorded;
- expansion, unloading: n cavity strains evenly spaced from the stage's start to its end, cavity and pore pressure.
"""
from __future__ import annotations

import numpy as np

from cases.study.programme import curve_key
from cases.study.reading.staged_tests import stage_times
from cases.study.reading.stage_records import COLUMNS, CURVE_OF

__all__ = ["logged_stages", "programme_columns"]

#: default shear end (%), when neither the stage nor [synthetic] max_strain_pct gives one
SHEAR_STRAIN_PCT = 15.0


class LoggingError(ValueError):
    """A stage whose records cannot be placed beforehand (its end follows from the material's response)."""


def _hold(duration, n, first=1.0):
    return np.geomspace(min(max(first, 1e-4 * duration), 0.1 * duration), duration, n)


def logged_stages(spec, settings: dict, index: int) -> dict:
    """{curve key: (abscissa name, abscissae in the file's units, stage index, CSV quantity, time since the stage
    start in s)} of the synthetic records of programme ``spec``, the ``index``-th test of its study."""
    n = settings["points"] + 2 * (index % 3)
    init = spec.initial
    p_now, sv_now = init.p, init.vertical
    strain, cavity = 0.0, 0.0
    logs = {}
    for k, s in enumerate(spec.stages):
        t = None
        if s.kind == "consolidation":
            target, start = (s.p, p_now) if s.p is not None else (s.sigma_v, sv_now)
            if start is not None and start != target:
                x_name, x = s.abscissa, np.geomspace(start, target, n + 1)[1:]
                t = s.duration * (x - start) / (target - start)
            else:
                x_name, x = "time", _hold(s.duration, n)
            quantities = ("void_ratio",)
            p_now = s.p if s.p is not None else (s.sigma_v * (1 + 2 * s.K0) / 3 if s.K0 is not None else None)
            sv_now = s.sigma_v if s.sigma_v is not None else s.p
            strain = None
        elif s.kind == "shear":
            top = 100.0 * s.to_strain if s.to_strain is not None else settings["max_strain_pct"] or SHEAR_STRAIN_PCT
            x_name, x = "axial_strain", np.linspace(top / n, top, n) * (-1.0 if s.direction == "extension" else 1.0)
            t = np.abs(x) / 100.0 / s.strain_rate
            quantities = ("q", "void_ratio") if s.drainage == "drained" else ("q", "excess_pore_pressure")
            p_now = sv_now = strain = None
        elif s.kind in ("creep", "relaxation", "hold"):
            x_name, x = "time", _hold(s.duration, n, 0.1 if s.kind == "hold" else 1.0)
            undrained = s.drainage == "undrained"
            quantities = {("creep", "oedometer"): ("axial_strain",),
                          ("creep", "triaxial"): ("axial_strain", "excess_pore_pressure" if undrained
                                                  else "volumetric_strain"),
                          ("relaxation", "oedometer"): ("sigma_v",),
                          ("relaxation", "triaxial"): ("q", "excess_pore_pressure") if undrained else ("q",),
                          ("hold", "sbp"): ("cavity_pressure", "pore_pressure")}[s.kind, spec.apparatus]
            if s.kind == "relaxation":
                p_now = sv_now = None
            elif s.kind == "creep":
                strain = None
        elif s.kind == "crs":
            if strain is None or s.to_strain is None:
                raise LoggingError(f"{spec.where}: stages[{k}] ({s.name}): synthetic records of a crs stage need "
                                   "to_axial_strain and a known strain at its start")
            end = 100.0 * s.to_strain
            x_name, x = "axial_strain", np.linspace(strain, end, n + 1)[1:]
            t = np.abs(x - strain) / 100.0 / abs(s.strain_rate)
            quantities, strain, p_now, sv_now = ("sigma_v",), end, None, None
        elif s.kind == "load":
            x_name = "time"
            x = np.concatenate([np.linspace(s.ramp_time / 3, s.ramp_time, 3), _hold(s.duration, n, 2 * s.ramp_time)])
            quantities, sv_now, p_now, strain = ("axial_strain",), s.sigma_v, None, None
        else:  # expansion, unloading
            if s.to_strain is None:
                raise LoggingError(f"{spec.where}: stages[{k}] ({s.name}): synthetic records of an unloading need "
                                   "to_cavity_strain")
            end = 100.0 * s.to_strain
            x_name, x = "cavity_strain", np.linspace(cavity, end, n + 1)[1:]
            t = np.abs(x - cavity) / 100.0 / s.strain_rate
            quantities, cavity = ("cavity_pressure", "pore_pressure"), end
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
