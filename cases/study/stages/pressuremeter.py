"""The stages of a self-boring pressuremeter test: expansion (cavity strain rate > 0 to a larger cavity strain, at
most :data:`MAX_CAVITY_STRAIN`), hold (cavity wall held for ``duration`` s: the pore pressure dissipates) and
unloading (at its rate to a smaller cavity strain >= 0, or, as the last stage, to a cavity pressure), in any order
after a first expansion; each one loading phase of the FE (:class:`LoadingPhase`). No FE code here: reading a study
file does not import the solver.

Signs and units: cavity strain u_a/a0 as a fraction (the study file and the CSVs give it in %), cavity strain rate
in 1/s (magnitude), cavity pressure in kPa (total radial stress on the wall, compression positive), durations in s.
Records: the total cavity pressure and the total pore pressure at the wall (:data:`SBP_QUANTITIES`) against the
cavity strain (expansion, unloading) or the time since the stage start.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cases.study.checks import StudyError
from cases.study.stages.base import LoggingError, StageKind, hold_times, one_end, rate_to

__all__ = ["Expansion", "Hold", "Unloading", "CavityRamp", "LoadingPhase", "MAX_CAVITY_STRAIN", "SBP_QUANTITIES",
           "HOLD_FIRST_STEP"]

#: largest cavity strain of an expansion (u_a/a0, -): the pressuremeter FE's range, and the end of the flat ``sbp``
#: type's expansion and of an expansion stage that gives none
MAX_CAVITY_STRAIN = 0.10
#: the quantities of an SBP stage's records: total cavity pressure and total pore pressure at the wall (kPa)
SBP_QUANTITIES = ("cavity_pressure", "pore_pressure")
#: first time step of a hold, as a fraction of its duration (the steps then grow geometrically)
HOLD_FIRST_STEP = 1e-4


@dataclass(frozen=True)
class LoadingPhase:
    """One loading phase of the FE: ``duration`` (s), the cavity strain at its end (fraction), its ``increments``
    and the sum of its time steps over the first (1: equal steps; a hold's steps grow geometrically)."""

    duration: float
    cavity_strain: float
    increments: int
    growth_ratio: float = 1.0


class CavityRamp(StageKind):
    """What expansion and unloading share: the cavity strain at ``strain_rate`` (1/s, magnitude) to ``to_strain``
    (fraction)."""

    apparatus = ("sbp",)
    required = ("strain_rate",)
    abscissae = ("cavity_strain", "time")
    held = ("cavity_strain",)
    rate_controlled = True

    @classmethod
    def describe(cls, stage):
        return f"{stage.strain_rate:g} 1/s to {100 * stage.to_strain:g} %"

    @classmethod
    def elapsed(cls, stage, strain, cavity):
        if stage.to_strain is not None and cavity is not None:
            return abs(stage.to_strain - cavity) / stage.strain_rate
        return None

    @classmethod
    def cavity_after(cls, stage, cavity):
        return stage.to_strain

    @classmethod
    def control_variable(cls, stage):
        return "cavity_strain"

    @classmethod
    def check_cavity(cls, stage, strain: float, last: bool, fail) -> float:
        """Check the stage from the cavity strain ``strain`` at its start (``last``: the test's last stage;
        ``fail(field, value, why)`` raises); the cavity strain at its end."""
        if stage.strain_rate is None or not np.isfinite(stage.strain_rate) or not stage.strain_rate > 0:
            fail("strain_rate", stage.strain_rate, "the cavity strain rate must be > 0 (1/s)")
        if cls.ends_at_pressure(stage, last, fail):
            return strain
        pct = None if stage.to_strain is None else 100.0 * stage.to_strain
        if stage.to_strain is None or not np.isfinite(stage.to_strain):
            fail("to_cavity_strain", pct, f"an {cls.name} stage needs the cavity strain it reaches (%)")
        if not cls.reachable(stage.to_strain, strain):
            fail("to_cavity_strain", pct, cls.range_text(strain))
        return stage.to_strain

    @classmethod
    def ends_at_pressure(cls, stage, last: bool, fail) -> bool:
        """Whether the stage ends at a cavity pressure (checked)."""
        return False

    @classmethod
    def reachable(cls, end: float, strain: float) -> bool:
        """Whether the cavity strain ``end`` may end the stage from ``strain``."""
        raise NotImplementedError

    @classmethod
    def range_text(cls, strain: float) -> str:
        """Where the stage may go from the cavity strain ``strain``."""
        raise NotImplementedError

    @classmethod
    def fe_phase(cls, stage, strain: float, increments: int, recorded):
        """The FE loading phase from the cavity strain ``strain``: equal increments, ceil(``increments`` x strain
        change / :data:`MAX_CAVITY_STRAIN`) of them; an end at a pressure is simulated to the last record (its
        smallest recorded cavity strain, or its latest record time at its rate) and left out (None) without
        records. recorded: the stage's recorded abscissae (cavity strain %, or s since the stage start)."""
        target = stage.to_strain
        if target is None:
            if recorded.size == 0:
                return None
            target = (float(recorded.min()) / 100.0 if stage.abscissa == "cavity_strain"
                      else strain - stage.strain_rate * float(recorded.max()))
        n = max(1, int(np.ceil(increments * abs(target - strain) / MAX_CAVITY_STRAIN - 1e-9)))
        return LoadingPhase(abs(target - strain) / stage.strain_rate, target, n)

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """n cavity strains evenly spaced from the stage's start to its end, cavity and pore pressure recorded."""
        if stage.to_strain is None:
            raise LoggingError(f"{where}: synthetic records of an unloading need to_cavity_strain")
        start, end = now["cavity"], 100.0 * stage.to_strain
        x = np.linspace(start, end, n + 1)[1:]
        t = np.abs(x - start) / 100.0 / stage.strain_rate
        now["cavity"] = end
        return "cavity_strain", x, t, SBP_QUANTITIES


class Expansion(CavityRamp):
    """The cavity expanded at ``strain_rate`` (1/s) to ``to_strain`` (default :data:`MAX_CAVITY_STRAIN`)."""

    name = "expansion"
    optional = ("to_cavity_strain",)
    opens_pressuremeter_test = True

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        values.setdefault("to_strain", MAX_CAVITY_STRAIN)

    @classmethod
    def reachable(cls, end, strain):
        return strain < end <= MAX_CAVITY_STRAIN

    @classmethod
    def range_text(cls, strain):
        return (f"an expansion goes above the current cavity strain {100 * strain:g} % and at most to "
                f"{100 * MAX_CAVITY_STRAIN:g} % (the pressuremeter FE's range)")


class Unloading(CavityRamp):
    """The cavity unloaded at ``strain_rate`` (1/s) to ``to_strain`` (fraction, >= 0) or, as the last stage, to the
    total cavity pressure ``to_pressure`` (kPa)."""

    name = "unloading"
    optional = ("to_cavity_strain", "to_pressure")
    strain_end = "non_negative"

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        if not one_end(ck, table, where, ("to_cavity_strain", "to_pressure")):
            raise StudyError(f"{ck.path}: {where}.to_cavity_strain is missing (an unloading stage ends at "
                             "to_cavity_strain (%) or to_pressure (kPa))")

    @classmethod
    def describe(cls, stage):
        return rate_to(stage, "to_pressure", "kPa")

    @classmethod
    def loading_phase(cls, stage, current):
        return "unloading"

    @classmethod
    def ends_at_pressure(cls, stage, last, fail):
        if stage.to_pressure is None:
            return False
        if stage.to_strain is not None:
            fail("to_pressure", stage.to_pressure, "give to_cavity_strain or to_pressure, not both")
        if not np.isfinite(stage.to_pressure) or not stage.to_pressure > 0:
            fail("to_pressure", stage.to_pressure, "the cavity pressure reached must be > 0 (kPa)")
        if not last:
            fail("to_pressure", stage.to_pressure, "an unloading to a pressure is supported as the last stage only "
                 "(give to_cavity_strain when stages follow)")
        return True

    @classmethod
    def reachable(cls, end, strain):
        return 0.0 <= end < strain

    @classmethod
    def range_text(cls, strain):
        return f"an unloading goes below the current cavity strain {100 * strain:g} % and not below 0 %"


class Hold(StageKind):
    """The cavity wall held for ``duration`` (s): the pore pressure dissipates."""

    name = "hold"
    apparatus = ("sbp",)
    required = ("duration",)
    held = ("cavity_strain",)
    holds = True
    keeps_cavity_strain = True

    @classmethod
    def describe(cls, stage):
        return f"cavity strain held {stage.duration:g} s"

    @classmethod
    def check_cavity(cls, stage, strain, last, fail):
        """A duration > 0 s; the cavity strain is unchanged."""
        if stage.duration is None or not np.isfinite(stage.duration) or not stage.duration > 0:
            fail("duration", stage.duration, "a hold needs a duration > 0 s")
        return strain

    @classmethod
    def fe_phase(cls, stage, strain, increments, recorded):
        """``increments`` time steps growing geometrically from :data:`HOLD_FIRST_STEP` of the duration, or from
        the first positive record time (s since the stage start) when earlier."""
        first = min([HOLD_FIRST_STEP * stage.duration, *recorded[recorded > 0]])
        return LoadingPhase(stage.duration, strain, increments, stage.duration / first)

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """n times log-spaced from 1e-4 of the duration (at least 0.1 s) to its end."""
        return "time", hold_times(stage.duration, n, 0.1), None, SBP_QUANTITIES
