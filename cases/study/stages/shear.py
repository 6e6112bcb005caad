"""Shear (triaxial cell): the axial strain at ``strain_rate`` (1/s, its size; in extension also its negative value
as recorded) signed by ``direction`` (``compression`` +, ``extension`` -), the radial total stress held; ``drainage``
``drained`` or ``undrained`` (volume held, the excess pore pressure an unknown). It ends at ``to_axial_strain`` (%,
the stage's own axial strain; in extension its size or its negative value as recorded), else at its last record.
Records against the stage's own axial strain (%, zeroed at the start of shear, as triaxial reports give it) or the
time since the stage start (s).
"""
from __future__ import annotations

import numpy as np

from cases.study.stages.base import TRIAXIAL_AXIAL, StageKind

__all__ = ["Shear", "SHEAR_STRAIN_PCT"]

#: axial strain (%) of the synthetic records when neither the stage nor [synthetic] max_strain_pct gives an end
SHEAR_STRAIN_PCT = 15.0


class Shear(StageKind):
    """Axial strain at a rate (1/s) to ``to_strain`` (fraction), drained or undrained, compression or extension."""

    name = "shear"
    apparatus = ("triaxial",)
    required = ("drainage", "strain_rate")
    optional = ("direction", "to_axial_strain")
    abscissae = ("axial_strain", "time")
    held = ("axial_strain",)
    controls = {"triaxial": TRIAXIAL_AXIAL}
    drainable = True
    rate_controlled = True
    shearing = True
    strain_end = "any"
    signed_rate = "1/s"

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        """The direction defaults to compression; the rate and the end are kept as their sizes, either negative (as
        recorded) only in extension."""
        values.setdefault("direction", "compression")
        if values.get("to_strain") == 0.0:
            ck.fail(f"{where}.to_axial_strain", table["to_axial_strain"], "must be != 0 (%)")
        for field, key in (("strain_rate", "strain_rate"), ("to_strain", "to_axial_strain")):
            value = values.get(field)
            if value is not None and value < 0.0:
                if values["direction"] != "extension":
                    ck.fail(f"{where}.{key}", table[key], "a negative axial strain is reached in extension: give "
                            'direction = "extension", or the size')
                values[field] = -value

    @classmethod
    def describe(cls, stage):
        return f"{stage.drainage} {stage.direction} at {stage.strain_rate:g} 1/s"

    @classmethod
    def elapsed(cls, stage, strain, cavity):
        return stage.to_strain / stage.strain_rate if stage.to_strain is not None else None

    @classmethod
    def control_variable(cls, stage):
        return "axial_strain"

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """n axial strains evenly spaced to ``to_strain`` (else [synthetic] max_strain_pct, else
        :data:`SHEAR_STRAIN_PCT`; signed by the direction), q and the void ratio (drained) or the excess pore
        pressure (undrained)."""
        s = stage
        top = 100.0 * s.to_strain if s.to_strain is not None else settings["max_strain_pct"] or SHEAR_STRAIN_PCT
        x = np.linspace(top / n, top, n) * (-1.0 if s.direction == "extension" else 1.0)
        t = np.abs(x) / 100.0 / s.strain_rate
        now.update(p=None, sigma_v=None, strain=None)
        return "axial_strain", x, t, ("q", "void_ratio") if s.drainage == "drained" else ("q", "excess_pore_pressure")

    @classmethod
    def plan(cls, steps):
        """The forward model's steps: an axial strain ramp."""
        steps.shear_ramp()
