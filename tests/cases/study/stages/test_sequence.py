"""What follows from the order of the stages (cases.study.stages.sequence): stage times, the strain carried from
stage to stage in a laboratory programme, and the pressuremeter programme's checks."""
from __future__ import annotations

import pytest

from cases.study.checks import Checker, StudyError
from cases.study.programme import InitialState, Stage, TestSpec
from cases.study.stages.sequence import check_sbp_stages, check_sequence, stage_times


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
