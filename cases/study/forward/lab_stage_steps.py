"""The steps of one stage of a laboratory programme (:mod:`cases.study.forward.lab_staged`): control rows, stage
times of the steps (knots) and the increments of ``constitutive.labtests.mixed_control``, from the specimen's state
at the stage start. Units kPa, s, 1/s; strains are fractions, compression positive; axial = Voigt 11, radial = 22
and 33.

Controls of each stage kind (one mixed_control call per stage; the control rows of the Voigt components are the
kind's ``controls`` and its ``plan`` calls the builder here, :mod:`cases.study.stages`):
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
  ``to_strain``, or until sigma'_v reaches ``to_sigma_v`` (continued by :mod:`cases.study.forward.lab_staged`), else to
  the last record.
- ``load`` (oedometer): sigma'_v ramped linearly to ``sigma_v`` over ``ramp_time`` (default 1 s), then held until
  the stage's ``duration`` (default one day).
A drained stage that follows an undrained one first dissipates the excess pore pressure at constant total stress on
its stress-controlled components (their effective stress rises by it; ``excess_pore_pressure`` returns to 0).

Stepping: every stage is stepped through its recorded points (values come out AT the records, no interpolation),
with sub-steps between them: strain-controlled ramps in steps of at most the model's ``max_strain_step`` (0.25 %
when the model leaves it to its own triaxial integrator), stress ramps in steps of at most ``STRESS_STEP`` in
ln(stress). The particles of a batch are stepped side by side on aligned steps, each taking as many as its own ramp
asks for and resting through the rest of an interval (``StageSteps.taken``), so that a particle's steps, and its
curves to the bit, are those it has alone whatever the batch (the one exception: the ramp of a load stage of a
rate-independent model takes the grid of its most demanding particle, which differs from the others' only where
their stage starts at different sigma'_v: after a crs or relaxation stage). The holds of a rate-dependent model (the
kinds with ``StageKind.adaptive_hold``: creep, relaxation and the hold of a load stage, whose ramp keeps its equal
ln-stress steps; while ``ADAPTIVE_HOLDS``) are stepped adaptively, per particle, by
``constitutive.labtests.adaptive_control``: from a first step of ``HOLD_FIRST`` s, each step at most the fraction
``HOLD_RATE_CHANGE`` of the time over which the particle's rates change, changing no strain or stress by more than
that fraction of its change since the hold start (beyond a floor of 1e-4 strain, 1 % of the stress) and no strain by
more than the strain step. A hold thus takes few steps where nothing moves yet (the early decades of a hold after a
slow ramp) and about the steps of the geometric grid below where it moves (about 20 per decade of time where it
creeps as 1/t; as accurate as that grid, measured at the independent programmes' prior corners); the step table
(:meth:`StageSteps.steps`) instead places them at times since the hold start growing geometrically from
``HOLD_FIRST`` s, ``HOLD_STEPS_PER_DECADE`` per decade (and the recorded times). A rate-independent model
(``timed=False``) takes a hold at its recorded times only: nothing changes in it but what the first step brings (the
dissipation of an excess pore pressure), so sub-steps would repeat the same state.

Abscissa of a stage's records (``Stage.abscissa``): ``time`` (s since the stage start, every kind), ``axial_strain``
(shear: the stage's own axial strain, magnitude or signed; crs: the total axial strain of the test), ``p`` or
``sigma_v`` (consolidation: the controlled effective stress, kPa). A record outside the stage gives NaN for the
particles where it falls outside (failed).
"""
from __future__ import annotations

import math

import numpy as np

from cases.study.stages import KINDS
from constitutive import labtests
from constitutive.labtests import LinearPath

__all__ = ["StageSteps", "STRESS_STEP", "HOLD_FIRST", "HOLD_STEPS_PER_DECADE", "ADAPTIVE_HOLDS",
           "HOLD_RATE_CHANGE", "FALLBACK_STRAIN_STEP", "DEFAULT_DURATION", "DEFAULT_SHEAR_RATE", "DEFAULT_SHEAR_STRAIN",
           "DEFAULT_RAMP_TIME"]

#: largest change of ln(controlled stress) in one step of a stress ramp
STRESS_STEP = 0.02
#: first time step of a hold (s) and steps per decade of time since the hold start
HOLD_FIRST = 0.1
HOLD_STEPS_PER_DECADE = 20
#: strain step when the model leaves it to its own triaxial integrator (max_strain_step None)
FALLBACK_STRAIN_STEP = 0.0025
#: whether a rate-dependent model takes the holds of the stage kinds that ask for it (``StageKind.adaptive_hold``:
#: creep, relaxation, load) in adaptive steps (module docstring, "Stepping"; False: the step table), and the largest
#: change of the rates over a step there as a fraction of the rates (``adaptive_control``'s rtol: 0.1 is as accurate
#: as the geometric grid of HOLD_STEPS_PER_DECADE = 20 where a hold creeps as 1/t)
ADAPTIVE_HOLDS = True
HOLD_RATE_CHANGE = 0.1
DEFAULT_DURATION = 86400.0
DEFAULT_SHEAR_RATE = 1e-5
DEFAULT_SHEAR_STRAIN = 0.15
DEFAULT_RAMP_TIME = 1.0
NORMAL = labtests.NORMAL


def _linear_knots(points, bound):
    """Knots (K, n) of a linear segment: ``points`` (P, n) the segment start, the records and the end (stage time,
    each row increasing along axis 0 for every particle), each interval split into the number of equal parts that
    ``bound(a, b)`` asks for that particle ((P - 1, n) from the intervals' starts and ends). The particles' intervals
    are aligned on the largest number of parts among them: a particle that needs fewer has taken its own steps when
    its interval ends early, and rests there (its knot repeated, the step not taken), so that its steps are those it
    takes alone. Returns the knots without the start, the knot index of each point after the start, and the steps
    each particle takes (K, n) bool."""
    need = np.maximum(1, bound(points[:-1], points[1:]).astype(int))
    parts = need.max(axis=1)
    last = np.cumsum(parts) - 1
    part = np.arange(last[-1] + 1) - np.repeat(last - parts, parts)  # 1, ..., parts within each interval
    a, b = np.repeat(points[:-1], parts, axis=0), np.repeat(points[1:], parts, axis=0)
    own = np.repeat(need, parts, axis=0)
    taken = part[:, None] <= own
    return a + (b - a) * np.where(taken, part[:, None] / own, 1.0), last, taken


def _hold_first(length):
    """The first time step of a hold of ``length`` s (s)."""
    return min(HOLD_FIRST, length / 10.0)


def _hold_knots(start, end, records, timed=True):
    """Knots of a hold from stage time ``start`` to ``end`` (s, shared by the particles): geometric in the time
    since the hold start (``timed``; else its end only), plus the recorded times ``records`` (within the hold)."""
    length = end - start
    if length <= 0.0 or not timed:
        grid = np.array([end])
    else:
        first = _hold_first(length)
        count = max(2, int(math.ceil(HOLD_STEPS_PER_DECADE * math.log10(length / first))) + 1)
        grid = start + np.geomspace(first, length, count)
        grid[-1] = end
    return np.unique(np.concatenate([grid, np.asarray(records, dtype=float)]))


def _ln_parts(start, end):
    """Steps needed per particle for a stress ramp from ``start`` to ``end`` (n, 6) over the controlled normal
    components (ln-stress steps of at most STRESS_STEP)."""
    def bound(fa, fb):  # ramp fractions (..., n)
        a = start + (end - start) * fa[..., None]
        b = start + (end - start) * fb[..., None]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.abs(np.log(np.maximum(b, 1e-9) / np.maximum(a, 1e-9)))[..., :3]
        return np.ceil(np.nanmax(r, axis=-1) / STRESS_STEP - 1e-9)
    return bound


class StageSteps:
    """The steps of one stage (module docstring) from the specimen at the stage start ``carried`` ({"stress" (n, 6),
    "strain" (n, 6), "u" (n,), ...}), the stage's recorded abscissae ``record_x`` (sorted, unique) and the largest
    strain step; ``timed``: the model is rate dependent (holds sub-stepped in time, module docstring). Attributes:
    ``control`` (6,), ``undrained``, ``knots`` (K, n) stage times of the steps, ``taken`` (K, n) the steps each
    particle takes (None: every step), ``record_index`` the knot of each record, ``outside`` (n,) particles with a
    record outside the stage; :meth:`steps` the increments and time steps."""

    def __init__(self, apparatus, stage, carried, record_x, strain_step, timed=True):
        self.stage, self.apparatus = stage, apparatus
        kind = KINDS.get(apparatus, {}).get(stage.kind)
        if kind is None or apparatus not in kind.controls:
            raise ValueError(f"stage {stage.name}: kind {stage.kind!r} is not run in a {apparatus} apparatus")
        self.control = kind.controls[apparatus]
        if stage.drainage == "undrained" and not kind.drainable:
            raise ValueError(f"stage {stage.name}: a {stage.kind} stage is drained")
        # every strain held (oedometer relaxation): isochoric whatever the drainage, no pore pressure unknown
        self.undrained = stage.drainage == "undrained" and bool(np.any(~self.control & NORMAL))
        self.carried = carried
        self.strain_step, self.timed = strain_step, timed
        n = carried["stress"].shape[0]
        self.n = n
        # effective stress at the start of the path: an excess pore pressure dissipates at the start of a drained
        # stage on its stress-controlled normal components
        self.start = carried["stress"].copy()
        if not self.undrained:
            self.start += np.where(~self.control & NORMAL, carried["u"][:, None], 0.0)
        self.x = np.asarray(record_x, dtype=float)
        self.outside = np.zeros(n, dtype=bool)
        self.taken = None
        #: the sigma'_v a crs stage continues to past its last record (kPa; None: none)
        self.to_sigma_v = None
        kind.plan(self)
        self.adaptive = ADAPTIVE_HOLDS and timed and kind.adaptive_hold

    # each builder (called by the kind's ``plan``) sets knots (K, n), record_index (len(x),), strain_path (the
    # controlled strains since the stage start) and stress_path (the controlled effective stresses), LinearPath of
    # the stage time
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

    def _segments(self, ends, firsts, largest, rtols):
        """The smooth pieces of a stage stepped adaptively: (ends, first steps, largest steps) (stage times, s) and
        the step control's rtol (inf: none), each (S, n)."""
        self.segments = tuple(np.array([np.broadcast_to(np.asarray(v, dtype=float), (self.n,)) for v in x])
                              for x in (ends, firsts, largest, rtols))

    def _held_stress(self):
        return LinearPath.constant(self.start)

    def _no_strain(self):
        return LinearPath.constant(np.zeros((self.n, 6)))

    def hold(self, duration):
        """A hold of ``duration`` s (default one day): every controlled variable held, records against time."""
        duration = float(duration if duration is not None else DEFAULT_DURATION)
        if self.stage.abscissa != "time":
            raise ValueError(f"stage {self.stage.name}: records of a {self.stage.kind} stage are against time")
        tau = self._tau_records(np.broadcast_to(self.x[:, None], (len(self.x), self.n)), np.full(self.n, duration))
        grid = _hold_knots(0.0, duration, tau[:, 0], self.timed)
        self.knots = np.broadcast_to(grid[:, None], (grid.size, self.n))
        self.record_index = np.searchsorted(grid, tau[:, 0])
        self._segments([duration], [_hold_first(duration)], [np.inf], [HOLD_RATE_CHANGE])
        self.stress_path = self._held_stress()
        self.strain_path = self._no_strain()

    def consolidation_ramp(self):
        """The effective stresses ramped linearly in time to the consolidation's target."""
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
        knots, index, self.taken = _linear_knots(pts, _ln_parts(start, end))
        self.record_index = self._place_records(index, order)
        self.knots = knots * duration
        self.stress_path = LinearPath.ramp(start, end, np.full(self.n, duration))
        self.strain_path = self._no_strain()

    def _strain_ramp(self, rate, end_tau, tau_rec):
        """Axial strain = rate x stage time, records at stage times tau_rec (R, n), end (n,)."""
        tau_rec = self._tau_records(tau_rec, end_tau)
        pts, order = self._points(tau_rec, end_tau)
        step = self.strain_step
        knots, index, self.taken = _linear_knots(pts, lambda a, b: np.ceil(np.abs(rate) * (b - a) / step - 1e-9))
        self.knots, self.record_index = knots, self._place_records(index, order)
        self.stress_path = self._held_stress()
        end_strain = np.zeros((self.n, 6))
        end_strain[:, 0] = rate  # after a stage time of 1 s
        self.strain_path = LinearPath.ramp(np.zeros((self.n, 6)), end_strain, np.ones(self.n))

    def shear_ramp(self):
        """The axial strain at the shear's rate, signed by its direction, to its end."""
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

    def crs_ramp(self):
        """The axial strain at the crs stage's signed rate to its end (or its last record, continued to to_sigma_v
        by the programme)."""
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

    def load_ramp_and_hold(self):
        """sigma'_v ramped to the load stage's target over its ramp_time, then held to its duration."""
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
            knots, _, taken = _linear_knots(fractions, _ln_parts(start, end))
            ramp_knots = knots[:, np.argmax(taken.sum(axis=0))] * ramp   # the grid of the most demanding particle
        else:
            ramp_knots = np.zeros(0)
        hold = _hold_knots(ramp, duration, t[~in_ramp], self.timed)
        # adaptive: the ramp in equal steps (those of a ramp without records), then the hold
        base = ramp / np.maximum(_ln_parts(start, end)(np.zeros(self.n), np.ones(self.n)), 1.0)
        self._segments([ramp, duration], [base, _hold_first(duration - ramp)], [base, np.inf],
                       [np.inf, HOLD_RATE_CHANGE])
        grid = np.unique(np.concatenate([ramp_knots, t[in_ramp], hold]))
        self.knots = np.broadcast_to(grid[:, None], (grid.size, self.n))
        self.record_index = np.searchsorted(grid, t)
        self.stress_path = (LinearPath.ramp(start, end, np.full(self.n, ramp), capped=True) if ramp > 0 else
                            LinearPath.constant(end))
        self.strain_path = self._no_strain()

    # ------------------------------------------------------------------ the adaptive path (``adaptive``)
    def records(self):
        """Stage times (R, n) of the records (in the order of ``record_x``)."""
        return self.knots[self.record_index]

    def target(self):
        """The path of ``constitutive.labtests.adaptive_control`` (LinearPath): the controlled strains since the
        stage start and the controlled total stresses (effective when drained; undrained the stress at the stage
        start, held)."""
        stress = LinearPath.constant(self.carried["stress"]) if self.undrained else self.stress_path
        return self.strain_path.where(self.control, stress)

    # ------------------------------------------------------------------ the step table
    def steps(self):
        """(increments (K, n, 6), dt (K, n)) for mixed_control from the carried state."""
        knots = self.knots
        prev = np.concatenate([np.zeros((1, self.n)), knots[:-1]], axis=0)
        dt = knots - prev
        strain = self.strain_path.values(knots)
        strain_prev = np.concatenate([np.zeros((1, self.n, 6)), strain[:-1]], axis=0)
        stress = self.stress_path.values(knots)
        stress_prev = np.concatenate([self.carried["stress"][None], stress[:-1]], axis=0)
        inc = np.where(self.control, strain - strain_prev, stress - stress_prev)
        if self.undrained:  # total stresses held: increments of zero on the stress-controlled components
            inc = np.where(self.control, inc, 0.0)
        return inc, dt
