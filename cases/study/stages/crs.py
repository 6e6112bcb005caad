"""Constant rate of strain: the axial strain at the SIGNED ``strain_rate`` (1/s; > 0 loading, < 0 unloading), every
strain controlled (the radial strain held at zero: an oedometer, or a K0 consolidation in a triaxial cell whose cell
pressure follows the specimen, its radial effective stress a curve), to the total axial strain ``to_axial_strain``
(%) or until sigma'_v reaches ``to_sigma_v`` (kPa), else to its last record. Records against the total axial strain
of the test (%) or the time since the stage start (s).
"""
from __future__ import annotations

import numpy as np

from cases.study.stages.base import OEDOMETER_STRAIN, LoggingError, StageKind, one_end, rate_to

__all__ = ["ConstantRateOfStrain"]


class ConstantRateOfStrain(StageKind):
    """Axial strain at a signed rate (1/s) to ``to_strain`` (total axial strain, fraction) or ``to_sigma_v``
    (kPa)."""

    name = "crs"
    apparatus = ("triaxial", "oedometer")
    required = ("strain_rate",)
    optional = ("to_axial_strain", "to_sigma_v")
    abscissae = ("axial_strain", "time")
    held = ("axial_strain", "volumetric_strain", "void_ratio")
    controls = {"triaxial": OEDOMETER_STRAIN, "oedometer": OEDOMETER_STRAIN}
    rate_controlled = True
    strain_end = "any"
    signed_rate = "1/s, signed: > 0 loading, < 0 unloading"

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        one_end(ck, table, where, ("to_axial_strain", "to_sigma_v"))

    @classmethod
    def check_from(cls, ck, stage, where, strain):
        """A stage ending at a total axial strain moves in the direction of its rate from the strain at its start."""
        if stage.to_strain is not None and strain is not None and (stage.to_strain - strain) * stage.strain_rate <= 0:
            ck.fail(f"{where}.to_axial_strain", 100 * stage.to_strain, f"not reached at strain_rate "
                    f"{stage.strain_rate:g} 1/s from the previous stage's end {100 * strain:g} % (a negative rate "
                    "unloads)")

    @classmethod
    def describe(cls, stage):
        return rate_to(stage, "to_sigma_v", "kPa")

    @classmethod
    def elapsed(cls, stage, strain, cavity):
        if stage.to_strain is not None and strain is not None:
            return (stage.to_strain - strain) / stage.strain_rate
        return None

    @classmethod
    def strain_after(cls, stage, strain):
        return stage.to_strain

    @classmethod
    def loading_phase(cls, stage, current):
        return "loading" if (stage.strain_rate or 0.0) >= 0.0 else "unloading"

    @classmethod
    def control_variable(cls, stage):
        return "axial_strain"

    @classmethod
    def continues_to_stress(cls, stage):
        return stage.to_strain is None and stage.to_sigma_v is not None

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """n total axial strains evenly spaced from the stage's start to ``to_strain``, sigma'_v recorded (and
        sigma'_r in a triaxial cell)."""
        if now["strain"] is None or stage.to_strain is None:
            raise LoggingError(f"{where}: synthetic records of a crs stage need to_axial_strain and a known strain "
                               "at its start")
        start, end = now["strain"], 100.0 * stage.to_strain
        x = np.linspace(start, end, n + 1)[1:]
        t = np.abs(x - start) / 100.0 / abs(stage.strain_rate)
        now.update(strain=end, p=None, sigma_v=None)
        return "axial_strain", x, t, ("sigma_v", "sigma_r") if apparatus == "triaxial" else ("sigma_v",)

    @classmethod
    def plan(cls, steps):
        """The forward model's steps: an axial strain ramp at the signed rate."""
        steps.crs_ramp()
