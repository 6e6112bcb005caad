"""Mesh convergence of the coupled, partially drained SBP curve with Modified Cam Clay (Burswood settings of
fem.pressuremeter, 0.0185 %/s: T = c t/a^2 ~ 0.2-1, the partially drained test), 100 increments.

Measured (notes/fem.md), final cavity pressure / wall excess pore pressure in kPa, n_radial x 4 cells:
  outer='fixed' (R = 3200 a0): 30: 140.79/45.85, 60: 139.95/45.24, 120: 139.68/45.04, 240: 139.59/44.97,
    480: 139.56/44.94; successive differences 0.84/0.27/0.088/0.039 (pressure), order 1.6/1.6/1.2; the default
    60 x 4 mesh errs +0.43 kPa (0.31 %) and +0.33 kPa (0.7 %) against the Richardson limits 139.53/44.91.
  outer='field' (R = 200 a0): 30: 139.63/44.85, 60: 139.36/44.70, 120: 139.32/44.69, 240: 139.30/44.68;
    the default mesh errs ~0.07 kPa (0.05 %) in pressure.
"""
import numpy as np
import pytest

import constitutive as C
import fem

A0 = 0.0415


def final_values(outer, n_radial):
    R = (3200.0 if outer == "fixed" else 200.0) * A0
    mesh = fem.Mesh.cavity_strip(a0=A0, outer_radius=R, n_radial=n_radial, n_vertical=4)
    mcc = C.ModifiedCamClay(M=1.2, lambda_=0.40, kappa=0.026, nu=0.3, ocr=58.4 / 31.0)
    r = fem.solve(fem.pressuremeter(mcc, mesh=mesh, strain_rate=0.000185, outer=outer, save_fields="none"))
    return r.cavity_pressure[-1], r.cavity_excess_pore_pressure[-1]


@pytest.mark.slow
def test_partially_drained_mcc_curve_converges_with_mesh():
    """30/60/120/240 radial cells, outer='fixed': monotone convergence of order > 1 (measured 1.6/1.6), and the
    default 60-cell values within 0.5 % (pressure) and 1 % (pore pressure) of the Richardson limit."""
    vals = np.array([final_values("fixed", n) for n in (30, 60, 120, 240)])
    d = -np.diff(vals, axis=0)                                      # both decrease under refinement
    assert np.all(d > 0)
    order = np.log2(d[:-1] / d[1:])
    assert np.all(order > 1.0), order
    limit = vals[-1] - d[-1] / (2.0 ** order[-1] - 1.0)
    err60 = (vals[1] - limit) / limit
    assert err60[0] < 0.005 and err60[1] < 0.01, err60
