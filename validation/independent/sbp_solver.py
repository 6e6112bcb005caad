"""The independent generator's self-boring pressuremeter: a plane-strain cylindrical cavity in saturated soil, one
dimension in r, coupled consolidation (its own discretization and time stepping; numpy only).

Signs and units: compression positive (stresses, strains, pore pressure), kPa, m, s; radial displacement u outward
positive; cavity strain eps_c = u(a0)/a0 (small strain); permeability k in m/s, unit weight of water 9.81 kN/m3.

Equations (small strain, plane strain eps_z = 0, total stress sigma = sigma' + p_w):
    eps_r = -du/dr,  eps_t = -u/r,  eps_v = eps_r + eps_t,
    equilibrium          d sigma_r/dr + (sigma_r - sigma_t)/r = 0,                                           (1)
    continuity (Darcy)   d eps_v/dt = -(k/gamma_w) (1/r) d/dr (r d p_w/dr).                                  (2)
Discretization: nodes r_i = a0 (R/a0)^(i/n) (uniform in ln r), linear u; in each element the volumetric strain is
the element mean, exact for any u, -(r_2 u_2 - r_1 u_1)/A with A = (r_2^2 - r_1^2)/2, and the deviatoric strain
eps_r - eps_t = u/r - du/dr at the mid-point (a B-bar element: one isochoric constraint per element makes the
undrained nodal displacements exactly u = u_a a0/r); one pore pressure per element, Eq. (2) by finite volumes
(flux across the node between two element centres; impermeable cavity wall, p_w = u0 at R). The virtual work of (1)
gives the internal forces f = sum B^T (sigma'_r + p_w, sigma'_t + p_w) A; the cavity pressure is the reaction at the
wall node, f_0/a0. Boundary conditions: u(a0) prescribed (strain control of the probe), u(R) = u(a0) a0/R (the
elastic far field, exact outside the plastic zone).

Time stepping: backward Euler on Eq. (2), tangent stiffness on (1) with the equilibrium residual of the previous
step carried into the next (no iterations: the error is first order in the step and measured by the tests), the
stresses by :func:`validation.independent.sbp_material.update`. Steps are limited by the cavity strain increment, the
largest viscoplastic strain increment of any element (both ``max_strain``) and, in a hold, by ``growth`` times the
time since the hold started (log-spaced steps). The wall pore pressure is extrapolated from the first two element
centres with zero gradient at the (impermeable) wall.
"""
from __future__ import annotations

import numpy as np

from .sbp_material import Points, tangent, update

__all__ = ["GAMMA_W", "Cavity", "block_solve"]

GAMMA_W = 9.81


def block_solve(diag, upper, rhs):
    """x of the symmetric block-tridiagonal system with 2 x 2 blocks: ``diag`` (n, 2, 2), ``upper`` (n-1, 2, 2) (block
    j, j+1; the lower blocks are their transposes), ``rhs`` (n, 2). Block elimination without pivoting (the
    displacement of each block is eliminated before its pore pressure, whose pivot then stays negative)."""
    d, u, b = diag.tolist(), upper.tolist(), rhs.tolist()
    n = len(d)
    inv, y = [None] * n, [None] * n
    c, yj = d[0], b[0]
    for j in range(n):
        if j:
            (w00, w01), (w10, w11) = _times_transpose(u[j - 1], inv[j - 1])
            (a00, a01), (a10, a11) = u[j - 1]
            c = [[d[j][0][0] - w00 * a00 - w01 * a10, d[j][0][1] - w00 * a01 - w01 * a11],
                 [d[j][1][0] - w10 * a00 - w11 * a10, d[j][1][1] - w10 * a01 - w11 * a11]]
            yj = [b[j][0] - w00 * y[j - 1][0] - w01 * y[j - 1][1], b[j][1] - w10 * y[j - 1][0] - w11 * y[j - 1][1]]
        det = c[0][0] * c[1][1] - c[0][1] * c[1][0]
        inv[j] = ((c[1][1] / det, -c[0][1] / det), (-c[1][0] / det, c[0][0] / det))
        y[j] = yj
    x = [None] * n
    z = y[n - 1]
    for j in range(n - 1, -1, -1):
        if j < n - 1:
            (a00, a01), (a10, a11) = u[j]
            z = [y[j][0] - a00 * x[j + 1][0] - a01 * x[j + 1][1], y[j][1] - a10 * x[j + 1][0] - a11 * x[j + 1][1]]
        (i00, i01), (i10, i11) = inv[j]
        x[j] = (i00 * z[0] + i01 * z[1], i10 * z[0] + i11 * z[1])
    return np.array(x)


def _times_transpose(a, b):
    """a^T b of 2 x 2 nested sequences (the lower block U^T times an inverse)."""
    return ((a[0][0] * b[0][0] + a[1][0] * b[1][0], a[0][0] * b[0][1] + a[1][0] * b[1][1]),
            (a[0][1] * b[0][0] + a[1][1] * b[1][0], a[0][1] * b[0][1] + a[1][1] * b[1][1]))


class Cavity:
    """A cavity of radius ``a0`` (m) in soil with in situ sigma'_v0 (kPa), K0, pore pressure u0 (kPa), permeability
    (m/s) and void ratio e0; ``material`` a :class:`validation.independent.sbp_material.CavityClay` (or any object with
    its methods) with ``initial_size`` the size of its surface (kPa). ``n`` elements to ``outer`` a0.

    :meth:`expand` / :meth:`hold` run a stage; every step appends (time s, cavity strain -, cavity pressure kPa,
    wall pore pressure kPa) to ``rows``."""

    def __init__(self, material, initial_size, a0, sigma_v0, K0, u0, permeability, e0, n=100, outer=200.0):
        self.material, self.a0, self.u0 = material, a0, u0
        r = a0 * outer ** (np.arange(n + 1) / n)
        self.r = r
        h, rm = np.diff(r), 0.5 * (r[1:] + r[:-1])
        self.area = h * rm                                               # = (r2^2 - r1^2)/2 per radian
        bv = np.stack([r[:-1], -r[1:]], axis=1) / self.area[:, None]
        bd = np.stack([1.0 / h + 0.5 / rm, -1.0 / h + 0.5 / rm], axis=1)
        self.B = np.stack([(bv + bd) / 2.0, (bv - bd) / 2.0], axis=1)  # (n, 2 strains r/t, 2 nodes)
        self.bv = bv
        self.centre = rm
        # finite-volume transmissibilities (m2/(kPa s) per radian): interfaces between elements, outer drained face
        kw = permeability / GAMMA_W
        self.t_inner = kw * r[1:-1] / np.diff(rm)
        self.t_outer = kw * r[-1] / (r[-1] - rm[-1])
        sh = K0 * sigma_v0
        self.pts = Points(np.tile([sh, sh, sigma_v0], (n, 1)).astype(float), np.full(n, float(initial_size)),
                          np.full(n, 1.0 + e0))
        self.p = np.full(n, float(u0))
        self.u = np.zeros(n + 1)
        self.time = 0.0
        self.far = a0 / r[-1]
        self.rows = []
        self.residual = np.zeros(n + 1)
        self._record()

    # ------------------------------------------------------------------ assembly
    def _forces(self, sigma, p):
        """Internal nodal forces (per radian, kN/m) of effective stresses (n, 3) and pore pressures (n,)."""
        total = sigma[:, :2] + p[:, None]
        fe = np.einsum("esa,es->ea", self.B, total) * self.area[:, None]
        f = np.zeros(self.r.size)
        f[:-1] += fe[:, 0]
        f[1:] += fe[:, 1]
        return f

    def _step(self, dt, du_wall):
        """One step of length dt (s) with the wall displacement increment du_wall (m): the coupled system in the
        unknowns (du_{j+1}, dp_j), j = 0..n-1 (node j+1, element j), block tridiagonal (:func:`block_solve`)."""
        n = self.p.size
        D, De = tangent(self.material, self.pts)
        Ke = np.einsum("esa,est,etb->eab", self.B, D[:, :2, :2], self.B) * self.area[:, None, None]
        k_diag = np.zeros(n + 1)
        k_diag[:-1] += Ke[:, 0, 0]
        k_diag[1:] += Ke[:, 1, 1]
        k_off = Ke[:, 0, 1]                                 # node e - node e+1
        l_in, l_out = self.bv[:, 0] * self.area, self.bv[:, 1] * self.area   # element e - node e, node e+1
        h_diag = np.zeros(n)
        h_diag[:-1] += self.t_inner
        h_diag[1:] += self.t_inner
        h_diag[-1] += self.t_outer
        hp = h_diag * self.p
        hp[:-1] -= self.t_inner * self.p[1:]
        hp[1:] -= self.t_inner * self.p[:-1]
        hp[-1] -= self.t_outer * self.u0
        load = -self.residual
        if self.material.viscous:
            s = np.einsum("kij,kj->ki", De, self.material.creep_rate(self.pts) * dt)[:, :2]
            fv = np.einsum("esa,es->ea", self.B, s) * self.area[:, None]
            load = load.copy()
            load[:-1] += fv[:, 0]
            load[1:] += fv[:, 1]
        du0, dun = du_wall, du_wall * self.far
        rhs = np.zeros((n, 2))
        rhs[:, 0] = load[1:]
        rhs[0, 0] -= k_off[0] * du0
        rhs[-2, 0] -= k_off[-1] * dun
        rhs[-1, 0] = dun
        rhs[:, 1] = dt * hp
        rhs[0, 1] -= l_in[0] * du0
        rhs[-1, 1] -= l_out[-1] * dun
        diag = np.zeros((n, 2, 2))
        diag[:, 0, 0] = k_diag[1:]
        diag[:, 0, 1] = diag[:, 1, 0] = l_out
        diag[:, 1, 1] = -dt * h_diag
        diag[-1, 0, :] = diag[-1, :, 0] = 0.0
        diag[-1, 0, 0] = 1.0
        upper = np.zeros((n - 1, 2, 2))
        upper[:, 0, 0] = k_off[1:]
        upper[:, 0, 1] = l_in[1:]
        upper[:, 1, 1] = -dt * -self.t_inner
        upper[-1, 0, 0] = 0.0
        x = block_solve(diag, upper, rhs)
        du = np.concatenate([[du0], x[:, 0]])
        eps = np.einsum("esa,ea->es", self.B, np.stack([du[:-1], du[1:]], axis=1))
        self.pts = update(self.material, self.pts, np.concatenate([eps, np.zeros((n, 1))], axis=1), dt)
        self.p = self.p + x[:, 1]
        self.u = self.u + du
        self.time += dt
        f = self._forces(self.pts.sigma, self.p)
        self.residual = f.copy()
        self.residual[0] = self.residual[-1] = 0.0
        self._record(f)

    def _record(self, f=None):
        f = self._forces(self.pts.sigma, self.p) if f is None else f
        x1, x2 = self.centre[:2] - self.a0
        wall = self.p[0] - (self.p[1] - self.p[0]) * x1 ** 2 / (x2 ** 2 - x1 ** 2)
        self.rows.append((self.time, self.u[0] / self.a0, f[0] / self.a0, wall))

    def _creep_step(self, max_strain):
        if not self.material.viscous:
            return np.inf
        rate = np.max(np.abs(self.material.creep_rate(self.pts)))
        return max_strain / rate if rate > 0 else np.inf

    # ------------------------------------------------------------------ stages
    def expand(self, rate, to_strain, max_strain=5e-5):
        """Cavity strain at ``rate`` (1/s, > 0) to ``to_strain`` (-)."""
        start = self.u[0] / self.a0
        end = self.time + (to_strain - start) / rate
        while end - self.time > 1e-9 * max(end, 1.0):
            dt = min(end - self.time, max_strain / abs(rate), self._creep_step(max_strain))
            self._step(dt, rate * dt * self.a0)
        return self

    def hold(self, duration, max_strain=5e-5, growth=0.05, first_step=0.01):
        """Cavity strain held for ``duration`` s."""
        start = self.time
        end = start + duration
        while end - self.time > 1e-9 * max(end, 1.0):
            dt = min(end - self.time, max(growth * (self.time - start), first_step), self._creep_step(max_strain))
            self._step(dt, 0.0)
        return self
