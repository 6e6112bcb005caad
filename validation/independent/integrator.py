"""Mixed-control explicit integration of an axisymmetric material point (the independent generator's own scheme).

Each component, axial (a) and radial (r), is either strain controlled (d eps_i/dt given) or stress controlled
(d sigma'_i/dt given) during a stage: triaxial drained shear = axial strain and radial stress; undrained shear =
both strains (d eps_r = -d eps_a / 2: volume held); oedometer = radial strain zero; creep = both stresses held;
relaxation = axial strain held. In (a, r) components (compression positive, radial counted twice in the work)
    d sigma_ar = S D T d eps_ar - S c,   T = [[1, 2], [2/3, -2/3]] (eps_v, eps_q from eps_a, eps_r),
                                         S = [[1, 2/3], [1, -1/3]] (sigma_a, sigma_r from p, q),                (1)
with D the tangent in (p, q) -- elastic De = diag(K, 3G) or elastoplastic De - De n n^T De / (n De n + H) -- and
c = De (d(eps^vp) + (d eps_s, 0)) the viscous part (the creep law's viscoplastic strain and delayed swelling, models
Eq. 6 and 10). The unknown half of (d eps, d sigma) follows from the known half by a 2 x 2
solve.

Time stepping: forward Euler, one tangent per sub-step, sub-steps sized so that no strain component (controlled,
viscous, or resulting) changes by more than ``max_strain`` and no controlled stress by more than ``max_stress``
times p', with the step also at most ``growth`` times the time since the stage start (log-spaced steps in holds).
A step that leaves the elastic domain is split at the crossing (linear interpolation of f); a plastic step whose
multiplier turns negative is redone elastically (unloading). The error is first order in the sub-step size
(measured in tests/cases/test_independent_generator.py).
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Control", "Point", "run_stage"]


@dataclass(frozen=True)
class Control:
    """What a stage holds: ``axial`` and ``radial`` are ("strain" | "stress", rate in 1/s or kPa/s); the stage
    ends after ``duration`` s, or at the first sub-step where sigma'_a reaches ``until_sigma_a`` (kPa; the overshoot
    is one sub-step)."""

    axial: tuple
    radial: tuple
    duration: float
    until_sigma_a: float | None = None


class Point:
    """Strains, effective stresses, time and the recorded trajectory of one specimen."""

    def __init__(self, model, state):
        self.model, self.state = model, state
        self.eps_a = self.eps_r = self.time = 0.0
        self.rows = []
        self.record()

    @property
    def sigma_a(self):
        return self.state.p + 2.0 * self.state.q / 3.0

    @property
    def sigma_r(self):
        return self.state.p - self.state.q / 3.0

    def record(self):
        s = self.state
        self.rows.append((self.time, self.eps_a, self.eps_r, self.sigma_a, self.sigma_r, s.v - 1.0))


def _tangent(model, s, plastic):
    """(A, n, nDn_H, De) with A = S D T of Eq. (1); n and the denominator of the multiplier when plastic."""
    K, G = model.moduli(s)
    if plastic:
        n_p, n_q, H = model.plastic(s)
        a, b = K * n_p, 3.0 * G * n_q
        den = n_p * a + n_q * b + H
        D = ((K - a * a / den, -a * b / den), (-b * a / den, 3.0 * G - b * b / den))
    else:
        n_p = n_q = den = None
        D = ((K, 0.0), (0.0, 3.0 * G))
    # A = S D T
    DT = [[D[i][0] * 1.0 + D[i][1] * 2.0 / 3.0, D[i][0] * 2.0 - D[i][1] * 2.0 / 3.0] for i in range(2)]
    A = [[DT[0][j] + 2.0 / 3.0 * DT[1][j] for j in range(2)], [DT[0][j] - DT[1][j] / 3.0 for j in range(2)]]
    return A, (n_p, n_q), den, (K, G)


def _solve(A, b, ctrl, dt):
    """(d eps_a, d eps_r, d sigma_a, d sigma_r) of d sigma = A d eps - b under the stage's controls."""
    (ka, ra), (kr, rr) = ctrl.axial, ctrl.radial
    if ka == "strain" and kr == "strain":
        de = (ra * dt, rr * dt)
    elif ka == "stress" and kr == "stress":
        sa, sr = ra * dt + b[0], rr * dt + b[1]
        det = A[0][0] * A[1][1] - A[0][1] * A[1][0]
        de = ((A[1][1] * sa - A[0][1] * sr) / det, (A[0][0] * sr - A[1][0] * sa) / det)
    elif ka == "strain":
        dea = ra * dt
        de = (dea, (rr * dt + b[1] - A[1][0] * dea) / A[1][1])
    else:
        der = rr * dt
        de = ((ra * dt + b[0] - A[0][1] * der) / A[0][0], der)
    ds = (A[0][0] * de[0] + A[0][1] * de[1] - b[0], A[1][0] * de[0] + A[1][1] * de[1] - b[1])
    return de, ds


def _step(point, ctrl, dt, plastic):
    """One forward-Euler sub-step of length dt; returns (d eps_a, d eps_r, inelastic strains) without updating: the
    plastic (d eps_v^p, d eps_q^p), or the viscous (d eps_v^vp, d eps_q^vp, d eps_s)."""
    model, s = point.model, point.state
    A, n, den, (K, G) = _tangent(model, s, plastic)
    dep = (0.0, 0.0)
    b = (0.0, 0.0)
    if model.viscous:
        ev, eq = model.creep_rate(s)
        dep = (ev * dt, eq * dt, model.swelling_rate(s) * dt)
        cp, cq = K * (dep[0] + dep[2]), 3.0 * G * dep[1]
        b = (cp + 2.0 * cq / 3.0, cp - cq / 3.0)
    de, _ = _solve(A, b, ctrl, dt)
    if plastic:
        dev, deq = de[0] + 2.0 * de[1], 2.0 / 3.0 * (de[0] - de[1])
        dL = (n[0] * K * dev + n[1] * 3.0 * G * deq) / den
        if dL < 0.0:
            return None
        dep = (dL * n[0], dL * n[1])
    return de, dep


def _apply(point, de, dep, dt):
    dev, deq = de[0] + 2.0 * de[1], 2.0 / 3.0 * (de[0] - de[1])
    point.model.advance(point.state, dev, deq, *dep)
    point.eps_a += de[0]
    point.eps_r += de[1]
    point.time += dt


def _advance(point, ctrl, dt):
    """One sub-step, elastic, plastic, or split at the yield surface (elastoplastic model)."""
    model = point.model
    if model.viscous:
        de, dep = _step(point, ctrl, dt, False)
        _apply(point, de, dep, dt)
        return
    f0 = model.yield_value(point.state)
    if f0 >= -1e-12:
        out = _step(point, ctrl, dt, True)
        if out is not None:
            _apply(point, *out, dt)
            return
    de, dep = _step(point, ctrl, dt, False)
    saved = (point.state.p, point.state.q, point.state.v, point.state.size, point.state.chi,
             point.eps_a, point.eps_r, point.time)
    _apply(point, de, dep, dt)
    f1 = model.yield_value(point.state)
    if f0 < -1e-12 and f1 > 0.0:
        s = point.state
        s.p, s.q, s.v, s.size, s.chi, point.eps_a, point.eps_r, point.time = saved
        frac = f0 / (f0 - f1)
        de, dep = _step(point, ctrl, frac * dt, False)
        _apply(point, de, dep, frac * dt)
        out = _step(point, ctrl, (1.0 - frac) * dt, True)
        if out is None:
            out = _step(point, ctrl, (1.0 - frac) * dt, False)
        _apply(point, *out, (1.0 - frac) * dt)


def run_stage(point: Point, ctrl: Control, max_strain=2e-5, max_stress=1e-3, growth=0.02, first_step=1e-3):
    """Integrate one stage from the point's current state; every sub-step is appended to ``point.rows``."""
    start, end = point.time, point.time + ctrl.duration
    model = point.model
    rates = [abs(r) for kind, r in (ctrl.axial, ctrl.radial) if kind == "strain"]
    stress_rates = [abs(r) for kind, r in (ctrl.axial, ctrl.radial) if kind == "stress"]
    while point.time < end * (1.0 - 1e-14) and end - point.time > 1e-9:
        dt = end - point.time
        dt = min(dt, max(growth * (point.time - start), first_step))
        if any(rates):
            dt = min(dt, max_strain / max(rates))
        if any(stress_rates):
            dt = min(dt, max_stress * point.state.p / max(stress_rates))
        if model.viscous:
            ev, eq = model.creep_rate(point.state)
            rate = abs(ev) + abs(eq) + abs(model.swelling_rate(point.state))
            if rate > 0:
                dt = min(dt, max_strain / rate)
        out = _step(point, ctrl, dt, False)
        de = out[0]
        if max(abs(de[0]), abs(de[1])) > max_strain:
            dt *= max_strain / max(abs(de[0]), abs(de[1]))
        before = point.sigma_a
        _advance(point, ctrl, dt)
        point.record()
        target = ctrl.until_sigma_a
        if target is not None and (before - target) * (point.sigma_a - target) <= 0.0:
            break
    return point
