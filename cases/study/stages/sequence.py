"""What follows from the order of a programme's stages: the stage times (:func:`stage_times`), the range of each
stage's records (:func:`stage_spans`), where each stage's records lie on its test's axes (:func:`record_axes`), the
checks that span stages of a laboratory programme (:func:`check_sequence`) and of a pressuremeter programme
(:func:`check_sbp_stages`). Units: s, strains as fractions (% in the messages, as in the study file), 1/s.
"""
from __future__ import annotations

from cases.study.stages import KINDS

__all__ = ["stage_times", "stage_spans", "record_axes", "check_sequence", "check_sbp_stages"]

#: abscissae whose values are the test's own whatever the stage: an effective stress (kPa) or a cavity strain (%)
TEST_ABSCISSAE = ("p", "sigma_v", "cavity_strain")


def stage_times(spec) -> list:
    """[(start, end)] of each stage of a programme in s since the test start, None where it follows from the
    material's response (after a CRS stage to a stress, a consolidation's strain before a CRS to a strain, an
    unloading to a pressure); the last stage's end is infinite (recorded to its last record)."""
    out, t, strain, cavity = [], 0.0, 0.0, 0.0
    for k, s in enumerate(spec.stages):
        kind = s.procedure
        d = kind.elapsed(s, strain, cavity)
        strain, cavity = kind.strain_after(s, strain), kind.cavity_after(s, cavity)
        end = float("inf") if k == len(spec.stages) - 1 else (None if t is None or d is None else t + d)
        out.append((t, end))
        t = end
    return out


def stage_spans(spec) -> list:
    """[{abscissa: (start, end, what)}] of each stage of a programme: the values its records may take against an
    abscissa whose two ends are known before any solve, in the records' units, and the words naming the end (e.g.
    "to_axial_strain 10 %"). time: (0, duration) s since the stage start; axial_strain: a shear stage's own strain
    magnitude (0, to_axial_strain) %, a crs stage's total strain from its start to to_axial_strain %; cavity_strain:
    from the stage's start to its to_cavity_strain %; p, sigma_v: a consolidation from the effective stress at its
    start (the initial state, or the target of a consolidation or load stage just before it) to its target, kPa. An
    abscissa whose end follows from the material's response is absent."""
    out, strain, cavity = [], 0.0, 0.0
    stress = {"p": spec.initial.p, "sigma_v": spec.initial.vertical} if spec.initial is not None else {}
    for s in spec.stages:
        kind = s.procedure
        spans = {}
        duration = kind.elapsed(s, strain, cavity)
        if duration is not None:
            spans["time"] = (0.0, duration, f"its duration {duration:g} s")
        if s.to_strain is not None:
            end = 100.0 * s.to_strain
            if kind.shearing:
                spans["axial_strain"] = (0.0, abs(end), f"to_axial_strain {abs(end):g} %")
            elif kind.control_variable(s) == "axial_strain" and strain is not None:
                spans["axial_strain"] = (100.0 * strain, end, f"to_axial_strain {end:g} %")
            elif kind.control_variable(s) == "cavity_strain" and cavity is not None:
                spans["cavity_strain"] = (100.0 * cavity, end, f"to_cavity_strain {end:g} %")
        after = {}
        if kind.consolidates or kind.stress_target(s) is not None:
            target = kind.stress_target(s)
            if s.p is not None:
                after = {"p": target, "sigma_v": target}
            elif s.K0 is not None:
                after = {"sigma_v": target, "p": target * (1.0 + 2.0 * s.K0) / 3.0}
            else:
                after = {"sigma_v": target}
            for q in ("p", "sigma_v"):
                if kind.consolidates and q in after and q in stress:
                    spans[q] = (stress[q], after[q], f"its target {q} {after[q]:g} kPa")
        out.append(spans)
        strain, cavity, stress = kind.strain_after(s, strain), kind.cavity_after(s, cavity), after
    return out


def record_axes(spec) -> list:
    """[{abscissa: (axis, offset)}] of each stage of a programme: a record's abscissa plus ``offset`` (the records'
    units) lies on one axis, named ``axis``, with the records of every other stage on that axis, so that the stages of
    one test can be drawn as one curve. An effective stress (p, sigma_v), a cavity strain and a crs stage's total axial
    strain are the test's own (offset 0). A shear stage's own axial strain (%, zeroed at its start) continues that of
    the shear stages just before it: the offset is their strains, signed by their direction; the axis ends at any other
    stage and at a shear stage whose end follows from the material (no ``to_axial_strain``). The time since a stage's
    start lies on no shared axis (absent)."""
    out, axis, offset = [], None, 0.0
    for k, s in enumerate(spec.stages):
        kind = s.procedure
        axes = {a: (a, 0.0) for a in kind.abscissae if a in TEST_ABSCISSAE}
        if kind.shearing:
            if axis is None:
                axis, offset = f"axial_strain of the shear from stage {k}", 0.0
            axes["axial_strain"] = (axis, offset)
            if s.to_strain is None:
                axis = None
            else:
                offset += (-100.0 if s.direction == "extension" else 100.0) * abs(s.to_strain)
        else:
            axis = None
            if "axial_strain" in kind.abscissae:
                axes["axial_strain"] = ("axial_strain", 0.0)
        out.append(axes)
    return out


def check_sequence(ck, stages, where: str):
    """Check each stage of a laboratory programme against the total axial strain at its start, where it is known
    (the previous stage's end, or the test start): ``StageKind.check_from``. ``where`` names the test entry."""
    strain = 0.0
    for k, s in enumerate(stages):
        s.procedure.check_from(ck, s, f"{where}.stages[{k}]", strain)
        strain = s.procedure.strain_after(s, strain)


def check_sbp_stages(ck, stages, where: str, test: str = ""):
    """Check the ``stages`` of the SBP programme of test ``test`` before any solve; ``ck``
    (cases.study.checks.Checker) names the study file, ``where`` the test entry (``tests[2]``). A first
    expansion, then any of the kinds of apparatus sbp, each recorded against one of its abscissae and checked from
    the cavity strain at its start (``check_cavity`` of :mod:`cases.study.stages.pressuremeter`). The StudyError
    names the file, the test, the stage, the field (as in the file: ``to_cavity_strain`` in %) and the value."""
    kinds = KINDS["sbp"]
    strain = 0.0
    for k, stage in enumerate(stages):
        at = f"{where}.stages[{k}]"
        named = f" (test {test}, stage {stage.name})" if test else f" (stage {stage.name})"

        def fail(field, value, why):
            ck.fail(f"{at}.{field}", value, why + named)

        if stage.kind not in tuple(kinds):
            fail("kind", stage.kind, f"supported for apparatus 'sbp': {', '.join(kinds)}")
        kind = kinds[stage.kind]
        if k == 0 and not kind.opens_pressuremeter_test:
            fail("kind", stage.kind, "the first stage of a pressuremeter test is an expansion")
        if stage.abscissa not in kind.abscissae:
            fail("abscissa", stage.abscissa, f"a {stage.kind} stage is recorded against " + " or ".join(kind.abscissae))
        strain = kind.check_cavity(stage, strain, k == len(stages) - 1, fail)
