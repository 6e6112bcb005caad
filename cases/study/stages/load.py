"""Load stage of an incremental oedometer: sigma'_v ramped linearly to ``sigma_v`` (kPa) over ``ramp_time`` (s,
default 1 s), then held until the stage's ``duration`` (s, ramp included), zero radial strain. Records against the
time since the stage start (s); a rate-dependent model takes the hold in adaptive time steps.
"""
from __future__ import annotations

import numpy as np

from cases.study.stages.base import OEDOMETER_STRESS, StageKind, hold_times

__all__ = ["Load", "RAMP_TIME"]

#: default ramp of a load stage (s)
RAMP_TIME = 1.0


class Load(StageKind):
    """sigma'_v ramped to ``sigma_v`` (kPa) over ``ramp_time`` (s), held to ``duration`` (s)."""

    name = "load"
    apparatus = ("oedometer",)
    required = ("sigma_v", "duration")
    optional = ("ramp_time",)
    held = ("sigma_v",)
    controls = {"oedometer": OEDOMETER_STRESS}
    ramped_hold = True
    adaptive_hold = True

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        """The ramp (default :data:`RAMP_TIME`) is shorter than the stage."""
        values.setdefault("ramp_time", RAMP_TIME)
        if values["ramp_time"] >= values["duration"]:
            ck.fail(f"{where}.ramp_time", values["ramp_time"], f"must be < the stage's duration "
                    f"{values['duration']:g} s")

    @classmethod
    def describe(cls, stage):
        return f"sigma'_v {stage.sigma_v:g} kPa, ramp {stage.ramp_time:g} s, {stage.duration:g} s"

    @classmethod
    def stress_target(cls, stage):
        return stage.p if stage.p is not None else stage.sigma_v

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """3 times during the ramp, then n log-spaced times to the stage's end, the axial strain recorded."""
        x = np.concatenate([np.linspace(stage.ramp_time / 3, stage.ramp_time, 3),
                            hold_times(stage.duration, n, 2 * stage.ramp_time)])
        now.update(sigma_v=stage.sigma_v, p=None, strain=None)
        return "time", x, None, ("axial_strain",)

    @classmethod
    def plan(cls, steps):
        """The forward model's steps: the stress ramp, then the hold."""
        steps.load_ramp_and_hold()
