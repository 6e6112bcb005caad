"""Compiled (numba, the policy of :mod:`constitutive.jit`) loops of the FE solver (:mod:`fem.solver`): the coupled
residual in one pass over the cells with the trial strains before it and the convergence measures after it, the
extrapolated predictor and the band assembly of the Jacobian. Equations of the :mod:`fem.solver` module docstring,
FE sign convention (tension positive) except where a soil-convention array (compression positive, Voigt,
:mod:`fem.material_point`) is named.

The numpy form of the residual needs ~20 array operations of (n, 8, 4)-sized stacks per evaluation (0.22 ms for
the 240-cell pressuremeter, a fifth of an ANICREEP solve); one loop over the cells does it in a few tens of
microseconds, and each numpy call replaced by a loop here saves its ~1-3 us of call overhead. Deterministic: the
cells are visited in order, so the result does not depend on anything but the inputs (rank-count independence of
the calibrations). Each kernel performs the floating-point operations of the numpy expression its docstring
states, in the same order (no fastmath: no contraction into fused multiply-adds, no reassociation), so it gives
the same bits (tests/fem/test_fem_kernels.py).
"""
from __future__ import annotations

import math

from constitutive.jit import jit


@jit
def trial_strain(B, x, udofs, committed, strain, dstrain_soil):
    """strain[e] = B[e] U_e (n, 4, FE) of the global dof vector x, and the soil-convention increment from the
    committed strain: dstrain_soil[e, :4] = -(strain[e] - committed[e]) (columns 4-5 are left as they are)."""
    for e in range(B.shape[0]):
        for c in range(4):
            s = 0.0
            for j in range(8):
                s += B[e, c, j] * x[udofs[e, j]]
            strain[e, c] = s
            dstrain_soil[e, c] = -(s - committed[e, c])


@jit
def coupled_residual(x, x_n, stress, sig0_fe, VBt, absVBt, hg, vol_row, abs_vol_row, n_bar, k_dt, H, S, absS,
                     udofs, pdofs, load, R, scale):
    """Fill R (momentum and mass residuals) and scale (per-dof sums of the absolute contributions, the reference
    of the convergence test). Per cell e (Solver docstring), with sigma' = -stress[e, :4] (``stress`` is the
    soil-convention effective stress (n, 6)):

        R_u += V B^T (sigma' - sigma'_0) - vol_row n_bar.p + K_hg U
        R_p -= n_bar (vol_row.(U - U_n)) + dt k/gamma_w H p + tau S (p - p_n)

    then R -= load and scale += |load| (the boundary loads at the step's amplitude; zeros without any).
    ``k_dt`` is dt k/gamma_w per cell; with the stabilization switched off S and absS are zero. The structural
    zeros of B (no zz entry in a u_r column, no rr or tt entry in a u_z one) and of K_hg (no u_r-u_z coupling),
    checked by :func:`structural_zeros`, are skipped: a product 0 x (finite) could only change the sign of a zero
    sum, which the accumulation into R (from +0) does not keep, so R is that of the full sums bit for bit."""
    R[:] = 0.0
    scale[:] = 0.0
    for e in range(VBt.shape[0]):
        pore = 0.0
        for a in range(4):
            pore += n_bar[e, a] * x[pdofs[e, a]]
        ds0 = -stress[e, 0] - sig0_fe[e, 0]
        ds1 = -stress[e, 1] - sig0_fe[e, 1]
        ds2 = -stress[e, 2] - sig0_fe[e, 2]
        ds3 = -stress[e, 3] - sig0_fe[e, 3]
        as0 = abs(stress[e, 0]) + abs(sig0_fe[e, 0])
        as1 = abs(stress[e, 1]) + abs(sig0_fe[e, 1])
        as2 = abs(stress[e, 2]) + abs(sig0_fe[e, 2])
        as3 = abs(stress[e, 3]) + abs(sig0_fe[e, 3])
        dvol = 0.0
        abs_dvol = 0.0
        for i in range(8):
            f = -vol_row[e, i] * pore
            ref = abs_vol_row[e, i] * abs(pore)
            if i % 2 == 0:  # u_r: B has no zz entry
                f += VBt[e, i, 0] * ds0
                ref += absVBt[e, i, 0] * as0
                f += VBt[e, i, 2] * ds2
                ref += absVBt[e, i, 2] * as2
            else:           # u_z: no rr, tt entries
                f += VBt[e, i, 1] * ds1
                ref += absVBt[e, i, 1] * as1
            f += VBt[e, i, 3] * ds3
            ref += absVBt[e, i, 3] * as3
            for j in range(i % 2, 8, 2):  # K_hg couples equal directions only
                f += hg[e, i, j] * x[udofs[e, j]]
            d = udofs[e, i]
            R[d] += f
            scale[d] += ref
            du = x[d] - x_n[d]
            dvol += vol_row[e, i] * du
            abs_dvol += abs_vol_row[e, i] * abs(du)
        for a in range(4):
            flow = 0.0
            storage = 0.0
            abs_storage = 0.0
            for b in range(4):
                pb = pdofs[e, b]
                flow += H[e, a, b] * x[pb]
                dp = x[pb] - x_n[pb]
                storage += S[e, a, b] * dp
                abs_storage += absS[e, a, b] * abs(dp)
            flow *= k_dt[e]
            d = pdofs[e, a]
            R[d] -= n_bar[e, a] * dvol + flow + storage
            scale[d] += n_bar[e, a] * abs_dvol + abs(flow) + abs_storage
    for d in range(R.shape[0]):
        R[d] -= load[d]
        scale[d] += abs(load[d])


def structural_zeros(B, hg):
    """True when B (n, 4, 8) and hg (n, 8, 8) are zero where :func:`coupled_residual` skips them."""
    return not (B[:, 1, 0::2].any() or B[:, 0, 1::2].any() or B[:, 2, 1::2].any() or hg[:, 0::2, 1::2].any()
                or hg[:, 1::2, 0::2].any())


@jit
def relative_residual(R, scale, dofs, floor):
    """The convergence measure of the dofs ``dofs`` (fem.Problem docstring): max_i |R_i|/(scale_i + floor max_j
    scale_j + 1e-300) over i, j in ``dofs`` (0 for no dofs; nan when an R_i there is not finite)."""
    smax = 0.0
    for d in dofs:
        smax = max(smax, scale[d])
    ref = floor * smax
    out = 0.0
    for d in dofs:
        r = abs(R[d]) / (scale[d] + ref + 1e-300)
        if r > out:
            out = r
        elif r != r:
            return r
    return out


@jit
def newton_measures(R, scale, ufree, pfree, cdofs, floor, rhs):
    """(finite, ru, rp) of the residual R: whether every R_i is finite, and the relative residuals of the free
    displacement and pore-pressure dofs (:func:`relative_residual`; both nan when not finite). Also fills the
    right-hand side of the Newton correction, rhs = -R with zeros at the constrained dofs ``cdofs``."""
    for v in R:
        if not math.isfinite(v):
            return False, math.nan, math.nan
    for d in range(R.shape[0]):
        rhs[d] = -R[d]
    for d in cdofs:
        rhs[d] = 0.0
    return True, relative_residual(R, scale, ufree, floor), relative_residual(R, scale, pfree, floor)


@jit
def extrapolate(x, velocity, dt, acceleration, c, guess):
    """The solver's extrapolated start of a step: guess = x + dt velocity, then guess += c acceleration when
    ``acceleration`` has entries (a zero-length array: first order)."""
    second = acceleration.shape[0] > 0
    for i in range(x.shape[0]):
        g = x[i] + dt * velocity[i]
        if second:
            g += c * acceleration[i]
        guess[i] = g


@jit
def step_rates(x_new, x, dt, velocity, h, new_velocity, acceleration):
    """The rates of a converged step: new_velocity = (x_new - x)/dt and, when ``velocity`` (the previous step's)
    has entries, acceleration = (new_velocity - velocity)/h."""
    second = velocity.shape[0] > 0
    for i in range(x.shape[0]):
        v = (x_new[i] - x[i]) / dt
        new_velocity[i] = v
        if second:
            acceleration[i] = (v - velocity[i]) / h


@jit
def band_matrix(const, idx, values, sel, out):
    """The band storage of the Jacobian: out = const + bincount(idx, values.ravel()[sel], out.size), the element
    entries ``values`` (C-contiguous) summed into their band positions in the order given, as numpy does."""
    flat = values.ravel()
    out[:] = 0.0
    for k in range(idx.shape[0]):
        out[idx[k]] += flat[sel[k]]
    for k in range(out.shape[0]):
        out[k] = const[k] + out[k]
