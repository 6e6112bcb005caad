"""Programmes holding two hidden effects at once, as real clays show them, and a triaxial rate-step programme.

Each case is one programme of the clay of :mod:`validation.independent.programmes` with the effects of one entry of
:data:`CASES` (their generating parameters: ``COMBINED`` of that module for two effects, ``EFFECTS`` for one; the
equations: :mod:`validation.independent.models`, Eq. 6-10), where the programme carries the signatures of both:
- ``relaxation`` and ``il`` (holds after unloading): viscosity + time-dependent swelling: relaxation after loading
  (the stress falls) and after unloading (with the strain held the stress rises), creep after loading (compression
  grows) and after unloading (the specimen keeps swelling);
- ``crs`` (two rates a decade apart): viscosity + destructuration (rate effect and the steep post-yield compression
  of a bonded clay);
- ``ck0u`` (K0 consolidation, compression and extension): viscosity + anisotropy;
- ``ratestep`` (:data:`MULTI_PROGRAMMES`, new): isotropic consolidation to p' 200 kPa over 1 day, a 1-day hold,
  then one undrained compression in ten stages of 1.5 % axial strain each cycling the strain rate 0.1, 0.05,
  0.01 %/min (:data:`RATE_STEPS`, 1/s) to 15 %: viscosity + destructuration (softening with steps of strength at
  every change of rate), viscosity alone and the plain clay (the negative control) of the same programme.
The existing programmes keep their random streams of logging and noise (those of the effect cases of the same
programme and seed); ``ratestep`` has its own.

Files as the effect cases' (:mod:`validation.independent.recording`: SYNTHETIC headers naming no effect, a study file
with the Modified Cam Clay base), in folders ``multi_<programme>_<letter>_s<seed>`` (letters shuffled per programme);
their truth in KEY.json beside the other cases': ``"effects"`` (the list, catalog names: viscosity, anisotropy,
destructuration, time-dependent swelling; [] on the control), ``"effect"`` (the first of them, the one a one-effect
reader compares with; "none" on the control). ``python -m validation.independent --write-multi`` writes these cases
only (the other folders untouched).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .programmes import CLAY, COMBINED, DAY, EFFECTS, PROGRAMMES, Stage, Test
from .recording import SEEDS, header, records, study_text, write_csv

__all__ = ["RATE_STEPS", "MULTI_PROGRAMMES", "CASES", "generator_effect", "case_ids", "multi_tests", "write_multi"]

#: axial strain rates of the rate-step stages, 0.1, 0.05, 0.01 %/min (1/s), cycled
RATE_STEPS = (1.667e-5, 8.333e-6, 1.667e-6)


def _ratestep(e0, stages=10, total=15.0):
    shear = tuple(Stage("shear", f"shear{k + 3}", {"drainage": "undrained", "direction": "compression",
                                                  "strain_rate": RATE_STEPS[k % len(RATE_STEPS)],
                                                  "to_axial_strain": total / stages}, "strain")
                  for k in range(stages))
    return Test("CIU_ratestep", "triaxial", {"p0": 40.0, "e0": e0},
                (Stage("consolidation", "consolidation1", {"p": 200.0, "duration": DAY}, "time"),
                 Stage("creep", "creep2", {"duration": DAY}, "log")) + shear)


#: programme -> (description for the headers, its tests), as ``PROGRAMMES`` of the programmes module
MULTI_PROGRAMMES = {
    "ratestep": ("isotropically consolidated undrained compression (CIU, OCR 1) in ten stages of 1.5 % cycling the "
                 "axial strain rate 0.1, 0.05, 0.01 %/min to 15 %", (_ratestep(1.28),)),
}
#: (programme, hidden effects) of the multi-effect set
CASES = (("relaxation", ("viscosity", "time-dependent swelling")),
         ("il", ("viscosity", "time-dependent swelling")),
         ("crs", ("viscosity", "destructuration")),
         ("ck0u", ("viscosity", "anisotropy")),
         ("ratestep", ("viscosity", "destructuration")),
         ("ratestep", ("viscosity",)),
         ("ratestep", ()))
#: the noise and logging streams: the effect cases' for the existing programmes (controls use 10 and 11)
_STREAM = {**{p: k for k, p in enumerate(PROGRAMMES)}, "ratestep": 12}


def generator_effect(effects) -> str:
    """The generator's effect name of a list of effects: "none", one of ``EFFECTS`` or a ``COMBINED`` key."""
    name = "+".join(effects) or "none"
    if name not in EFFECTS and name not in COMBINED:
        raise ValueError(f"no generating parameters for {name!r}")
    return name


def multi_tests(programme):
    """(description, tests) of a programme of the multi-effect set."""
    return {**PROGRAMMES, **MULTI_PROGRAMMES}[programme]


def case_ids() -> dict:
    """{(programme, effects): "multi_<programme>_<letter>"}: a fixed shuffle per programme of its cases."""
    out = {}
    for k, prog in enumerate(dict.fromkeys(p for p, _ in CASES)):
        mine = [effects for p, effects in CASES if p == prog]
        order = np.random.default_rng(6060 + k).permutation(len(mine))
        out.update({(prog, effects): f"multi_{prog}_{chr(ord('A') + int(j))}" for effects, j in zip(mine, order)})
    return out


def write_multi(folder, seeds=SEEDS) -> dict:
    """Write the multi-effect cases (:data:`CASES` x seed) under ``folder`` and add their truth to its KEY.json (the
    other entries kept as they are); returns their part of the key."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names, key = case_ids(), {}
    for prog, effects in CASES:
        desc, tests = multi_tests(prog)
        effect = generator_effect(effects)
        for seed in seeds:
            case = f"{names[prog, effects]}_s{seed}"
            d = folder / case
            d.mkdir(exist_ok=True)
            for ti, test in enumerate(tests):
                write_csv(d / f"{test.name}.csv", header(case, desc, test, seed),
                          records(test, effect, seed, _STREAM[prog], ti))
            (d / "study.toml").write_text(study_text(case, desc, tests))
            key[case] = {"programme": prog, "effect": effects[0] if effects else "none", "effects": list(effects),
                         "seed": seed, "parameters": {**CLAY, **{**EFFECTS, **COMBINED}[effect]}}
    path = folder / "KEY.json"
    full = json.loads(path.read_text()) if path.is_file() else {}
    full = {c: v for c, v in full.items() if "effects" not in v} | key
    path.write_text(json.dumps(full, indent=1, sort_keys=True) + "\n")
    return key
