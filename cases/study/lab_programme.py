"""Staged laboratory programmes (triaxial cell, oedometer) driven stage by stage through
``constitutive.labtests.mixed_control``, batched over particles (a model whose parameters are (n,) arrays).

A test (:class:`cases.study.programme.TestSpec` with ``apparatus``, ``initial`` and ``stages``) starts from its
initial state and runs its stages in order; stress, model state, strain, excess pore pressure and time are carried
from one stage to the next. Units kPa, s, 1/s; strains are fractions, compression positive; axial = Voigt 11,
radial = 22 and 33.

Controls of each stage kind (one mixed_control call per stage, ``STRAIN``/``STRESS`` rows of the Voigt components):
- ``consolidation``, drained, linear ramp in time over ``duration`` (default one day): triaxial cell: every normal
  effective stress ramped from the current value to the target (``p``: isotropic; ``sigma_v`` with ``K0``:
  sigma'_h = K0 sigma'_v; ``sigma_v`` alone: the current ratio sigma'_r/sigma'_a kept); oedometer: sigma'_v ramped,
  radial strain zero. A lower target is swelling.
- ``shear`` (triaxial): axial strain at ``strain_rate`` (magnitude; default 1e-5 1/s), signed by ``direction``
  (compression +, extension -), radial total stress held; undrained: volume held, the excess pore pressure an
  unknown. It ends at ``to_strain`` (the stage's own axial strain), else at the last record, else at 15 %.
- ``creep``: every controlled stress held for ``duration`` (triaxial: axial and radial; oedometer: sigma'_v with
  radial strain zero); undrained: total stresses held, volume held.
- ``relaxation``: axial strain held for ``duration`` (triaxial: radial stress held; oedometer: radial strain zero).
- ``crs`` (oedometer): axial strain at the SIGNED ``strain_rate`` (< 0 unloading) to the total axial strain
  ``to_strain``, or until sigma'_v reaches ``to_sigma_v`` (the crossing located within the last strain step by
  CROSSING_ITERATIONS regula-falsi iterations), else to the last record.
- ``load`` (oedometer): sigma'_v ramped linearly to ``sigma_v`` over ``ramp_time`` (default 1 s), then held until
  the stage's ``duration`` (default one day).
A drained stage that follows an undrained one first dissipates the excess pore pressure at constant total stress on
its stress-controlled components (their effective stress rises by it; ``excess_pore_pressure`` returns to 0).

Stepping: every stage is stepped through its recorded points (values come out AT the records, no interpolation),
with sub-steps between them: strain-controlled ramps in steps of at most the model's ``max_strain_step`` (0.25 %
when the model leaves it to its own triaxial integrator), stress ramps in steps of at most ``STRESS_STEP`` in
ln(stress), holds at times since the hold start growing geometrically from ``HOLD_FIRST`` s,
``HOLD_STEPS_PER_DECADE`` per decade (and the recorded times).

Abscissa of a stage's records (``Stage.abscissa``): ``time`` (s since the stage start, every kind), ``axial_strain``
(shear: the stage's own axial strain, magnitude or signed; crs: the total axial strain of the test), ``p`` or
``sigma_v`` (consolidation: the controlled effective stress, kPa). A record outside the stage gives NaN for the
particles where it falls outside (failed).

Initial state per test (``InitialState``): effective stress ``p0`` (isotropic) or ``sigma_v0`` with ``K0``; void
ratio ``e0`` (else the flat ``TestSpec.e0``, else the ``e0`` argument, else the model's own ``e0`` parameter); for a
model whose void ratio is a parameter (ANICREEP: (1 + e0) enters its elasticity, hardening, fluidity mu, omega and the
void-ratio update) the test's e0 replaces that parameter for the test. Preconsolidation: ``preconsolidation``
(vertical, kPa) or ``ocr`` (relative to sigma'_v0, or p0 when isotropic); ANICREEP: sigma_p0 = preconsolidation
(= ocr sigma'_v0); Modified Cam Clay: ocr = preconsolidation / sigma'_v0, i.e. the yield surface through the initial
stress scaled by ocr (the surface through the stress ratio's preconsolidation state; for an isotropic start
p'_c0 = ocr p'_0); neither given: the model's parameter (MCC ocr/pc0, ANICREEP sigma_p0) applies. A model without a
preconsolidation state (SIMSAND) refuses them (ValueError).

A particle whose initial state is refused by the model or whose integration fails gets NaN curves and
``failed = True``; no exception for a particle.

Quantities (curve key ``<quantity>`` for a one-stage test, ``<quantity>@<stage name>`` otherwise; ``e`` and ``u``
are aliases of void_ratio and excess_pore_pressure): q (sigma'_a - sigma'_r, kPa), p (p', kPa), void_ratio,
volumetric_strain and axial_strain (% since the test start), excess_pore_pressure (kPa since the test start),
pore_pressure (u0 + excess, kPa), axial_stress, radial_stress (effective, kPa), time (s since the test start),
stress_ratio (q/p'), mean_stress (p').
"""
from __future__ import annotations

import math

import numpy as np

from constitutive import labtests
from constitutive.base import ParameterError

from .programme import split_key

__all__ = ["simulate_programme", "specimen_model", "STAGE_CONTROLS", "QUANTITIES", "ALIASES", "STRESS_STEP",
           "HOLD_FIRST", "HOLD_STEPS_PER_DECADE", "DEFAULT_DURATION", "DEFAULT_SHEAR_RATE", "DEFAULT_SHEAR_STRAIN"]

STRAIN, STRESS = True, False
TRIAXIAL_STRESS = np.array([STRESS, STRESS, STRESS, STRAIN, STRAIN, STRAIN])   # every normal stress controlled
TRIAXIAL_AXIAL = np.array([STRAIN, STRESS, STRESS, STRAIN, STRAIN, STRAIN])    # axial strain, radial stress
OEDOMETER_STRESS = np.array([STRESS, STRAIN, STRAIN, STRAIN, STRAIN, STRAIN])  # sigma'_v, radial strain zero
OEDOMETER_STRAIN = np.ones(6, dtype=bool)                                      # every strain controlled
#: (apparatus, kind) -> control rows
STAGE_CONTROLS = {("triaxial", "consolidation"): TRIAXIAL_STRESS, ("triaxial", "shear"): TRIAXIAL_AXIAL,
                  ("triaxial", "creep"): TRIAXIAL_STRESS, ("triaxial", "relaxation"): TRIAXIAL_AXIAL,
                  ("oedometer", "consolidation"): OEDOMETER_STRESS, ("oedometer", "creep"): OEDOMETER_STRESS,
                  ("oedometer", "relaxation"): OEDOMETER_STRAIN, ("oedometer", "crs"): OEDOMETER_STRAIN,
                  ("oedometer", "load"): OEDOMETER_STRESS}
QUANTITIES = ("q", "p", "void_ratio", "volumetric_strain", "axial_strain", "excess_pore_pressure", "pore_pressure",
              "axial_stress", "radial_stress", "time", "stress_ratio", "mean_stress")
ALIASES = {"e": "void_ratio", "u": "excess_pore_pressure", "sigma_v": "axial_stress"}
#: largest change of ln(controlled stress) in one step of a stress ramp
STRESS_STEP = 0.02
#: first time step of a hold (s) and steps per decade of time since the hold start
HOLD_FIRST = 0.1
HOLD_STEPS_PER_DECADE = 20
#: strain step when the model leaves it to its own triaxial integrator (max_strain_step None)
FALLBACK_STRAIN_STEP = 0.0025
DEFAULT_DURATION = 86400.0
DEFAULT_SHEAR_RATE = 1e-5
DEFAULT_SHEAR_STRAIN = 0.15
DEFAULT_RAMP_TIME = 1.0
#: regula-falsi iterations locating the end of a crs stage at to_sigma_v within its last strain step
CROSSING_ITERATIONS = 4
NORMAL = labtests.NORMAL


# ---------------------------------------------------------------------------------------------- the specimen
def _rebuild(model, changes: dict):
    """A model of the same class and switches with some parameters replaced (None removes one)."""
    cls = type(model)
    args = {k: v for k, v in model.parameters().items() if v is not None}
    args.update(changes)
    args = {k: v for k, v in args.items() if v is not None}
    args.update({s: getattr(model, s) for s in cls.switches})
    if cls.oriented:
        args["vertical_axis"] = model.vertical_axis
    return cls(**args)


def specimen_model(model, initial, e0=None):
    """(the model for this specimen, its void ratio at the start) from the test's initial state (module
    docstring, "Initial state"). ``e0``: the void ratio when the test gives none (scalar or (n,))."""
    changes = {}
    start_e = initial.e0 if initial.e0 is not None else e0
    if type(model).void_ratio_parameter:
        if start_e is not None:
            changes["e0"] = start_e
        else:
            start_e = model.e0
    if start_e is None:
        raise ValueError(f"{model.name}: the test gives no initial void ratio e0")
    pre = initial.preconsolidation
    if pre is None and initial.ocr is not None:
        pre = initial.ocr * initial.vertical
    if pre is not None:
        names = type(model).parameter_names
        if "sigma_p0" in names:
            changes["sigma_p0"] = pre
        elif "ocr" in names:
            changes.update(ocr=pre / initial.vertical, pc0=None)
        else:
            raise ValueError(f"{model.name} has no preconsolidation state: a test's ocr / preconsolidation does not "
                             f"apply")
    return (_rebuild(model, changes) if changes else model), start_e


def _initial_stress(initial, n):
    stress = np.zeros((n, 6))
    if initial.p0 is not None:
        stress[:, :3] = initial.p0
    else:
        stress[:, 0] = initial.sigma_v0
        stress[:, 1] = stress[:, 2] = initial.K0 * initial.sigma_v0
    return stress


def _particle(model, i):
    """The one-particle model of particle i of a batched model."""
    return _rebuild(model, {k: (np.asarray(v)[i] if np.ndim(v) else v)
                            for k, v in model.parameters().items() if v is not None})


def _start_state(model, stress, e, n):
    """(state, refused (n,)): the model's initial state; a particle whose start the model refuses is marked and
    given the state of an accepted one (its curves become NaN)."""
    e = np.broadcast_to(np.asarray(e, dtype=float), (n,))
    try:
        return model.initial_state(stress, e), np.zeros(n, dtype=bool)
    except (ValueError, ParameterError):
        if n == 1:
            return None, np.ones(1, dtype=bool)
    refused = np.zeros(n, dtype=bool)
    for i in range(n):
        try:
            _particle(model, i).initial_state(stress[i:i + 1], e[i:i + 1])
        except (ValueError, ParameterError):
            refused[i] = True
    if np.all(refused):
        return None, refused
    good = int(np.flatnonzero(~refused)[0])
    stress[refused] = stress[good]
    e = np.where(refused, e[good], e)
    trial = _rebuild(model, {k: (np.where(refused, np.asarray(v)[good], v) if np.ndim(v) else v)
                             for k, v in model.parameters().items() if v is not None})
    state = trial.initial_state(stress, e)
    return state, refused


# ---------------------------------------------------------------------------------------------- stepping plans
def _linear_knots(points, bound):
    """Knots (K, n) of a linear segment: ``points`` (P, n) the segment start, the records and the end (stage time,
    each row increasing along axis 0 for every particle), each interval split in the largest number of equal parts
    that ``bound(a, b)`` (the parts needed per particle, (n,)) asks for over the particles. Returns the knots
    without the start and the knot index of each point after the start."""
    knots, index = [], []
    for a, b in zip(points[:-1], points[1:]):
        parts = max(1, int(np.max(bound(a, b))))
        knots += [a + (b - a) * (j / parts) for j in range(1, parts + 1)]
        index.append(len(knots) - 1)
    return np.array(knots), np.array(index)


def _hold_knots(start, end, records):
    """Knots of a hold from stage time ``start`` to ``end`` (s, shared by the particles): geometric in the time
    since the hold start, plus the recorded times ``records`` (within the hold)."""
    length = end - start
    if length <= 0.0:
        grid = np.array([end])
    else:
        first = min(HOLD_FIRST, length / 10.0)
        count = max(2, int(math.ceil(HOLD_STEPS_PER_DECADE * math.log10(length / first))) + 1)
        grid = start + np.geomspace(first, length, count)
        grid[-1] = end
    return np.unique(np.concatenate([grid, np.asarray(records, dtype=float)]))


def _ln_parts(start, end):
    """Steps needed per particle for a stress ramp from ``start`` to ``end`` (n, 6) over the controlled normal
    components (ln-stress steps of at most STRESS_STEP)."""
    def bound(fa, fb):
        a = start + (end - start) * fa[:, None]
        b = start + (end - start) * fb[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.abs(np.log(np.maximum(b, 1e-9) / np.maximum(a, 1e-9)))[:, :3]
        return np.ceil(np.nanmax(r, axis=1) / STRESS_STEP - 1e-9)
    return bound


def _ramp_target(start, end, fraction):
    """Stress (K, n, 6) at ramp fractions (K, n)."""
    return start[None] + (end - start)[None] * fraction[..., None]


class _Stage:
    """The stepping of one stage (module docstring, "Controls"), built from the carried state of the specimen."""

    def __init__(self, apparatus, stage, carried, record_x, strain_step):
        self.stage, self.apparatus = stage, apparatus
        kind = stage.kind
        if (apparatus, kind) not in STAGE_CONTROLS:
            raise ValueError(f"stage {stage.name}: kind {kind!r} is not run in a {apparatus} apparatus")
        self.control = STAGE_CONTROLS[(apparatus, kind)]
        self.undrained = stage.drainage == "undrained"
        if self.undrained and kind not in ("shear", "creep", "relaxation"):
            raise ValueError(f"stage {stage.name}: a {kind} stage is drained")
        self.carried = carried
        self.strain_step = strain_step
        n = carried["stress"].shape[0]
        self.n = n
        # effective stress at the start of the path: an excess pore pressure dissipates at the start of a drained
        # stage on its stress-controlled normal components
        self.start = carried["stress"].copy()
        if not self.undrained:
            self.start += np.where(~self.control & NORMAL, carried["u"][:, None], 0.0)
        x = np.asarray(record_x, dtype=float)
        self.x = x
        self.outside = np.zeros(n, dtype=bool)
        getattr(self, "_" + kind)()

    # each builder sets self.knots (K, n), self.record_index (len(x),), self.strain_target and self.stress_target
    # (functions of the knots -> (K, n, 6) on the controlled components), self.dt_of (knots -> time (K, n))
    def _tau_records(self, tau, end):
        """Record stage times (R, n) checked against [0, end] (n,): particles with a record outside are marked."""
        tol = 1e-9 * np.maximum(1.0, np.abs(end))
        self.outside |= np.any((tau < -tol) | (tau > end + tol), axis=0)
        return np.clip(tau, 0.0, end)

    def _points(self, tau_rec, end):
        """(P, n) segment points: 0, the records in stage-time order, the end; and the order of the records."""
        order = np.argsort(tau_rec.mean(axis=1), kind="stable")
        pts = np.concatenate([np.zeros((1, self.n)), tau_rec[order], end[None]], axis=0)
        pts = np.maximum.accumulate(pts, axis=0)
        return pts, order

    def _place_records(self, index, order):
        """Knot index of each record (in the given order of self.x) from the knot index of the sorted points."""
        rec = np.empty(len(order), dtype=int)
        rec[order] = index[:-1]
        return rec

    def _zero_stress(self):
        return lambda knots: np.broadcast_to(self.start, knots.shape + (6,))

    def _hold(self, duration):
        duration = float(duration if duration is not None else DEFAULT_DURATION)
        if self.stage.abscissa != "time":
            raise ValueError(f"stage {self.stage.name}: records of a {self.stage.kind} stage are against time")
        tau = self._tau_records(np.broadcast_to(self.x[:, None], (len(self.x), self.n)), np.full(self.n, duration))
        grid = _hold_knots(0.0, duration, tau[:, 0])
        self.knots = np.broadcast_to(grid[:, None], (grid.size, self.n))
        self.record_index = np.searchsorted(grid, tau[:, 0])
        self.stress_target = self._zero_stress()
        self.strain_target = lambda knots: np.zeros(knots.shape + (6,))

    def _creep(self):
        self._hold(self.stage.duration)

    def _relaxation(self):
        self._hold(self.stage.duration)

    def _consolidation(self):
        st = self.stage
        duration = float(st.duration if st.duration is not None else DEFAULT_DURATION)
        end = self.start.copy()
        if self.apparatus == "oedometer":
            if st.sigma_v is None:
                raise ValueError(f"stage {st.name}: an oedometer consolidation goes to sigma_v")
            end[:, 0] = st.sigma_v
        elif st.p is not None:
            end[:, :3] = st.p
        else:
            ratio = st.K0 if st.K0 is not None else 0.5 * (self.start[:, 1] + self.start[:, 2]) / self.start[:, 0]
            end[:, 0] = st.sigma_v
            end[:, 1] = end[:, 2] = ratio * st.sigma_v
        start = self.start
        if st.abscissa == "time":
            frac = self.x[:, None] / duration + np.zeros((1, self.n))
        elif st.abscissa in ("p", "sigma_v"):
            if st.abscissa == "p" and self.apparatus == "oedometer":
                raise ValueError(f"stage {st.name}: an oedometer consolidation is recorded against sigma_v or time")
            a, b = ((start[:, :3].mean(axis=1), end[:, :3].mean(axis=1)) if st.abscissa == "p"
                    else (start[:, 0], end[:, 0]))
            with np.errstate(divide="ignore", invalid="ignore"):
                frac = (self.x[:, None] - a[None]) / (b - a)[None]
            frac = np.where(np.isfinite(frac), frac, 1.0)
        else:
            raise ValueError(f"stage {st.name}: a consolidation is recorded against time, p or sigma_v")
        frac = self._tau_records(frac, np.ones(self.n))
        pts, order = self._points(frac, np.ones(self.n))
        knots, index = _linear_knots(pts, _ln_parts(start, end))
        self.record_index = self._place_records(index, order)
        self.knots = knots * duration
        self.stress_target = lambda k: _ramp_target(start, end, k / duration)
        self.strain_target = lambda k: np.zeros(k.shape + (6,))

    def _strain_ramp(self, rate, end_tau, tau_rec):
        """Axial strain = rate x stage time, records at stage times tau_rec (R, n), end (n,)."""
        tau_rec = self._tau_records(tau_rec, end_tau)
        pts, order = self._points(tau_rec, end_tau)
        step = self.strain_step
        knots, index = _linear_knots(pts, lambda a, b: np.ceil(np.abs(rate) * (b - a) / step - 1e-9))
        self.knots, self.record_index = knots, self._place_records(index, order)
        self.stress_target = self._zero_stress()

        def strain(k):
            out = np.zeros(k.shape + (6,))
            out[..., 0] = rate * k
            return out
        self.strain_target = strain

    def _shear(self):
        st = self.stage
        sign = -1.0 if st.direction == "extension" else 1.0
        rate = abs(st.strain_rate) if st.strain_rate else DEFAULT_SHEAR_RATE
        if st.abscissa == "axial_strain":
            tau = np.abs(self.x)[:, None] / rate + np.zeros((1, self.n))
        elif st.abscissa == "time":
            tau = self.x[:, None] + np.zeros((1, self.n))
        else:
            raise ValueError(f"stage {st.name}: a shear stage is recorded against axial_strain or time")
        if st.to_strain is not None:
            end = abs(st.to_strain) / rate
        else:
            end = float(tau.max()) if tau.size else DEFAULT_SHEAR_STRAIN / rate
        self._strain_ramp(sign * rate, np.full(self.n, end), tau)

    def _crs(self):
        st = self.stage
        if not st.strain_rate:
            raise ValueError(f"stage {st.name}: a crs stage needs a non-zero strain_rate")
        rate = float(st.strain_rate)
        eps0 = self.carried["strain"][:, 0]
        if st.abscissa == "axial_strain":
            tau = (self.x[:, None] - eps0[None]) / rate
        elif st.abscissa == "time":
            tau = self.x[:, None] + np.zeros((1, self.n))
        else:
            raise ValueError(f"stage {st.name}: a crs stage is recorded against axial_strain or time")
        if st.to_strain is not None:
            end = (st.to_strain - eps0) / rate
        elif tau.size:
            end = tau.max(axis=0)
        else:
            end = np.zeros(self.n)
        self.to_sigma_v = st.to_sigma_v if st.to_strain is None else None
        self.rate = rate
        self._strain_ramp(rate, np.maximum(end, 0.0), tau)

    def _load(self):
        st = self.stage
        if st.sigma_v is None:
            raise ValueError(f"stage {st.name}: a load stage needs sigma_v")
        if st.abscissa != "time":
            raise ValueError(f"stage {st.name}: records of a load stage are against time")
        ramp = float(st.ramp_time if st.ramp_time is not None else DEFAULT_RAMP_TIME)
        duration = float(st.duration if st.duration is not None else DEFAULT_DURATION)
        if duration < ramp:
            raise ValueError(f"stage {st.name}: duration {duration:g} s is shorter than its ramp_time {ramp:g} s")
        tau = self._tau_records(np.broadcast_to(self.x[:, None], (len(self.x), self.n)), np.full(self.n, duration))
        t = tau[:, 0]
        start, end = self.start, self.start.copy()
        end[:, 0] = st.sigma_v
        in_ramp = t <= ramp
        if ramp > 0:  # the ramp's knots: fractions of the ramp split by ln-stress steps, in stage time
            fractions = np.concatenate([[0.0], np.sort(t[in_ramp]) / ramp, [1.0]])[:, None] + np.zeros((1, self.n))
            ramp_knots = _linear_knots(fractions, _ln_parts(start, end))[0][:, 0] * ramp
        else:
            ramp_knots = np.zeros(0)
        hold = _hold_knots(ramp, duration, t[~in_ramp])
        grid = np.unique(np.concatenate([ramp_knots, t[in_ramp], hold]))
        self.knots = np.broadcast_to(grid[:, None], (grid.size, self.n))
        self.record_index = np.searchsorted(grid, t)
        self.stress_target = (lambda k: _ramp_target(start, end, np.minimum(k / ramp, 1.0))) if ramp > 0 else \
            (lambda k: np.broadcast_to(end, k.shape + (6,)))
        self.strain_target = lambda k: np.zeros(k.shape + (6,))

    # ------------------------------------------------------------------ the step table
    def steps(self):
        """(increments (K, n, 6), dt (K, n)) for mixed_control from the carried state."""
        knots = self.knots
        prev = np.concatenate([np.zeros((1, self.n)), knots[:-1]], axis=0)
        dt = knots - prev
        strain = self.strain_target(knots)
        strain_prev = np.concatenate([np.zeros((1, self.n, 6)), strain[:-1]], axis=0)
        stress = self.stress_target(knots)
        stress_prev = np.concatenate([self.carried["stress"][None], stress[:-1]], axis=0)
        inc = np.where(self.control, strain - strain_prev, stress - stress_prev)
        if self.undrained:  # total stresses held: increments of zero on the stress-controlled components
            inc = np.where(self.control, inc, 0.0)
        return inc, dt


# ---------------------------------------------------------------------------------------------- the programme
def _select(mask, a, b):
    """Per-particle choice between two arrays or state dicts: a where mask, else b."""
    if isinstance(a, dict):
        return {k: _select(mask, a[k], b[k]) for k in a}
    return np.where(mask.reshape((-1,) + (1,) * (np.ndim(a) - 1)), a, b)


def _run(model, carried, control, inc, dt, undrained, record):
    hist = labtests.mixed_control(model, carried["stress"], carried["state"], control, inc, dt,
                                  undrained=undrained, record=record, on_failure="nan")
    return hist


def _advance(carried, hist, u_start):
    """The carried specimen after a mixed_control history (final record)."""
    return {"stress": hist["stress"][:, -1], "state": hist["state"], "strain": carried["strain"] +
            hist["strain"][:, -1], "u": u_start + hist["pore_pressure"][:, -1],
            "t": carried["t"] + hist["time"][:, -1], "failed": carried["failed"] | hist["failed"]}


def _to_sigma_v(model, carried, rate, target, step, max_steps=4000):
    """Continue a crs stage (oedometer, all strains controlled) until sigma'_v reaches ``target`` for every
    particle: strain steps of ``step`` at ``rate``; the step that crosses is repeated with the secant fraction."""
    n = carried["stress"].shape[0]
    sign = np.sign(target - carried["stress"][:, 0])
    done = (sign == 0) | carried["failed"]
    h = math.copysign(step, rate)
    for _ in range(max_steps):
        if np.all(done):
            break
        inc = np.zeros((1, n, 6))
        inc[0, :, 0] = np.where(done, 0.0, h)
        dt = np.where(done, 0.0, abs(h / rate))[None]
        hist = _run(model, carried, OEDOMETER_STRAIN, inc, dt, False, None)
        nxt = _advance(carried, hist, carried["u"])
        s0, s1 = carried["stress"][:, 0], nxt["stress"][:, 0]
        crossed = ~done & (np.sign(target - s1) != sign)
        if np.any(crossed):  # regula falsi on the fraction of the step that reaches the target
            lo, hi, s_lo, s_hi = np.zeros(n), np.ones(n), s0, s1
            for _ in range(CROSSING_ITERATIONS):
                with np.errstate(divide="ignore", invalid="ignore"):
                    f = lo + (target - s_lo) * (hi - lo) / (s_hi - s_lo)
                f = np.where(np.isfinite(f) & crossed, np.clip(f, lo, hi), 0.0)
                hist2 = _run(model, carried, OEDOMETER_STRAIN, inc * f[None, :, None], dt * f[None], False, None)
                cut = _advance(carried, hist2, carried["u"])
                s_f = cut["stress"][:, 0]
                below = np.sign(target - s_f) == sign
                lo, s_lo = np.where(below, f, lo), np.where(below, s_f, s_lo)
                hi, s_hi = np.where(below, hi, f), np.where(below, s_hi, s_f)
            nxt = _select(crossed, cut, nxt) | {"failed": nxt["failed"] | cut["failed"]}
        carried = _select(~done, nxt, carried) | {"failed": nxt["failed"]}
        done |= crossed | carried["failed"]
    carried["failed"] = carried["failed"] | ~done
    return carried


def _quantities(hist, carried, u_start, u0):
    """Named quantities (n, R) of a stage's recorded history, in the units of the module docstring."""
    s = hist["stress"]
    strain = carried["strain"][:, None] + hist["strain"]
    axial, radial = s[..., 0], 0.5 * (s[..., 1] + s[..., 2])
    q, p = axial - radial, s[..., :3].mean(axis=-1)
    u = u_start[:, None] + hist["pore_pressure"]
    return {"q": q, "p": p, "void_ratio": hist["void_ratio"],
            "volumetric_strain": 100.0 * strain[..., :3].sum(axis=-1), "axial_strain": 100.0 * strain[..., 0],
            "excess_pore_pressure": u, "pore_pressure": u0 + u, "axial_stress": axial, "radial_stress": radial,
            "time": carried["t"][:, None] + hist["time"], "stress_ratio": q / p, "mean_stress": p}


def _keys_by_stage(spec, keys):
    """{stage name: [curve keys]} (a key without a stage belongs to the only stage of a one-stage test)."""
    out = {s.name: [] for s in spec.stages}
    for key in keys:
        quantity, stage = split_key(key)
        if stage is None:
            if len(spec.stages) != 1:
                raise ValueError(f"test {spec.name}: curve {key!r} names no stage (<quantity>@<stage name>)")
            stage = spec.stages[0].name
        if stage not in out:
            raise ValueError(f"test {spec.name}: curve {key!r}: no stage {stage!r}")
        if ALIASES.get(quantity, quantity) not in QUANTITIES:
            raise ValueError(f"test {spec.name}: curve {key!r}: unknown quantity {quantity!r} (known: "
                             f"{', '.join(QUANTITIES + tuple(ALIASES))})")
        out[stage].append(key)
    return out


def simulate_programme(model, spec, abscissae: dict, n: int, e0=None):
    """Curves of a staged laboratory test for n particles (module docstring).

    model: a material-point model whose parameters are scalars or (n,) arrays; spec: TestSpec with ``apparatus``
    (triaxial | oedometer), ``initial`` and ``stages``; abscissae: {curve key: recorded abscissae} in the stage's
    abscissa unit (strain as a fraction, time in s since the stage start, stress in kPa); e0: the void ratio at the
    start when the test gives none (scalar or (n,)). Returns ({curve key: (n, len(x)) values}, failed (n,) bool);
    a failed particle's curves are NaN.
    """
    if spec.apparatus not in ("triaxial", "oedometer"):
        raise ValueError(f"test {spec.name}: apparatus {spec.apparatus!r} is not a laboratory cell (triaxial, "
                         f"oedometer)")
    model, start_e = specimen_model(model, spec.initial, e0)
    stress0 = _initial_stress(spec.initial, n)
    state, refused = _start_state(model, stress0, start_e, n)
    by_stage = _keys_by_stage(spec, abscissae)
    out = {k: np.full((n, len(np.atleast_1d(abscissae[k]))), np.nan) for k in abscissae}
    if state is None:
        return out, np.ones(n, dtype=bool)
    step = model.max_strain_step or FALLBACK_STRAIN_STEP
    carried = {"stress": stress0, "state": state, "strain": np.zeros((n, 6)), "u": np.zeros(n),
               "t": np.zeros(n), "failed": refused.copy()}
    u0 = spec.initial.u0
    for stage in spec.stages:
        keys = by_stage[stage.name]
        xs = [np.atleast_1d(np.asarray(abscissae[k], dtype=float)) for k in keys]
        x_all = np.unique(np.concatenate(xs)) if xs else np.zeros(0)
        plan = _Stage(spec.apparatus, stage, carried, x_all, step)
        inc, dt = plan.steps()
        record = np.zeros(len(dt), dtype=bool)
        record[plan.record_index] = True
        record[-1] = True  # the stage's end state is carried on
        u_start = carried["u"] if plan.undrained else np.zeros(n)
        hist = _run(model, carried, plan.control, inc, dt, plan.undrained, record)
        if keys:
            values = _quantities(hist, carried, u_start, u0)
            slot = np.cumsum(record)  # history column of each recorded knot (column 0: the stage start)
            for key, x in zip(keys, xs):
                quantity = ALIASES.get(split_key(key)[0], split_key(key)[0])
                cols = slot[plan.record_index[np.searchsorted(x_all, x)]]
                out[key] = values[quantity][:, cols]
        carried = _advance(carried, hist, u_start)
        carried["failed"] |= plan.outside
        if stage.kind == "crs" and plan.to_sigma_v is not None:
            carried = _to_sigma_v(model, carried, plan.rate, plan.to_sigma_v, step)
    failed = carried["failed"] | ~np.all([np.all(np.isfinite(v), axis=1) for v in out.values()] or
                                         [np.ones(n, dtype=bool)], axis=0)
    for key in out:
        out[key][failed] = np.nan
    return out, failed
