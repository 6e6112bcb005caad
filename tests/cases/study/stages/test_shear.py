"""The shear stage kind (cases.study.stages.shear): fields, checks, description, records and logging."""
from __future__ import annotations

import numpy as np
from stage_tables import WHERE, read, refused

from cases.study.stages.shear import SHEAR_STRAIN_PCT, Shear


def test_parsed_with_its_defaults():
    st = read("triaxial", kind="shear", drainage="undrained", strain_rate=1e-5, to_axial_strain=12.0)
    assert st.procedure is Shear and (st.direction, st.to_strain, st.abscissa) == ("compression", 0.12,
                                                                                    "axial_strain")
    assert st.describe() == "shear2: undrained compression at 1e-05 1/s"
    assert Shear.elapsed(st, None, None) == 0.12 / 1e-5


def test_an_extension_may_be_written_with_its_recorded_negative_rate_and_end():
    stages = [read("triaxial", kind="shear", drainage="undrained", strain_rate=rate, direction="extension",
                   to_axial_strain=end) for rate, end in ((-1e-5, -2.5), (1e-5, 2.5), (-1e-5, 2.5))]
    assert [(st.direction, st.strain_rate, st.to_strain) for st in stages] == [("extension", 1e-5, 0.025)] * 3


def test_refusals():
    refused("triaxial", f"{WHERE}.strain_rate is missing", kind="shear", drainage="drained")
    refused("triaxial", f"{WHERE}.drainage = 'partly': expected one of drained, undrained", kind="shear",
            drainage="partly", strain_rate=1e-5)
    negative = 'a negative axial strain is reached in extension: give direction = "extension", or the size'
    for field, value, why in (("to_axial_strain", -5.0, negative), ("to_axial_strain", 0.0, "must be != 0 (%)"),
                              ("strain_rate", -1e-5, negative), ("strain_rate", 0.0, "must be != 0 (1/s)")):
        refused("triaxial", f"{WHERE}.{field} = {value!r}: {why}", **{"kind": "shear", "drainage": "drained",
                                                                       "strain_rate": 1e-5, field: value})
    refused("triaxial", f"{WHERE}.to_axial_strain = 150.0: a strain in % must be <= 100", kind="shear",
            drainage="drained", strain_rate=1e-5, to_axial_strain=150.0)


def test_records_and_logging():
    drained = read("triaxial", kind="shear", drainage="drained", strain_rate=1e-5, direction="extension")
    undrained = read("triaxial", kind="shear", drainage="undrained", strain_rate=1e-5)
    assert "excess_pore_pressure" in Shear.held_quantities(drained)
    assert "void_ratio" in Shear.held_quantities(undrained) and "q" not in Shear.held_quantities(undrained)
    now = {"p": 100.0, "sigma_v": 100.0, "strain": 0.0, "cavity": 0.0}
    x_name, x, t, quantities = Shear.logged(drained, "triaxial", 5, now, {"max_strain_pct": None}, "here")
    assert x_name == "axial_strain" and x[-1] == -SHEAR_STRAIN_PCT and np.all(t > 0)
    assert quantities == ("q", "void_ratio") and now["p"] is None and now["strain"] is None
    assert Shear.logged(undrained, "triaxial", 5, dict(now), {"max_strain_pct": 10.0}, "")[3] == \
        ("q", "excess_pore_pressure")
