"""Von Mises / Tresca-matched model: yield stress, exact radial return, consistent tangent, plane-strain matching."""
import numpy as np
import pytest

from constitutive import ParameterError, VonMises
from constitutive.invariants import deviatoric_stress, mean_stress

SU, G, NU = 30.0, 3000.0, 0.3


def model(**kw):
    args = dict(s_u=SU, nu=NU, G=G)
    args.update(kw)
    return VonMises(**args)


def test_parameters_rejected():
    with pytest.raises(ParameterError, match="s_u"):
        model(s_u=-1.0)
    with pytest.raises(ParameterError, match="G"):
        model(G=0.0)
    with pytest.raises(ParameterError, match="nu"):
        model(nu=0.5)
    with pytest.raises(ParameterError, match="exactly one"):
        VonMises(s_u=SU, nu=NU, E=1e4, G=G)
    assert np.isclose(VonMises(s_u=SU, nu=NU, E=2 * G * (1 + NU)).G, G)


def test_simple_shear_yields_at_su():
    """Simple shear: tau = G gamma until tau = s_u (von Mises q = sqrt(3) tau), then stays at s_u exactly."""
    m = model()
    gamma = np.linspace(0, 4 * SU / G, 41)
    stress = np.full((1, 6), 100.0) * np.array([1, 1, 1, 0, 0, 0])
    state = m.initial_state(stress, 1.0)
    taus = [0.0]
    for dg in np.diff(gamma):
        stress, state, _ = m.update(stress, state, np.array([[0, 0, 0, dg, 0, 0]]), 1.0)
        taus.append(stress[0, 3])
    expected = np.minimum(G * gamma, SU)
    np.testing.assert_allclose(taus, expected, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(mean_stress(stress), 100.0, rtol=1e-14)


def test_radial_return_exact_for_proportional_loading():
    """One large step equals many small ones for a proportional (fixed-direction) deviatoric strain path."""
    m = model()
    rng = np.random.default_rng(1)
    direction = rng.normal(size=(5, 6))
    direction[:, :3] -= direction[:, :3].mean(axis=1, keepdims=True)  # isochoric
    total = direction * 0.05
    stress0 = np.tile([80.0, 90.0, 70.0, 0, 0, 0], (5, 1))
    one, st1, _ = m.update(stress0, m.initial_state(stress0), total, 1.0)
    many, st = stress0, m.initial_state(stress0)
    for _ in range(100):
        many, st, _ = m.update(many, st, total / 100, 1.0)
    # initial stress has a deviator, so the path is not exactly radial from the origin; compare the deviatoric size
    np.testing.assert_allclose(deviatoric_stress(one), np.sqrt(3) * SU, rtol=1e-13)
    np.testing.assert_allclose(deviatoric_stress(many), np.sqrt(3) * SU, rtol=1e-13)
    # start from an isotropic stress: then the path is radial and one step == many steps to round-off
    iso = np.tile([80.0, 80.0, 80.0, 0, 0, 0], (5, 1))
    one, st1, _ = m.update(iso, m.initial_state(iso), total, 1.0)
    many, st = iso, m.initial_state(iso)
    for _ in range(100):
        many, st, _ = m.update(many, st, total / 100, 1.0)
    np.testing.assert_allclose(one, many, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(st1["plastic_strain"], st["plastic_strain"], rtol=1e-10, atol=1e-14)


def test_consistent_tangent_matches_finite_differences():
    m = model(s_u=np.array([30.0, 30.0, 50.0]), G=np.array([3000.0, 3000.0, 5000.0]))
    stress0 = np.array([[100.0, 60.0, 80.0, 10.0, -5.0, 3.0]] * 3)
    rng = np.random.default_rng(2)
    dstrain = rng.normal(scale=0.01, size=(3, 6))
    dstrain[0] *= 1e-4  # elastic point
    state = m.initial_state(stress0)
    s, _, C = m.update(stress0, state, dstrain, 1.0)
    h = 1e-7
    for j in range(6):
        dp, dm = dstrain.copy(), dstrain.copy()
        dp[:, j] += h
        dm[:, j] -= h
        fd = (m.update(stress0, state, dp, 1.0)[0] - m.update(stress0, state, dm, 1.0)[0]) / (2 * h)
        np.testing.assert_allclose(C[:, :, j], fd, rtol=1e-6, atol=1e-6 * G)


def test_plane_strain_matches_tresca():
    """Plane strain (eps_z = 0), isochoric in-plane shearing: sigma_r - sigma_theta -> 2 s_u (Tresca)."""
    m = model(nu=0.49)
    stress = np.tile([100.0, 100.0, 100.0, 0, 0, 0], (1, 1))
    state = m.initial_state(stress)
    for _ in range(200):
        stress, state, _ = m.update(stress, state, np.array([[1e-4, -1e-4, 0, 0, 0, 0]]), 1.0)
    np.testing.assert_allclose(stress[0, 0] - stress[0, 1], 2 * SU, rtol=1e-9)
    np.testing.assert_allclose(stress[0, 2], 0.5 * (stress[0, 0] + stress[0, 1]), rtol=1e-9)


def test_update_does_not_mutate_inputs():
    m = model()
    stress = np.array([[100.0, 100.0, 100.0, 0, 0, 0]])
    state = m.initial_state(stress, 1.0)
    ds = np.array([[0.05, -0.05, 0, 0, 0, 0]])
    copies = stress.copy(), {k: v.copy() for k, v in state.items()}, ds.copy()
    m.update(stress, state, ds, 1.0)
    np.testing.assert_array_equal(stress, copies[0])
    np.testing.assert_array_equal(ds, copies[2])
    for k in state:
        np.testing.assert_array_equal(state[k], copies[1][k])
