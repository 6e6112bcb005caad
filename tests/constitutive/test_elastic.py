"""Linear elasticity through the laboratory-test drivers: every curve has a closed form (Hooke's law)."""
import numpy as np

from constitutive import LinearElastic
from constitutive import labtests as lt

E, NU = 10000.0, 0.25
K, G = E / (3 * (1 - 2 * NU)), E / (2 * (1 + NU))
EA = np.linspace(0.0, 0.01, 11)


def test_drained_triaxial_is_hooke():
    c = lt.drained_triaxial(LinearElastic(E, NU), 1.0, 100.0, EA)
    eps_q = 2.0 / 3.0 * (c["axial_strain"][0] - c["radial_strain"][0])
    np.testing.assert_allclose(c["q"][0], 3 * G * eps_q, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(c["q"][0], E * EA, rtol=1e-12, atol=1e-9)  # constant radial stress: dq = E d eps_a
    np.testing.assert_allclose(c["radial_stress"][0], 100.0, rtol=1e-12)
    np.testing.assert_allclose(c["p"][0] - 100.0, c["q"][0] / 3.0, rtol=1e-12, atol=1e-9)  # stress path slope 3
    np.testing.assert_allclose(c["volumetric_strain"][0], (c["p"][0] - 100.0) / K, rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(c["radial_strain"][0], -NU * EA, rtol=1e-10, atol=1e-15)
    np.testing.assert_array_equal(c["excess_pore_pressure"][0], 0.0)


def test_undrained_triaxial_is_isochoric_with_u_equal_q_over_3():
    c = lt.undrained_triaxial(LinearElastic(E, NU), 1.0, 100.0, EA)
    np.testing.assert_allclose(c["volumetric_strain"][0], 0.0, atol=1e-14)
    np.testing.assert_allclose(c["p"][0], 100.0, rtol=1e-12)  # isotropic elasticity: no p' change at constant volume
    np.testing.assert_allclose(c["q"][0], 3 * G * EA, rtol=1e-10)
    np.testing.assert_allclose(c["excess_pore_pressure"][0], c["q"][0] / 3.0, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(c["total_radial_stress"][0], 100.0, rtol=1e-12)


def test_isotropic_compression_and_crs_oedometer():
    m = LinearElastic(E, NU)
    c = lt.isotropic_compression(m, 1.0, 100.0, [150.0, 200.0, 120.0])
    np.testing.assert_allclose(c["volumetric_strain"][0], (np.array([150.0, 200.0, 120.0]) - 100.0) / K, rtol=1e-10)
    np.testing.assert_allclose(c["q"][0], 0.0, atol=1e-9)
    c = lt.oedometer_crs(m, 1.0, 50.0, EA[1:], strain_rate=1e-6, k0=0.5)
    E_oed = K + 4.0 * G / 3.0
    np.testing.assert_allclose(c["axial_stress"][0] - 50.0, E_oed * EA[1:], rtol=1e-12)
    np.testing.assert_allclose(c["radial_stress"][0] - 25.0, NU / (1 - NU) * E_oed * EA[1:], rtol=1e-12)
    np.testing.assert_allclose(c["time"][0], EA[1:] / 1e-6, rtol=1e-12)
    # e_{k+1} = e_k - (1 + e_k) d eps_v per step (specific volume at the start of the step): 1 + e = 2 (1 - d eps)^k
    np.testing.assert_allclose(1.0 + c["e"][0], 2.0 * (1.0 - 0.001) ** np.arange(1, 11), rtol=1e-12)


def test_oedometer_loading_and_stages_hold_state():
    m = LinearElastic(E, NU)
    c = lt.oedometer_loading(m, 1.0, 50.0, [100.0, 200.0], stage_duration=1000.0, n_times=5)
    E_oed = K + 4.0 * G / 3.0
    expect = np.repeat([50.0, 150.0], 5) / E_oed
    np.testing.assert_allclose(c["axial_strain"][0], expect, rtol=1e-10)
    np.testing.assert_allclose(c["stage_time"][0], np.tile(np.geomspace(1.0, 1000.0, 5), 2), rtol=1e-12)
    np.testing.assert_allclose(c["time"][0, [4, 9]], [1000.0, 2000.0], rtol=1e-12)
    stages = [{"type": "shear", "axial_strain": [0.005]}, {"type": "creep", "duration": 100.0, "n_times": 3},
              {"type": "shear", "axial_strain": [0.01]}, {"type": "relaxation", "duration": 100.0, "n_times": 3}]
    c = lt.triaxial_stages(m, 1.0, 100.0, stages)
    np.testing.assert_allclose(c["axial_strain"][0], [0.005] * 4 + [0.01] * 4, rtol=1e-10)
    np.testing.assert_allclose(c["q"][0], E * c["axial_strain"][0], rtol=1e-9)
    np.testing.assert_array_equal(c["stage"][0], [0, 1, 1, 1, 2, 3, 3, 3])
