"""The stage kinds of a test programme, one module per kind (or per family of kinds that share almost everything):
each a :class:`~cases.study.stages.base.StageKind` subclass holding the kind's fields, their checks, its description,
the abscissae and curves of its records, its logging plan and its control in the forward models; the forward models
and readers ask the stage (``Stage.procedure``) rather than compare kind names.

- ``consolidation``: drained ramp to p' or sigma'_v (triaxial, oedometer);
- ``shear``: axial strain at a rate, drained or undrained (triaxial);
- ``lab_holds``: ``creep`` (stresses held) and ``relaxation`` (axial strain held) (triaxial, oedometer);
- ``crs``: constant rate of strain, signed, to a strain or a stress (oedometer; triaxial: K0 consolidation, the
  radial strain held at zero);
- ``load``: incremental load stage, ramp then hold (oedometer);
- ``pressuremeter``: ``expansion``, ``hold``, ``unloading`` of a self-boring pressuremeter test (sbp);
- ``sequence``: what follows from the order of the stages (stage times, the checks that span stages).

:data:`KINDS` {apparatus: {kind name: StageKind subclass}}, in the order the messages list them. A new kind is a new
module here, its class listed in :data:`ORDER`. No FE code: reading a study file does not import the solver.
"""
from __future__ import annotations

from cases.study.stages.base import Stage, StageKind, kind_named
from cases.study.stages.consolidation import Consolidation
from cases.study.stages.crs import ConstantRateOfStrain
from cases.study.stages.lab_holds import Creep, Relaxation
from cases.study.stages.load import Load
from cases.study.stages.pressuremeter import Expansion, Hold, Unloading
from cases.study.stages.shear import Shear

__all__ = ["KINDS", "ORDER", "Stage", "StageKind", "kind_named"]

#: the stage kinds, in the order the messages list them
ORDER = (Consolidation, Shear, Creep, Relaxation, ConstantRateOfStrain, Load, Expansion, Hold, Unloading)
#: {apparatus: {kind name: StageKind subclass}} of the kinds each apparatus runs
KINDS = {apparatus: {kind.name: kind for kind in ORDER if apparatus in kind.apparatus}
         for apparatus in ("triaxial", "oedometer", "sbp")}
