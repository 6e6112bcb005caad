"""ANICREEP's initial fabric alpha_0 and rotational-hardening factor (constitutive.anicreep, (I)): the default is the
model without them bit for bit; a fixed fabric (omega_ratio = 0) in the rate-independent limit is the inclined
Modified Cam Clay ellipse of Wheeler et al. (2003), whose undrained path has a closed form; bad values are named.
(omega_ratio against the closed-form rotation under isotropic loading: tests/constitutive/test_anicreep.py.)"""
import numpy as np
import pytest

from constitutive import ANICREEP, ParameterError, labtests
from constitutive.anicreep import anisotropy_constants

CLAY = dict(M=1.2, lambda_=0.25, kappa=0.05, nu=0.25, e0=1.27)


def _k0_state(M, sigma_v):
    """The K0_nc state (K0_nc of (K) from M, scalar or (n,)) at sigma'_v, axial direction 1: (n, 6) stress."""
    k0 = np.atleast_1d(anisotropy_constants(M)[0])
    s = np.zeros((k0.size, 6))
    s[:, 0], s[:, 1], s[:, 2] = sigma_v, k0 * sigma_v, k0 * sigma_v
    return s


def _pq(stress):
    return stress[:, :3].mean(axis=1), stress[:, 0] - stress[:, 1]


@pytest.mark.parametrize("viscous", [False, True])
def test_default_fabric_and_rotation_give_the_model_without_them_bit_for_bit(viscous):
    M = np.array([1.0, 1.2, 1.5])
    alpha_k0 = anisotropy_constants(M)[2]
    extra = dict(C_alpha_e=0.01) if viscous else {}
    plain = ANICREEP(M=M, lambda_=0.25, kappa=0.05, nu=0.25, e0=1.27, sigma_p0=100.0, viscous=viscous, **extra)
    given = ANICREEP(M=M, lambda_=0.25, kappa=0.05, nu=0.25, e0=1.27, sigma_p0=100.0, viscous=viscous,
                     alpha0=alpha_k0, omega_ratio=1.0, **extra)
    s0 = _k0_state(M, 80.0)
    outs = []
    for m in (plain, given):
        st = m.initial_state(s0)
        sig = s0
        for k in range(6):
            de = np.array([[2e-3, -1e-3, -1e-3, 0.0, 0.0, 0.0]] * 3) * (1 if k < 4 else -1)
            sig, st, tangent = m.update(sig, st, de, 600.0)
        outs.append((sig, tangent, st))
    assert np.array_equal(outs[0][0], outs[1][0]) and np.array_equal(outs[0][1], outs[1][1])
    for key in outs[0][2]:
        assert np.array_equal(outs[0][2][key], outs[1][2][key]), key


@pytest.mark.parametrize("alpha0, direction", [(0.30, 1.0), (0.30, -1.0), (0.0, 1.0), (0.55, -1.0)])
def test_a_fixed_fabric_follows_the_inclined_ellipse_in_undrained_shear(alpha0, direction):
    """Rate independent, omega_ratio = 0: the surface f = (q - a p')^2 - (M^2 - a^2)(p'_m - p')p' keeps its
    inclination a = alpha0, and an isochoric path from the K0_nc state on it gives, with (E) and (H) integrated
    exactly, kappa ln(p'/p'_0) = -(lambda - kappa) ln(p'_m/p'_m0) at every step: on the surface
    q = a p' +- sqrt((M^2 - a^2)(p'_m0 (p'_0/p')^(kappa/(lambda - kappa)) - p') p'), compression (+) from the start,
    extension (-) after an elastic stretch at constant p'."""
    M, lam, kap = CLAY["M"], CLAY["lambda_"], CLAY["kappa"]
    m = ANICREEP(**CLAY, sigma_p0=100.0, viscous=False, alpha0=alpha0, omega_ratio=0.0)
    s0 = _k0_state(M, 100.0)
    st = m.initial_state(s0)
    p0, q0 = _pq(s0)
    pm0 = p0[0] + (q0[0] - alpha0 * p0[0]) ** 2 / ((M**2 - alpha0**2) * p0[0])   # (F) through the K0_nc state
    assert st["pm_ref"][0] == pytest.approx(pm0, rel=1e-14)
    n = 120
    inc = np.tile([1.0, -0.5, -0.5, 0.0, 0.0, 0.0], (n, 1)) * direction * 0.15 / n
    out = labtests.mixed_control(m, s0, st, np.ones(6, bool), inc, np.ones(n))   # every strain prescribed
    p, q = _pq(out["stress"][0])
    plastic = np.abs(p / p0[0] - 1.0) > 1e-9
    assert plastic.sum() > n // 2 and np.all(np.diff(plastic.astype(int)) >= 0)   # plastic from first yield on
    pm = pm0 * (p0[0] / p[plastic]) ** (kap / (lam - kap))
    root = np.sqrt((M**2 - alpha0**2) * (pm - p[plastic]) * p[plastic])
    np.testing.assert_allclose(q[plastic], alpha0 * p[plastic] + direction * root, rtol=1e-8, atol=1e-8 * p0[0])
    np.testing.assert_allclose(out["state"]["pm_ref"][0], pm[-1], rtol=1e-9)
    np.testing.assert_allclose(out["state"]["alpha"], st["alpha"], rtol=0, atol=1e-14)   # the fabric never rotates
    if direction < 0:   # elastic at constant p' until the surface's lower branch
        q_yield = alpha0 * p0[0] - np.sqrt((M**2 - alpha0**2) * (pm0 - p0[0]) * p0[0])
        assert np.all(q[~plastic] >= q_yield - 1e-6 * p0[0]) and q[plastic][0] < q_yield


@pytest.mark.parametrize("extra, message", [
    (dict(alpha0=1.3), "M = 1.2 must exceed alpha0 = 1.3"),
    (dict(alpha0=-0.1), "alpha0 = -0.1"),
    (dict(omega_ratio=-1.0), "omega_ratio = -1"),
    (dict(anisotropy=False, alpha0=0.3), "alpha0 = 0.3 given but anisotropy=False"),
    (dict(anisotropy=False, omega_ratio=0.0), "omega_ratio = 0.0 given but anisotropy=False"),
])
def test_bad_fabric_parameters_are_named(extra, message):
    with pytest.raises(ParameterError, match=message):
        ANICREEP(**CLAY, sigma_p0=100.0, C_alpha_e=0.01, **extra)
