"""Compiled (numba, the policy of :mod:`constitutive.jit`) element loops of the coupled residual, one pass over the
cells: the equations are those of :mod:`fem.solver` (module docstring), FE sign convention (tension positive).

The numpy form of the same sums needs ~20 array operations of (n, 8, 4)-sized stacks per residual (0.22 ms for the
240-cell pressuremeter, a fifth of an ANICREEP solve); one loop over the cells does it in a few tens of
microseconds. Deterministic: the cells are visited in order, so the result does not depend on anything but the
inputs (rank-count independence of the calibrations).
"""
from __future__ import annotations

from constitutive.jit import jit


@jit
def cell_strain(B, x, udofs, out):
    """out[e] = B[e] U_e (n, 4): the uniform strain of each cell from the global dof vector x."""
    for e in range(B.shape[0]):
        for c in range(4):
            s = 0.0
            for j in range(8):
                s += B[e, c, j] * x[udofs[e, j]]
            out[e, c] = s


@jit
def coupled_residual(x, x_n, stress_fe, sig0_fe, VBt, absVBt, hg, vol_row, abs_vol_row, n_bar, k_dt, H, S, absS,
                     udofs, pdofs, R, scale):
    """Fill R (momentum and mass residuals) and scale (per-dof sums of the absolute contributions, the reference
    of the convergence test) for the element terms; loads are added by the caller. Per cell e (Solver docstring):

        R_u += V B^T (sigma' - sigma'_0) - vol_row n_bar.p + K_hg U
        R_p -= n_bar (vol_row.(U - U_n)) + dt k/gamma_w H p + tau S (p - p_n)

    ``k_dt`` is dt k/gamma_w per cell; with the stabilization switched off S and absS are zero."""
    R[:] = 0.0
    scale[:] = 0.0
    for e in range(VBt.shape[0]):
        pore = 0.0
        for a in range(4):
            pore += n_bar[e, a] * x[pdofs[e, a]]
        dvol = 0.0
        abs_dvol = 0.0
        for i in range(8):
            f = -vol_row[e, i] * pore
            ref = abs_vol_row[e, i] * abs(pore)
            for c in range(4):
                f += VBt[e, i, c] * (stress_fe[e, c] - sig0_fe[e, c])
                ref += absVBt[e, i, c] * (abs(stress_fe[e, c]) + abs(sig0_fe[e, c]))
            for j in range(8):
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
