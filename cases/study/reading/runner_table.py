"""The ``[runner]`` table of a study file: which route of the one runner (:mod:`cases.study.routes.dispatch`) calibrates
the study, and the settings of that route that are not part of the calibration problem itself.

    [runner]
    route = "study"            # "study": the general route (any model and test type, --diagnose);
                               # "sand": SIMSAND triaxial tests on a strain grid with predicted tests and CSL figures
                               # (cases.study.routes.sand); "sbp": the pressuremeter route (cases.study.routes.sbp)

Sand route fields: ``records`` ("plain": columns eps_a_pct, q_kPa, e; "stress_ratio": eps_a (%), sr =
sigma'_a/sigma'_r, eps_v (% compression positive) with header e0, sigma3_kPa), ``substitutes`` (calibration tests
that ``--undrained`` recordings replace; a test's own ``role = "predict"`` keeps it out of the calibration),
``note`` (said in every output while no ``--undrained`` recording is given), ``grid_pct`` ([step, to] segments of
the simulation's axial strain grid in %, from 0; default: the recorded strains), ``max_failure_fraction`` (failed
forward solves allowed per stage), ``volume_at_pct`` (axial strains, %, of the predicted tests' volumetric strain
table), ``error_groups`` (the default file of ``--error-groups``, relative to the study file), ``noise_levels``
(allowed ``--noise`` values of a synthetic study; records of level X in the folder noise<X>), ``hold_at`` (the
[reference] key whose values hold the parameters not identified with ``--free``), ``spread`` (the [reference] key of
the MAP spread figure), ``truth`` (the [reference] key of the generating values of synthetic records: their curves
are drawn dashed). Pressuremeter route fields: ``sweeps`` (MCMC sweeps per stage of the full setting),
``note`` (said of synthetic recordings), ``truth`` (the [reference] key of the generating values of synthetic
recordings). A field of the other route, an unknown field or a key that names no [reference] is an error naming the
file, ``runner.<field>`` and the value.
"""
from __future__ import annotations

__all__ = ["ROUTES", "read_runner"]

ROUTES = ("study", "sand", "sbp")
FIELDS = {"study": (),
          "sand": ("records", "substitutes", "note", "grid_pct", "max_failure_fraction", "volume_at_pct",
                   "error_groups", "noise_levels", "hold_at", "spread", "truth"),
          "sbp": ("sweeps", "note", "truth")}
DEFAULTS = {"records": "plain", "substitutes": [], "note": "", "grid_pct": None,
            "max_failure_fraction": 0.1, "volume_at_pct": [], "error_groups": None, "noise_levels": None,
            "hold_at": None, "spread": None, "sweeps": None, "truth": None}


def _names(ck, value, where, choices):
    if not isinstance(value, list) or any(v not in choices for v in value):
        ck.fail(where, value, f"expected a list of names among {', '.join(choices)}")
    return list(value)


def _numbers(ck, value, where):
    if not isinstance(value, list):
        ck.fail(where, value, "expected a list of numbers")
    return [ck.number(v, where, non_negative=True) for v in value]


def read_runner(ck, table, tests, references, calibrated) -> dict:
    """The checked ``[runner]`` table: {"route": ..., and every field of that route, defaults filled}; ``tests``
    the study's test names, ``references`` its [reference] keys, ``calibrated`` the names of its tests whose role is
    "calibrate"."""
    route = ck.text(table.get("route", "study"), "runner.route", ROUTES)
    ck.table(table, "runner", ("route", *FIELDS[route]))
    out = {"route": route, **{k: DEFAULTS[k] for k in FIELDS[route]}}
    for k, v in table.items():
        where = f"runner.{k}"
        if k in ("route",):
            continue
        if k == "records":
            out[k] = ck.text(v, where, ("plain", "stress_ratio"))
        elif k == "substitutes":
            out[k] = _names(ck, v, where, tests)
        elif k in ("note", "error_groups"):
            if not isinstance(v, str):
                ck.fail(where, v, "expected a string")
            out[k] = v
        elif k == "grid_pct":
            if not isinstance(v, list) or not v or any(not isinstance(s, list) or len(s) != 2 for s in v):
                ck.fail(where, v, "expected [[step, to], ...] segments of axial strain (%)")
            segments, start = [], 0.0
            for step, to in v:
                step, to = ck.number(step, where, positive=True), ck.number(to, where, positive=True)
                if not to > start:
                    ck.fail(where, v, "each segment must end beyond the previous one")
                segments.append((step, to))
                start = to
            out[k] = segments
        elif k == "max_failure_fraction":
            out[k] = ck.number(v, where, positive=True)
            if out[k] > 1.0:
                ck.fail(where, v, "a fraction: expected a number in (0, 1]")
        elif k in ("volume_at_pct", "noise_levels"):
            out[k] = _numbers(ck, v, where)
        elif k in ("hold_at", "spread", "truth"):
            out[k] = ck.text(v, where, tuple(references) or ("(a [reference] key)",))
        elif k == "sweeps":
            out[k] = ck.integer(v, where, 1)
    if route == "sand" and not set(out["substitutes"]) <= set(calibrated):
        ck.fail("runner.substitutes", out["substitutes"], "a substituted test must be a calibration test")
    return out
