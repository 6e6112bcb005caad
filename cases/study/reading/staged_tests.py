"""The programme form of a ``[[tests]]`` entry: ``apparatus``, the specimen's initial state (``[tests.initial]`` or
the same fields in the test's table) and its ``[[tests.stages]]`` in order, checked into a
:class:`~cases.study.programme.TestSpec` with ``type = "programme"``.

Every field is checked before any solve; a message names the file, ``tests['NAME'].stages[k].field``, the value and what
is supported (for the apparatus, for the stage kind). Units: kPa, s, 1/s; strains in % in the file (fractions in the
record); compression positive.
"""
from __future__ import annotations

from dataclasses import replace

from cases.study.checks import StudyError, did_you_mean
from cases.study.programme import ROLES, InitialState, Stage, TestSpec
from cases.study.reading.stage_records import COLUMNS, CURVE_OF
from cases.study.stages import KINDS
from cases.study.stages.sequence import check_sbp_stages, check_sequence, stage_spans
from constitutive.registry import SBP_MODELS

__all__ = ["PROGRAMME_FIELDS", "INITIAL_FIELDS", "STAGE_FIELDS", "programme_spec", "chosen_curves",
           "PRECONSOLIDATION_PARAMETERS"]

#: test-level fields of a programme entry besides the initial state (per apparatus)
PROGRAMME_FIELDS = {"triaxial": ("name", "file", "apparatus", "weight", "role", "initial", "stages"),
                    "oedometer": ("name", "file", "apparatus", "weight", "role", "initial", "stages"),
                    "sbp": ("name", "file", "apparatus", "weight", "role", "initial", "stages", "permeability",
                            "probe_radius", "depth")}
INITIAL_FIELDS = ("e0", "p0", "sigma_v0", "K0", "ocr", "preconsolidation", "u0")
#: the fields every stage table may have besides its kind's own
STAGE_FIELDS = ("kind", "name", "abscissa", "curves", "e_end")
#: the model parameters a per-test ``ocr`` / ``preconsolidation`` replaces
PRECONSOLIDATION_PARAMETERS = ("ocr", "pc0", "sigma_p0")


def programme_spec(ck, t, where, spec, model, file, name) -> TestSpec:
    """The TestSpec of the programme entry ``t`` (named ``where`` in messages, ``tests['NAME']``) of a study of
    ``model`` (registry ``spec``)."""
    apparatus = ck.text(t["apparatus"], f"{where}.apparatus", tuple(KINDS))
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
    role = ck.text(t.get("role", "calibrate"), f"{where}.role", ROLES)
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
    stages = tuple(stage(ck, s, f"{where}.stages[{k}]", k + 1, apparatus)
                   for k, s in enumerate(stages_in))
    names = [s.name for s in stages]
    for k, n in enumerate(names):
        if names.index(n) != k:
            ck.fail(f"{where}.stages[{k}].name", n, "stage names must be unique within a test")
    if apparatus == "sbp":
        check_sbp_stages(ck, stages, where, name)
    check_sequence(ck, stages, where)
    measured_void_ratio(ck, where, initial, stages, apparatus, spec, model)
    mirror = {"e0": initial.e0, "p0": initial.p0, "sigma_v0": initial.sigma_v0,
              "K0": None if initial.p0 is not None else initial.K0, "u0": initial.u0 if apparatus == "sbp" else None,
              "consolidation": None if apparatus != "triaxial" else ("isotropic" if initial.p0 is not None else "K0"),
              "strain_rate": stages[0].strain_rate if apparatus == "sbp" else None}
    return TestSpec(name=name, type="programme", file=file, where=f"{ck.path}: {where}", apparatus=apparatus,
                    initial=initial, stages=stages, weight=weight, role=role, **site, **mirror)


def measured_void_ratio(ck, where, initial, stages, apparatus, spec, model):
    """The void ratio of a laboratory programme: ``e0`` at its start or one stage's ``e_end`` (where it was measured,
    e.g. at the end of consolidation), not both; a stage's ``e_end`` needs the stage's duration and its end in its
    abscissa to be known before any solve (:func:`cases.study.stages.sequence.stage_spans`). ``e0`` may be left out
    where it is a parameter of the ``model`` (registry ``spec``)."""
    measured = [k for k, s in enumerate(stages) if s.e_end is not None]
    if len(measured) > 1:
        k = measured[1]
        ck.fail(f"{where}.stages[{k}].e_end", stages[k].e_end, f"the void ratio is already given at the end of stage "
                f"{stages[measured[0]].name!r}: give it at one stage")
    if measured:
        k = measured[0]
        at = f"{where}.stages[{k}].e_end"
        if initial.e0 is not None:
            ck.fail(at, stages[k].e_end, "the initial state gives e0 as well: give the void ratio at the start (e0) "
                    "or where it was measured (a stage's e_end), not both")
        if apparatus == "sbp":
            ck.fail(at, stages[k].e_end, "a pressuremeter test takes e0 (or the model's parameter), not a stage's "
                    "e_end")
        spans = stage_spans(TestSpec(name="", type="programme", initial=initial, stages=stages))[k]
        if "time" not in spans or stages[k].abscissa not in spans:
            ck.fail(at, stages[k].e_end, f"the end of stage {stages[k].name!r} follows from the material's response: "
                    "the void ratio at its end cannot set the specimen's start; give it at a stage whose duration "
                    f"and end in {stages[k].abscissa} are known")
    elif initial.e0 is None and not spec.e0_parameter:
        raise StudyError(f"{ck.path}: {where}.e0 is missing: {model} needs the void ratio at the start of each test "
                         "(e0) or where it was measured (a stage's e_end)")


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


def stage(ck, s, where, number, apparatus) -> Stage:
    """One checked stage table ``s`` at ``where`` (``number`` 1-based) of an ``apparatus`` programme: its fields
    and checks are its kind's (:mod:`cases.study.stages`)."""
    ck.table(s, where, None, ("kind",))
    kind_name, kinds = s["kind"], KINDS[apparatus]
    if kind_name not in tuple(kinds):
        ck.fail(f"{where}.kind", kind_name, f"supported for apparatus {apparatus!r}: {', '.join(kinds)}")
    kind = kinds[kind_name]
    ck.table(s, where, (*STAGE_FIELDS, *kind.required, *kind.optional), kind.required)
    name = ck.text(s.get("name", f"{kind_name}{number}"), f"{where}.name")
    if "@" in name or name.strip().isdigit():
        ck.fail(f"{where}.name", name, "a stage name has no '@' and is not a number (the stage column takes both)")
    v = dict(kind.read_value(ck, k, x, f"{where}.{k}") for k, x in s.items() if k not in STAGE_FIELDS)
    kind.check(ck, s, where, apparatus, v)
    chosen = ck.text(s["abscissa"], f"{where}.abscissa", kind.abscissae) if "abscissa" in s else None
    e_end = ck.number(s["e_end"], f"{where}.e_end", positive=True) if "e_end" in s else None
    out = Stage(kind_name, name, abscissa=chosen or kind.abscissa_of(v), chosen_abscissa=chosen, e_end=e_end, **v)
    if "curves" in s:
        out = replace(out, chosen_curves=chosen_curves(ck, s["curves"], f"{where}.curves", out, apparatus))
    return out


def chosen_curves(ck, value, where, stage, apparatus) -> tuple:
    """The curve names of a stage's ``curves`` list (a CSV quantity such as ``sigma_v`` gives its curve name,
    ``axial_stress``): each a recorded quantity of the apparatus that the stage neither controls nor holds, once."""
    names = {q: CURVE_OF.get(q, q) for q in COLUMNS[apparatus] if q not in ("time", "stage_time")}
    if not isinstance(value, list) or not value:
        ck.fail(where, value, f"expected a non-empty list of curve names among {', '.join(names.values())}")
    held = set(stage.procedure.held_quantities(stage)) | {stage.abscissa}
    out = []
    for c in value:
        if not isinstance(c, str) or (c not in names and c not in names.values()):
            ck.fail(where, value, f"{c!r} is not a curve of an {apparatus} programme; "
                    f"{did_you_mean(c, [*names.values(), *names])}expected among {', '.join(names.values())}")
        quantity = c if c in names else next(q for q, n in names.items() if n == c)
        if quantity in held:
            ck.fail(where, value, f"{c!r} is not a curve of this {stage.drainage} {stage.kind} stage (recorded "
                    f"against {stage.abscissa}; it controls or holds {', '.join(sorted(held))})")
        if names[quantity] in out:
            ck.fail(where, value, f"{c!r} is given twice")
        out.append(names[quantity])
    return tuple(out)
