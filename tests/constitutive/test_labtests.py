"""Mixed-control driver with Modified Cam Clay: critical state, convergence order, batching, failure handling."""
import numpy as np
import pytest

from constitutive import IntegrationError, LinearElastic, ModifiedCamClay
from constitutive import labtests as lt

M, LAM, KAP = 1.2, 0.2, 0.04


def test_drained_triaxial_reaches_critical_state():
    """q/p' -> M and e -> e_cs(p') = e_N - lambda ln p' - (lambda - kappa) ln 2 (MCC CSL below the NCL)."""
    m = ModifiedCamClay(M=M, lambda_=LAM, kappa=KAP, G=2000.0, ocr=1.5)
    c = lt.drained_triaxial(m, 1.0, 100.0, [0.5, 1.0, 2.0], substeps=200)
    e_N = 1.0 + KAP * np.log(100.0 / 150.0) + LAM * np.log(150.0)  # NCL through the initial yield surface
    e_cs = e_N - LAM * np.log(c["p"][0]) - (LAM - KAP) * np.log(2.0)
    eta = c["q"][0] / c["p"][0]
    np.testing.assert_allclose(eta[-1], M, rtol=1e-6)
    np.testing.assert_allclose(c["e"][0, -1], e_cs[-1], atol=1e-7)
    assert np.all(np.diff(np.abs(eta - M)) < 0) and np.all(np.diff(np.abs(c["e"][0] - e_cs)) < 0)
    # the driver holds sigma'_r to its Newton tolerance, 1e-10 x (1 kPa + max |sigma'|); q - 3 (p' - 100) is
    # 3 (100 - sigma'_r): stress path slope 3 to three times that (measured 1.4e-10 kPa)
    held = 1e-10 * (1.0 + np.abs(c["axial_stress"][0]).max())
    np.testing.assert_allclose(c["radial_stress"][0], 100.0, rtol=0.0, atol=held)
    np.testing.assert_allclose(c["q"][0], 3 * (c["p"][0] - 100.0), rtol=0.0, atol=3.0 * held)


def test_convergence_order_of_driver_and_model():
    """Halving the strain increment: differences shrink by 2 (backward Euler, first order)."""
    m = ModifiedCamClay(M=M, lambda_=LAM, kappa=KAP, nu=0.3, ocr=1.2)
    qs = np.array([lt.drained_triaxial(m, 1.0, 100.0, [0.02, 0.05, 0.10], substeps=s)["q"][0] for s in (8, 16, 32, 64)])
    d = np.abs(np.diff(qs, axis=0))
    order = np.log2(d[:-1] / d[1:])
    np.testing.assert_allclose(order, 1.0, atol=0.15)
    extrapolated = 2 * qs[-1] - qs[-2]
    assert np.all(np.abs(qs[-1] - extrapolated) < 2e-3 * extrapolated)


@pytest.mark.parametrize("driver", [lt.drained_triaxial, lt.undrained_triaxial])
def test_batched_equals_individual(driver):
    rng = np.random.default_rng(7)
    n = 6
    prm = dict(M=rng.uniform(0.8, 1.5, n), lambda_=rng.uniform(0.1, 0.3, n), kappa=rng.uniform(0.01, 0.05, n),
               nu=rng.uniform(0.1, 0.4, n), ocr=rng.uniform(1.0, 4.0, n))
    e0, p0 = rng.uniform(0.6, 1.4, n), rng.uniform(50, 300, n)
    ea = np.linspace(0, 0.15, 16)[1:]
    batch = driver(ModifiedCamClay(**prm), e0, p0, ea, substeps=2)
    for i in range(n):
        one = driver(ModifiedCamClay(**{k: v[i] for k, v in prm.items()}), e0[i], p0[i], ea, substeps=2)
        for key in ("q", "p", "e", "volumetric_strain", "excess_pore_pressure"):
            np.testing.assert_allclose(batch[key][i], one[key][0], rtol=1e-12, atol=1e-12 * np.abs(one["p"]).max())


def test_undrained_driver_matches_strain_controlled_model():
    """Undrained triaxial through the mixed driver (du unknown, total radial stress fixed) equals integrating the
    model directly along the isochoric path eps_r = -eps_a/2 (exact for isotropic models)."""
    m = ModifiedCamClay(M=M, lambda_=LAM, kappa=KAP, nu=0.25, ocr=2.0)
    ea = np.linspace(0, 0.1, 51)[1:]
    c = lt.undrained_triaxial(m, 0.9, 150.0, ea)
    stress = np.array([[150.0, 150.0, 150.0, 0, 0, 0]])
    state = m.initial_state(stress, 0.9)
    qs = []
    for _ in ea:
        stress, state, _ = m.update(stress, state, 0.002 * np.array([[1.0, -0.5, -0.5, 0, 0, 0]]), 1.0)
        qs.append(stress[0, 0] - stress[0, 1])
    np.testing.assert_allclose(c["q"][0], qs, rtol=1e-8)
    np.testing.assert_allclose(c["radial_strain"][0], -ea / 2, rtol=1e-10)


class _FailsAtStrain(LinearElastic):
    """Linear elastic, but point 1 fails (IntegrationError) once its axial strain would pass 0.004."""

    def initial_state(self, stress0, void_ratio0=None):
        st = super().initial_state(stress0, void_ratio0)
        st["eps_a"] = np.zeros(len(st["void_ratio"]))
        return st

    def update(self, stress, state, dstrain, dt, tangent=True):
        if state["eps_a"][1] + dstrain[1, 0] > 0.004:
            raise IntegrationError(1, "test failure")
        s, st, C = super().update(stress, {"void_ratio": state["void_ratio"]}, dstrain, dt)
        st["eps_a"] = state["eps_a"] + dstrain[:, 0]
        return s, st, C


def test_failure_raises_or_freezes_only_that_point():
    m = _FailsAtStrain(E=np.full(3, 1e4), nu=0.3)
    ea = np.linspace(0, 0.01, 11)[1:]
    with pytest.raises(IntegrationError) as info:
        lt.drained_triaxial(m, 1.0, 100.0, ea)
    assert info.value.point == 1
    c = lt.drained_triaxial(m, 1.0, 100.0, ea, on_failure="nan")
    np.testing.assert_array_equal(c["failed"], [False, True, False])
    np.testing.assert_allclose(c["q"][[0, 2]], 1e4 * np.vstack([ea, ea]), rtol=1e-10)
    np.testing.assert_allclose(c["q"][1, :4], 1e4 * ea[:4], rtol=1e-10)
    assert np.all(np.isnan(c["q"][1, 4:]))


# ------------------------------------------------------------------------------ routing to a model's fast path
def _simsand_batch():
    from constitutive import SIMSAND
    return SIMSAND(nu=0.2, K_0=100.0, n=0.6, e_ref=0.75, lambda_c=0.03, xi=0.6, phi_mu=np.array([30.0, 34.0, 45.0]),
                   k_p=0.003, A_d=1.0, n_p=np.array([2.0, 1.0, 10.0]), n_d=2.0)


@pytest.mark.parametrize("driver, drained", [(lt.drained_triaxial, True), (lt.undrained_triaxial, False)])
def test_route_auto_equals_the_models_own_triaxial_test(driver, drained):
    """A model with triaxial_test (SIMSAND) is dispatched to it: the same curves, bit for bit, under the same names,
    plus time and total stresses; failed points (on_failure='nan') stay NaN."""
    model = _simsand_batch()
    ea = np.linspace(0.005, 0.1, 20)
    via = driver(model, 0.8, np.array([100.0, 200.0, 800.0]), ea, on_failure="nan", strain_rate=2e-5)
    direct = model.triaxial_test(0.8, np.array([100.0, 200.0, 800.0]), ea, drained=drained, on_failure="nan")
    for key, val in direct.items():
        np.testing.assert_array_equal(via[key], val, err_msg=key)
    generic = driver(model, 0.8, 100.0, ea[:2], route="generic")
    assert set(generic) == set(via)
    ok = ~via["failed"]
    np.testing.assert_allclose(via["time"][ok], np.broadcast_to(ea / 2e-5, via["q"].shape)[ok], rtol=1e-12)
    np.testing.assert_array_equal(via["total_radial_stress"] - via["radial_stress"], via["excess_pore_pressure"])


def test_route_falls_back_to_the_generic_driver_or_refuses_when_asked_for_fast():
    m = ModifiedCamClay(M=M, lambda_=LAM, kappa=KAP, nu=0.3, ocr=1.5)
    ea = [0.01, 0.02]
    np.testing.assert_array_equal(lt.drained_triaxial(m, 1.0, 100.0, ea)["q"],
                                  lt.drained_triaxial(m, 1.0, 100.0, ea, route="generic")["q"])
    with pytest.raises(ValueError, match="ModifiedCamClay has no triaxial_test"):
        lt.drained_triaxial(m, 1.0, 100.0, ea, route="fast")
    with pytest.raises(ValueError, match="k0 = 0.5"):
        lt.drained_triaxial(_simsand_batch(), 0.8, 100.0, ea, k0=0.5, route="fast")
    with pytest.raises(ValueError, match="route must be one of"):
        lt.drained_triaxial(m, 1.0, 100.0, ea, route="quick")


# ------------------------------------------------------------------------------ stopping at a target stress
def _oedometer_ramp(n_steps, step=0.0025):
    """MCC (two points, lambda 0.2 and 0.3) at sigma'_v = 50 kPa, K0 0.6, normally consolidated; an oedometer strain
    ramp (every strain prescribed) of ``n_steps`` axial steps."""
    m = ModifiedCamClay(M=M, lambda_=np.array([LAM, 0.3]), kappa=KAP, nu=0.3)
    stress = np.tile([50.0, 30.0, 30.0, 0.0, 0.0, 0.0], (2, 1))
    inc = np.zeros((n_steps, 2, 6))
    inc[:, :, 0] = step
    return m, stress, m.initial_state(stress, 1.2), inc, np.full(n_steps, step / 1e-6)


def test_stop_leaves_a_point_before_the_step_that_passes_the_target():
    """``stop``: the point whose sigma'_v would pass 100 kPa stays where it was before that step (its values those
    of the run without stop after the step before, bit for bit), the value it would have reached is returned; the
    point that does not reach its target (1e4 kPa) is the run without stop."""
    m, stress, state, inc, dt = _oedometer_ramp(40)
    free = lt.mixed_control(m, stress, state, lt.ALL_STRAIN, inc, dt)
    target = np.array([100.0, 1e4])
    hist = lt.mixed_control(m, stress, state, lt.ALL_STRAIN, inc, dt, stop=(0, target, np.ones(2)))
    assert list(hist["stopped"]) == [True, False]
    k = hist["stop_step"][0]
    s_free = free["stress"][0, :, 0]
    assert s_free[k] < 100.0 <= s_free[k + 1]  # record k + 1 is the end of step k
    assert hist["stop_value"][0] == s_free[k + 1]
    assert np.all(hist["final_stress"][0] == free["stress"][0, k])
    assert hist["strain"][0, -1, 0] == pytest.approx(0.0025 * k, rel=1e-12)
    assert hist["time"][0, -1] == pytest.approx(2500.0 * k, rel=1e-12)
    np.testing.assert_array_equal(hist["stress"][1], free["stress"][1])
    assert np.all(hist["final_stress"][1] == free["final_stress"][1])


class _CountingMCC(ModifiedCamClay):
    """MCC counting its updates."""
    calls = 0

    def update(self, *args, **kwargs):
        type(self).calls += 1
        return super().update(*args, **kwargs)


def test_a_step_with_every_strain_prescribed_fails_at_once_with_the_models_reason():
    """Every strain prescribed: nothing for the driver's Newton to solve, so a model failure is final without step
    cuts (one update per step, the failing one included), and the error carries the model's reason: here MCC's
    unstable point (M 0.8, lambda - kappa = 0.01, yield on the dry side of critical under oedometer loading). The
    Python driver, whose model updates can be counted (the compiled one: test_compiled_step_loop.py)."""
    m = _CountingMCC(M=0.8, lambda_=0.1, kappa=0.09, nu=0.25, pc0=400.0)
    stress = np.array([[20.0, 11.0, 11.0, 0.0, 0.0, 0.0]])
    inc = np.zeros((80, 6))
    inc[:, 0] = 0.0025
    _CountingMCC.calls = 0
    hist = lt.mixed_control(m, stress, m.initial_state(stress, 1.26), lt.ALL_STRAIN, inc, np.ones(80),
                            on_failure="nan", compiled=False)
    assert hist["failed"][0]
    (k, reason), = hist["reasons"].items()
    assert k == 0 and "unstable material point" in reason
    failed_at = int(reason.split(":")[0].split()[1])
    assert _CountingMCC.calls == 1 + 80  # the start's tangent and one update per step
    assert np.all(np.isnan(hist["stress"][0, failed_at + 1:]))
    with pytest.raises(IntegrationError, match="unstable material point"):
        lt.mixed_control(m, stress, m.initial_state(stress, 1.26), lt.ALL_STRAIN, inc, np.ones(80), compiled=False)
