"""What follows from the order of the stages (cases.study.stages.sequence): stage times, the strain carried from
stage to stage in a laboratory programme, and the pressuremeter programme's checks."""
from __future__ import annotations

import pytest

from cases.study.checks import Checker, StudyError
from cases.study.programme import InitialState, Stage, TestSpec
from cases.study.stages.sequence import check_sbp_stages, check_sequence, record_axes, stage_times


def programme(apparatus, *stages):
    return TestSpec(name="t", type="programme", apparatus=apparatus, initial=InitialState(sigma_v0=50.0, K0=0.5),
                    stages=stages)


def test_stage_times_follow_the_kinds():
    oed = programme("oedometer", Stage("consolidation", "c", sigma_v=100.0, duration=600.0),
                    Stage("crs", "up", strain_rate=1e-5, to_strain=0.1), Stage("relaxation", "r", duration=60.0),
                    Stage("crs", "down", strain_rate=-1e-5, to_strain=0.05), Stage("load", "l", duration=10.0))
    # the strain at the first crs start follows from the consolidation: its end and all later ones are unknown
    assert stage_times(oed) == [(0.0, 600.0), (600.0, None), (None, None), (None, None), (None, float("inf"))]
    sbp = programme("sbp", Stage("expansion", "e", strain_rate=1e-3, to_strain=0.05),
                    Stage("hold", "h", duration=60.0), Stage("unloading", "u", strain_rate=1e-3, to_strain=0.02),
                    Stage("unloading", "v", strain_rate=1e-3, to_pressure=100.0))
    assert stage_times(sbp) == [(0.0, 50.0), (50.0, 110.0), (110.0, 140.0), (140.0, float("inf"))]


def test_a_crs_stage_moves_in_the_direction_of_its_rate():
    ok = (Stage("crs", "up", strain_rate=1e-5, to_strain=0.1), Stage("relaxation", "r", duration=60.0),
          Stage("crs", "down", strain_rate=-1e-5, to_strain=0.05))
    check_sequence(Checker("study.toml"), ok, "tests[0]")
    bad = ok[:2] + (Stage("crs", "down", strain_rate=1e-5, to_strain=0.05),)
    with pytest.raises(StudyError, match=r"tests\[0\]\.stages\[2\]\.to_axial_strain = 5\.0: not reached"):
        check_sequence(Checker("study.toml"), bad, "tests[0]")
    after_creep = (ok[0], Stage("creep", "c", duration=60.0), bad[2])
    check_sequence(Checker("study.toml"), after_creep, "tests[0]")  # the strain after creep is not known


def test_a_pressuremeter_programme_opens_with_an_expansion():
    with pytest.raises(StudyError, match=r"stages\[0\]\.kind = 'hold': the first stage of a pressuremeter test is "
                                         r"an expansion \(test T, stage h\)"):
        check_sbp_stages(Checker("study.toml"), (Stage("hold", "h", duration=1.0),), "tests[0]", "T")
    with pytest.raises(StudyError, match=r"stages\[0\]\.kind = 'shear': supported for apparatus 'sbp': expansion, "
                                         r"hold, unloading"):
        check_sbp_stages(Checker("study.toml"), (Stage("shear", "s"),), "tests[0]", "T")
    with pytest.raises(StudyError, match=r"stages\[1\]\.abscissa = 'cavity_strain': a hold stage is recorded "
                                         r"against time"):
        check_sbp_stages(Checker("study.toml"), (Stage("expansion", "e", strain_rate=1e-3, to_strain=0.05),
                                                 Stage("hold", "h", duration=1.0, abscissa="cavity_strain")),
                         "tests[0]", "T")


def test_the_stages_of_one_shear_lie_end_to_end_on_its_axial_strain():
    """By hand: compression stages to 2 and 3 %, a third without an end (where the material says: its successor
    starts a new axis) and a fourth, then a reconsolidation (stress axis p) and two extension stages to 2 and 1 %:
    offsets 0, 2, 5 | 0 | - | 0, -2 (%); a time since the stage start lies on no shared axis."""
    triax = programme("triaxial",
                      Stage("consolidation", "c1", p=100.0, duration=600.0),
                      Stage("shear", "s1", drainage="undrained", strain_rate=1e-6, to_strain=0.02),
                      Stage("shear", "s2", drainage="undrained", strain_rate=1e-7, to_strain=0.03),
                      Stage("shear", "s3", drainage="undrained", strain_rate=1e-6),
                      Stage("shear", "s4", drainage="undrained", strain_rate=1e-6, to_strain=0.01),
                      Stage("consolidation", "c2", p=150.0, duration=600.0),
                      Stage("shear", "e1", drainage="undrained", direction="extension", strain_rate=1e-6,
                            to_strain=0.02),
                      Stage("shear", "e2", drainage="undrained", direction="extension", strain_rate=1e-7,
                            to_strain=0.01))
    axes = record_axes(triax)
    assert axes[0] == {"p": ("p", 0.0), "sigma_v": ("sigma_v", 0.0)} == axes[5]
    strain = [a["axial_strain"] for a in axes[1:5] + axes[6:]]
    assert [offset for _, offset in strain] == pytest.approx([0.0, 2.0, 5.0, 0.0, 0.0, -2.0])
    runs = [axis for axis, _ in strain]
    assert runs[0] == runs[1] == runs[2] and len({runs[0], runs[3], runs[4]}) == 3 and runs[4] == runs[5]
    assert all("time" not in a for a in axes)
    oed = programme("oedometer", Stage("crs", "up", strain_rate=1e-5, to_strain=0.1),
                    Stage("relaxation", "r", duration=60.0), Stage("crs", "down", strain_rate=-1e-5, to_strain=0.05))
    assert record_axes(oed) == [{"axial_strain": ("axial_strain", 0.0)}, {}, {"axial_strain": ("axial_strain", 0.0)}]
