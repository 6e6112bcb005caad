"""The laboratory holds (cases.study.stages.lab_holds): creep and relaxation, their checks, descriptions, records
and logging plans per apparatus."""
from __future__ import annotations

from stage_tables import WHERE, read, refused

from cases.study.stages.base import OEDOMETER_STRAIN, OEDOMETER_STRESS
from cases.study.stages.lab_holds import Creep, Relaxation


def test_creep_and_relaxation_are_parsed_and_described():
    creep = read("triaxial", kind="creep", duration=3600.0, drainage="undrained")
    relax = read("oedometer", kind="relaxation", duration=600.0)
    assert creep.procedure is Creep and relax.procedure is Relaxation
    assert creep.describe() == "creep2: undrained, stresses held 3600 s"
    assert relax.describe() == "relaxation2: drained, strain held 600 s"
    assert creep.abscissa == relax.abscissa == "time"
    assert Creep.controls["oedometer"] is OEDOMETER_STRESS and Relaxation.controls["oedometer"] is OEDOMETER_STRAIN


def test_an_oedometer_hold_is_drained():
    for kind in ("creep", "relaxation"):
        refused("oedometer", f"{WHERE}.drainage = 'undrained': an oedometer {kind} stage is drained (undrained "
                f"{kind} is supported for apparatus 'triaxial')", kind=kind, duration=10.0, drainage="undrained")
    refused("triaxial", f"{WHERE}.duration is missing", kind="creep")


def test_records_logging_and_history():
    creep = read("triaxial", kind="creep", duration=1e4)
    relax = read("triaxial", kind="relaxation", duration=1e4, drainage="undrained")
    assert "p" in Creep.held_quantities(creep) and "q" in Creep.held_quantities(creep)
    assert Relaxation.held_quantities(relax) == ("axial_strain", "volumetric_strain", "void_ratio")
    now = {"p": 100.0, "sigma_v": 100.0, "strain": 1.0, "cavity": 0.0}
    x_name, x, t, quantities = Relaxation.logged(relax, "triaxial", 6, now, {}, "")
    assert x_name == "time" and t is None and x[0] == 1.0 and x[-1] == 1e4
    assert quantities == ("q", "excess_pore_pressure") and now["strain"] == 1.0 and now["p"] is None
    assert Creep.logged(creep, "oedometer", 6, now, {}, "")[3] == ("axial_strain",) and now["strain"] is None
    assert Creep.loading_phase(creep, 100.0) == Relaxation.loading_phase(relax, 100.0) == "hold"
    assert Relaxation.strain_after(relax, 0.02) == 0.02 and Creep.strain_after(creep, 0.02) is None
