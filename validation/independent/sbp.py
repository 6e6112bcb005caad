"""The self-boring pressuremeter (SBP) programme of the independent generator: two expansions of the same clay at
cavity strain rates a decade apart, each followed by a hold, simulated by the generator's own coupled cavity solver
(:mod:`validation.independent.sbp_solver`) on the clay of :mod:`validation.independent.programmes` with one hidden
effect (:data:`EFFECTS`: ``none``, the negative control, or ``viscosity``).

Site (:data:`SITE`; kPa, m, m/s): a probe of radius 41.5 mm at 8 m depth, sigma'_v0 60 kPa, K0 0.7, in situ pore
pressure 70 kPa, void ratio 1.25, permeability 1e-10 m/s; the clay's preconsolidation (100 kPa on the K0 = 0.55 line,
:data:`validation.independent.programmes.CLAY`) makes it lightly overconsolidated. Tests (:data:`TESTS`): ``SBP_fast``
expands to 10 % cavity strain at 1 %/min, ``SBP_slow`` at 0.1 %/min; each then holds the cavity strain for 1 h
(pore pressure dissipation; a viscous clay also relaxes).

Logging (each test and noise seed at its own points): the expansion at three early points (0.04, 0.1, 0.25 %) then
every 0.2-0.3 % of cavity strain (+-25 % jitter), the hold log-spaced in the time since its start
(:func:`validation.independent.recording.log_points`); values interpolated linearly in time between the solver's steps.
Noise on the recorded pressures only (total cavity pressure and total pore pressure at the membrane):
x N(1, 0.015^2) + N(0, 0.3^2) kPa; the cavity strain (the control) and the times are exact.

Files (per hidden effect x noise seed, in a folder named by an opaque case id ``sbp_<letter>_s<seed>``): one CSV per
test (``#`` header lines with the site, the stages and the noise, never the hidden effect; columns ``stage``,
``time_s``, ``stage_time_s``, ``cavity_strain_pct``, ``cavity_pressure_kPa``, ``pore_pressure_kPa``), a study file
with a Modified Cam Clay base in the staged-programme schema (apparatus ``sbp``) and a cheap FE preset, and the
hidden truth added to ``KEY.json``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .programmes import CLAY, PROGRAMMES, Stage, Test, material
from .programmes import EFFECTS as ALL_EFFECTS
from .recording import HEADER, SEEDS, _strain_points, log_points, write_csv
from .sbp_material import CavityClay
from .sbp_solver import Cavity

__all__ = ["PROGRAMME", "SITE", "EFFECTS", "TESTS", "COLUMNS", "FE", "case_ids", "simulate", "records", "header",
           "study_text", "write_sbp"]

PROGRAMME = "sbp"
DESCRIPTION = ("self-boring pressuremeter: expansion to 10 % cavity strain at 1 %/min and at 0.1 %/min, each "
               "followed by a 1-hour hold")
#: the site (kPa, m, m/s)
SITE = {"a0": 0.0415, "depth": 8.0, "sigma_v0": 60.0, "K0": 0.7, "u0": 70.0, "permeability": 1e-10, "e0": 1.25}
EFFECTS = ("viscosity", "none")
HOLD = 3600.0


def _test(name, rate):
    return Test(name, "sbp", {k: SITE[k] for k in ("sigma_v0", "K0", "u0", "e0")},
                (Stage("expansion", "expansion1", {"strain_rate": rate, "to_cavity_strain": 10.0}, "strain"),
                 Stage("hold", "hold2", {"duration": HOLD}, "log")))


TESTS = (_test("SBP_fast", 0.01 / 60.0), _test("SBP_slow", 0.001 / 60.0))
COLUMNS = ("stage", "time_s", "stage_time_s", "cavity_strain_pct", "cavity_pressure_kPa", "pore_pressure_kPa")
#: the project's FE discretization written into the study files (cases.study.reading.presets.Preset fields): the full
#: one and the quick one
FE = {"radial_cells": 40, "layers": 1, "increments": 40, "outer": "field", "outer_radius_a0": 200.0}
FE_QUICK = {"radial_cells": 30, "layers": 1, "increments": 30, "outer": "field", "outer_radius_a0": 200.0}


def case_ids() -> dict:
    """{effect: opaque letter}: a fixed shuffle of A, B."""
    order = np.random.default_rng(2026 + len(PROGRAMMES)).permutation(len(EFFECTS))
    return {effect: "AB"[j] for effect, j in zip(EFFECTS, order)}


def cavity_clay(test: Test, effect: str, clay=None, conventions=None):
    """(:class:`CavityClay`, the size of its surface in kPa) of the clay with ``effect`` at the test's in situ state
    (``clay``, ``conventions``: :func:`simulate`)."""
    model, _ = material(effect, clay, conventions)
    c = {**CLAY, **(clay or {})}
    k0 = c["K0_nc"]
    point = (c["sigma_p"] * (1 + 2 * k0) / 3.0, c["sigma_p"] * (1 - k0))
    init = test.initial
    sh = init["K0"] * init["sigma_v0"]
    size = model.initial_state((init["sigma_v0"] + 2 * sh) / 3.0, init["sigma_v0"] - sh, 1.0 + init["e0"],
                               point).size
    return CavityClay(model, 1.0 + init["e0"]), size


def simulate(test: Test, effect: str, n=100, max_strain=1e-4, growth=0.05, outer=200.0, clay=None, conventions=None):
    """({stage name: (start, end) row indices}, rows (time s, cavity strain -, cavity pressure kPa, wall pore
    pressure kPa)) of ``test`` on the clay with ``effect``; ``n`` elements to ``outer`` a0, the solver's step limits;
    ``clay`` overrides values of the clay, ``conventions`` are the models' options
    (:mod:`validation.independent.models`)."""
    material_, size = cavity_clay(test, effect, clay, conventions)
    init = test.initial
    cavity = Cavity(material_, size, SITE["a0"], init["sigma_v0"], init["K0"], init["u0"], SITE["permeability"],
                    init["e0"], n=n, outer=outer)
    spans = {}
    for stage in test.stages:
        start = len(cavity.rows) - 1
        f = stage.fields
        if stage.kind == "expansion":
            cavity.expand(f["strain_rate"], f["to_cavity_strain"] / 100.0, max_strain=max_strain)
        else:
            cavity.hold(f["duration"], max_strain=max_strain, growth=growth)
        spans[stage.name] = (start, len(cavity.rows))
    return spans, np.array(cavity.rows)


def _logged_times(stage, seg, rng):
    """Logged times (s since the test start) of a stage whose solver rows are ``seg``."""
    t = seg[:, 0]
    if stage.kind == "expansion":
        x = seg[:, 1] - seg[0, 1]
        return np.interp(_strain_points(x[-1], rng, rng.uniform(0.002, 0.003)), x, t)
    return log_points(stage, t, seg[:, 1], rng)


def records(test, effect, seed, test_index, simulated=None, **solver) -> dict:
    """{column: values} of one test logged and with noise for a noise seed, from its ``simulated`` (spans, rows) or
    :func:`simulate` with ``solver`` (its step and grid arguments)."""
    spans, rows = simulated or simulate(test, effect, **solver)
    rng = np.random.default_rng([seed, len(PROGRAMMES), test_index])
    noise = np.random.default_rng([seed, len(PROGRAMMES), test_index, 7])
    out = {c: [] for c in COLUMNS}
    for number, stage in enumerate(test.stages, start=1):
        a, b = spans[stage.name]
        seg = rows[a:b]
        times = _logged_times(stage, seg, rng)
        n = len(times)
        out["stage"] += [number] * n
        out["time_s"] += list(times)
        out["stage_time_s"] += list(times - seg[0, 0])
        out["cavity_strain_pct"] += list(100.0 * np.interp(times, seg[:, 0], seg[:, 1]))
        for column, j in (("cavity_pressure_kPa", 2), ("pore_pressure_kPa", 3)):
            exact = np.interp(times, seg[:, 0], seg[:, j])
            out[column] += list(exact * noise.normal(1.0, 0.015, n) + noise.normal(0.0, 0.3, n))
    return {k: np.array(v, dtype=float) for k, v in out.items()}


def _describe(stage) -> str:
    f = stage.fields
    if stage.kind == "expansion":
        return (f"{stage.name} (expansion): cavity strain rate {f['strain_rate']:g} 1/s to {f['to_cavity_strain']:g} "
                "% cavity strain")
    return f"{stage.name} (hold): cavity strain held for {f['duration']:g} s"


def header(case, test, seed) -> list:
    """The ``#`` header lines of one SBP test's CSV (the site, the stages, the noise)."""
    init = ", ".join(f"{k} {v:g}" for k, v in test.initial.items())
    lines = [f"synthetic: {HEADER} (python -m validation.independent --write)", f"case: {case}",
             f"programme: {DESCRIPTION}", f"test: {test.name}", "apparatus: sbp (self-boring pressuremeter)",
             f"site: depth {SITE['depth']:g} m, probe radius {SITE['a0']:g} m, permeability {SITE['permeability']:g} "
             "m/s (from a dissipation test elsewhere on the site)",
             f"initial_state: {init} (kPa; effective stresses, u0 the in situ pore pressure)"]
    lines += [f"stage_{k}: {_describe(s)}" for k, s in enumerate(test.stages, start=1)]
    lines += ["columns: stage number; time since the test start; cavity strain u/a0 since the start of the test; "
              "total cavity pressure and total pore pressure at the membrane",
              f"noise: about 1.5 % per point on the pressures, seed {seed}"]
    return lines


def study_text(case) -> str:
    """The study file an engineer would write from the file headers: Modified Cam Clay, the SBP programme."""
    fe = ["[fe]"] + [f"{k} = {_value(v)}" for k, v in FE.items()] + ["", "[fe.quick]"]
    fe += [f"{k} = {_value(v)}" for k, v in FE_QUICK.items()]
    lines = [f"# {HEADER}: {DESCRIPTION}.",
             "# Written by validation.independent; the study an engineer would write from the file headers, with "
             "Modified Cam Clay", "# as the base model (lambda_ from oedometer tests on the clay).",
             f'name = "{case}"',
             f'description = "SYNTHETIC (independent generator): {DESCRIPTION}; Modified Cam Clay."',
             "", "[model]", 'name = "ModifiedCamClay"', "", "[model.fixed]", "nu = 0.25",
             f"lambda_ = {CLAY['lambda_']!r}", "", "[model.free]", "M = [0.8, 1.6]", "kappa = [0.01, 0.09]",
             'pc0 = { bounds = [60.0, 300.0], prior = "log-uniform" }', "", "[sigma_eps]", "bounds = [0.001, 0.3]",
             "", *fe, ""]
    for t in TESTS:
        lines += ["[[tests]]", f'name = "{t.name}"', f'file = "{t.name}.csv"', 'apparatus = "sbp"',
                  f"depth = {SITE['depth']!r}", f"permeability = {SITE['permeability']!r}",
                  f"probe_radius = {SITE['a0']!r}"]
        lines.append("initial = { " + ", ".join(f"{k} = {v!r}" for k, v in t.initial.items()) + " }")
        for s in t.stages:
            lines += ["", "[[tests.stages]]", f'kind = "{s.kind}"', f'name = "{s.name}"']
            lines += [f"{k} = {_value(v)}" for k, v in s.fields.items()]
        lines.append("")
    return "\n".join(lines)


def _value(v):
    return f'"{v}"' if isinstance(v, str) else repr(v)


def write_sbp(folder, seeds=SEEDS) -> dict:
    """Write every SBP case (hidden effect x noise seed) under ``folder`` and add their truth to its ``KEY.json``
    (the other programmes' entries are kept); returns the SBP part of the key."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    letters = case_ids()
    key = {}
    for effect in EFFECTS:
        simulated = {}
        for seed in seeds:
            case = f"{PROGRAMME}_{letters[effect]}_s{seed}"
            d = folder / case
            d.mkdir(exist_ok=True)
            for ti, test in enumerate(TESTS):
                if test.name not in simulated:
                    simulated[test.name] = simulate(test, effect)
                write_csv(d / f"{test.name}.csv", header(case, test, seed),
                           records(test, effect, seed, ti, simulated[test.name]))
            (d / "study.toml").write_text(study_text(case))
            key[case] = {"programme": PROGRAMME, "effect": effect, "seed": seed,
                         "parameters": {**CLAY, **ALL_EFFECTS[effect], **SITE}}
    path = folder / "KEY.json"
    full = json.loads(path.read_text()) if path.is_file() else {}
    full = {c: v for c, v in full.items() if v["programme"] != PROGRAMME} | key
    path.write_text(json.dumps(full, indent=1, sort_keys=True) + "\n")
    return key
