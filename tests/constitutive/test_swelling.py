"""Delayed swelling in series with a base model (constitutive.swelling, (S1)-(S4)) against closed forms.

Oracles: the Kelvin-element solutions of (S2)-(S3) after an instantaneous unloading, derived by hand below (creep
under held stress, relaxation under held strain with Modified Cam Clay's exponential elasticity and with a linear
elastic base), the backward-Euler recurrence of the linear relaxation ODE, first-order convergence in dt, the base
model itself (first loading, tau_s -> infinity, kappa_s = 0), point-by-point runs, and central finite differences
of the tangent.
"""

import numpy as np
import pytest

from constitutive import ANICREEP, IntegrationError, LinearElastic, ModifiedCamClay, ParameterError
from constitutive import labtests as lt
from constitutive.swelling import DelayedSwelling

M, LAM, KAP = 1.2, 0.2, 0.02
E0 = 1.0
P_MAX, P_U = 200.0, 50.0                  # kPa: unloading from p'_max to p'_u
HOLD = np.array([False, False, False, True, True, True])   # normal stresses held, shear strains zero


def mcc(**kw):
    return ModifiedCamClay(**{"M": M, "lambda_": LAM, "kappa": KAP, "nu": 0.3, "ocr": 1.0, **kw})


def isotropic(p):
    return np.array([[p, p, p, 0.0, 0.0, 0.0]])


def unloaded_void_ratio(base, e0, p_max, p_u):
    """Void ratio after an instantaneous elastic unloading (closed forms of the base elasticity): MCC integrates
    p' = p'_n exp((1 + e_n) d eps_v/kappa) exactly in one step, so e = e0 - kappa ln(p'_u/p'_max); linear elasticity
    gives d eps_v = (p'_u - p'_max)/K."""
    if isinstance(base, ModifiedCamClay):
        return e0 - KAP * np.log(p_u / p_max)
    return e0 - (1.0 + e0) * (p_u - p_max) / base.bulk_modulus


def unloading_strain(base, e0, p_max, p_u):
    """The isotropic strain increment (n = 1, Voigt) of that unloading."""
    dv = (e0 - unloaded_void_ratio(base, e0, p_max, p_u)) / (1.0 + e0)
    return np.array([[dv / 3.0] * 3 + [0.0] * 3])


# ------------------------------------------------------------------------------------- (1) creep after unloading
def creep_after_unloading(model, steps_per_tau, n_tau=1.0):
    """Isotropic unloading P_MAX -> P_U in one step with dt = 0, then p' held for n_tau tau_s in steps tau_s/N.
    Returns (swelling strain at the end, volumetric strain of the hold, the driver's history)."""
    tau = float(model.tau_s)
    n = int(round(steps_per_tau * n_tau))
    inc = np.zeros((n + 1, 6))
    inc[0, :3] = P_U - P_MAX
    dt = np.concatenate([[0.0], np.full(n, tau / steps_per_tau)])
    state0 = model.initial_state(isotropic(P_MAX), E0)
    hist = lt.mixed_control(model, isotropic(P_MAX), state0, HOLD, inc, dt)
    ev = hist["strain"][0, :, :3].sum(axis=1)
    return hist["state"]["swelling_strain"][0], ev[-1] - ev[1], hist


def creep_closed_form(c, s):
    """eps_s(t) under held p' after an instantaneous unloading, s = t/tau_s, c = kappa_s ln(p'_u/p'_max)/(1 + e_u).

    (S3) with (S2) and the void ratio of (S4), 1 + e = (1 + e_u) exp(-eps_s) (the base strain is constant at held
    stress): tau_s y' = c exp(y) - y, y(0) = 0. Expanding in the small c: y0 = c (1 - exp(-s)) (the textbook
    eps_eq (1 - exp(-t/tau_s))), then y1' + y1 = c y0 gives y1 = c^2 (1 - exp(-s) - s exp(-s)); error O(c^3)."""
    return c * (1.0 - np.exp(-s)) + c * c * (1.0 - np.exp(-s) - s * np.exp(-s))


@pytest.mark.parametrize("base", [LinearElastic(E=3000.0, nu=0.25), mcc()], ids=["elastic", "mcc"])
def test_creep_after_unloading_converges_to_closed_form(base):
    kappa_s, tau_s = 0.005, 1.0e4
    model = DelayedSwelling(base, kappa_s, tau_s)
    c = kappa_s * np.log(P_U / P_MAX) / (1.0 + unloaded_void_ratio(base, E0, P_MAX, P_U))
    exact = creep_closed_form(c, 1.0)
    runs = [creep_after_unloading(model, N) for N in (10, 20, 40, 80)]
    y = np.array([r[0] for r in runs])
    # at held stress the base strain does not change: the hold's volumetric strain is the swelling strain
    np.testing.assert_allclose([r[1] for r in runs], y, rtol=1e-9)
    err = y - exact
    assert np.all(err > 0.0)   # backward Euler decays as 1/(1 + a) per step, slower than exp(-a): it lags behind
    np.testing.assert_allclose(err[:-1] / err[1:], 2.0, rtol=0.06)        # first order: error halves with dt
    # Richardson extrapolation removes the O(dt) error; left: backward Euler's O(dt^2) term (for the linear decay
    # ln (1 + h)^(-1/h) = -1 + h/2 - h^2/3, so y_N = y + A h + B h^2 with |B| = (5/24) e^-1 |c| at t = tau_s, and
    # 2 y_2N - y_N = y - B h^2/2, h = 1/40) and the expansion's O(c^3)
    h = 1.0 / 40.0
    np.testing.assert_allclose(2.0 * y[-1] - y[-2], exact, rtol=0.0,
                               atol=1.2 * (5.0 / 24.0) * np.exp(-1.0) * abs(c) * h * h / 2.0 + abs(c) ** 3)
    # the swelling is measured in the void ratio too (S4): e rises during the hold
    e = runs[-1][2]["void_ratio"][0]
    assert np.all(np.diff(e[1:]) > 0.0)


def test_creep_tends_to_the_equilibrium_swelling():
    """After many tau_s the swelling strain is (S2) at the final void ratio, eps_s = kappa_s ln(p'_u/p'_max)/(1 + e),
    and close to the root of y = c exp(y), whose 1 + e = (1 + e_u) exp(-y) the steps approach as prod(1 - d eps_s)
    (relative difference about sum d eps_s^2/2 / |y| ~ 1e-4 with 4 steps per tau_s)."""
    kappa_s = 0.02
    model = DelayedSwelling(mcc(), kappa_s, 100.0)
    y, _, hist = creep_after_unloading(model, 4, n_tau=40.0)
    e_end = hist["void_ratio"][0, -1]
    np.testing.assert_allclose(y, kappa_s * np.log(P_U / P_MAX) / (1.0 + e_end), rtol=1e-12)
    c = kappa_s * np.log(P_U / P_MAX) / (1.0 + unloaded_void_ratio(model.base, E0, P_MAX, P_U))
    root = c
    for _ in range(50):   # fixed point of y = c exp(y), contraction |c| < 1
        root = c * np.exp(root)
    np.testing.assert_allclose(y, root, rtol=1e-4)


# ------------------------------------------------------------------------------ (2) relaxation after unloading
def relaxation(model, steps_per_tau, n_tau=1.0):
    """Unloading P_MAX -> P_U in one increment with dt = 0, then the strain held for n_tau tau_s in steps of
    tau_s/N through the model's update. Returns (swelling strains, p' at the end of every hold step)."""
    stress = isotropic(P_MAX)
    state = model.initial_state(stress, E0)
    stress, state, _ = model.update(stress, state, unloading_strain(model.base, E0, P_MAX, P_U), 0.0)
    ys, ps = [], []
    for _ in range(int(round(steps_per_tau * n_tau))):
        stress, state, _ = model.update(stress, state, np.zeros((1, 6)), float(model.tau_s) / steps_per_tau)
        ys.append(state["swelling_strain"][0])
        ps.append(stress[0, :3].mean())
    return np.array(ys), np.array(ps)


def test_relaxation_with_mcc_elasticity_closed_form_and_recurrence():
    """Strain held after unloading, MCC elasticity inside the surface: the void ratio stays e_u (total strain
    held), the base takes -eps_s, p' = p'_u exp(-v_u eps_s/kappa) exactly, so (S2) is linear in eps_s:
    eps_eq = c - r eps_s, c = kappa_s ln(p'_u/p'_max)/v_u, r = kappa_s/kappa. Then
    tau_s y' = c - (1 + r) y:  y = c/(1 + r) (1 - exp(-(1 + r) t/tau_s)); backward Euler with a = dt/tau_s is the
    recurrence y_{k+1} = (y_k + a c)/(1 + a (1 + r)), which the integrator must reproduce to round-off."""
    kappa_s, tau_s = 0.01, 5.0e3
    model = DelayedSwelling(mcc(), kappa_s, tau_s)
    v_u = 1.0 + unloaded_void_ratio(model.base, E0, P_MAX, P_U)
    c, r = kappa_s * np.log(P_U / P_MAX) / v_u, kappa_s / KAP
    ys, ps = relaxation(model, 10, n_tau=3.0)
    a, y, rec = 0.1, 0.0, []
    for _ in ys:
        y = (y + a * c) / (1.0 + a * (1.0 + r))
        rec.append(y)
    np.testing.assert_allclose(ys, rec, rtol=1e-12)
    np.testing.assert_allclose(ps, P_U * np.exp(-v_u * ys / KAP), rtol=1e-12)
    assert np.all(np.diff(ps) > 0.0) and ps[-1] < P_MAX        # p' rises towards, not to, p'_max
    errors = [relaxation(model, N)[0][-1] - c / (1 + r) * (1 - np.exp(-(1 + r))) for N in (10, 20, 40, 80)]
    np.testing.assert_allclose(np.array(errors[:-1]) / errors[1:], 2.0, rtol=0.05)


def test_relaxation_with_linear_elastic_base_small_strain_closed_form():
    """Linear elastic base (constant K), strain held: p' = p'_u - K eps_s. For small K|eps_s|/p'_u,
    ln(p'/p'_max) = L_u - K eps_s/p'_u + O((K eps_s/p'_u)^2), L_u = ln(p'_u/p'_max), so
    tau_s y' = c - (1 + r) y with c = kappa_s L_u/(1 + e_u), r = kappa_s K/((1 + e_u) p'_u):
    y = c/(1 + r) (1 - exp(-(1 + r) t/tau_s)) and p' = p'_u - K y rises. The neglected term is
    kappa_s/(1 + e_u) (K y/p'_u)^2/2 in the rate, about 1e-4 of y here."""
    kappa_s, tau_s = 0.01, 1.0e3
    base = LinearElastic(E=300.0, nu=0.25)        # K = 200 kPa
    K = base.bulk_modulus
    model = DelayedSwelling(base, kappa_s, tau_s)
    v_u = 1.0 + unloaded_void_ratio(base, E0, P_MAX, P_U)
    c, r = kappa_s * np.log(P_U / P_MAX) / v_u, kappa_s * K / (v_u * P_U)
    closed = c / (1.0 + r) * (1.0 - np.exp(-(1.0 + r)))
    (y20, _), (y40, p40) = relaxation(model, 20), relaxation(model, 40)
    np.testing.assert_allclose(p40, P_U - K * y40, rtol=1e-12)
    assert np.all(np.diff(p40) > 0.0)
    assert abs(y40[-1] - closed) < 0.02 * abs(closed)                 # O(dt) error of 40 steps per tau_s
    np.testing.assert_allclose(2.0 * y40[-1] - y20[-1], closed, rtol=3e-4)   # Richardson: to the linearization


# ------------------------------------------------------------------ (3) first loading, (4) tau_s -> oo, kappa_s = 0
def oedometer_programme(model, e0=1.0, sigma_v0=50.0, hold=5.0e4):
    """Oedometer (lateral strain zero) through the lab driver: sigma'_v 50 -> 200 kPa, hold, unload to 50 kPa,
    hold, each hold of ``hold`` s in log-spaced steps. Returns the driver history."""
    holds = np.diff(np.geomspace(1.0, hold, 25))
    dts = np.concatenate([np.full(10, 10.0), holds, np.full(10, 10.0), holds])
    inc = np.zeros((dts.size, 6))
    inc[:10, 0] = 15.0
    inc[10 + holds.size:20 + holds.size, 0] = -15.0
    n = lt.batch_size(model, e0)
    stress0 = np.zeros((n, 6))
    stress0[:, :3] = sigma_v0
    return lt.mixed_control(model, stress0, model.initial_state(stress0, np.full(n, e0)), lt.OEDOMETER_STRESS, inc,
                            dts)


def anicreep(**kw):
    return ANICREEP(**{"M": M, "lambda_": LAM, "kappa": KAP, "nu": 0.25, "e0": E0, "sigma_p0": 60.0,
                       "C_alpha_e": 0.005, "anisotropy": False, **kw})


@pytest.mark.parametrize("base", [mcc(), anicreep()], ids=["mcc", "anicreep"])
def test_first_loading_is_the_base_model(base):
    """Monotonic first loading: p' never falls below p'_max, eps_s stays 0 and the base gets the strain bit for
    bit (CRS oedometer, all strains prescribed: identical results; drained triaxial compression, whose p' rises
    along its 3:1 path)."""
    model = DelayedSwelling(base, 0.03, 1.0e3)
    ea = np.linspace(0.0, 0.08, 17)[1:]
    ref, got = lt.oedometer_crs(base, E0, 60.0, ea, 1e-6), lt.oedometer_crs(model, E0, 60.0, ea, 1e-6)
    for key in ("axial_stress", "radial_stress", "e", "volumetric_strain"):
        np.testing.assert_array_equal(got[key], ref[key])
    # stress-controlled radial stress: the driver's Newton iterates may pass below p'_max (the swelling law then
    # changes the iterate's tangent, not the converged state), so the two agree to the driver's tolerance
    # 1e-10 (1 kPa + max |sigma'|)
    ref = lt.drained_triaxial(base, E0, 60.0, ea, route="generic")
    got = lt.drained_triaxial(model, E0, 60.0, ea, route="generic")
    held = 1e-10 * (1.0 + np.abs(ref["axial_stress"]).max())
    for key in ("axial_stress", "radial_stress"):
        np.testing.assert_allclose(got[key], ref[key], rtol=0.0, atol=10.0 * held)
    np.testing.assert_allclose(got["volumetric_strain"], ref["volumetric_strain"], rtol=1e-9)


def test_long_time_constant_or_zero_index_recovers_the_base():
    """tau_s -> infinity: the difference from the base falls as 1/tau_s (a = dt/tau_s); kappa_s = 0: none."""
    base = mcc(nu=None, G=3000.0)
    ref = oedometer_programme(base)
    diff = {}
    for tau in (1e8, 1e9, 1e300):
        got = oedometer_programme(DelayedSwelling(base, 0.03, tau))
        diff[tau] = np.abs(got["strain"] - ref["strain"]).max()
    np.testing.assert_allclose(diff[1e8] / diff[1e9], 10.0, rtol=0.01)
    assert diff[1e300] < 1e-14
    got = oedometer_programme(DelayedSwelling(base, 0.0, 1e3))
    np.testing.assert_allclose(got["strain"], ref["strain"], rtol=0.0, atol=1e-14)


# -------------------------------------------------------------------------------------- (5) points, tangent
def test_batch_with_different_parameters_equals_point_by_point():
    rng = np.random.default_rng(3)
    n = 5
    prm = dict(M=rng.uniform(0.9, 1.4, n), lambda_=rng.uniform(0.1, 0.3, n), kappa=rng.uniform(0.01, 0.05, n),
               nu=rng.uniform(0.15, 0.35, n), ocr=1.0)
    swell = dict(kappa_s=rng.uniform(0.001, 0.05, n), tau_s=np.exp(rng.uniform(np.log(1e2), np.log(1e6), n)))
    e0 = rng.uniform(0.7, 1.5, n)
    batch = oedometer_programme(DelayedSwelling(ModifiedCamClay(**prm), **swell), e0=e0)
    for i in range(n):
        one = oedometer_programme(DelayedSwelling(ModifiedCamClay(**{k: np.ravel(v)[i % np.size(v)]
                                                                     for k, v in prm.items()}),
                                                  **{k: v[i] for k, v in swell.items()}), e0=e0[i])
        np.testing.assert_allclose(batch["strain"][i], one["strain"][0], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(batch["stress"][i], one["stress"][0], rtol=1e-12)
        for key in ("swelling_strain", "p_max", "void_ratio"):
            np.testing.assert_allclose(batch["state"][key][i], one["state"][key][0], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("kind", ["elastic inside", "plastic"])
def test_tangent_is_consistent(kind):
    """Central differences of the updated stress in the strain increment, on an increment where (S2) is active:
    inside MCC's surface after an unloading, and on the surface in an isochoric shear increment of a normally
    consolidated point (p' falls below p'_max while it yields)."""
    model = DelayedSwelling(mcc(), 0.02, 500.0)
    stress = np.array([[120.0, 100.0, 100.0, 5.0, 0.0, 0.0]])
    state = model.initial_state(stress, E0)
    if kind == "elastic inside":
        stress, state, _ = model.update(stress, state, np.array([[-0.004, -0.003, -0.003, 0.0, 0.0, 0.0]]), 0.0)
        deps = np.array([[2e-4, -1e-4, 5e-5, 3e-4, 1e-4, -2e-4]])
    else:
        deps = np.array([[4e-3, -2e-3, -2e-3, 1e-3, 0.0, 0.0]])
    s_new, st_new, C = model.update(stress, state, deps, 300.0)
    assert st_new["swelling_strain"][0] < 0.0               # the swelling law acted in this increment
    h = 1e-7
    fd = np.empty((6, 6))
    for j in range(6):
        d = np.zeros((1, 6))
        d[0, j] = h
        plus, minus = model.update(stress, state, deps + d, 300.0)[0], model.update(stress, state, deps - d, 300.0)[0]
        fd[:, j] = (plus - minus)[0] / (2.0 * h)
    np.testing.assert_allclose(C[0], fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max())


# --------------------------------------------------------------------------------------- lab drivers, classes
def test_oedometer_loading_unloading_and_holds_in_the_lab_driver():
    """Through labtests.oedometer_loading (stress-controlled stages, each ramped then held): after loading nothing
    swells (the held MCC specimen keeps its strain, as the base model does); after the unloading stage the specimen
    keeps swelling (compressive strain falls, void ratio rises) while the base model holds still."""
    base = mcc()
    model = DelayedSwelling(base, 0.02, 2.0e3)
    kw = dict(stage_duration=1.0e5, n_times=12)
    ref = lt.oedometer_loading(base, E0, 50.0, [200.0, 50.0], **kw)
    got = lt.oedometer_loading(model, E0, 50.0, [200.0, 50.0], **kw)
    loading, unloading = got["stage"][0] == 0, got["stage"][0] == 1
    # stress-controlled steps: equal to the driver's Newton tolerance (its iterates may dip below p'_max)
    np.testing.assert_allclose(got["axial_strain"][0, loading], ref["axial_strain"][0, loading], rtol=1e-9)
    assert np.ptp(ref["axial_strain"][0, unloading]) < 1e-12
    assert np.all(np.diff(got["axial_strain"][0, unloading]) < 0.0) and np.all(np.diff(got["e"][0, unloading]) > 0.0)
    assert got["axial_strain"][0, -1] < ref["axial_strain"][0, -1]


def test_oedometer_swelling_comes_to_rest_at_the_equilibrium_of_s2():
    """Loading to 200 kPa, unloading to 50 kPa and a hold of 500 tau_s in the oedometer: at the end the swelling
    strain is kappa_s/(1 + e) ln(p'/p'_max) at the final p', e and the p'_max of the loading (S2); the stress is
    held, p' is not (the isotropic swelling compresses the laterally confined base: sigma'_h and p' rise)."""
    kappa_s = 0.02
    hist = oedometer_programme(DelayedSwelling(mcc(), kappa_s, 2.0e3), hold=1.0e6)
    state, p = hist["state"], hist["stress"][0, :, :3].mean(axis=1)
    np.testing.assert_allclose(state["p_max"][0], p.max(), rtol=1e-14)
    end = kappa_s / (1.0 + state["void_ratio"][0]) * np.log(p[-1] / p.max())
    np.testing.assert_allclose(state["swelling_strain"][0], end, rtol=1e-8)
    n_hold = (p.size - 21) // 2              # records: start, 10 loading steps, hold, 10 unloading steps, hold
    assert p[20 + n_hold] < p[-1] < p.max()


def test_parameters_are_checked():
    with pytest.raises(ParameterError, match="kappa_s"):
        DelayedSwelling(mcc(), -0.01, 1e3)
    with pytest.raises(ParameterError, match="tau_s"):
        DelayedSwelling(mcc(), 0.01, 0.0)


def test_the_registry_builds_it_and_a_rebuild_keeps_it():
    """The switch ``swelling`` of constitutive.registry.build_model puts DelayedSwelling in series with the model;
    ``replaced`` (what the staged programmes do to a specimen's model) changes the base's and the swelling's
    parameters and keeps the base's switches and options; the result integrates like the hand-built wrapper."""
    from constitutive.registry import build_model
    args = dict(M=M, lambda_=LAM, kappa=KAP, nu=0.25, e0=E0, sigma_p0=60.0, C_alpha_e=0.005)
    model = build_model("ANICREEP", {**args, "kappa_s": 0.02, "tau_s": 1e3},
                        {"anisotropy": False, "swelling": True, "specific_volume": "current"}, vertical_axis=2)
    assert isinstance(model, DelayedSwelling) and model.base.anisotropy is False
    assert model.base.vertical_axis == 2 and model.base.specific_volume == "current"
    again = model.replaced({"sigma_p0": 70.0, "tau_s": 2e3})
    assert again.base.sigma_p0 == 70.0 and again.tau_s == 2e3 and again.kappa_s == 0.02
    assert again.base.specific_volume == "current" and again.base.vertical_axis == 2
    with pytest.raises(ParameterError, match="tau_s"):
        build_model("ANICREEP", {**args, "kappa_s": 0.02}, {"anisotropy": False, "swelling": True})
    plain = DelayedSwelling(anicreep(), 0.02, 1e3)
    built = build_model("ANICREEP", {**args, "kappa_s": 0.02, "tau_s": 1e3}, {"anisotropy": False, "swelling": True})
    np.testing.assert_array_equal(oedometer_programme(plain)["strain"], oedometer_programme(built)["strain"])


def test_reloading_past_p_max_converges_at_the_no_swelling_end():
    # a point with some swelling left that is reloaded above p'_max: (S2) gives eps_s^eq = 0, so R(x) = x - x_hi is
    # linear with slope 1 and its root is x_hi = eps_s,n/(1 + a), the bracket's end that is never evaluated; Newton
    # from the lagged estimate lands on it exactly (two base updates), where a strict-inside rule bisected ~30 times
    base = mcc()
    calls = []

    class Counting(type(base)):
        def update(self, *args, **kwargs):
            calls.append(1)
            return super().update(*args, **kwargs)

    counted = Counting(**{k: v for k, v in base.parameters().items() if v is not None})
    model = DelayedSwelling(counted, kappa_s=0.01, tau_s=1e4)
    state = model.initial_state(isotropic(P_MAX), E0)
    state = {**state, "swelling_strain": np.array([-4e-8])}                 # a residual swelling strain
    stress = isotropic(0.999 * P_MAX)                                        # just below p'_max, reloaded above it
    dstrain = np.array([[2e-4, 2e-4, 2e-4, 0.0, 0.0, 0.0]])
    calls.clear()
    _, new, _ = model.update(stress, state, dstrain, 10.0)
    a = 10.0 / 1e4
    assert new["swelling_strain"][0] == pytest.approx(-4e-8 / (1.0 + a), rel=1e-9, abs=1e-18)
    assert len(calls) <= 2


def test_an_iteration_cut_short_raises_with_the_bracket_and_the_point():
    """A point still at |R| > tolerance after max_iterations base updates raises IntegrationError naming it (the
    first such point of the batch: points 1 and 2 unload, point 0 loads and converges at once), with |R| and the
    bracket; with no base update allowed it is the first point, |R| = inf and the bracket [x_0, x_hi]."""
    model = DelayedSwelling(mcc(), 0.05, 1.0e3)
    stress = np.vstack([isotropic(P_MAX)] * 3)
    state = model.initial_state(stress, E0)
    dstrain = np.zeros((3, 6))
    dstrain[:, :3] = np.array([[1e-3], [-5e-3], [-5e-3]])
    model.max_iterations = 1
    with pytest.raises(IntegrationError, match=r"did not converge in 1 base updates \(\|R\| = \S+, bracket") as info:
        model.update(stress, state, dstrain, 1.0e4)
    assert info.value.point == 1
    model.max_iterations = 0
    with pytest.raises(IntegrationError, match=r"\(\|R\| = inf, bracket \[0, 0\]") as info:
        model.update(stress, state, dstrain, 1.0e4)
    assert info.value.point == 0
