"""The stages of a self-boring pressuremeter test as a study file gives them, checked before any solve: which stage
kinds follow which, their rates, targets and abscissae. No FE code: reading a study file does not import the solver.

Signs and units: cavity strain u_a/a0 as a fraction (the study file gives it in %), cavity strain rate in 1/s,
cavity pressure in kPa (total radial stress on the wall, compression positive), durations in s.
"""
from __future__ import annotations

import numpy as np

__all__ = ["MAX_STRAIN", "SBP_QUANTITIES", "ABSCISSAE", "check_sbp_stages"]

#: largest cavity strain of the expansion (u_a/a0, -)
MAX_STRAIN = 0.10
#: the quantities of an SBP stage's records: total cavity pressure and total pore pressure at the wall (kPa)
SBP_QUANTITIES = ("cavity_pressure", "pore_pressure")
#: the abscissae an SBP stage's records may take, per stage kind
ABSCISSAE = {"expansion": ("cavity_strain", "time"), "hold": ("time",), "unloading": ("cavity_strain", "time")}


def check_sbp_stages(ck, stages, where: str, test: str = ""):
    """Check the ``stages`` of the SBP programme of test ``test`` before any solve; ``ck``
    (cases.study.reading.checks.Checker) names the study file, ``where`` the test entry (``tests[2]``). A first expansion,
    then any of: expansion at a cavity strain rate > 0 to a cavity strain above the current one, at most
    :data:`MAX_STRAIN` (the FE's range); hold for a duration > 0; unloading at a rate > 0 to a cavity strain below
    the current one (>= 0), or, as the last stage, to a cavity pressure > 0. Records against cavity strain
    (expansion, unloading) or time since the stage start. The StudyError names the file, the test, the stage, the
    field (as in the file: ``to_cavity_strain`` in %) and the value."""
    strain = 0.0
    for k, stage in enumerate(stages):
        at = f"{where}.stages[{k}]"
        named = f" (test {test}, stage {stage.name})" if test else f" (stage {stage.name})"

        def fail(field, value, why):
            ck.fail(f"{at}.{field}", value, why + named)

        if stage.kind not in ABSCISSAE:
            fail("kind", stage.kind, f"supported for apparatus 'sbp': {', '.join(ABSCISSAE)}")
        if k == 0 and stage.kind != "expansion":
            fail("kind", stage.kind, "the first stage of a pressuremeter test is an expansion")
        if stage.abscissa not in ABSCISSAE[stage.kind]:
            fail("abscissa", stage.abscissa, f"a {stage.kind} stage is recorded against "
                 + " or ".join(ABSCISSAE[stage.kind]))
        if stage.kind == "hold":
            if stage.duration is None or not np.isfinite(stage.duration) or not stage.duration > 0:
                fail("duration", stage.duration, "a hold needs a duration > 0 s")
            continue
        if stage.strain_rate is None or not np.isfinite(stage.strain_rate) or not stage.strain_rate > 0:
            fail("strain_rate", stage.strain_rate, "the cavity strain rate must be > 0 (1/s)")
        if stage.kind == "unloading" and stage.to_pressure is not None:
            if stage.to_strain is not None:
                fail("to_pressure", stage.to_pressure, "give to_cavity_strain or to_pressure, not both")
            if not np.isfinite(stage.to_pressure) or not stage.to_pressure > 0:
                fail("to_pressure", stage.to_pressure, "the cavity pressure reached must be > 0 (kPa)")
            if k != len(stages) - 1:
                fail("to_pressure", stage.to_pressure, "an unloading to a pressure is supported as the last stage "
                     "only (give to_cavity_strain when stages follow)")
            continue
        pct = None if stage.to_strain is None else 100.0 * stage.to_strain
        if stage.to_strain is None or not np.isfinite(stage.to_strain):
            fail("to_cavity_strain", pct, f"an {stage.kind} stage needs the cavity strain it reaches (%)")
        if stage.kind == "expansion" and not strain < stage.to_strain <= MAX_STRAIN:
            fail("to_cavity_strain", pct, f"an expansion goes above the current cavity strain {100 * strain:g} % "
                 f"and at most to {100 * MAX_STRAIN:g} % (the pressuremeter FE's range)")
        if stage.kind == "unloading" and not 0.0 <= stage.to_strain < strain:
            fail("to_cavity_strain", pct, f"an unloading goes below the current cavity strain {100 * strain:g} % "
                 "and not below 0 %")
        strain = stage.to_strain
