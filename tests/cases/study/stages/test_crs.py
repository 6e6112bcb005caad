"""The constant-rate-of-strain stage kind (cases.study.stages.crs): the signed rate, one end, the direction check
from the strain at its start, description and logging."""
from __future__ import annotations

import pytest
from stage_tables import WHERE, read, refused

from cases.study.checks import Checker, StudyError
from cases.study.stages.base import LoggingError
from cases.study.stages.crs import ConstantRateOfStrain


def test_signed_rate_and_ends():
    unload = read("oedometer", kind="crs", strain_rate=-1e-6, to_axial_strain=2.0)
    to_stress = read("oedometer", kind="crs", strain_rate=1e-6, to_sigma_v=400.0)
    assert unload.procedure is ConstantRateOfStrain and unload.to_strain == 0.02
    assert unload.describe() == "crs2: -1e-06 1/s to 2 %" and to_stress.describe() == "crs2: 1e-06 1/s to 400 kPa"
    assert ConstantRateOfStrain.continues_to_stress(to_stress) and not ConstantRateOfStrain.continues_to_stress(unload)
    assert ConstantRateOfStrain.loading_phase(unload, 100.0) == "unloading"
    assert ConstantRateOfStrain.elapsed(unload, 0.05, None) == pytest.approx(3e4)
    assert ConstantRateOfStrain.elapsed(unload, None, None) is None


def test_refusals():
    refused("oedometer", f"{WHERE}.strain_rate = 0: must be != 0 (1/s, signed: > 0 loading, < 0 unloading)",
            kind="crs", strain_rate=0)
    refused("oedometer", f"{WHERE}.to_sigma_v = 400.0: the stage ends at to_axial_strain: give one end", kind="crs",
            strain_rate=1e-6, to_axial_strain=5.0, to_sigma_v=400.0)
    st = read("oedometer", kind="crs", strain_rate=-1e-6, to_axial_strain=8.0)
    with pytest.raises(StudyError, match=r"tests\[0\]\.stages\[3\]\.to_axial_strain = 8\.0: not reached at "
                                         r"strain_rate -1e-06 1/s from the previous stage's end 5 %"):
        ConstantRateOfStrain.check_from(Checker("study.toml"), st, "tests[0].stages[3]", 0.05)
    ConstantRateOfStrain.check_from(Checker("study.toml"), st, "tests[0].stages[3]", None)


def test_logging_needs_a_known_start():
    st = read("oedometer", kind="crs", strain_rate=1e-6, to_axial_strain=10.0)
    now = {"p": None, "sigma_v": None, "strain": 4.0, "cavity": 0.0}
    x_name, x, t, quantities = ConstantRateOfStrain.logged(st, "oedometer", 3, now, {}, "")
    assert x_name == "axial_strain" and list(x) == [6.0, 8.0, 10.0] and t[-1] == pytest.approx(6e4)
    assert quantities == ("sigma_v",) and now["strain"] == 10.0
    with pytest.raises(LoggingError, match="here: synthetic records of a crs stage need to_axial_strain"):
        ConstantRateOfStrain.logged(st, "oedometer", 3, {**now, "strain": None}, {}, "here")


def test_a_triaxial_cell_runs_a_crs_stage_as_a_k0_consolidation_recording_the_radial_stress():
    st = read("triaxial", kind="crs", strain_rate=1e-6, to_axial_strain=10.0)
    assert ConstantRateOfStrain.controls["triaxial"].all()  # every strain controlled: the radial strain held at 0
    now = {"p": None, "sigma_v": None, "strain": 0.0, "cavity": 0.0}
    assert ConstantRateOfStrain.logged(st, "triaxial", 2, now, {}, "")[3] == ("sigma_v", "sigma_r")
    assert "volumetric_strain" in ConstantRateOfStrain.held_quantities(st)  # equal to the axial strain
