"""The ``[[tests]]`` entries of a study file: the fields each flat test type takes, checked into a
:class:`~cases.study.programme.TestSpec` (a programme entry, ``apparatus`` with ``[[tests.stages]]``, is read by
:mod:`cases.study.reading.staged_tests`)."""
from __future__ import annotations

from pathlib import Path

from cases.study.checks import StudyError
from cases.study.programme import ROLES, TEST_TYPES, TestSpec, programme_of
from cases.study.reading.records import COLUMNS, CURVE_OF, DRAINED_ONLY, UNDRAINED_ONLY
from cases.study.reading.staged_tests import programme_spec
from constitutive.registry import SBP_MODELS

__all__ = ["TEST_FIELDS", "test_spec", "test_where"]


#: fields of a [[tests]] entry per type: required, optional (name, file, type are common; consolidation-dependent
#: fields of the triaxial are checked separately)
TEST_FIELDS = {
    "triaxial": (("drainage", "direction", "consolidation", "strain_rate"),
                 ("p0", "sigma_v0", "K0", "e0", "substeps", "curves")),
    "oedometer_crs": (("sigma_v0", "K0", "strain_rate"), ("e0", "substeps", "curves")),
    "oedometer_creep": (("sigma_v0", "K0", "stage_stress", "stage_duration"), ("e0", "load_time", "n_times", "curves")),
    "sbp": (("sigma_v0", "K0", "u0", "permeability", "probe_radius", "strain_rate"), ("depth", "e0", "curves")),
}
#: number fields: > 0, >= 0 (u0, depth) or an integer >= minimum
POSITIVE = ("p0", "sigma_v0", "K0", "e0", "strain_rate", "permeability", "probe_radius", "stage_duration", "load_time",
            "weight")
NON_NEGATIVE = ("u0", "depth")
INTEGERS = {"substeps": 1, "n_times": 2}
CHOICES = {"drainage": ("drained", "undrained"), "direction": ("compression", "extension"),
           "consolidation": ("isotropic", "K0")}


def test_where(t, i) -> str:
    """How an error message names the entry ``t`` of ``[[tests]]`` (0-based ``i``): ``tests['CIU_OCR2']`` by its
    name (given, or the stem of its file, the name it then takes); ``tests[i]`` only when it has neither."""
    if isinstance(t, dict):
        name = t.get("name", Path(t["file"]).stem if isinstance(t.get("file"), str) else None)
        if isinstance(name, str) and name.strip():
            return f"tests[{name!r}]"
    return f"tests[{i}]"


def test_spec(ck, t, i, spec, model, check_files) -> TestSpec:
    """The TestSpec of the entry ``t`` (``tests[i]``): a flat type (``type`` and its conditions, expanded by
    :func:`~cases.study.programme.programme_of`) or a programme (``apparatus`` and ``[[tests.stages]]``,
    :mod:`cases.study.reading.staged_tests`)."""
    where = test_where(t, i)
    ck.table(t, where, None, ("file",) if "apparatus" in t else ("type", "file"))
    file = Path(ck.text(t["file"], f"{where}.file"))
    file = file if file.is_absolute() else ck.path.parent / file
    if check_files and not file.is_file():
        ck.fail(f"{where}.file", t["file"], f"data file not found ({file})")
    name = ck.text(t.get("name", file.stem), f"{where}.name")
    if "apparatus" in t:
        return programme_spec(ck, t, where, spec, model, file, name)
    kind = ck.text(t["type"], f"{where}.type", TEST_TYPES)
    for k in ("stages", "initial", "ocr", "preconsolidation"):
        if k in t:
            ck.fail(f"{where}.{k}", t[k], f"{k} is a field of a stage programme (apparatus = \"triaxial\" | "
                    "\"oedometer\" | \"sbp\" with [[tests.stages]]), not of the one-stage shorthand type = "
                    f"{kind!r}")
    required, optional = TEST_FIELDS[kind]
    ck.table(t, where, ("name", "type", "file", "weight", "role", *required, *optional), ("type", "file", *required))
    values = {}
    for k, v in t.items():
        w = f"{where}.{k}"
        if k in CHOICES:
            values[k] = ck.text(v, w, CHOICES[k])
        elif k == "role":
            values[k] = ck.text(v, w, ROLES)
        elif k in POSITIVE or k in NON_NEGATIVE:
            values[k] = ck.number(v, w, positive=k in POSITIVE, non_negative=k in NON_NEGATIVE)
        elif k in INTEGERS:
            values[k] = ck.integer(v, w, INTEGERS[k])
        elif k == "stage_stress":
            if not isinstance(v, list) or not v:
                ck.fail(w, v, "expected a list of vertical effective stresses (kPa), one per load stage")
            values[k] = tuple(ck.number(x, w, positive=True) for x in v)
        elif k == "curves":
            allowed = [CURVE_OF.get(q, q) for q, (_, role) in COLUMNS[kind].items() if "curve" in role]
            if not isinstance(v, list) or not v or any(c not in allowed for c in v):
                ck.fail(w, v, f"expected a non-empty list of curve names among {', '.join(allowed)}")
            values[k] = tuple(v)
    if kind == "triaxial":
        if values["consolidation"] == "isotropic":
            need, forbid = ("p0",), ("sigma_v0", "K0")
        else:
            need, forbid = ("sigma_v0", "K0"), ("p0",)
        for k in need:
            if k not in values:
                raise StudyError(f"{ck.path}: {where}.{k} is missing (consolidation = "
                                 f"{values['consolidation']!r} needs {' and '.join(need)})")
        for k in forbid:
            if k in values:
                ck.fail(f"{where}.{k}", t[k], f"not used with consolidation = {values['consolidation']!r} (give "
                        f"{' and '.join(need)})")
        if "curves" in values:
            wrong = DRAINED_ONLY if values["drainage"] == "undrained" else UNDRAINED_ONLY
            for c in values["curves"]:
                if c in wrong:
                    ck.fail(f"{where}.curves", t["curves"], f"curve {c!r} is not recorded in a "
                            f"{values['drainage']} test")
    if kind == "oedometer_creep" and values.get("load_time", 1.0) >= values["stage_duration"]:
        ck.fail(f"{where}.load_time", values.get("load_time", 1.0), f"must be < stage_duration "
                f"{values['stage_duration']:g} s")
    if kind == "sbp" and model not in SBP_MODELS:
        ck.fail(f"{where}.type", kind, f"the pressuremeter FE runs {' or '.join(SBP_MODELS)} here, not {model}")
    if spec.e0_parameter and "e0" in values:
        ck.fail(f"{where}.e0", t["e0"], f"e0 is a parameter of {model}: set it in [model.fixed] (or [model.free]); a "
                "stage programme's initial state (apparatus = ...) may give it per test")
    if not spec.e0_parameter and "e0" not in values:
        raise StudyError(f"{ck.path}: {where}.e0 is missing: {model} needs the void ratio at the start of each test")
    return programme_of(TestSpec(name=name, type=kind, file=file, where=f"{ck.path}: {where}", **values))
