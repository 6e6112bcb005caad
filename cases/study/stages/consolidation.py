"""Consolidation: the specimen taken drained to a target effective stress by a linear ramp in time over
``duration`` (s, default one day); a lower target is swelling. Triaxial cell: to ``p`` (isotropic) or to ``sigma_v``
with ``K0`` (sigma'_h = K0 sigma'_v); oedometer: to ``sigma_v`` with zero radial strain (no p, no K0). Stresses in kPa,
compression positive. Records against the controlled stress (p' or sigma'_v, kPa) or the time since the stage start.
"""
from __future__ import annotations

import numpy as np

from cases.study.checks import StudyError
from cases.study.stages.base import OEDOMETER_STRESS, TRIAXIAL_STRESS, StageKind, hold_times

__all__ = ["Consolidation", "CONSOLIDATION_DURATION"]

#: default ramp duration (s)
CONSOLIDATION_DURATION = 86400.0


class Consolidation(StageKind):
    """A drained ramp of the effective stresses to ``p`` or ``sigma_v`` (kPa) over ``duration`` (s)."""

    name = "consolidation"
    apparatus = ("triaxial", "oedometer")
    optional = ("p", "sigma_v", "K0", "duration")
    abscissae = ("time", "p", "sigma_v")
    held = ("q", "p", "sigma_v", "sigma_r", "excess_pore_pressure")
    controls = {"triaxial": TRIAXIAL_STRESS, "oedometer": OEDOMETER_STRESS}
    consolidates = True

    @classmethod
    def check(cls, ck, table, where, apparatus, values):
        """The target: ``p`` (isotropic, triaxial) or ``sigma_v`` (with ``K0`` in a triaxial cell; an oedometer
        holds the radial strain at zero and takes no K0); the duration defaults to one day."""
        v = values
        if ("p" in v) == ("sigma_v" in v):
            raise StudyError(f"{ck.path}: {where}: a consolidation stage goes to p (isotropic, triaxial) or to "
                             f"sigma_v (kPa), one of them; got "
                             f"{sorted(k for k in ('p', 'sigma_v') if k in v) or 'neither'}")
        if apparatus == "oedometer":
            for k in ("p", "K0"):
                if k in v:
                    ck.fail(f"{where}.{k}", table[k], "an oedometer consolidates to sigma_v with zero radial strain "
                            f"(no {k})")
        elif "p" in v and "K0" in v:
            ck.fail(f"{where}.K0", table["K0"], "an isotropic consolidation (p) has no K0; give sigma_v and K0")
        elif "sigma_v" in v and "K0" not in v:
            raise StudyError(f"{ck.path}: {where}.K0 is missing (a triaxial consolidation to sigma_v holds sigma'_h = "
                             "K0 sigma'_v)")
        v.setdefault("duration", CONSOLIDATION_DURATION)

    @classmethod
    def abscissa_of(cls, values):
        return "p" if "p" in values else "sigma_v"

    @classmethod
    def describe(cls, stage):
        return (f"to p' {stage.p:g} kPa" if stage.p is not None else
                f"to sigma'_v {stage.sigma_v:g} kPa" + ("" if stage.K0 is None else f" (K0 {stage.K0:g})"))

    @classmethod
    def stress_target(cls, stage):
        return stage.p if stage.p is not None else stage.sigma_v

    @classmethod
    def consolidation_path(cls, stage):
        return "isotropic" if stage.p is not None else "K0"

    @classmethod
    def control_variable(cls, stage):
        return stage.abscissa

    @classmethod
    def logged(cls, stage, apparatus, n, now, settings, where):
        """n stresses spaced geometrically from the stage's start to its target (the ramp is linear in time), the
        void ratio recorded; n log-spaced times when the start stress is not known beforehand."""
        s = stage
        target, start = (s.p, now["p"]) if s.p is not None else (s.sigma_v, now["sigma_v"])
        t = None
        if start is not None and start != target:
            x_name, x = s.abscissa, np.geomspace(start, target, n + 1)[1:]
            t = s.duration * (x - start) / (target - start)
        else:
            x_name, x = "time", hold_times(s.duration, n)
        now["p"] = s.p if s.p is not None else (s.sigma_v * (1 + 2 * s.K0) / 3 if s.K0 is not None else None)
        now["sigma_v"] = s.sigma_v if s.sigma_v is not None else s.p
        now["strain"] = None
        return x_name, x, t, ("void_ratio",)

    @classmethod
    def plan(cls, steps):
        """The forward model's steps: a stress ramp."""
        steps.consolidation_ramp()
