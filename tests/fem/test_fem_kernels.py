"""The solver's compiled loops (fem._residual_kernel) against plain-Python / numpy statements of the same sums, bit
for bit: each loop performs the floating-point operations of the expression it replaces, in the same order."""
import numpy as np

import fem
from fem import _residual_kernel as K
from fem.element import ElementGeometry


def strip(n_radial=4, n_vertical=2):
    mesh = fem.Mesh.cavity_strip(a0=0.0415, outer_radius=20 * 0.0415, n_radial=n_radial, n_vertical=n_vertical)
    return mesh, ElementGeometry(mesh.nodes, mesh.cells)


def full_residual(x, x_n, stress, sig0_fe, VBt, absVBt, hg, vol_row, abs_vol_row, n_bar, k_dt, H, S, absS, udofs,
                  pdofs, load):
    """The coupled residual (fem.solver docstring) with every product of the element matrices, zeros included."""
    R, scale = np.zeros(x.size), np.zeros(x.size)
    stress_fe = -stress[:, :4]
    for e in range(VBt.shape[0]):
        pore = sum_in_order(n_bar[e, a] * x[pdofs[e, a]] for a in range(4))
        dvol = abs_dvol = 0.0
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
            dvol += vol_row[e, i] * (x[d] - x_n[d])
            abs_dvol += abs_vol_row[e, i] * abs(x[d] - x_n[d])
        for a in range(4):
            flow = sum_in_order(H[e, a, b] * x[pdofs[e, b]] for b in range(4)) * k_dt[e]
            dp = [x[pdofs[e, b]] - x_n[pdofs[e, b]] for b in range(4)]
            storage = sum_in_order(S[e, a, b] * dp[b] for b in range(4))
            abs_storage = sum_in_order(absS[e, a, b] * abs(dp[b]) for b in range(4))
            R[pdofs[e, a]] -= n_bar[e, a] * dvol + flow + storage
            scale[pdofs[e, a]] += n_bar[e, a] * abs_dvol + abs(flow) + abs_storage
    return R - load, scale + np.abs(load)


def sum_in_order(terms):
    s = 0.0
    for t in terms:
        s += t
    return s


def same_bits(a, b):
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def test_coupled_residual_skips_only_structural_zeros():
    """The compiled residual skips the zero entries of B and K_hg: R and the reference magnitudes are those of the
    full sums, bit for bit, on random states (with zero displacements and stresses equal to the in-situ ones in a
    few cells: sums of zeros, where the sign of a zero could differ), with and without a boundary load and the
    pressure projection."""
    mesh, g = strip()
    rng = np.random.default_rng(1)
    ne, n = mesh.n_cells, 3 * mesh.n_nodes
    edofs = (3 * mesh.cells[:, :, None] + np.arange(3)).reshape(ne, 12)
    udofs, pdofs = edofs[:, [0, 1, 3, 4, 6, 7, 9, 10]], edofs[:, [2, 5, 8, 11]]
    VBt = g.volume[:, None, None] * np.transpose(g.B, (0, 2, 1)).copy()
    hg = 0.05 * 3000.0 * g.hg
    S = 1e-4 * (g.M - g.n_bar[:, :, None] * g.n_bar[:, None, :] / g.volume[:, None, None])
    assert K.structural_zeros(g.B, g.hg)
    sig0_fe = -np.tile([27.9, 31.0, 27.9, 0.0], (ne, 1))
    x, x_n = rng.normal(size=n) * 1e-3, rng.normal(size=n) * 1e-3
    stress = np.zeros((ne, 6))
    stress[:, :4] = -sig0_fe + rng.normal(size=(ne, 4))
    x[edofs[:2]] = 0.0
    x_n[edofs[:2]] = 0.0
    stress[:2, :4] = -sig0_fe[:2]
    k_dt = np.full(ne, 3e-10)
    for load, S in ((np.zeros(n), S), (rng.normal(size=n), S), (np.zeros(n), np.zeros_like(S))):
        args = (x, x_n, stress, sig0_fe, VBt, np.abs(VBt), hg, g.vol_row, np.abs(g.vol_row), g.n_bar, k_dt, g.H,
                S, np.abs(S), udofs, pdofs, load)
        R, scale = np.empty(n), np.empty(n)
        K.coupled_residual(*args, R, scale)
        R_full, scale_full = full_residual(*args)
        assert same_bits(R, R_full) and same_bits(scale, scale_full)


def test_trial_strain_and_newton_measures():
    mesh, g = strip()
    rng = np.random.default_rng(2)
    ne, n = mesh.n_cells, 3 * mesh.n_nodes
    udofs = (3 * mesh.cells[:, :, None] + np.arange(2)).reshape(ne, 8)
    x, committed = rng.normal(size=n), rng.normal(size=(ne, 4))
    strain, dstrain = np.empty((ne, 4)), np.full((ne, 6), 7.0)
    K.trial_strain(g.B, x, udofs, committed, strain, dstrain)
    expected = np.array([[sum_in_order(g.B[e, c, j] * x[udofs[e, j]] for j in range(8)) for c in range(4)]
                         for e in range(ne)])
    assert same_bits(strain, expected)
    assert same_bits(dstrain[:, :4], -(expected - committed)) and np.all(dstrain[:, 4:] == 7.0)

    R, scale = rng.normal(size=n), rng.uniform(0.5, 2.0, size=n)
    scale[:3] = 1e-12                                   # below the floor
    ufree, pfree, cdofs = np.arange(0, n, 3), np.arange(2, n, 3), np.array([1, 4, 7])
    rhs = np.empty(n)
    finite, ru, rp = K.newton_measures(R, scale, ufree, pfree, cdofs, 1e-6, rhs)
    expected_rhs = -R
    expected_rhs[cdofs] = 0.0
    assert finite and same_bits(rhs, expected_rhs)
    for dofs, measure in ((ufree, ru), (pfree, rp)):
        ref = scale[dofs] + 1e-6 * scale[dofs].max() + 1e-300
        assert measure == np.max(np.abs(R[dofs]) / ref)
    R[5] = np.nan
    assert not K.newton_measures(R, scale, ufree, pfree, cdofs, 1e-6, rhs)[0]


def test_predictor_rates_and_band_assembly():
    rng = np.random.default_rng(3)
    x, x_new, v, a = (rng.normal(size=50) for _ in range(4))
    dt, c, h = 0.3, 0.7, 0.45
    out = np.empty(50)
    K.extrapolate(x, v, dt, np.zeros(0), 0.0, out)
    assert same_bits(out, x + dt * v)
    K.extrapolate(x, v, dt, a, c, out)
    expected = x + dt * v
    expected += c * a
    assert same_bits(out, expected)
    velocity, acceleration = np.empty(50), np.empty(50)
    K.step_rates(x_new, x, dt, v, h, velocity, acceleration)
    assert same_bits(velocity, (x_new - x) / dt) and same_bits(acceleration, ((x_new - x) / dt - v) / h)

    const, values = rng.normal(size=40), rng.normal(size=(5, 8, 8))
    sel = rng.choice(values.size, 200, replace=False)
    idx = rng.integers(0, 40, size=200)                # repeated positions: summed in order
    band = np.empty(40)
    K.band_matrix(const, idx, values, sel, band)
    assert same_bits(band, const + np.bincount(idx, values.ravel()[sel], 40))
