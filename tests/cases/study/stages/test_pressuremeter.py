"""The pressuremeter stage kinds (cases.study.stages.pressuremeter): expansion, hold and unloading parsed, checked
from the cavity strain at their start, described, logged, and their FE loading phases."""
from __future__ import annotations

import numpy as np
import pytest
from stage_tables import WHERE, read, refused

from cases.study.stages.base import LoggingError
from cases.study.stages.pressuremeter import (
    HOLD_FIRST_STEP,
    MAX_CAVITY_STRAIN,
    SBP_QUANTITIES,
    Expansion,
    Hold,
    LoadingPhase,
    Unloading,
)


def test_parsed_with_defaults_and_described():
    exp = read("sbp", kind="expansion", strain_rate=1e-3)
    hold = read("sbp", kind="hold", duration=600.0)
    unl = read("sbp", kind="unloading", strain_rate=1e-3, to_pressure=150.0)
    assert (exp.procedure, hold.procedure, unl.procedure) == (Expansion, Hold, Unloading)
    assert exp.to_strain == MAX_CAVITY_STRAIN and exp.abscissa == "cavity_strain" and hold.abscissa == "time"
    assert exp.describe() == "expansion2: 0.001 1/s to 10 %"
    assert hold.describe() == "hold2: cavity strain held 600 s"
    assert unl.describe() == "unloading2: 0.001 1/s to 150 kPa"
    assert Unloading.loading_phase(unl, 0.0) == "unloading" and Hold.loading_phase(hold, 0.0) == "hold"


def test_refusals_while_reading():
    refused("sbp", f"{WHERE}.to_cavity_strain is missing (an unloading stage ends at to_cavity_strain (%) or "
            "to_pressure (kPa))", kind="unloading", strain_rate=1e-3)
    refused("sbp", f"{WHERE}.to_pressure = 100.0: the stage ends at to_cavity_strain: give one end", kind="unloading",
            strain_rate=1e-3, to_cavity_strain=2.0, to_pressure=100.0)
    refused("sbp", f"{WHERE}.to_cavity_strain = -1.0: must be >= 0", kind="unloading", strain_rate=1e-3,
            to_cavity_strain=-1.0)


def test_checked_from_the_cavity_strain_at_the_start():
    def fail(field, value, why):
        raise ValueError(f"{field} = {value!r}: {why}")

    exp = read("sbp", kind="expansion", strain_rate=1e-3, to_cavity_strain=5.0)
    assert Expansion.check_cavity(exp, 0.0, False, fail) == 0.05
    with pytest.raises(ValueError, match="an expansion goes above the current cavity strain 6 %"):
        Expansion.check_cavity(exp, 0.06, False, fail)
    unl = read("sbp", kind="unloading", strain_rate=1e-3, to_pressure=150.0)
    assert Unloading.check_cavity(unl, 0.05, True, fail) == 0.05
    with pytest.raises(ValueError, match="supported as the last stage only"):
        Unloading.check_cavity(unl, 0.05, False, fail)
    hold = read("sbp", kind="hold", duration=60.0)
    assert Hold.check_cavity(hold, 0.05, False, fail) == 0.05


def test_loading_phases_of_the_fe():
    exp = read("sbp", kind="expansion", strain_rate=1e-3, to_cavity_strain=5.0)
    assert Expansion.fe_phase(exp, 0.0, 40, np.zeros(0)) == LoadingPhase(50.0, 0.05, 20)
    hold = read("sbp", kind="hold", duration=600.0)
    assert Hold.fe_phase(hold, 0.05, 20, np.zeros(0)) == LoadingPhase(600.0, 0.05, 20, 1.0 / HOLD_FIRST_STEP)
    assert Hold.fe_phase(hold, 0.05, 20, np.array([0.0, 0.01, 1.0])).growth_ratio == pytest.approx(6e4)
    unl = read("sbp", kind="unloading", strain_rate=1e-3, to_pressure=150.0)
    assert Unloading.fe_phase(unl, 0.05, 40, np.zeros(0)) is None
    assert Unloading.fe_phase(unl, 0.05, 40, np.array([4.0, 3.0])).cavity_strain == pytest.approx(0.03)


def test_logging():
    unl = read("sbp", kind="unloading", strain_rate=1e-3, to_cavity_strain=2.0)
    now = {"p": None, "sigma_v": None, "strain": 0.0, "cavity": 5.0}
    x_name, x, t, quantities = Unloading.logged(unl, "sbp", 3, now, {}, "")
    assert x_name == "cavity_strain" and list(x) == [4.0, 3.0, 2.0] and t[-1] == pytest.approx(30.0)
    assert quantities == SBP_QUANTITIES and now["cavity"] == 2.0
    hold = read("sbp", kind="hold", duration=600.0)
    assert Hold.logged(hold, "sbp", 4, now, {}, "")[1][0] == pytest.approx(0.1) and now["cavity"] == 2.0
    to_pressure = read("sbp", kind="unloading", strain_rate=1e-3, to_pressure=150.0)
    with pytest.raises(LoggingError, match="synthetic records of an unloading need to_cavity_strain"):
        Unloading.logged(to_pressure, "sbp", 3, now, {}, "")
