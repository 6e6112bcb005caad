"""Laboratory holds: creep (the controlled stresses held) and relaxation (the axial strain held) for ``duration``
(s), drained or, in a triaxial cell, undrained (total stresses and volume held). Triaxial creep holds the axial and
radial stresses, oedometer creep sigma'_v with zero radial strain; relaxation holds the axial strain with the radial
stress held (triaxial) or every strain (oedometer). Records against the time since the stage start (s); a
rate-dependent model takes them in adaptive time steps (``cases.study.forward.lab_stage_steps``).
"""
from __future__ import annotations

from cases.study.stages.base import (
    OEDOMETER_STRAIN,
    OEDOMETER_STRESS,
    TRIAXIAL_AXIAL,
    TRIAXIAL_STRESS,
    StageKind,
    hold_times,
)

__all__ = ["LabHold", "Creep", "Relaxation"]


class LabHold(StageKind):
    """What creep and relaxation share: a ``duration`` (s), a ``drainage``, records against time."""

    apparatus = ("triaxial", "oedometer")
    required = ("duration",)
    optional = ("drainage",)
    drainable = True
    holds = True
    adaptive_hold = True
    #: what is held, in the description
    held_text = ""

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        """An oedometer hold is drained."""
        if apparatus == "oedometer" and values.get("drainage") == "undrained":
            ck.fail(f"{where}.drainage", "undrained", f"an oedometer {cls.name} stage is drained (undrained "
                    f"{cls.name} is supported for apparatus 'triaxial')")

    @classmethod
    def describe(cls, stage):
        return f"{stage.drainage}, {cls.held_text} held {stage.duration:g} s"

    @classmethod
    def plan(cls, steps):
        """The forward model's steps: a hold of the stage's duration."""
        steps.hold(steps.stage.duration)

    @classmethod
    def recorded(cls, stage, apparatus) -> tuple:
        """The CSV quantities of the stage's synthetic records."""
        raise NotImplementedError

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """n times log-spaced from 1e-4 of the duration (at least 1 s) to its end."""
        cls.after_hold(now)
        return "time", hold_times(stage.duration, n, 1.0), None, cls.recorded(stage, apparatus)

    @classmethod
    def after_hold(cls, now):
        """``now`` (see :meth:`StageKind.logged`) at the end of the hold."""


class Creep(LabHold):
    """Stresses held for ``duration`` (s); records of the axial strain (and the volumetric strain or the excess
    pore pressure in a triaxial cell)."""

    name = "creep"
    held = ("q", "sigma_v")
    controls = {"triaxial": TRIAXIAL_STRESS, "oedometer": OEDOMETER_STRESS}
    held_text = "stresses"

    @classmethod
    def held_quantities(cls, stage):
        return super().held_quantities(stage) + (("p", "sigma_r") if stage.drainage == "drained" else ())

    @classmethod
    def recorded(cls, stage, apparatus):
        if apparatus == "oedometer":
            return ("axial_strain",)
        return ("axial_strain", "excess_pore_pressure" if stage.drainage == "undrained" else "volumetric_strain")

    @classmethod
    def after_hold(cls, now):
        now["strain"] = None


class Relaxation(LabHold):
    """Axial strain held for ``duration`` (s); records of sigma'_v (oedometer) or q (and the excess pore pressure
    when undrained)."""

    name = "relaxation"
    held = ("axial_strain",)
    controls = {"triaxial": TRIAXIAL_AXIAL, "oedometer": OEDOMETER_STRAIN}
    keeps_axial_strain = True
    held_text = "strain"

    @classmethod
    def recorded(cls, stage, apparatus):
        if apparatus == "oedometer":
            return ("sigma_v",)
        return ("q", "excess_pore_pressure") if stage.drainage == "undrained" else ("q",)

    @classmethod
    def after_hold(cls, now):
        now.update(p=None, sigma_v=None)
