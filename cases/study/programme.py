"""The test record of a study: one :class:`TestSpec` per test, an apparatus, the specimen's initial state and its
stages in order (:class:`Stage`, :class:`InitialState`).

Apparatus: ``triaxial`` (axial strain or axial stress controlled, radial total stress controlled), ``oedometer``
(radial strain zero), ``sbp`` (self-boring pressuremeter, coupled FE). Stage kinds per apparatus:
:data:`cases.study.stages.KINDS`, one module per kind in ``cases.study.stages``; each stage's fields are listed with
:class:`Stage` (units kPa, s, 1/s; strains are fractions here and % in the files; compression positive).

The flat test types of a study file (``triaxial``, ``oedometer_crs``, ``oedometer_creep``, ``sbp`` with their
conditions) are shorthand for one- or few-stage programmes; :func:`programme_of` expands them (the flat fields stay
on the record, and the forward models of the flat types keep using them):
- ``triaxial``: drained or undrained, compression or extension, consolidated isotropically (``p0``) or along K0
  (``sigma_v0``, ``K0``), sheared at the axial strain rate ``strain_rate``: one ``shear`` stage;
- ``oedometer_crs``: constant rate of strain from ``sigma_v0`` (``K0`` the initial sigma'_h/sigma'_v): one ``crs``
  stage;
- ``oedometer_creep``: incremental oedometer, load stages ``stage_stress`` each ramped over ``load_time`` and held
  for ``stage_duration``, recorded at ``n_times`` log-spaced hold times per stage: one ``load`` stage per stress;
- ``sbp``: self-boring pressuremeter expansion at the cavity strain rate ``strain_rate`` from the in situ state
  (``sigma_v0``, ``K0``, pore pressure ``u0``, permeability in m/s, probe radius in m): one ``expansion`` stage.
A test written as a programme has ``type = "programme"``.
``e0`` is the void ratio at the start of the test (for a model whose void ratio is a parameter, the parameter unless
a programme's initial state gives it). The record holds conditions only; the recorded abscissae come with the
observations.

Curve keys: the quantity name for a one-stage test and for the flat types (``q``, ``void_ratio``, ...), else
``<quantity>@<stage name>`` (:func:`curve_key`).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from cases.study.stages import KINDS, Stage
from cases.study.stages.crs import ConstantRateOfStrain
from cases.study.stages.load import Load
from cases.study.stages.pressuremeter import MAX_CAVITY_STRAIN, Expansion
from cases.study.stages.shear import Shear

__all__ = ["TestSpec", "Stage", "InitialState", "TEST_TYPES", "ROLES", "APPARATUS", "programme_of", "curve_key",
           "split_key", "condition_features"]

TEST_TYPES = ("triaxial", "oedometer_crs", "oedometer_creep", "sbp")
#: what a study does with a test (``role``): calibrate on it (default), or predict it without its data and score the
#: prediction against them (docs/reference.md section 10)
ROLES = ("calibrate", "predict")
APPARATUS = tuple(KINDS)
#: the apparatus of each flat test type
APPARATUS_OF = {"triaxial": "triaxial", "oedometer_crs": "oedometer", "oedometer_creep": "oedometer", "sbp": "sbp"}


@dataclass(frozen=True)
class InitialState:
    """The specimen at the start of the first stage (kPa): void ratio ``e0``; effective stresses ``p0`` (isotropic)
    or ``sigma_v0`` with sigma'_h0 = ``K0`` sigma'_v0; preconsolidation ``ocr`` (relative to sigma'_v0, or p0 when
    isotropic) or ``preconsolidation`` (vertical, kPa) -- None: the model's parameter (MCC ocr/pc0, ANICREEP
    sigma_p0) applies; pore pressure ``u0``."""

    e0: float | None = None
    p0: float | None = None
    sigma_v0: float | None = None
    K0: float = 1.0
    ocr: float | None = None
    preconsolidation: float | None = None
    u0: float = 0.0

    @property
    def p(self) -> float:
        """Mean effective stress at the start (kPa)."""
        return self.p0 if self.p0 is not None else self.sigma_v0 * (1.0 + 2.0 * self.K0) / 3.0

    @property
    def vertical(self) -> float:
        """Vertical effective stress at the start (kPa)."""
        return self.sigma_v0 if self.sigma_v0 is not None else self.p0


@dataclass(frozen=True)
class TestSpec:
    """One test and its conditions (units kPa, m, s, 1/s). ``file`` and ``where`` name the study file's entry (for
    messages); a test made in code leaves them empty."""

    __test__ = False  # not a pytest class

    name: str
    type: str
    file: Path | None = None
    where: str = ""
    drainage: str | None = None
    direction: str | None = None
    consolidation: str | None = None
    p0: float | None = None
    sigma_v0: float | None = None
    K0: float | None = None
    e0: float | None = None
    strain_rate: float | None = None
    substeps: int | None = None
    stage_stress: tuple = ()
    stage_duration: float | None = None
    load_time: float = 1.0
    n_times: int = 20
    u0: float | None = None
    permeability: float | None = None
    probe_radius: float | None = None
    depth: float | None = None
    curves: tuple | None = None
    apparatus: str | None = None
    initial: InitialState = field(default_factory=InitialState)
    stages: tuple = ()
    weight: float = 1.0
    role: str = "calibrate"

    @property
    def staged(self) -> bool:
        """Whether the test was written as a stage programme (not a flat type)."""
        return self.type == "programme"

    def stage(self, name: str) -> Stage:
        """The stage called ``name``."""
        return next(s for s in self.stages if s.name == name)

    @property
    def k0(self) -> float:
        """sigma'_r0 / sigma'_a0 at the start of a triaxial test (1 when isotropically consolidated)."""
        return 1.0 if self.consolidation == "isotropic" else self.K0

    @property
    def start_p(self) -> float:
        """Mean effective stress at the start of a triaxial test (kPa)."""
        return self.p0 if self.consolidation == "isotropic" else self.sigma_v0 * (1.0 + 2.0 * self.K0) / 3.0

    @property
    def start_q(self) -> float:
        """Deviator stress sigma'_a0 - sigma'_r0 at the start of a triaxial test (kPa; 0 when isotropic)."""
        if self.k0 == 1.0:
            return 0.0
        return 3.0 * self.start_p * (1.0 - self.k0) / (1.0 + 2.0 * self.k0)

    @property
    def site(self) -> dict:
        """The in situ state of an SBP test, as the pressuremeter problem takes it (kPa, m/s, m)."""
        return {"sigma_v0": self.sigma_v0, "K0": self.K0, "u0": self.u0, "permeability": self.permeability,
                "a0": self.probe_radius}

    def hold_stage(self, t):
        """Stage index and time since the stage start of records at times ``t`` (s since the test start) of an
        incremental oedometer: stage k spans (k D, (k + 1) D], loaded during its first ``load_time`` s."""
        d = self.stage_duration
        stage = np.maximum(np.ceil(np.asarray(t) / d - 1e-12).astype(int) - 1, 0)
        return stage, t - stage * d

    def conditions(self) -> dict:
        """The test conditions as plain data (for summaries and the diagnosis input): the flat fields of a flat type,
        the apparatus, initial state and stages of a programme; the weight when it is not 1, the role when it is not
        "calibrate"."""
        skip = ("name", "file", "where", "apparatus", "initial", "stages", "weight", "role")
        out = {f.name: (list(v) if isinstance(v, tuple) else v) for f in fields(self)
               for v in [getattr(self, f.name)] if f.name not in skip and v not in (None, ())}
        if self.staged:
            out = {"type": self.type, "apparatus": self.apparatus, **plain(self.initial),
                   "stages": [plain(s) for s in self.stages]}
            if self.permeability is not None:
                out.update(permeability=self.permeability, probe_radius=self.probe_radius)
        if self.weight != 1.0:
            out["weight"] = self.weight
        if self.role != "calibrate":
            out["role"] = self.role
        return out

    def describe(self) -> str:
        if self.staged:
            return f"{self.apparatus} programme: " + "; ".join(s.describe() for s in self.stages)
        if self.type == "triaxial":
            start = (f"isotropic p'0 {self.p0:g} kPa" if self.consolidation == "isotropic"
                     else f"K0 {self.K0:g}, sigma'_v0 {self.sigma_v0:g} kPa")
            rate = "" if self.strain_rate is None else f", {self.strain_rate:g} 1/s"
            return f"{self.drainage} triaxial {self.direction} ({start}{rate})"
        if self.type == "oedometer_crs":
            return f"CRS oedometer (sigma'_v0 {self.sigma_v0:g} kPa, {self.strain_rate:g} 1/s)"
        if self.type == "oedometer_creep":
            return (f"incremental oedometer, stages {', '.join(f'{s:g}' for s in self.stage_stress)} kPa held "
                    f"{self.stage_duration:g} s each")
        return (f"SBP expansion (sigma'_v0 {self.sigma_v0:g} kPa, K0 {self.K0:g}, u0 {self.u0:g} kPa, "
                f"k {self.permeability:g} m/s, {self.strain_rate:g} 1/s)")


def plain(record) -> dict:
    """The fields of a Stage or InitialState that are set, as plain data (tuples as lists)."""
    return {f.name: (list(v) if isinstance(v, tuple) else v) for f in fields(record)
            for v in [getattr(record, f.name)] if v not in (None, ())}


def programme_of(spec: TestSpec) -> TestSpec:
    """The test with ``apparatus``, ``initial`` and ``stages`` filled from its flat type's fields (see the module
    docstring); a programme (stages given) is returned as it is."""
    if spec.stages:
        return spec
    kind = spec.type
    k0 = (1.0 if spec.consolidation == "isotropic" else spec.K0) if kind == "triaxial" else spec.K0
    initial = InitialState(e0=spec.e0, p0=spec.p0 if kind == "triaxial" and spec.consolidation == "isotropic"
                           else None, sigma_v0=None if spec.consolidation == "isotropic" else spec.sigma_v0,
                           K0=1.0 if k0 is None else k0, u0=spec.u0 or 0.0)
    if kind == "triaxial":
        stages = (Stage(Shear.name, f"{Shear.name}1", drainage=spec.drainage or "drained", direction=spec.direction,
                        strain_rate=spec.strain_rate, abscissa="axial_strain"),)
    elif kind == "oedometer_crs":
        stages = (Stage(ConstantRateOfStrain.name, f"{ConstantRateOfStrain.name}1", strain_rate=spec.strain_rate,
                        abscissa="axial_strain"),)
    elif kind == "oedometer_creep":
        stages = tuple(Stage(Load.name, f"{Load.name}{k}", sigma_v=s, ramp_time=spec.load_time,
                             duration=spec.stage_duration) for k, s in enumerate(spec.stage_stress, start=1))
    else:
        stages = (Stage(Expansion.name, f"{Expansion.name}1", strain_rate=spec.strain_rate,
                        to_strain=MAX_CAVITY_STRAIN, abscissa="cavity_strain"),)
    if spec.curves is not None and len(stages) == 1:
        stages = (replace(stages[0], curves=tuple(spec.curves)),)
    return replace(spec, apparatus=APPARATUS_OF[kind], initial=initial, stages=stages)


def curve_key(spec: TestSpec, quantity: str, stage: Stage) -> str:
    """The curve name of ``quantity`` recorded in ``stage`` of ``spec``: the quantity for a flat type or a one-stage
    programme, else ``<quantity>@<stage name>``."""
    return quantity if not spec.staged or len(spec.stages) == 1 else f"{quantity}@{stage.name}"


def split_key(key: str) -> tuple:
    """(quantity, stage name or None) of a curve key."""
    quantity, _, stage = key.partition("@")
    return quantity, stage or None


def condition_features(spec: TestSpec) -> dict:
    """The conditions of a test as features of the state space of docs/reference.md (P2) (the distance between tests
    that sizes the model error of a prediction): numbers ``e0`` (initial void ratio), ``ln p0`` (initial mean
    effective stress, kPa), ``ln ocr`` (initial overconsolidation ratio), ``ln permeability`` (m/s, pressuremeter)
    where given; per stage kind present, ``ln <kind> stress`` (the largest target effective stress, kPa), ``ln <kind>
    rate`` (the mean log strain rate magnitude, 1/s) and ``ln <kind> duration`` (s, the mean log duration) where its
    stages give them; texts ``apparatus``, ``stages`` (the kinds in order) and per kind ``<kind> drainage`` and, where
    given, ``<kind> direction`` (compression, extension; "negative rate" for a CRS stage that unloads)."""
    spec = programme_of(spec)
    init = spec.initial
    state = {"apparatus": spec.apparatus, "stages": " ".join(s.kind for s in spec.stages)}
    if init.e0 is not None:
        state["e0"] = float(init.e0)
    if init.p0 is not None or init.sigma_v0 is not None:
        state["ln p0"] = float(np.log(init.p))
    if init.ocr is not None or init.preconsolidation is not None:
        ocr = init.ocr if init.ocr is not None else init.preconsolidation / init.vertical
        state["ln ocr"] = float(np.log(ocr))
    if spec.permeability is not None:
        state["ln permeability"] = float(np.log(spec.permeability))
    by_kind = {}
    for st in spec.stages:
        by_kind.setdefault(st.kind, []).append(st)
    for kind, stages in by_kind.items():
        stress = [v for st in stages for v in (st.p, st.sigma_v, st.to_sigma_v) if v is not None]
        rate = [abs(st.strain_rate) for st in stages if st.strain_rate]
        duration = [st.duration for st in stages if st.duration]
        direction = ({st.direction for st in stages if st.direction}
                     | {"negative rate" for st in stages if (st.strain_rate or 0.0) < 0})
        if stress:
            state[f"ln {kind} stress"] = float(np.log(max(stress)))
        if rate:
            state[f"ln {kind} rate"] = float(np.mean(np.log(rate)))
        if duration:
            state[f"ln {kind} duration"] = float(np.mean(np.log(duration)))
        state[f"{kind} drainage"] = " ".join(sorted({st.drainage for st in stages}))
        if direction:
            state[f"{kind} direction"] = " ".join(sorted(direction))
    return state
