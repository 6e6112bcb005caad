"""The exact undrained cavity expansion by the strain-path method (large strain, plane strain): a second, independent
way of computing a fast self-boring pressuremeter expansion, for the model-form controls
(:mod:`validation.independent.controls`, variant ``exact_cavity``).

Signs and units: compression positive, kPa, m, s. A material point at initial radius r0 of an incompressible medium
around a cavity expanded from radius a0 to a is at r with r^2 = r0^2 + a^2 - a0^2; its logarithmic strains are
    eps_r = -eps_theta = 1/2 ln(1 + (a^2 - a0^2) / r0^2),  eps_z = 0,                                      (1)
whatever the material. Each point's effective stresses follow from its own stress-strain response along the path
(1) (:func:`validation.independent.sbp_material.update`, the generator's explicit integration), and equilibrium,
d sigma_r/dr + (sigma_r - sigma_theta)/r = 0 in the deformed configuration, integrated from the far field gives the
total cavity pressure
    sigma_r(a) - sigma_h0 = int_{a0}^{inf} (sigma'_r - sigma'_theta) r0 dr0 / (r0^2 + a^2 - a0^2)         (2)
(the trapezoidal rule in ln r0 on a log-spaced grid of initial radii to ``outer`` a0, plus the elastic tail
G (a^2 - a0^2) / R^2 beyond R = outer a0). The pore pressure at the membrane is the total radial stress there less the
effective one of the point at r0 = a0: u_w = sigma_r(a) - sigma'_r(a0) (equivalently the total mean stress change
less the effective one, as sigma_r - sigma_theta and sigma_z take the same difference). The cavity strain is
(a - a0)/a0.
"""
from __future__ import annotations

import numpy as np

from .sbp_material import Points, update

__all__ = ["strain_path_expansion"]


def strain_path_expansion(material, sigma0, size, v, a0, u0, rate, to_strain, max_strain=1e-4, n=400,
                          outer=1000.0) -> np.ndarray:
    """Rows (time s, cavity strain -, cavity pressure kPa, wall pore pressure kPa) of the undrained expansion at
    cavity strain ``rate`` (1/s) to ``to_strain`` (-), steps of at most ``max_strain`` cavity strain, of a medium whose
    points (``material``: the cavity solver's material protocol) start at effective principal stresses ``sigma0``
    (r, theta, z; kPa, sigma'_r = sigma'_theta) with surface ``size`` (kPa) and specific volume ``v``; in situ pore
    pressure ``u0`` (kPa); ``n`` initial radii from a0 to ``outer`` a0 (m)."""
    r0 = a0 * outer ** (np.arange(n) / (n - 1.0))
    pts = Points(np.tile(np.asarray(sigma0, float), (n, 1)), np.full(n, float(size)), np.full(n, float(v)))
    sigma_h0 = sigma0[0] + u0
    steps = int(np.ceil(to_strain / max_strain))
    strains = to_strain * np.arange(steps + 1) / steps
    rows = [(0.0, 0.0, sigma_h0, u0)]
    eps_r = np.zeros(n)
    for k in range(1, steps + 1):
        c = (a0 * (1.0 + strains[k])) ** 2 - a0 ** 2
        new = 0.5 * np.log1p(c / r0 ** 2)
        d = new - eps_r
        eps_r = new
        pts = update(material, pts, np.stack([d, -d, np.zeros(n)], axis=1), (strains[k] - strains[k - 1]) / rate)
        g = (pts.sigma[:, 0] - pts.sigma[:, 1]) * r0 ** 2 / (r0 ** 2 + c)
        G = material.moduli(Points(pts.sigma[-1:], pts.size[-1:], pts.v[-1:]))[1][0]
        pressure = sigma_h0 + np.trapezoid(g, np.log(r0)) + G * c / r0[-1] ** 2
        rows.append((strains[k] / rate, strains[k], pressure, pressure - pts.sigma[0, 0]))
    return np.array(rows)
