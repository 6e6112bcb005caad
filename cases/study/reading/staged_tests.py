"""The programme form of a ``[[tests]]`` entry: ``apparatus``, the specimen's initial state (``[tests.initial]`` or
the same fields in the test's table) and its ``[[tests.stages]]`` in order, checked into a
:class:`~cases.study.programme.TestSpec` with ``type = "programme"``.

Every field is checked before any solve; a message names the file, ``tests[i].stages[k].field``, the value and what
is supported (for the apparatus, for the stage kind). Units: kPa, s, 1/s; strains in % in the file (fractions in the
record); compression positive.
"""
from __future__ import annotations

from pathlib import Path

from constitutive.registry import SBP_MODELS

from cases.study.reading.checks import StudyError
from cases.study.programme import STAGE_KINDS, InitialState, Stage, TestSpec
from cases.study.reading.sbp_stages import check_sbp_stages

__all__ = ["PROGRAMME_FIELDS", "STAGE_FIELDS", "INITIAL_FIELDS", "programme_spec", "stage_times",
           "PRECONSOLIDATION_PARAMETERS"]

#: test-level fields of a programme entry besides the initial state (per apparatus)
PROGRAMME_FIELDS = {"triaxial": ("name", "file", "apparatus", "weight", "initial", "stages"),
                    "oedometer": ("name", "file", "apparatus", "weight", "initial", "stages"),
                    "sbp": ("name", "file", "apparatus", "weight", "initial", "stages", "permeability",
                            "probe_radius", "depth")}
INITIAL_FIELDS = ("e0", "p0", "sigma_v0", "K0", "ocr", "preconsolidation", "u0")
#: the model parameters a per-test ``ocr`` / ``preconsolidation`` replaces
PRECONSOLIDATION_PARAMETERS = ("ocr", "pc0", "sigma_p0")
#: fields of a stage table per kind (required, optional); ``kind`` and ``name`` are common
STAGE_FIELDS = {
    "consolidation": ((), ("p", "sigma_v", "K0", "duration")),
    "shear": (("drainage", "strain_rate"), ("direction", "to_axial_strain")),
    "creep": (("duration",), ("drainage",)),
    "relaxation": (("duration",), ("drainage",)),
    "crs": (("strain_rate",), ("to_axial_strain", "to_sigma_v")),
    "load": (("sigma_v", "duration"), ("ramp_time",)),
    "expansion": (("strain_rate",), ("to_cavity_strain",)),
    "hold": (("duration",), ()),
    "unloading": (("strain_rate",), ("to_cavity_strain", "to_pressure")),
}
#: defaults: consolidation ramp (s), load ramp (s), expansion end (%)
CONSOLIDATION_DURATION = 86400.0
RAMP_TIME = 1.0
EXPANSION_STRAIN_PCT = 10.0
CHOICES = {"drainage": ("drained", "undrained"), "direction": ("compression", "extension")}
#: TOML field -> Stage field, for the fields whose names differ (strains in % -> fractions)
RENAMED = {"to_axial_strain": "to_strain", "to_cavity_strain": "to_strain"}


def programme_spec(ck, t, i, spec, model, file, name) -> TestSpec:
    """The TestSpec of the programme entry ``t`` (``tests[i]``) of a study of ``model`` (registry ``spec``)."""
    where = f"tests[{i}]"
    apparatus = ck.text(t["apparatus"], f"{where}.apparatus", tuple(STAGE_KINDS))
    if "type" in t:
        ck.fail(f"{where}.type", t["type"], "a test with an apparatus and [[tests.stages]] has no type (type is the "
                "one-stage shorthand)")
    inline = [k for k in INITIAL_FIELDS if k in t]
    ck.table(t, where, (*PROGRAMME_FIELDS[apparatus], *INITIAL_FIELDS), ("stages",))
    if "initial" in t and inline:
        ck.fail(f"{where}.{inline[0]}", t[inline[0]], "the initial state is given in [tests.initial]: give it there "
                "or in the test's table, not both")
    initial = initial_state(ck, t.get("initial", {k: t[k] for k in inline}),
                            f"{where}.initial" if "initial" in t else where, apparatus, spec, model)
    weight = ck.number(t.get("weight", 1.0), f"{where}.weight", positive=True)
    site = {k: ck.number(t[k], f"{where}.{k}", positive=k != "depth", non_negative=k == "depth")
            for k in ("permeability", "probe_radius", "depth") if k in t}
    if apparatus == "sbp":
        for k in ("permeability", "probe_radius"):
            if k not in site:
                raise StudyError(f"{ck.path}: {where}.{k} is missing (apparatus 'sbp' needs permeability (m/s) and "
                                 "probe_radius (m))")
        if model not in SBP_MODELS:
            ck.fail(f"{where}.apparatus", apparatus, f"the pressuremeter FE runs {' or '.join(SBP_MODELS)} here, "
                    f"not {model}")
    stages_in = t["stages"]
    if not isinstance(stages_in, list) or not stages_in:
        ck.fail(f"{where}.stages", stages_in, "expected one or more [[tests.stages]] tables")
    stages = tuple(stage(ck, s, f"{where}.stages[{k}]", k + 1, apparatus, initial)
                   for k, s in enumerate(stages_in))
    names = [s.name for s in stages]
    for k, n in enumerate(names):
        if names.index(n) != k:
            ck.fail(f"{where}.stages[{k}].name", n, "stage names must be unique within a test")
    if apparatus == "sbp":
        check_sbp_stages(ck, stages, where, name)
    check_ends(ck, stages, where)
    mirror = {"e0": initial.e0, "p0": initial.p0, "sigma_v0": initial.sigma_v0,
              "K0": None if initial.p0 is not None else initial.K0, "u0": initial.u0 if apparatus == "sbp" else None,
              "consolidation": None if apparatus != "triaxial" else ("isotropic" if initial.p0 is not None else "K0"),
              "strain_rate": stages[0].strain_rate if apparatus == "sbp" else None}
    return TestSpec(name=name, type="programme", file=file, where=f"{ck.path}: {where} ({name})", apparatus=apparatus,
                    initial=initial, stages=stages, weight=weight, **site, **mirror)


def initial_state(ck, t, where, apparatus, spec, model) -> InitialState:
    """The checked initial state of a programme (table ``t`` at ``where``)."""
    ck.table(t, where, INITIAL_FIELDS)
    v = {k: ck.number(x, f"{where}.{k}", positive=k != "u0", non_negative=k == "u0") for k, x in t.items()}
    need = {"triaxial": "p0 (isotropic) or sigma_v0 and K0", "oedometer": "sigma_v0 and K0",
            "sbp": "sigma_v0, K0 and u0"}[apparatus]
    if apparatus == "triaxial" and "p0" in v:
        for k in ("sigma_v0", "K0"):
            if k in v:
                ck.fail(f"{where}.{k}", t[k], "not used with p0 (an isotropic start): give p0, or sigma_v0 and K0")
    elif apparatus != "triaxial" and "p0" in v:
        ck.fail(f"{where}.p0", t["p0"], f"an {apparatus} test starts from sigma_v0 and K0, not p0")
    else:
        for k in ("sigma_v0", "K0") + (("u0",) if apparatus == "sbp" else ()):
            if k not in v:
                raise StudyError(f"{ck.path}: {where}.{k} is missing (apparatus {apparatus!r} starts from {need})")
    if "u0" in v and apparatus != "sbp":
        ck.fail(f"{where}.u0", t["u0"], "the in situ pore pressure is a field of an sbp test (laboratory stresses "
                "are effective)")
    if "e0" not in v and not spec.e0_parameter:
        raise StudyError(f"{ck.path}: {where}.e0 is missing: {model} needs the void ratio at the start of each test")
    given = [k for k in ("ocr", "preconsolidation") if k in v]
    if len(given) == 2:
        ck.fail(f"{where}.preconsolidation", t["preconsolidation"], "give ocr or preconsolidation, not both")
    if given:
        k = given[0]
        if apparatus == "sbp":
            ck.fail(f"{where}.{k}", t[k], "a per-test preconsolidation is supported for apparatus triaxial and "
                    "oedometer; the pressuremeter takes the model's parameter")
        if not set(PRECONSOLIDATION_PARAMETERS) & set(spec.parameters):
            ck.fail(f"{where}.{k}", t[k], f"{model} has no preconsolidation parameter (supported for models with "
                    f"{' or '.join(PRECONSOLIDATION_PARAMETERS)})")
        vertical = v.get("sigma_v0", v.get("p0"))
        if k == "ocr" and v[k] < 1.0:
            ck.fail(f"{where}.ocr", t[k], "must be >= 1 (preconsolidation / initial vertical effective stress)")
        if k == "preconsolidation" and v[k] < vertical:
            ck.fail(f"{where}.preconsolidation", t[k], f"must be >= the initial vertical effective stress "
                    f"{vertical:g} kPa")
    return InitialState(**v)


def stage(ck, s, where, number, apparatus, initial) -> Stage:
    """One checked stage table ``s`` at ``where`` (``number`` 1-based) of an ``apparatus`` programme."""
    ck.table(s, where, None, ("kind",))
    kind = s["kind"]
    if kind not in STAGE_KINDS[apparatus]:
        ck.fail(f"{where}.kind", kind, f"supported for apparatus {apparatus!r}: {', '.join(STAGE_KINDS[apparatus])}")
    required, optional = STAGE_FIELDS[kind]
    ck.table(s, where, ("kind", "name", *required, *optional), required)
    name = ck.text(s.get("name", f"{kind}{number}"), f"{where}.name")
    if "@" in name or name.strip().isdigit():
        ck.fail(f"{where}.name", name, "a stage name has no '@' and is not a number (the stage column takes both)")
    v = {}
    for k, x in s.items():
        w = f"{where}.{k}"
        if k in ("kind", "name"):
            continue
        if k in CHOICES:
            v[k] = ck.text(x, w, CHOICES[k])
        elif k == "strain_rate" and kind == "crs":
            v[k] = ck.number(x, w)
            if v[k] == 0:
                ck.fail(w, x, "must be != 0 (1/s, signed: > 0 loading, < 0 unloading)")
        elif k in ("to_axial_strain", "to_cavity_strain"):
            v[RENAMED[k]] = ck.number(x, w, positive=kind in ("shear", "expansion"),
                                      non_negative=kind == "unloading") / 100.0
            if abs(x) > 100.0:
                ck.fail(w, x, "a strain in % must be <= 100")
        else:
            v[k] = ck.number(x, w, positive=True)
    if kind in ("creep", "relaxation") and apparatus == "oedometer" and v.get("drainage") == "undrained":
        ck.fail(f"{where}.drainage", "undrained", f"an oedometer {kind} stage is drained (undrained {kind} is "
                "supported for apparatus 'triaxial')")
    if kind == "consolidation":
        consolidation_fields(ck, s, where, apparatus, v)
        v.setdefault("duration", CONSOLIDATION_DURATION)
    if kind == "load":
        v.setdefault("ramp_time", RAMP_TIME)
        if v["ramp_time"] >= v["duration"]:
            ck.fail(f"{where}.ramp_time", v["ramp_time"], f"must be < the stage's duration {v['duration']:g} s")
    if kind == "shear":
        v.setdefault("direction", "compression")
    if kind == "expansion":
        v.setdefault("to_strain", EXPANSION_STRAIN_PCT / 100.0)
    if kind in ("crs", "unloading"):
        ends = [k for k in ("to_axial_strain", "to_sigma_v", "to_cavity_strain", "to_pressure") if k in s]
        if len(ends) > 1:
            ck.fail(f"{where}.{ends[1]}", s[ends[1]], f"the stage ends at {ends[0]}: give one end")
        if kind == "unloading" and not ends:
            raise StudyError(f"{ck.path}: {where}.to_cavity_strain is missing (an unloading stage ends at "
                             "to_cavity_strain (%) or to_pressure (kPa))")
    abscissa = {"shear": "axial_strain", "crs": "axial_strain", "expansion": "cavity_strain",
                "unloading": "cavity_strain",
                "consolidation": "p" if "p" in v else "sigma_v"}.get(kind, "time")
    return Stage(kind, name, abscissa=abscissa, **v)


def consolidation_fields(ck, s, where, apparatus, v):
    """A consolidation stage's target: ``p`` (isotropic, triaxial) or ``sigma_v`` (with ``K0`` in a triaxial cell;
    an oedometer holds the radial strain at zero and takes no K0)."""
    if ("p" in v) == ("sigma_v" in v):
        raise StudyError(f"{ck.path}: {where}: a consolidation stage goes to p (isotropic, triaxial) or to sigma_v "
                         f"(kPa), one of them; got {sorted(k for k in ('p', 'sigma_v') if k in v) or 'neither'}")
    if apparatus == "oedometer":
        for k in ("p", "K0"):
            if k in v:
                ck.fail(f"{where}.{k}", s[k], "an oedometer consolidates to sigma_v with zero radial strain (no "
                        f"{k})")
    elif "p" in v and "K0" in v:
        ck.fail(f"{where}.K0", s["K0"], "an isotropic consolidation (p) has no K0; give sigma_v and K0")
    elif "sigma_v" in v and "K0" not in v:
        raise StudyError(f"{ck.path}: {where}.K0 is missing (a triaxial consolidation to sigma_v holds sigma'_h = "
                         "K0 sigma'_v)")


def check_ends(ck, stages, where):
    """A CRS stage whose end is a total axial strain moves in the direction of its rate when the strain at its
    start is known (the previous CRS stage's end, or the test start)."""
    start = 0.0
    for k, s in enumerate(stages):
        if s.kind == "crs" and s.to_strain is not None:
            if start is not None and (s.to_strain - start) * s.strain_rate <= 0:
                ck.fail(f"{where}.stages[{k}].to_axial_strain", 100 * s.to_strain, f"not reached at strain_rate "
                        f"{s.strain_rate:g} 1/s from the previous stage's end {100 * start:g} % (a negative rate "
                        "unloads)")
            start = s.to_strain
        elif s.kind not in ("relaxation",):
            start = None


def stage_times(spec) -> list:
    """[(start, end)] of each stage of a programme in s since the test start, None where it follows from the
    material's response (after a CRS stage to a stress, a consolidation's strain before a CRS to a strain, an
    unloading to a pressure); the last stage's end is infinite (recorded to its last record)."""
    out, t, strain, cavity = [], 0.0, 0.0, 0.0
    for k, s in enumerate(spec.stages):
        d = None
        if s.kind in ("consolidation", "creep", "relaxation", "load", "hold"):
            d = s.duration
        elif s.kind == "shear" and s.to_strain is not None:
            d = s.to_strain / s.strain_rate
        elif s.kind == "crs" and s.to_strain is not None and strain is not None:
            d = (s.to_strain - strain) / s.strain_rate
        elif s.kind in ("expansion", "unloading") and s.to_strain is not None and cavity is not None:
            d = abs(s.to_strain - cavity) / s.strain_rate
        strain = s.to_strain if s.kind == "crs" else (strain if s.kind == "relaxation" else None)
        cavity = s.to_strain if s.kind in ("expansion", "unloading") else (cavity if s.kind == "hold" else None)
        end = float("inf") if k == len(spec.stages) - 1 else (None if t is None or d is None else t + d)
        out.append((t, end))
        t = end
    return out
