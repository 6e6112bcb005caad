"""The load stage kind of an incremental oedometer (cases.study.stages.load): ramp default and check, description,
history and logging."""
from __future__ import annotations

from stage_tables import WHERE, read, refused

from cases.study.stages.load import RAMP_TIME, Load


def test_parsed_and_described():
    st = read("oedometer", kind="load", sigma_v=200.0, duration=86400.0)
    assert st.procedure is Load and st.ramp_time == RAMP_TIME and st.abscissa == "time"
    assert st.describe() == "load2: sigma'_v 200 kPa, ramp 1 s, 86400 s"
    assert Load.loading_phase(st, 100.0) == "loading" and Load.stress_target(st) == 200.0
    assert Load.ramped_hold and Load.adaptive_hold


def test_the_ramp_is_shorter_than_the_stage():
    refused("oedometer", f"{WHERE}.ramp_time = 100.0: must be < the stage's duration 100 s", kind="load",
            sigma_v=200.0, duration=100.0, ramp_time=100.0)
    refused("triaxial", f"{WHERE}.kind = 'load': supported for apparatus 'triaxial': consolidation, shear, creep, "
            "relaxation, crs", kind="load", sigma_v=200.0, duration=100.0)


def test_logging():
    st = read("oedometer", kind="load", sigma_v=200.0, duration=1e5, ramp_time=30.0)
    now = {"p": 50.0, "sigma_v": 100.0, "strain": 0.0, "cavity": 0.0}
    x_name, x, t, quantities = Load.logged(st, "oedometer", 5, now, {}, "")
    assert x_name == "time" and t is None and list(x[:3]) == [10.0, 20.0, 30.0] and len(x) == 8
    assert quantities == ("axial_strain",) and now == {"p": None, "sigma_v": 200.0, "strain": None, "cavity": 0.0}
