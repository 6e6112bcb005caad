"""A model-form discrepancy on the relative residuals (Kennedy & O'Hagan 2001; docs/reference.md section 9).

The paper's likelihood (Eqs. (4)-(6), (6g)) treats the relative errors r = (U_obs - U_num)/U_obs of a curve as
independent, N(0, s_j^2) per point, where s_j^2 = sigma_g^2 N_0 N_j / N_i makes every curve of a test weigh the
same whatever its number of points (N_i points in the test, N_0 curves, N_j points in curve j, sigma_g its error
group's parameter). A discrepancy class adds a smooth function of the curve's abscissa to the errors:

    r_j = delta_j(u) + eps,   delta_j ~ GP(0, a_k^2 exp(-(u - u')^2 / (2 l_j^2))),   eps ~ N(0, s_j^2 I),   (D1)

one Gaussian process per curve, independent between curves, with the amplitude a_k of the curve's discrepancy
group k (by default one group per curve name: a quantity has one amplitude) and one length scale l shared by every
curve, as a fraction of the curve's normalized abscissa u in [0, 1] (the recorded abscissa, or its logarithm for a
time record spanning more than two decades), never shorter than ``min_spacings`` of the curve's median record
spacing (l_j = max(l, floor_j)). delta is marginalized exactly, so each curve contributes

    ln N(r_j; 0, C_j) + N_j/2 ln(N_0 N_j / N_i),   C_j = s_j^2 I + a_k^2 K_j(l_j),                            (D2)

times the test's weight w_i. The constant makes (D2) at a_k = 0 exactly the curve's share of Eq. (4) / (6g): the
discrepancy class nests the base class, and the evidences of both (and of any enriched class without discrepancy)
are of the same likelihood family and comparable.

A long curve (a laboratory's logger writes thousands of records) would cost N_j^3/6 operations per parameter set in
(D2)'s Cholesky factor (0.8 s at N_j = 2000). Where it is cheaper, the kernel is expanded in the eigenfunctions of
the Laplacian on [-L, L] around the centred abscissa x = u - 1/2 (Solin & Sarkka 2020, the Hilbert-space reduced-rank
Gaussian process):

    a_k^2 K_j ~ Phi S Phi^T,  Phi_ik = sin(k pi (x_i + L) / (2L)) / sqrt(L),
    S_k = a_k^2 sqrt(2 pi) l_j exp(-(w_k l_j)^2 / 2),  w_k = k pi / (2L),  k = 1..m,                          (D3)

with L = 1/2 + BOUNDARY_MARGIN l_j (the boundary condition's effect decays as exp(-(L - 1/2)^2 / (2 l_j^2))) and m
the least with w_m l_j >= SPECTRAL_TAIL (the spectral density there 7e-13 of its peak); (D2) then follows from the
Woodbury identity and the determinant lemma with an m x m Cholesky factor, in O(N_j m + m^3) (m = 35 to 81 over
the default length prior). It is used for a parameter set whose m is at most a quarter of N_j (never for curves of
fewer than 140 records: those are factored exactly); against the exact (D2), within 1e-5 nats on curves of
400 and 700 records at the priors' corners (tests/inference/test_inference_discrepancy.py).

Priors (``amplitude`` and ``length`` bounds, log-uniform) keep delta from being confounded with the physics
(Brynjarsdottir & O'Hagan 2014): the amplitude is bounded near the noise scale (5 % by default) and the length scale
from below, so that the discrepancy is a smooth misfit of model form, neither a second noise term nor a stand-in for
an effect that moves curves by tens of percent.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

__all__ = ["Discrepancy", "CurveDiscrepancy", "normalized_abscissa", "where_it_lies", "BOUNDARY_MARGIN",
           "SPECTRAL_TAIL", "reduced_rank_basis", "spectral_roots"]

#: the half-width of the reduced-rank expansion's interval (D3), L = 1/2 + BOUNDARY_MARGIN l_j
BOUNDARY_MARGIN = 6.8
#: the highest frequency of the reduced-rank expansion (D3): w_m l_j >= SPECTRAL_TAIL
SPECTRAL_TAIL = 7.5


@dataclass(frozen=True)
class Discrepancy:
    """Settings of the model-form discrepancy (D1).

    groups: None (one amplitude per curve name) or {group: [curve name or (test, curve) key, ...]}, every curve in
        exactly one group (as the error groups of :class:`inference.Likelihood`);
    amplitude: bounds of each group's amplitude a_k (relative, as the residuals), log-uniform prior: by default
        0.1 % to 5 %, the scale of the noise and of the model-form misfits the discrepancy stands for (a convention
        or a coarse discretisation moves curves by 1-8 %); an amplitude free up to 30 % let it mimic physics (the
        creep of every incremental load stage in log time: ln Z 4 above the viscous class on an independent IL
        programme);
    length: bounds of the shared length scale l, a fraction of the normalized abscissa, log-uniform prior;
    min_spacings: the length scale of a curve is at least this many of its median record spacings;
    prefix: the parameters are ``<prefix>_<group>`` (amplitudes) and ``<prefix>_length``.
    """

    groups: dict | None = None
    amplitude: tuple = (1e-3, 0.05)
    length: tuple = (0.05, 1.0)
    min_spacings: float = 3.0
    prefix: str = "delta"

    def __post_init__(self):
        for name, (lo, hi) in (("amplitude", self.amplitude), ("length", self.length)):
            if not 0.0 < lo < hi:
                raise ValueError(f"discrepancy {name} bounds ({lo}, {hi}) must satisfy 0 < lower < upper")
        if not self.min_spacings > 0:
            raise ValueError(f"discrepancy min_spacings = {self.min_spacings} must be > 0")

    def group_of(self, curve_keys) -> dict:
        """{(test, curve): group} for the likelihood's curve keys; ValueError naming an unknown or doubled curve."""
        if self.groups is None:
            return {k: k[1] for k in curve_keys}
        out = {}
        for g, members in self.groups.items():
            for entry in ([members] if isinstance(members, (str, tuple)) else members):
                keys = [entry] if isinstance(entry, tuple) else [k for k in curve_keys if k[1] == entry]
                if not keys or not set(keys) <= set(curve_keys):
                    raise ValueError(f"discrepancy group {g}: {entry!r} names no recorded curve")
                for k in keys:
                    if out.get(k, g) != g:
                        raise ValueError(f"test {k[0]}, curve {k[1]} is in two discrepancy groups: {out[k]} and {g}")
                    out[k] = g
        missing = [k for k in curve_keys if k not in out]
        if missing:
            raise ValueError(f"test {missing[0][0]}, curve {missing[0][1]} is in no discrepancy group")
        return out

    def parameter_names(self, groups) -> tuple:
        """The parameter names for discrepancy groups ``groups`` (in order): amplitudes, then the length scale."""
        return tuple(f"{self.prefix}_{g}" for g in groups) + (f"{self.prefix}_length",)

    def bounds(self, names) -> dict:
        """{parameter: (lower, upper)} of the log-uniform priors of the parameters ``names`` (a likelihood's
        ``discrepancy_names``: the amplitudes, then the length scale)."""
        return {**{n: tuple(self.amplitude) for n in names[:-1]}, names[-1]: tuple(self.length)}


def normalized_abscissa(x, x_name: str = "") -> np.ndarray:
    """The abscissa of a curve mapped to [0, 1]: linear, or logarithmic for a time record (``x_name`` containing
    "time") whose positive values span more than two decades (log(x + x_min+), x_min+ the smallest positive x)."""
    x = np.asarray(x, dtype=float)
    if "time" in x_name and (x > 0).any():
        small = x[x > 0].min()
        if x.max() / small > 100.0:
            x = np.log(np.maximum(x, 0.0) + small)
    span = x.max() - x.min()
    return (x - x.min()) / span if span > 0 else np.zeros_like(x)


class CurveDiscrepancy:
    """The terms (D2) of one curve: its normalized abscissa at the used points and its length floor."""

    def __init__(self, u, n_curves: int, n_test: int, min_spacings: float):
        self.u = np.ascontiguousarray(u, dtype=float)
        self.n = self.u.size
        spacing = np.diff(np.sort(self.u))
        spacing = spacing[spacing > 0]
        self.floor = min_spacings * (float(np.median(spacing)) if spacing.size else 1.0)
        #: s_j^2 / sigma_g^2 and the constant of (D2)
        self.scale = n_curves * self.n / n_test
        self.constant = 0.5 * self.n * np.log(self.scale)

    def covariance(self, sigma, amplitude, length) -> np.ndarray:
        """C_j of (D2), (n, n), for one parameter set (floats): sigma_g, the amplitude a_k and the length scale l."""
        c = np.empty((self.n, self.n))
        _covariance_lower(self.u, self.floor, sigma * np.sqrt(self.scale), amplitude, length, c)
        return np.tril(c) + np.tril(c, -1).T

    def log_density(self, residuals, sigma, amplitude, length) -> np.ndarray:
        """(D2) for m rows: ``residuals`` (m, n) relative errors at the used points, ``sigma`` the error group's
        sigma_g (m,), ``amplitude`` (m,), ``length`` (m,). Rows with a non-finite residual give NaN; a covariance
        that is not positive definite raises LinAlgError."""
        residuals = np.ascontiguousarray(residuals, dtype=float)
        out = np.empty(residuals.shape[0])
        noise_sd = np.ascontiguousarray(sigma * np.sqrt(self.scale), dtype=float)
        amplitude = np.ascontiguousarray(amplitude, dtype=float)
        length = np.ascontiguousarray(length, dtype=float)
        row = _gaussian_log_densities(self.u, self.floor, residuals, noise_sd, amplitude, length, out)
        if row >= 0:
            raise np.linalg.LinAlgError(f"the discrepancy's covariance is not positive definite (noise "
                                        f"{noise_sd[row]:g}, amplitude {amplitude[row]:g}, length {length[row]:g})")
        return out - 0.5 * self.n * np.log(2.0 * np.pi) + self.constant

    def posterior_mean(self, residuals, sigma, amplitude, length) -> np.ndarray:
        """E[delta_j | r_j] = a^2 K C^-1 r at the used points for one parameter set (floats; ``residuals`` (n,)),
        with a^2 K of (D3) where :func:`log_density` takes it."""
        r = np.asarray(residuals, dtype=float)
        ell = max(length, self.floor)
        half, m = reduced_rank_basis(ell, self.n)
        if m == 0:
            c = self.covariance(sigma, amplitude, length)
            k = c.copy()
            np.fill_diagonal(k, amplitude**2)   # a^2 K: K is 1 on its diagonal
            return k @ np.linalg.solve(c, r)
        frequency = np.arange(1, m + 1) * np.pi / (2.0 * half)
        phi = np.sin(np.outer(self.u - 0.5 + half, frequency)) / np.sqrt(half)
        root = np.empty(m)
        spectral_roots(amplitude, ell, half, m, root)
        spectral = root**2
        s2 = sigma**2 * self.scale + 1e-10 * amplitude**2
        a = np.eye(m) + root[:, None] * (phi.T @ phi) * root[None, :] / s2
        c_inv_r = (r - phi @ (root * np.linalg.solve(a, root * (phi.T @ r) / s2))) / s2   # Woodbury
        return phi @ (spectral * (phi.T @ c_inv_r))


@numba.njit(cache=True, error_model="numpy")
def reduced_rank_basis(length, n):
    """(L, m) of the reduced-rank expansion (D3) for the length scale l_j = ``length`` on a curve of ``n`` records:
    the half-width L of its interval and its number of eigenfunctions m; m = 0 where the expansion is not taken (it
    would need more than n/4 functions: the exact factor is the cheaper)."""
    half = 0.5 + BOUNDARY_MARGIN * length
    m = int(math.ceil(SPECTRAL_TAIL * 2.0 * half / (math.pi * length)))
    return half, (m if 4 * m <= n else 0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def spectral_roots(amplitude, ell, half, m, roots):
    """S_k^1/2 of (D3), k = 1..m, in ``roots`` (>= m,): amplitude a_k, length scale l_j = ``ell``, half-width L."""
    root_scale = amplitude * math.sqrt(math.sqrt(2.0 * math.pi) * ell)
    for k in range(m):
        roots[k] = root_scale * math.exp(-0.25 * ((k + 1) * math.pi / (2.0 * half) * ell) ** 2)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _covariance_lower(u, floor, noise_sd, amplitude, length, c):
    """C_j of (D2) in the lower triangle and diagonal of ``c`` (n, n): a^2 exp(-d^2 / (2 l_j^2)) off the diagonal
    (d the distance between the normalized abscissae ``u``, l_j = max(``length``, ``floor``)), a^2 + s_j^2 on it
    (``noise_sd`` s_j), plus a relative jitter that keeps the matrix positive definite when the noise is negligible
    against the amplitude."""
    decay = -0.5 / max(length, floor) ** 2
    a2 = amplitude**2
    for r in range(u.size):
        for col in range(r):
            c[r, col] = a2 * math.exp(decay * (u[r] - u[col]) ** 2)
        c[r, r] = a2 + (noise_sd**2 + 1e-10 * a2)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _factor_and_solve(matrix, n, rhs, z):
    """(positive definite, sum ln L_kk, z.z): the Cholesky factor L of the symmetric positive definite ``matrix``
    [:n, :n] (given in its lower triangle and diagonal) computed row by row in place, and z = L^-1 ``rhs`` in ``z``
    (``z`` may be ``rhs``)."""
    log_det = 0.0
    for r in range(n):
        for c in range(r + 1):
            v = matrix[r, c]
            for k in range(c):
                v -= matrix[r, k] * matrix[c, k]
            if c < r:
                matrix[r, c] = v / matrix[c, c]
            elif v > 0.0:
                matrix[r, r] = math.sqrt(v)
                log_det += math.log(matrix[r, r])
            else:
                return False, 0.0, 0.0
    quad = 0.0
    for r in range(n):
        v = rhs[r]
        for k in range(r):
            v -= matrix[r, k] * z[k]
        z[r] = v / matrix[r, r]
        quad += z[r] * z[r]
    return True, log_det, quad


@numba.njit(cache=True, error_model="numpy", inline="always")
def _reduced_rank_log_density(u, residual, noise_sd, amplitude, ell, half, m, cos_sums, roots, proj, a):
    """(positive definite, ln N(r; 0, C) + (n/2) ln 2 pi) for one residual row with a^2 K of (D3): C = s2 I +
    Phi S Phi^T (s2 = s_j^2 plus :func:`_covariance_lower`'s jitter); r^T C^-1 r = r.r/s2 - y.y and ln det C =
    n ln s2 + 2 sum ln L_kk (Woodbury, determinant lemma), L L^T = I + S^1/2 Phi^T Phi S^1/2 / s2, y = L^-1 S^1/2
    Phi^T r / s2. Phi^T Phi from the sums C_p = sum_i cos(p theta_i), p = 0..2m (sin j t sin k t = (cos (j-k) t -
    cos (j+k) t) / 2), the multiples of theta_i by rotation. Scratch: cos_sums (>= 2m+1,), roots and proj (>= m,),
    a (>= m, m)."""
    n = u.size
    s2 = noise_sd**2 + 1e-10 * amplitude**2
    if not s2 > 0.0:
        return False, 0.0
    for p in range(2 * m + 1):
        cos_sums[p] = 0.0
    for k in range(m):
        proj[k] = 0.0
    rr = 0.0
    for i in range(n):
        theta = math.pi * (u[i] - 0.5 + half) / (2.0 * half)
        c1, s1 = math.cos(theta), math.sin(theta)
        c, s = 1.0, 0.0
        cos_sums[0] += 1.0
        for p in range(1, 2 * m + 1):
            c, s = c * c1 - s * s1, s * c1 + c * s1
            cos_sums[p] += c
            if p <= m:
                proj[p - 1] += residual[i] * s
        rr += residual[i] * residual[i]
    spectral_roots(amplitude, ell, half, m, roots)
    for k in range(m):   # proj becomes S^1/2 Phi^T r / s2
        proj[k] *= roots[k] / (math.sqrt(half) * s2)
    for j in range(m):
        for k in range(j + 1):
            a[j, k] = roots[j] * roots[k] * 0.5 * (cos_sums[j - k] - cos_sums[j + k + 2]) / (half * s2)
        a[j, j] += 1.0
    positive, log_det, yy = _factor_and_solve(a, m, proj, proj)
    if not positive:
        return False, 0.0
    return True, -0.5 * (rr / s2 - yy) - 0.5 * n * math.log(s2) - log_det


@numba.njit(cache=True, error_model="numpy")
def _gaussian_log_densities(u, floor, residuals, noise_sd, amplitude, length, out):
    """ln N(r_i; 0, C_i) + (n/2) ln 2 pi of (D2) for each row i of ``residuals`` (m, n), in ``out`` (m,), from the
    normalized abscissae ``u`` (n,), the length floor and the row's ``noise_sd``, ``amplitude`` and ``length``: by
    C_i's Cholesky factor (:func:`_covariance_lower`, :func:`_factor_and_solve`: -z.z/2 - sum ln L_kk), or by (D3)
    (:func:`_reduced_rank_log_density`) where its basis has at most n/4 functions; NaN for a row with a non-finite
    residual. Returns the first row whose covariance is not positive definite (its value NaN), or -1. Compiled as
    the kernels of ``constitutive`` (numpy's floating-point error model, no fastmath, cached), one row at a time:
    no (m, n, n) arrays and no call per row."""
    m, n = residuals.shape
    singular = -1
    lower = np.empty((0, 0))
    z = np.empty(n)
    basis = 0
    cos_sums, roots, proj, a = np.empty(0), np.empty(0), np.empty(0), np.empty((0, 0))
    for i in range(m):
        out[i] = np.nan
        finite = True
        for r in range(n):
            finite = finite and math.isfinite(residuals[i, r])
        if not finite:
            continue
        ell = max(length[i], floor)
        half, size = reduced_rank_basis(ell, n)
        if size > 0:
            if size > basis:
                basis = size
                cos_sums, roots, proj = np.empty(2 * size + 1), np.empty(size), np.empty(size)
                a = np.empty((size, size))
            positive, value = _reduced_rank_log_density(u, residuals[i], noise_sd[i], amplitude[i], ell, half, size,
                                                        cos_sums, roots, proj, a)
        else:
            if lower.shape[0] < n:
                lower = np.empty((n, n))
            _covariance_lower(u, floor, noise_sd[i], amplitude[i], length[i], lower)
            positive, log_det, quad = _factor_and_solve(lower, n, residuals[i], z)
            value = -0.5 * quad - log_det
        if not positive:
            singular = i if singular < 0 else singular
            continue
        out[i] = value
    return singular


def where_it_lies(likelihood, theta, top=None, simulated=None) -> list:
    """Where the discrepancy of a model-form class lies at ``theta``: per curve, the RMS and the largest |delta| of
    its posterior mean (relative, as the residuals: 0.03 is 3 %) and the range of the abscissa (x_name, in the
    curve's unit) where |delta| is at least half its largest value; the curves by decreasing RMS (the first ``top``).
    ``likelihood``: an :class:`inference.Likelihood` with a discrepancy; ``simulated``: the curves at ``theta`` when
    at hand ({(test, curve): values at the records}; else solved)."""
    out = []
    for (test, curve), mean in likelihood.discrepancy_mean(theta, simulated).items():
        used = np.isfinite(mean)
        if not used.any():
            continue
        c = likelihood.observations[test].curves[curve]
        d = np.abs(mean[used])
        x = c.x[used][d >= 0.5 * d.max()]
        out.append({"test": test, "curve": curve, "x_name": c.x_name, "x_unit": c.x_unit,
                    "x_start": float(x.min()), "x_end": float(x.max()), "rms": float(np.sqrt(np.mean(d**2))),
                    "max": float(d.max())})
    out.sort(key=lambda r: -r["rms"])
    return out if top is None else out[:top]
