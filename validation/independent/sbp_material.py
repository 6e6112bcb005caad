"""Material points of the independent cavity solver (:mod:`validation.independent.sbp_solver`): the clays of
:mod:`validation.independent.models` in principal stresses (r, theta, z), vectorized over the elements of a radial grid.

Sign and unit convention: compression positive, effective stresses in kPa, strains as fractions; the principal axes
are radial, hoop and vertical (plane strain: d eps_z = 0 in the cavity, but the driver takes any three).
p = (s_r + s_t + s_z)/3, deviator s_i = sigma_i - p, q = sqrt(3/2 s.s); a function f(p, q) has the gradient
    df/dsigma_i = (df/dp)/3 + (df/dq) 3 s_i / (2 q)                                                          (1)
in principal stresses, and a (p, q) strain rate (eps_v, eps_q) is eps_i = eps_v/3 + eps_q 3 s_i / (2 q) (coaxial
with the stress deviator; q = 0 gives no deviatoric part). Elasticity: D = K 1 x 1 + 2 G (I - 1 x 1 / 3) with K, G of
the models' Eq. (1) at the current p' and specific volume v.

:class:`CavityClay` adapts one model of :mod:`validation.independent.models` (its moduli, yield value, gradient and
hardening modulus, Eq. (1)-(5), and its creep rate, Eq. (6)-(7)); the hardening of the size is the models' Eq. (3)
(Eq. (7) for the creep law): d size = v size d eps_v^p / (lambda - kappa).

:func:`tangent` and :func:`update` are the explicit (forward Euler) stress integration of one step for a given strain
increment, as in :mod:`validation.independent.integrator`: an elastic trial; a step that leaves the elastic domain is
split at the crossing (linear interpolation of f); the plastic part uses the tangent at its start
    d sigma = D (d eps - dL n),  dL = n . D d eps / (n . D n + H)                                            (2)
(dL < 0: elastic unloading), then the stress is returned to the yield surface by the correction of Potts & Gens
(1985), dL' = f / (n . D n + H), sigma -= dL' D n, size grows by Eq. (3) with dL' (two passes). The creep law has
no elastic domain: d sigma = D (d eps - eps_vp_rate dt) with the rate at the start of the step.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .models import ClayState

__all__ = ["CavityClay", "Points", "invariants", "elastic_matrix", "tangent", "update"]

#: yield value (scaled by size^2) above which a point counts as on the surface
ON_SURFACE = -1e-9


@dataclass
class Points:
    """Arrays over n points: effective principal stresses ``sigma`` (n, 3) (kPa, r, theta, z), the surface size
    ``size`` (kPa; the models' p_mi or p_p) and the specific volume ``v``."""

    sigma: np.ndarray
    size: np.ndarray
    v: np.ndarray

    def copy(self) -> Points:
        return Points(self.sigma.copy(), self.size.copy(), self.v.copy())


def invariants(sigma):
    """(p, q, deviator direction 3 s / (2 q)) of principal stresses (n, 3); the direction is 0 where q = 0."""
    p = sigma.mean(axis=1)
    s = sigma - p[:, None]
    q = np.sqrt(1.5 * np.sum(s * s, axis=1))
    direction = np.divide(1.5 * s, q[:, None], out=np.zeros_like(s), where=q[:, None] > 0.0)
    return p, q, direction


def elastic_matrix(K, G):
    """D (n, 3, 3) of the principal components for bulk and shear moduli K, G (kPa)."""
    one = np.ones((3, 3)) / 3.0
    return (3.0 * K)[:, None, None] * one + (2.0 * G)[:, None, None] * (np.eye(3) - one)


class CavityClay:
    """One clay of :mod:`validation.independent.models` (``ElastoplasticClay`` without bonding, or ``ViscousClay``) for
    arrays of points. The model's own methods give the moduli, the yield value and its gradient (they take numpy
    arrays); the creep rate, written for scalars, is evaluated point by point."""

    def __init__(self, model, v0=None):
        if getattr(model, "a", 0.0):
            raise ValueError("the cavity solver's clay has no bonding (destructuration is not generated here)")
        self.model, self.v0 = model, v0
        self.viscous = model.viscous
        self.stiffness = model.lambda_ - model.kappa

    def _state(self, pts: Points, p=None, q=None):
        if p is None:
            p, q, _ = invariants(pts.sigma)
        return ClayState(p, q, pts.v, pts.size, 0.0, self.v0)

    def moduli(self, pts: Points):
        """(K, G) arrays (kPa) of the models' Eq. (1)."""
        return self.model.moduli(self._state(pts))

    def yield_value(self, pts: Points):
        """f(p, q, size) / size^2 of the models' Eq. (2) (dimensionless, < 0 inside)."""
        return self.model.yield_value(self._state(pts))

    def gradient(self, pts: Points):
        """(n (points, 3) of Eq. (1), H) for the unscaled f of the models' Eq. (2) and Eq. (5)."""
        p, q, direction = invariants(pts.sigma)
        n_p, n_q, H = self.model.plastic(self._state(pts, p, q))
        return n_p[:, None] / 3.0 + n_q[:, None] * direction, n_p, H

    def harden(self, pts: Points, dev_p):
        """Size after a plastic (or viscoplastic) volumetric strain ``dev_p``: models' Eq. (3) / (7) with the model's
        volume factor (its specific-volume convention; ``v0`` the initial specific volume)."""
        return pts.size + self.model.volume(self._state(pts, 0.0, 0.0)) * pts.size * dev_p / self.stiffness

    def creep_rate(self, pts: Points):
        """Viscoplastic principal strain rates (points, 3) (1/s) of the models' Eq. (6)."""
        p, q, direction = invariants(pts.sigma)
        rates = np.array([self.model.creep_rate(ClayState(pi, qi, vi, si))
                          for pi, qi, vi, si in zip(p, q, pts.v, pts.size)]).reshape(-1, 2)
        return rates[:, :1] / 3.0 + rates[:, 1:] * direction


def tangent(material, pts: Points):
    """(D (n, 3, 3) for the global stiffness: elastoplastic Eq. (2) on the surface, elastic elsewhere; elastic D)."""
    De = elastic_matrix(*material.moduli(pts))
    if material.viscous:
        return De, De
    on = material.yield_value(pts) >= ON_SURFACE
    if not np.any(on):
        return De, De
    n, _, H = material.gradient(pts)
    Dn = np.einsum("kij,kj->ki", De, n)
    den = np.einsum("ki,ki->k", n, Dn) + H
    Dep = De - np.where(on, 1.0 / den, 0.0)[:, None, None] * Dn[:, :, None] * Dn[:, None, :]
    return Dep, De


def _plastic(material, pts: Points, deps, mask):
    """Points ``mask`` (on the surface) take the strain ``deps`` by Eq. (2); those that unload stay elastic."""
    sub = Points(pts.sigma[mask], pts.size[mask], pts.v[mask])
    De = elastic_matrix(*material.moduli(sub))
    n, n_p, H = material.gradient(sub)
    Dn = np.einsum("kij,kj->ki", De, n)
    dL = np.maximum(np.einsum("ki,ki->k", Dn, deps[mask]) / (np.einsum("ki,ki->k", n, Dn) + H), 0.0)
    pts.sigma[mask] = sub.sigma + np.einsum("kij,kj->ki", De, deps[mask]) - dL[:, None] * Dn
    pts.size[mask] = material.harden(sub, dL * n_p)
    return mask.nonzero()[0][dL > 0.0]


def _return_to_surface(material, pts: Points, index, passes=2):
    """The drift correction of Potts & Gens (1985) at the points ``index``."""
    for _ in range(passes):
        sub = Points(pts.sigma[index], pts.size[index], pts.v[index])
        f = material.yield_value(sub) * sub.size ** 2
        De = elastic_matrix(*material.moduli(sub))
        n, n_p, H = material.gradient(sub)
        Dn = np.einsum("kij,kj->ki", De, n)
        dL = f / (np.einsum("ki,ki->k", n, Dn) + H)
        pts.sigma[index] = sub.sigma - dL[:, None] * Dn
        pts.size[index] = material.harden(sub, dL * n_p)


def update(material, pts: Points, deps, dt) -> Points:
    """The points after the principal strain increment ``deps`` (n, 3) in ``dt`` s (a new :class:`Points`)."""
    new = pts.copy()
    dev = deps.sum(axis=1)
    if material.viscous:
        De = elastic_matrix(*material.moduli(pts))
        dvp = material.creep_rate(pts) * dt
        new.sigma += np.einsum("kij,kj->ki", De, deps - dvp)
        new.size = material.harden(pts, dvp.sum(axis=1))
        new.v = pts.v * (1.0 - dev)
        return new
    De = elastic_matrix(*material.moduli(pts))
    f0 = material.yield_value(pts)
    new.sigma += np.einsum("kij,kj->ki", De, deps)
    f1 = material.yield_value(new)
    on = f0 >= ON_SURFACE
    crossing = ~on & (f1 > 0.0)
    plastic_at = []
    if np.any(on):
        new.sigma[on] = pts.sigma[on]
        plastic_at.append(_plastic(material, new, deps, on))
    if np.any(crossing):
        frac = f0[crossing] / (f0[crossing] - f1[crossing])
        new.sigma[crossing] = pts.sigma[crossing] + frac[:, None] * np.einsum("kij,kj->ki", De[crossing],
                                                                           deps[crossing])
        rest = np.zeros_like(deps)
        rest[crossing] = (1.0 - frac)[:, None] * deps[crossing]
        plastic_at.append(_plastic(material, new, rest, crossing))
    index = np.concatenate(plastic_at) if plastic_at else np.zeros(0, dtype=int)
    if index.size:
        _return_to_surface(material, new, index)
    new.v = pts.v * (1.0 - dev)
    return new
