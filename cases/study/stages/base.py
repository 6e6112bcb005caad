"""The stage record (:class:`Stage`) and what every stage kind declares (:class:`StageKind`): its fields in the study
file, their checks, its description, the abscissae and curves of its records, its logging plan and its control in the
forward models. One subclass per kind (``cases.study.stages.<kind>``), registered by its ``name``.

Units kPa, s, 1/s; strains are fractions in the record and % in the study file and the CSVs; compression positive.
Control rows of ``constitutive.labtests.mixed_control``: ``True`` where the Voigt component's strain is controlled,
``False`` where its stress is (axial = Voigt 11, radial = 22 and 33).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Stage", "StageKind", "LoggingError", "kind_named", "hold_times", "one_end", "rate_to", "TRIAXIAL_STRESS",
           "TRIAXIAL_AXIAL", "OEDOMETER_STRESS", "OEDOMETER_STRAIN", "CHOICES"]

STRAIN, STRESS = True, False
TRIAXIAL_STRESS = np.array([STRESS, STRESS, STRESS, STRAIN, STRAIN, STRAIN])   # every normal stress controlled
TRIAXIAL_AXIAL = np.array([STRAIN, STRESS, STRESS, STRAIN, STRAIN, STRAIN])    # axial strain, radial stress
OEDOMETER_STRESS = np.array([STRESS, STRAIN, STRAIN, STRAIN, STRAIN, STRAIN])  # sigma'_v, radial strain zero
OEDOMETER_STRAIN = np.ones(6, dtype=bool)                                      # every strain controlled
#: the text fields of a stage table and their values
CHOICES = {"drainage": ("drained", "undrained"), "direction": ("compression", "extension")}
#: quantities that carry no information in a drained / an undrained stage (not made curves)
DRAINED_HELD = ("excess_pore_pressure",)
UNDRAINED_HELD = ("volumetric_strain", "void_ratio")

_KINDS = {}


def kind_named(name: str):
    """The StageKind subclass whose ``name`` is ``name`` (KeyError when none)."""
    return _KINDS[name]


class LoggingError(ValueError):
    """A stage whose synthetic records cannot be placed beforehand (its end follows from the material's response)."""


def hold_times(duration: float, n: int, first: float = 1.0):
    """``n`` times (s since the stage start) log-spaced from 1e-4 of ``duration`` (at least ``first``, at most 0.1 of
    it) to its end: where a laboratory logs a hold."""
    return np.geomspace(min(max(first, 1e-4 * duration), 0.1 * duration), duration, n)


@dataclass(frozen=True)
class Stage:
    """One stage of a test (units kPa, s, 1/s; strains as fractions; compression positive).

    kind: the name of a stage kind (:mod:`cases.study.stages`, which lists each kind's fields); name: unique within
    the test (default ``<kind><number>``, 1-based).
    duration: consolidation ramp, creep, relaxation, load stage total (ramp included), sbp hold (s).
    p: consolidation target mean effective stress (isotropic path); sigma_v: consolidation / load target vertical
    effective stress; K0: consolidation in a triaxial cell along sigma'_h = K0 sigma'_v.
    drainage: ``drained`` | ``undrained`` (shear, creep, relaxation); direction: shear ``compression`` |
    ``extension``. strain_rate: shear (magnitude), crs (SIGNED: < 0 unloading), sbp cavity strain rate (magnitude).
    to_strain: shear: the stage's own axial strain magnitude; crs: total axial strain of the test reached;
    expansion / unloading: cavity strain reached. to_sigma_v: crs alternative end (kPa); to_pressure: sbp unloading
    alternative end (total cavity pressure, kPa); ramp_time: load stage ramp (s).
    abscissa: what the stage's records are plotted and simulated against: ``axial_strain``, ``time`` (since the stage
    start), ``p``, ``sigma_v``, ``cavity_strain``; curves: the recorded quantities of this stage (from the records).
    chosen_abscissa: the abscissa the study file chose (None: the kind's control variable where recorded, else
    time); chosen_curves: the curves the study file lets into the likelihood (None: every recorded one), by curve
    name (``q``, ``axial_stress`` for sigma'_v, ...). e_end: the void ratio measured at the end of the stage (a
    laboratory programme's specimen then starts from the void ratio that reaches it, found per parameter set).
    """

    kind: str
    name: str
    duration: float | None = None
    p: float | None = None
    sigma_v: float | None = None
    K0: float | None = None
    drainage: str = "drained"
    direction: str | None = None
    strain_rate: float | None = None
    to_strain: float | None = None
    to_sigma_v: float | None = None
    to_pressure: float | None = None
    ramp_time: float | None = None
    abscissa: str = "time"
    curves: tuple = ()
    chosen_abscissa: str | None = None
    chosen_curves: tuple | None = None
    e_end: float | None = None

    @property
    def procedure(self):
        """The StageKind subclass of this stage's kind (KeyError for an unknown kind)."""
        return kind_named(self.kind)

    def describe(self) -> str:
        """One line, e.g. ``shear3: undrained compression at 1e-05 1/s``."""
        try:
            return f"{self.name}: {self.procedure.describe(self)}"
        except (TypeError, KeyError):
            return f"{self.name}: {self.kind}"


class StageKind:
    """What a stage kind declares (class attributes and class methods; a subclass per kind overrides them).

    name: the ``kind`` of a ``[[tests.stages]]`` table; apparatus: those that run it; required, optional: the fields
    of its table besides ``kind`` and ``name``; abscissae: what its records may be plotted against (the first is the
    default); held: the quantities it controls or that carry no information in it (not made curves); controls:
    {apparatus: control rows of mixed_control} (laboratory kinds). Flags: drainable (may be undrained), holds (a
    hold: loading phase "hold"), rate_controlled (a strain at a rate), shearing (a deviator peak and a stress path
    direction), consolidates (sets the consolidation path), ramped_hold (a ramp, then a hold), keeps_axial_strain /
    keeps_cavity_strain (the strain at its end is the one at its start), adaptive_hold (a rate-dependent model takes
    it in adaptive time steps), opens_pressuremeter_test (may be the first stage of an sbp test)."""

    name = ""
    apparatus = ()
    required = ()
    optional = ()
    abscissae = ("time",)
    held = ()
    controls = {}
    drainable = False
    holds = False
    rate_controlled = False
    shearing = False
    consolidates = False
    ramped_hold = False
    keeps_axial_strain = False
    keeps_cavity_strain = False
    adaptive_hold = False
    opens_pressuremeter_test = False

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.name:  # a family's common class has no name
            _KINDS[cls.name] = cls

    #: the sign a strain end may take: "positive", "non_negative" or "any"
    strain_end = "positive"
    #: a strain rate that may be negative (any value but 0) says so in its refusal with this note; None: > 0
    signed_rate = None

    # ------------------------------------------------------------------ reading the study file
    @classmethod
    def read_value(cls, ck, key: str, value, where: str) -> tuple:
        """(Stage field, checked value) of the table field ``key`` = ``value`` at ``where``: a text field among its
        choices, a strain end in % (a fraction in the record, |value| <= 100), a signed strain rate != 0
        (``signed_rate``), any other number > 0."""
        if key in CHOICES:
            return key, ck.text(value, where, CHOICES[key])
        if key in ("to_axial_strain", "to_cavity_strain"):
            strain = ck.number(value, where, positive=cls.strain_end == "positive",
                               non_negative=cls.strain_end == "non_negative") / 100.0
            if abs(value) > 100.0:
                ck.fail(where, value, "a strain in % must be <= 100")
            return "to_strain", strain
        if key == "strain_rate" and cls.signed_rate:
            rate = ck.number(value, where)
            if rate == 0:
                ck.fail(where, value, f"must be != 0 ({cls.signed_rate})")
            return key, rate
        return key, ck.number(value, where, positive=True)

    @classmethod
    def check(cls, ck, table: dict, where: str, apparatus: str, values: dict):
        """The kind's own checks of the read ``values`` of ``table`` at ``where``, its defaults set in ``values``."""

    @classmethod
    def abscissa_of(cls, values: dict) -> str:
        """The abscissa of a stage read with ``values`` before its records are known."""
        return cls.abscissae[0]

    @classmethod
    def check_from(cls, ck, stage, where: str, strain):
        """Check the stage against the total axial strain at its start (fraction; None when it follows from the
        material's response)."""

    # ------------------------------------------------------------------ the test's history
    @classmethod
    def describe(cls, stage) -> str:
        """The stage's conditions in a few words (report and README)."""
        return cls.name

    @classmethod
    def elapsed(cls, stage, strain, cavity):
        """Duration of the stage (s), or None where it follows from the material's response; ``strain``, ``cavity``:
        the total axial strain and the cavity strain at its start (fractions, None where not known)."""
        return stage.duration

    @classmethod
    def strain_after(cls, stage, strain):
        """The total axial strain at the stage's end (fraction), None where it follows from the material."""
        return strain if cls.keeps_axial_strain else None

    @classmethod
    def cavity_after(cls, stage, cavity):
        """The cavity strain at the stage's end (fraction), None where it is not known."""
        return cavity if cls.keeps_cavity_strain else None

    @classmethod
    def stress_target(cls, stage):
        """The effective stress the stage drives the specimen to (p' or sigma'_v, kPa), None when it drives none."""
        return None

    @classmethod
    def consolidation_path(cls, stage):
        """"isotropic" | "K0" of a consolidation, None for the other kinds."""
        return None

    @classmethod
    def loading_phase(cls, stage, current: float) -> str:
        """"loading" | "unloading" | "hold" of the stage from the vertical (or mean) effective stress ``current``
        (kPa) at its start."""
        target = cls.stress_target(stage)
        if cls.holds:
            return "hold"
        if target is not None:
            return "loading" if target >= current else "unloading"
        return "loading"

    @classmethod
    def continues_to_stress(cls, stage) -> bool:
        """Whether the laboratory forward model continues the stage past its last record until sigma'_v reaches
        the stage's to_sigma_v (a crs stage)."""
        return False

    # ------------------------------------------------------------------ the records
    @classmethod
    def control_variable(cls, stage):
        """The quantity the stage controls, its records' abscissa when recorded and monotone (None: time)."""
        return None

    @classmethod
    def held_quantities(cls, stage) -> tuple:
        """The quantities of the stage's records that are not made curves (controlled, or no information)."""
        undrained = cls.drainable and stage.drainage == "undrained"
        return cls.held + (UNDRAINED_HELD if undrained else DRAINED_HELD)

    @classmethod
    def logged(cls, stage, apparatus: str, n: int, now: dict, settings: dict, where: str) -> tuple:
        """Where a laboratory logs the stage for SYNTHETIC records: (abscissa name, abscissae in the file's units,
        time since the stage start in s or None when the abscissa is the time, CSV quantities). ``now``: the
        specimen at the stage start {"p", "sigma_v" (kPa), "strain", "cavity" (% since the test start)}, None
        where not known beforehand, updated to the stage's end; ``n`` points; ``settings`` the [synthetic] table;
        ``where`` names the stage in a LoggingError."""
        raise NotImplementedError(f"{where}: no synthetic records of a {cls.name} stage")


def rate_to(stage, end: str, unit: str) -> str:
    """A ramp at a strain rate in words: "<rate> 1/s to <strain> %" when it ends at a strain (``stage.to_strain``, a
    fraction), else to the stage's field ``end`` in ``unit`` (e.g. "80 kPa")."""
    if stage.to_strain is not None:
        return f"{stage.strain_rate:g} 1/s to {100 * stage.to_strain:g} %"
    return f"{stage.strain_rate:g} 1/s to {getattr(stage, end):g} {unit}"


def one_end(ck, table: dict, where: str, ends: tuple):
    """Check that the stage ``table`` at ``where`` gives at most one of its ``ends`` (field names); the ones given."""
    given = [k for k in ends if k in table]
    if len(given) > 1:
        ck.fail(f"{where}.{given[1]}", table[given[1]], f"the stage ends at {given[0]}: give one end")
    return given
