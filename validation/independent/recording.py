"""Laboratory logging, measurement noise and the files of the independent generator.

Logging (each test and noise seed at its own points): shear and CRS stages every 0.4-0.6 % of axial strain (CRS
unloading every 0.15-0.25 %) with +-25 % jitter after three early points; consolidation ramps at 6 jittered times (the
last before 97 % of the ramp: the end state is logged by the next stage);
holds, relaxation and incremental load stages log-spaced in the time since the stage start (3 per decade from about
6 s, jittered; two records during a load ramp). Values at the logged points are interpolated linearly in time
between the integrator's sub-steps (sub-steps of at most 2e-5 strain, so the interpolation error is below the
noise by orders of magnitude).

Noise, on the recorded quantities only (never on the generating parameters, the logged times, or the controlled
axial strain of shear/CRS stages): measured stresses (shear, CRS, relaxation) x N(1, 0.015^2) + N(0, 0.3^2) kPa;
applied cell stresses (consolidation, holds) + N(0, 0.3^2) kPa; axial strain where it is a response (consolidation,
holds, load stages) x N(1, 0.01^2) + N(0, 0.002^2) %; void ratio + N(0, 0.002^2); sigma'_v of an incremental load
stage is the applied dead load (no noise).

The logging resolution (:data:`LOGGING`, per call of :func:`records`): a factor on the strain intervals, the points per
decade of log-spaced stages and the resolution (kPa) to which measured and applied stresses are read (0: not rounded);
the effect cases use the defaults, the model-form controls (:mod:`validation.independent.controls`) a sparser one.

Files (per programme x hidden effect x noise seed, in a folder named by an opaque case id): one CSV per test
(``#`` header lines with the conditions and the programme, never the hidden effect; columns ``stage`` (1-based
stage number), ``time_s`` (since the test start), ``stage_time_s`` (since the stage start), ``axial_strain_pct``
(since the test start; since the stage start in a shear stage), then ``q_kPa``, ``p_kPa`` (effective),
``excess_pore_pressure_kPa`` (undrained stages; from the start of a run of consecutive undrained stages), ``void_ratio``
(drained stages) for the triaxial, ``sigma_v_kPa`` (effective) for the oedometer; an empty cell: not recorded in
that stage), a study file ``study.toml`` with a Modified Cam Clay base in the staged-programme schema
(cases/study/reading/staged_tests.py), and the hidden truth in ``KEY.json`` at the top of the data folder.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .programmes import CLAY, EFFECTS, PROGRAMMES, simulate

__all__ = ["SEEDS", "LOGGING", "STRESS_NOISE", "STRAIN_NOISE", "log_points", "logged_times", "records", "write_all",
           "case_ids", "header", "write_csv", "study_text"]

SEEDS = (1, 2, 3)
#: noise of a measured stress: relative and absolute (kPa) standard deviations (module docstring)
STRESS_NOISE = (0.015, 0.3)
#: noise of an axial strain where it is a response: relative and absolute (%) standard deviations
STRAIN_NOISE = (0.01, 0.002)
#: the laboratory's logging resolution (module docstring): strain-interval factor, points per decade, stress resolution
LOGGING = {"spacing": 1.0, "per_decade": 3, "resolution": 0.0}
HEADER = "SYNTHETIC (independent generator): NOT MEASURED DATA"
COLUMNS = {"triaxial": ("stage", "time_s", "stage_time_s", "axial_strain_pct", "q_kPa", "p_kPa",
                        "excess_pore_pressure_kPa", "void_ratio"),
           "oedometer": ("stage", "time_s", "stage_time_s", "axial_strain_pct", "sigma_v_kPa")}


def case_ids() -> dict:
    """{(programme, effect): opaque letter}: a fixed shuffle of A-D per programme."""
    out = {}
    for k, prog in enumerate(PROGRAMMES):
        order = np.random.default_rng(2026 + k).permutation(len(EFFECTS))
        for effect, j in zip(EFFECTS, order):
            out[prog, effect] = "ABCD"[j]
    return out


def _strain_points(total, rng, spacing):
    """Logged strain magnitudes (fractions) of a stage reaching ``total``: three early points, then every
    ``spacing`` (fraction) with +-25 % jitter."""
    pts = [total * f for f in (0.004, 0.01, 0.025)] if total > 0.05 else []
    x = pts[-1] if pts else 0.0
    while True:
        x += spacing * rng.uniform(0.75, 1.25)
        if x >= total * 0.999:
            break
        pts.append(x)
    return np.array(pts + [total])


def log_points(stage, t, x, rng, spacing=1.0, per_decade=3) -> np.ndarray:
    """Logged times (s since the test start) in a stage with sub-step times ``t`` and control strains ``x``;
    ``spacing`` scales the strain interval and ``per_decade`` sets the points per decade of a log-spaced stage
    (:data:`LOGGING`: the laboratory's logging resolution)."""
    t0, t1 = t[0], t[-1]
    if stage.log == "strain":
        xs = np.abs(x - x[0])
        interval = (rng.uniform(0.004, 0.006) if stage.fields.get("strain_rate", 1) > 0 or stage.kind == "shear"
                    else rng.uniform(0.0015, 0.0025))
        pts = _strain_points(xs[-1], rng, spacing * interval)
        return np.interp(pts, xs, t)
    if stage.log == "time":
        u = (np.arange(1, 7) + rng.uniform(-0.3, 0.3, 6)) / 6.0
        return t0 + np.clip(u, 0.02, 0.97) * (t1 - t0)
    span = t1 - t0
    start = 6.0 * rng.uniform(0.8, 1.2)
    n = max(int(per_decade * math.log10(span / start)) + 1, 2)
    local = np.geomspace(start, span, n) * np.exp(rng.uniform(-0.08, 0.08, n))
    local = np.unique(np.clip(local, start, span))
    if stage.kind == "load":
        ramp = stage.fields["ramp_time"]
        local = np.concatenate([[0.3 * ramp, 0.7 * ramp], local[local > ramp]])
    return t0 + local


def logged_times(test, spans, rows, seed, prog_index, test_index, spacing=1.0, per_decade=3) -> list:
    """[(stage number, stage, its trajectory rows, the logged times)] of one test for a noise seed (``spacing``,
    ``per_decade``: :func:`log_points`)."""
    r = np.array(rows)
    rng = np.random.default_rng([seed, prog_index, test_index])
    out = []
    for number, stage in enumerate(test.stages, start=1):
        a, b = spans[stage.name]
        seg = r[a:b]
        out.append((number, stage, seg, log_points(stage, seg[:, 0], seg[:, 1], rng, spacing, per_decade)))
    return out


def records(test, effect, seed, prog_index, test_index, form: dict | None = None, noise_scale=1.0, **steps) -> dict:
    """{column: values} of one test logged and with noise, for a noise seed (NaN: not recorded in that stage).
    ``form``: a model-form control of :mod:`validation.independent.controls` ("clay", "conventions", "k0" go to
    :func:`simulate`, "steps" to the integrator, "logging" {"spacing", "per_decade", "resolution" (kPa: stresses
    rounded to it)}); ``noise_scale`` multiplies every noise standard deviation (0: noise-free, same logged points)."""
    form = form or {}
    simulated = {k: form[k] for k in ("clay", "conventions", "k0") if k in form}
    spans, rows = simulate(test, effect, **simulated, **{**form.get("steps", {}), **steps})
    logging = {**LOGGING, **form.get("logging", {})}
    resolution = logging.pop("resolution")
    noise = np.random.default_rng([seed, prog_index, test_index, 7])
    out = {c: [] for c in COLUMNS[test.apparatus]}
    u_start = None          # sigma'_r where the current run of undrained stages started (its excess pore pressure 0)
    sd_rel, sd_abs = STRESS_NOISE[0] * noise_scale, STRESS_NOISE[1] * noise_scale
    for number, stage, seg, times in logged_times(test, spans, rows, seed, prog_index, test_index, **logging):
        t = seg[:, 0]
        at = {j: np.interp(times, t, seg[:, j]) for j in range(1, 6)}
        ea, sa, sr, e = at[1], at[3], at[4], at[5]
        n = len(times)
        empty = np.full(n, np.nan)

        def measured(v):
            return _round(v * noise.normal(1.0, sd_rel, n) + noise.normal(0.0, sd_abs, n), resolution)

        def applied(v):
            return _round(v + noise.normal(0.0, sd_abs, n), resolution)
        strain = 100.0 * ea
        if stage.kind in ("consolidation", "creep", "load"):
            strain = (strain * noise.normal(1.0, STRAIN_NOISE[0] * noise_scale, n)
                      + noise.normal(0.0, STRAIN_NOISE[1] * noise_scale, n))
        elif stage.kind == "shear":
            strain = 100.0 * (ea - seg[0, 1])
        out["stage"] += [number] * n
        out["time_s"] += list(times)
        out["stage_time_s"] += list(times - t[0])
        out["axial_strain_pct"] += list(strain)
        if test.apparatus == "triaxial":
            undrained = stage.fields.get("drainage") == "undrained"
            u_start = (seg[0, 4] if u_start is None else u_start) if undrained else None
            stress = measured if stage.kind == "shear" else applied
            out["q_kPa"] += list(stress(sa - sr))
            out["p_kPa"] += list(stress((sa + 2 * sr) / 3.0))
            out["excess_pore_pressure_kPa"] += list(measured(u_start - sr) if undrained else empty)
            out["void_ratio"] += list(empty if undrained else e + noise.normal(0.0, 0.002 * noise_scale, n))
        else:
            out["sigma_v_kPa"] += list(sa if stage.kind == "load" else measured(sa))
    return {k: np.array(v) for k, v in out.items()}


def _round(v, resolution):
    """``v`` rounded to the logger's ``resolution`` (kPa; 0: not rounded)."""
    return np.round(v / resolution) * resolution if resolution else v


def _describe(stage) -> str:
    f = stage.fields
    parts = {"consolidation": lambda: (f"isotropic to p' {f['p']:g} kPa" if "p" in f else
                                       f"K0 {f['K0']:g} to sigma'_v {f['sigma_v']:g} kPa")
                                      + f" over {f['duration']:g} s",
             "creep": lambda: f"drained hold at constant stresses for {f['duration']:g} s",
             "shear": lambda: f"{f['drainage']} {f['direction']} at {f['strain_rate']:g} 1/s to "
                              f"{f['to_axial_strain']:g} % axial strain",
             "crs": lambda: f"constant rate of strain {f['strain_rate']:g} 1/s to "
                            + (f"{f['to_axial_strain']:g} % axial strain" if "to_axial_strain" in f
                               else f"sigma'_v {f['to_sigma_v']:g} kPa"),
             "relaxation": lambda: f"axial strain held for {f['duration']:g} s",
             "load": lambda: f"sigma'_v {f['sigma_v']:g} kPa, ramp {f['ramp_time']:g} s, stage {f['duration']:g} s"}
    return f"{stage.name} ({stage.kind}): {parts[stage.kind]()}"


def header(case, description, test, seed) -> list:
    """The ``#`` header lines of one test's CSV: the conditions and the programme's ``description``."""
    init = ", ".join(f"{k} {v:g}" for k, v in test.initial.items())
    lines = [f"synthetic: {HEADER} (python -m validation.independent --write)",
             f"case: {case}", f"programme: {description}", f"test: {test.name}",
             f"apparatus: {test.apparatus}", f"initial_state: {init} (kPa; effective stresses)"]
    lines += [f"stage_{k}: {_describe(s)}" for k, s in enumerate(test.stages, start=1)]
    undrained = [s.fields.get("drainage") == "undrained" for s in test.stages]
    consecutive = any(a and b for a, b in zip(undrained, undrained[1:]))
    lines += ["columns: stage number; time since the test start; compression positive; effective stresses"
              + ("" if test.apparatus != "triaxial" else "; excess pore pressure from the start of "
                 + ("undrained shearing (carried through consecutive undrained stages)" if consecutive
                    else "each undrained stage")), f"noise: about 1.5 % per point, seed {seed}"]
    return lines


def write_csv(path, header, columns):
    with open(path, "w") as fh:
        fh.writelines(f"# {h}\n" for h in header)
        fh.write(",".join(columns) + "\n")
        for row in zip(*columns.values()):
            fh.write(",".join(str(int(v)) if k == "stage" else "" if np.isnan(v) else f"{v:.5g}"
                              for k, v in zip(columns, row)) + "\n")


def _toml_value(v):
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(float(v))


def study_text(case, desc, tests) -> str:
    """The study file an engineer would write from the headers of a programme described by ``desc``."""
    low = min(t.initial.get("p0", t.initial.get("sigma_v0", 0)) for t in tests)
    lines = [f"# {HEADER}: {desc}. Written by validation.independent; the study an engineer would write from the file",
             "# headers, with Modified Cam Clay as the base model.",
             f'name = "{case}"', f'description = "SYNTHETIC (independent generator): {desc}; Modified Cam Clay."',
             "", "[model]", 'name = "ModifiedCamClay"', "", "[model.fixed]", "nu = 0.25", "", "[model.free]",
             "M = [0.8, 1.6]", "lambda_ = [0.1, 0.5]", "kappa = [0.01, 0.09]",
             f'pc0 = {{ bounds = [{max(30.0, 1.2 * low):g}, 400.0], prior = "log-uniform" }}', "",
             "[sigma_eps]", "bounds = [0.001, 0.3]", ""]
    for t in tests:
        lines += ["[[tests]]", f'name = "{t.name}"', f'file = "{t.name}.csv"', f'apparatus = "{t.apparatus}"']
        lines += [f"{k} = {_toml_value(v)}" for k, v in t.initial.items()]
        for s in t.stages:
            lines += ["", "[[tests.stages]]", f'kind = "{s.kind}"', f'name = "{s.name}"']
            lines += [f"{k} = {_toml_value(v)}" for k, v in s.fields.items()]
        lines.append("")
    return "\n".join(lines)


def write_all(folder, seeds=SEEDS) -> dict:
    """Write every case (programme x effect x seed) under ``folder`` and ``KEY.json``; returns the key."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    key = {}
    letters = case_ids()
    for pi, (prog, (_, tests)) in enumerate(PROGRAMMES.items()):
        for effect in EFFECTS:
            for seed in seeds:
                case = f"{prog}_{letters[prog, effect]}_s{seed}"
                d = folder / case
                d.mkdir(exist_ok=True)
                for ti, test in enumerate(tests):
                    write_csv(d / f"{test.name}.csv", header(case, PROGRAMMES[prog][0], test, seed),
                              records(test, effect, seed, pi, ti))
                (d / "study.toml").write_text(study_text(case, PROGRAMMES[prog][0], tests))
                key[case] = {"programme": prog, "effect": effect, "seed": seed,
                             "parameters": {**CLAY, **EFFECTS[effect]}}
    (folder / "KEY.json").write_text(json.dumps(key, indent=1, sort_keys=True) + "\n")
    return key
