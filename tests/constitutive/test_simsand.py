"""SIMSAND (docs/reference.md section 3): parameter checks, closed-form pieces, oracles of the expected behaviour,
integration accuracy and batching. Compression positive, kPa."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from constitutive import IntegrationError, ParameterError, labtests
from constitutive.invariants import deviatoric_stress, isotropic_stiffness, lode_sin3theta, mean_stress
from constitutive.sand.simsand import P_AT, SIMSAND, friction_from_angle, friction_ratio

#: synthetic-study true values (docs/reference.md section 5)
TRUE = dict(nu=0.2, K_0=100.0, n=0.6, e_ref=0.75, lambda_c=0.03, xi=0.6, phi_mu=30.0, k_p=0.003, A_d=1.0, n_p=2.0,
            n_d=2.0)
SYNTHETIC_BOUNDS = dict(e_ref=(0.5, 1.5), lambda_c=(0.001, 0.1), xi=(0.01, 1.0), phi_mu=(20.0, 50.0),
                        k_p=(1e-4, 1e-2), A_d=(0.5, 2.0), n_p=(0.1, 10.0), n_d=(0.1, 10.0))
#: compiled kernel against the numpy reference, point by point: two implementations of the same adaptive integrator
#: round differently (scalar loop; array operations and BLAS products), and the local error estimate that sizes the
#: substeps is a difference of two stage increments, whose relative round-off eps |d sigma|/|d sigma_2 - d sigma_1|
#: reaches ~1e-10 at small local errors; the curves then agree to ~1e-10 relative, not to eps (measured <= 7e-14)
IMPLEMENTATIONS_RTOL = 1e-9
TOYOURA_BOUNDS = dict(K_0=(50.0, 300.0), n=(0.1, 0.9), e_ref=(0.5, 1.5), lambda_c=(0.001, 0.1), xi=(0.1, 1.0),
                      phi_mu=(20.0, 50.0), k_p=(0.001, 0.1), A_d=(0.1, 2.0), n_p=(0.0, 10.0), n_d=(0.0, 10.0))


def sample_prior(bounds, n, seed):
    rng = np.random.default_rng(seed)
    params = dict(TRUE)
    params.update({k: rng.uniform(lo, hi, n) for k, (lo, hi) in bounds.items()})
    return params


def triaxial_stress(sa, sr):
    return np.array([[sa, sr, sr, 0.0, 0.0, 0.0]])


# ----------------------------------------------------------------------------------------------- parameters
@pytest.mark.parametrize("name, value", [("phi_mu", 0.0), ("phi_mu", 90.0), ("phi_mu", 95.0), ("K_0", -1.0),
                                         ("e_ref", 0.0), ("e_ref", -0.5), ("k_p", 0.0), ("nu", 0.5),
                                         ("xi", 0.0), ("A_d", -0.1), ("n_p", -1.0), ("lambda_c", -0.01)])
def test_bad_parameters_raise_naming_parameter_and_value(name, value):
    params = dict(TRUE, **{name: value})
    with pytest.raises(ParameterError, match=f"{name} = {value:g}"):
        SIMSAND(**params)


def test_mismatched_parameter_arrays_raise():
    with pytest.raises(ParameterError, match="share one length"):
        SIMSAND(**dict(TRUE, e_ref=np.full(3, 0.75), k_p=np.full(4, 0.003)))


# ----------------------------------------------------------------------------------------------- closed forms
def test_friction_ratio_compression_and_extension():
    """Sheng et al.: M(sin3theta = +1) = M_c = 6 sin phi/(3 - sin phi), M(-1) = c M_c,
    c = (3 - sin phi)/(3 + sin phi)."""
    for phi in (20.0, 30.0, 45.0):
        s = np.sin(np.radians(phi))
        Mc = 6 * s / (3 - s)
        c = (3 - s) / (3 + s)
        t = np.tan(np.radians(phi))
        assert friction_ratio(t, 1.0, derivatives=False) == pytest.approx(Mc, rel=1e-14)
        assert friction_ratio(t, -1.0, derivatives=False) == pytest.approx(c * Mc, rel=1e-14)
        assert friction_from_angle(phi) == pytest.approx(Mc, rel=1e-14)


def test_friction_ratio_derivatives_match_finite_differences():
    t, s3, h = np.array([0.4, 0.9, 2.5]), np.array([0.3, -0.7, 0.95]), 1e-6
    M, dM_dt, dM_ds3 = friction_ratio(t, s3)
    fd_t = (friction_ratio(t + h, s3, False) - friction_ratio(t - h, s3, False)) / (2 * h)
    fd_s = (friction_ratio(t, s3 + h, False) - friction_ratio(t, s3 - h, False)) / (2 * h)
    np.testing.assert_allclose(dM_dt, fd_t, rtol=1e-7)
    np.testing.assert_allclose(dM_ds3, fd_s, rtol=1e-7)


def test_model_uses_lode_dependent_peak_ratio_in_six_components():
    """A 6-component stress in triaxial compression gives M_p = M_c(phi_p), in extension c M_c(phi_p), with
    tan phi_p = (e_c/e)^n_p tan phi_mu computed here from (VI)-(VII)."""
    model = SIMSAND(**TRUE)
    e, p = 0.62, 300.0
    ec = 0.75 * np.exp(-0.03 * (p / P_AT) ** 0.6)
    sin_p = np.sin(np.arctan((ec / e) ** 2.0 * np.tan(np.radians(30.0))))
    Mc, c = 6 * sin_p / (3 - sin_p), (3 - sin_p) / (3 + sin_p)
    for stress, expected in ((triaxial_stress(p + 2 * 60.0, p - 60.0), Mc),
                             (triaxial_stress(p - 2 * 60.0, p + 60.0), c * Mc)):
        Mp, _ = model.friction_ratios(mean_stress(stress), e, lode_sin3theta(stress))
        assert Mp[0] == pytest.approx(expected, rel=1e-12)


# ----------------------------------------------------------------------------------------------- elasticity
def test_isotropic_compression_is_elastic_and_follows_III():
    """From the origin of loading an isotropic strain path is elastic: p' follows dp'/d eps_v = K(p', e) of (III)
    with e = e_0 - (1 + e_0) eps_v, integrated independently by scipy (rtol 1e-11); substepping at stol 1e-5."""
    model = SIMSAND(**TRUE, stol=1e-5)
    e0, p0, n_inc, d = 0.7, 50.0, 50, 2e-4
    stress = 50.0 * np.array([[1, 1, 1, 0, 0, 0.0]])
    state = model.initial_state(stress, e0)
    for _ in range(n_inc):
        stress, state, tangent = model.update(stress, state, np.array([[d, d, d, 0, 0, 0]]), 0.0)
    ev_total = 3 * d * n_inc

    def rate(ev, p):
        e = e0 - (1 + e0) * ev
        return 100.0 * P_AT * (2.97 - e) ** 2 / (1 + e) * (p / P_AT) ** 0.6

    ref = solve_ivp(rate, (0, ev_total), [p0], rtol=1e-11, atol=1e-10).y[0, -1]
    assert mean_stress(stress)[0] == pytest.approx(ref, rel=2e-5)
    assert deviatoric_stress(stress)[0] < 1e-9 and state["eps_dp"][0] == 0.0
    assert state["void_ratio"][0] == pytest.approx(e0 - (1 + e0) * ev_total, rel=1e-13)
    e = state["void_ratio"][0]
    K = 100.0 * P_AT * (2.97 - e) ** 2 / (1 + e) * (mean_stress(stress)[0] / P_AT) ** 0.6
    np.testing.assert_allclose(tangent[0], isotropic_stiffness(K, 3 * K * (1 - 0.4) / (2 * 1.2))[0], rtol=1e-12)


def test_unloading_is_elastic_with_stiffness_III():
    """After drained shearing onto the yield surface, a small axial unloading increment leaves eps_d^p unchanged,
    returns the elastic tangent of (III) and d sigma = D d eps to first order."""
    model = SIMSAND(**TRUE)
    c = model.triaxial_test(0.7, 200.0, [0.01])
    sa, sr, e = c["axial_stress"][0, -1], c["radial_stress"][0, -1], c["e"][0, -1]
    stress = triaxial_stress(sa, sr)
    state = model.initial_state(triaxial_stress(200.0, 200.0), 0.7)
    # the yield surface through the sheared stress: eps_d^p from (IV) (what the fast path reached)
    Mp, _ = model.friction_ratios(mean_stress(stress), e, 1.0)
    eta = (sa - sr) / mean_stress(stress)[0]
    state = {"void_ratio": np.array([e]), "void_ratio_initial": np.array([0.7]),
             "eps_dp": 0.003 * eta / (Mp - eta), "substep": np.ones(1)}
    d = np.array([[-1e-6, 0.2e-6, 0.2e-6, 0, 0, 0]])
    new, new_state, tangent = model.update(stress, state, d, 0.0)
    assert new_state["eps_dp"][0] == state["eps_dp"][0]
    p = mean_stress(stress)[0]
    K = 100.0 * P_AT * (2.97 - e) ** 2 / (1 + e) * (p / P_AT) ** 0.6
    D = isotropic_stiffness(K, 0.75 * K)[0]
    np.testing.assert_allclose(new[0] - stress[0], D @ d[0], rtol=1e-4, atol=1e-9 * K)
    new_p = mean_stress(new)[0]
    e_new = new_state["void_ratio"][0]
    K_new = 100.0 * P_AT * (2.97 - e_new) ** 2 / (1 + e_new) * (new_p / P_AT) ** 0.6
    np.testing.assert_allclose(tangent[0], isotropic_stiffness(K_new, 0.75 * K_new)[0], rtol=1e-12)


# ----------------------------------------------------------------------------------------------- plasticity
@pytest.mark.parametrize("ratio", [1.0, 0.6])
def test_stress_dilatancy_V(ratio):
    """On the yield surface at eta = ratio M_pt, a tiny plastic increment has d eps_v^p/d eps_d^p = A_d (M_pt - eta)
    (zero at eta = M_pt); plastic strains are measured as d eps - D^-1 d sigma."""
    model = SIMSAND(**TRUE)
    e, p = 0.6, 400.0
    Mp, Mpt = (float(x) for x in model.friction_ratios(p, e, 1.0))
    assert Mp > Mpt  # dense: the yield surface can reach M_pt before peak
    eta = ratio * Mpt
    q = eta * p
    stress = triaxial_stress(p + 2 * q / 3, p - q / 3)
    state = {"void_ratio": np.array([e]), "void_ratio_initial": np.array([e]),
             "eps_dp": np.array([0.003 * eta / (Mp - eta)]), "substep": np.ones(1)}
    d = 1e-8 * np.array([[1.0, -0.2, -0.2, 0, 0, 0]])
    new, new_state, _ = model.update(stress, state, d, 0.0)
    K = 100.0 * P_AT * (2.97 - e) ** 2 / (1 + e) * (p / P_AT) ** 0.6
    dp_el = np.linalg.solve(isotropic_stiffness(K, 0.75 * K)[0], new[0] - stress[0])
    dep = d[0] - dp_el
    dev_p = dep[:3].sum()
    ded_p = 2.0 / 3.0 * (dep[0] - dep[1])
    assert new_state["eps_dp"][0] - state["eps_dp"][0] == pytest.approx(ded_p, rel=1e-4)
    assert dev_p / ded_p == pytest.approx(1.0 * (Mpt - eta), abs=2e-4 * Mpt)


def test_tangent_is_the_continuum_elastoplastic_tangent():
    """For vanishing plastic increments the stress increment equals tangent @ d eps (general direction); the
    tangent for a zero increment on the yield surface is the loading one."""
    model = SIMSAND(**TRUE)
    stress = np.array([[420.0, 300.0, 260.0, 40.0, -15.0, 10.0]])
    p, q = mean_stress(stress)[0], deviatoric_stress(stress)[0]
    Mp, _ = model.friction_ratios(p, 0.65, lode_sin3theta(stress))
    state = {"void_ratio": np.array([0.65]), "void_ratio_initial": np.array([0.65]),
             "eps_dp": 0.003 * (q / p) / (Mp - q / p), "substep": np.ones(1)}
    _, _, C = model.update(stress, state, np.zeros((1, 6)), 0.0)
    d = 1e-9 * np.array([[1.0, -0.3, -0.2, 0.4, 0.1, -0.2]])
    new, new_state, _ = model.update(stress, state, d, 0.0)
    assert new_state["eps_dp"][0] > state["eps_dp"][0]
    np.testing.assert_allclose(new[0] - stress[0], C[0] @ d[0], rtol=1e-5, atol=1e-6 * np.abs(C[0] @ d[0]).max())


def test_origin_of_loading_pure_shear_in_six_components():
    """From an isotropic state (q = 0, eps_d^p = 0) a pure shear increment yields at once; q grows, eps_d^p > 0."""
    model = SIMSAND(**TRUE)
    stress = 100.0 * np.array([[1.0, 1, 1, 0, 0, 0]])
    state = model.initial_state(stress, 0.7)
    for _ in range(20):
        stress, state, _ = model.update(stress, state, np.array([[0, 0, 0, 5e-4, 0, 0]]), 0.0)
    assert np.all(np.isfinite(stress)) and state["eps_dp"][0] > 0
    assert 0.2 < deviatoric_stress(stress)[0] / mean_stress(stress)[0] < 1.3
    assert abs(lode_sin3theta(stress)[0]) < 1e-6  # simple shear of an isotropic material: Lode angle 0


def test_six_component_update_is_objective():
    """Rotating the stress and strain increments rotates the result (tensor handling of the shear components)."""
    model = SIMSAND(**TRUE)
    a = np.radians([25.0, -40.0, 60.0])
    Rz = np.array([[np.cos(a[0]), -np.sin(a[0]), 0], [np.sin(a[0]), np.cos(a[0]), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(a[1]), -np.sin(a[1])], [0, np.sin(a[1]), np.cos(a[1])]])
    R = Rz @ Rx

    def to_tensor(v, shear_factor):
        return np.array([[v[0], v[3] * shear_factor, v[5] * shear_factor],
                         [v[3] * shear_factor, v[1], v[4] * shear_factor],
                         [v[5] * shear_factor, v[4] * shear_factor, v[2]]])

    def to_voigt(t, shear_factor):
        return np.array([t[0, 0], t[1, 1], t[2, 2], t[0, 1] / shear_factor, t[1, 2] / shear_factor,
                         t[0, 2] / shear_factor])

    s0 = np.array([300.0, 200.0, 180.0, 20.0, 0.0, -10.0])
    d = np.array([2e-3, -5e-4, -8e-4, 1e-3, 3e-4, 0.0])
    results = []
    for rot in (np.eye(3), R):
        s = to_voigt(rot @ to_tensor(s0, 1.0) @ rot.T, 1.0)[None]
        de = to_voigt(rot @ to_tensor(d, 0.5) @ rot.T, 0.5)[None]
        st = model.initial_state(s, 0.7)
        for _ in range(5):
            s, st, _ = model.update(s, st, de, 0.0)
        results.append((to_tensor(s[0], 1.0), st["eps_dp"][0]))
    np.testing.assert_allclose(R @ results[0][0] @ R.T, results[1][0], rtol=1e-6, atol=1e-6 * 300)
    assert results[1][1] == pytest.approx(results[0][1], rel=1e-6)


# ----------------------------------------------------------------------------------------------- drained paths
def test_drained_compression_reaches_the_critical_state():
    """Dense and loose samples both tend to q/p' -> M(phi_mu) and e -> e_c(p') at large strain."""
    model = SIMSAND(**TRUE)
    M = friction_from_angle(30.0)
    for e0, p0 in ((0.6, 800.0), (0.8, 25.0)):
        c = model.triaxial_test(e0, p0, np.linspace(0.02, 1.0, 50))
        eta, p, e = c["q"][0, -1] / c["p"][0, -1], c["p"][0, -1], c["e"][0, -1]
        assert eta == pytest.approx(M, abs=0.005)  # H = eps_d^p/(k_p + eps_d^p) is 0.997 at eps_d^p ~ 1
        assert e == pytest.approx(model.critical_void_ratio(p), abs=1e-3)


def test_true_value_curves_dense_peaks_and_dilates_loose_contracts():
    """The three synthetic tests of docs/reference.md section 5 with the true values: (0.6, 800) peaks then softens and
    dilates; (0.8, 25) contracts monotonically without a peak; all stay below the peak envelope."""
    model = SIMSAND(**TRUE)
    ea = np.linspace(0.0025, 0.25, 100)
    dense = model.triaxial_test(0.6, 800.0, ea)
    eta = dense["q"][0] / dense["p"][0]
    assert eta.max() > eta[-1] + 0.05 and np.argmax(eta) < 40  # peak then softening
    assert dense["volumetric_strain"][0, -1] < -0.02  # net dilation
    assert dense["e"][0, -1] > 0.6
    loose = model.triaxial_test(0.8, 25.0, ea)
    eta = loose["q"][0] / loose["p"][0]
    assert np.all(np.diff(eta) > -1e-9)  # no peak
    assert np.all(np.diff(loose["e"][0]) < 1e-12)  # contracts throughout
    medium = model.triaxial_test(0.7, 200.0, ea)
    assert np.all(np.isfinite(medium["q"])) and np.all(medium["q"] > 0)
    # drained path: p' = p'_0 + q/3
    for c, p0 in ((dense, 800.0), (loose, 25.0), (medium, 200.0)):
        np.testing.assert_allclose(c["p"][0], p0 + c["q"][0] / 3.0, rtol=1e-9)


def test_generic_driver_converges_to_the_fast_path_when_the_step_is_halved():
    """labtests.drained_triaxial (6-component update, radial stress met at step ends) converges to the fast path
    (radial stress held within every substep) as the strain increment is halved, at second order."""
    model = SIMSAND(**TRUE, stol=1e-5)
    ea = np.linspace(0.0025, 0.025, 10)
    ref = model.triaxial_test(0.7, 200.0, ea)
    errors = []
    for sub in (1, 2, 4):
        c = labtests.drained_triaxial(model, 0.7, 200.0, ea, substeps=sub, route="generic")
        errors.append(np.abs(c["q"][0] - ref["q"][0]).max() / ref["q"][0].max())
        np.testing.assert_allclose(c["e"][0], ref["e"][0], atol=2e-5)
    assert errors[0] < 1e-3
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0


def test_fast_path_converges_when_the_increment_is_halved():
    ea = np.linspace(0.0025, 0.1, 40)
    curves = [SIMSAND(**TRUE).triaxial_test(0.6, 800.0, ea, substeps=s) for s in (1, 2)]
    tight = SIMSAND(**TRUE, stol=1e-6).triaxial_test(0.6, 800.0, ea)
    for c in curves:
        assert np.abs(c["q"][0] - tight["q"][0]).max() < 2e-3 * tight["q"][0].max()
        assert np.abs(c["e"][0] - tight["e"][0]).max() < 5e-4


def test_batch_equals_separate_runs():
    """The compiled fast path integrates each point on its own: a batch gives the bits of separate runs, in any order;
    the generic driver agrees to round-off."""
    params = sample_prior({k: SYNTHETIC_BOUNDS[k] for k in ("phi_mu", "k_p", "A_d", "n_p")}, 4, seed=3)
    ea = np.linspace(0.005, 0.1, 20)
    batch = SIMSAND(**params).triaxial_test(0.7, 200.0, ea)
    order = np.array([2, 0, 3, 1])
    shuffled = SIMSAND(**{k: (v[order] if np.ndim(v) else v) for k, v in params.items()}).triaxial_test(0.7, 200.0, ea)
    generic = labtests.drained_triaxial(SIMSAND(**params), 0.7, 200.0, ea[:5], route="generic")
    for i in range(4):
        single = SIMSAND(**{k: (v[i] if np.ndim(v) else v) for k, v in params.items()})
        one = single.triaxial_test(0.7, 200.0, ea)
        for k in ("q", "e", "radial_strain"):
            np.testing.assert_array_equal(batch[k][i], one[k][0])
            np.testing.assert_array_equal(shuffled[k][np.flatnonzero(order == i)[0]], one[k][0])
        one = labtests.drained_triaxial(single, 0.7, 200.0, ea[:5], route="generic")
        np.testing.assert_allclose(generic["q"][i], one["q"][0], rtol=1e-10)


def _triaxial_in_worker(args):
    params, drained = args
    return SIMSAND(**params).triaxial_test(0.8, 100.0, np.linspace(0.005, 0.1, 20), drained=drained,
                                           on_failure="nan")["q"]


def test_compiled_triaxial_path_runs_in_forked_worker_processes():
    """A process pool (fork) gives the same bits as the parent process, drained and undrained, failures included."""
    import multiprocessing as mp
    params = sample_prior(SYNTHETIC_BOUNDS, 12, seed=5)
    jobs = [(params, True), (params, False)]
    expected = [_triaxial_in_worker(job) for job in jobs]
    with mp.get_context("fork").Pool(2) as pool:
        got = pool.map(_triaxial_in_worker, jobs)
    for g, x in zip(got, expected):
        np.testing.assert_array_equal(g, x)


@pytest.mark.parametrize("stol", [1e-3, 1e-5])
def test_compiled_triaxial_path_equals_the_numpy_reference(stol):
    """The compiled kernel against the numpy integrator in the triaxial space (its oracle, triaxial_integrator="numpy"):
    the same failures; the same curves point by point (IMPLEMENTATIONS_RTOL); in a batch within 1e-6 of the curve scale
    (the numpy crossing iteration runs until every crossing point of the batch has converged; measured <= 8e-9)."""
    params = sample_prior(SYNTHETIC_BOUNDS, 12 if stol >= 1e-3 else 6, seed=11)
    ea = np.linspace(0.005, 0.25, 50)
    for drained, e0, p0 in ((True, 0.7, 200.0), (False, 0.8, 25.0), (True, 0.6, 800.0))[:3 if stol >= 1e-3 else 1]:
        c = SIMSAND(**params, stol=stol).triaxial_test(e0, p0, ea, drained=drained, on_failure="nan")
        r = SIMSAND(**params, stol=stol, triaxial_integrator="numpy").triaxial_test(e0, p0, ea, drained=drained,
                                                                                     on_failure="nan")
        np.testing.assert_array_equal(c["failed"], r["failed"])
        assert 0 < (~c["failed"]).sum()
        ok = ~c["failed"]
        for k in ("q", "p", "e", "axial_strain", "radial_strain"):
            scale = np.abs(r[k][ok]).max(axis=1, keepdims=True) + 1e-12
            assert np.abs(c[k][ok] - r[k][ok]).max() / (1.0 if k == "e" else scale.min()) < 1e-6, k
            assert np.all(np.isnan(c[k][~ok][:, -1]))
        for i in np.flatnonzero(ok)[:2]:
            one = SIMSAND(**{k: (v[i] if np.ndim(v) else v) for k, v in params.items()}, stol=stol,
                          triaxial_integrator="numpy").triaxial_test(e0, p0, ea, drained=drained)
            np.testing.assert_allclose(c["q"][i], one["q"][0], rtol=IMPLEMENTATIONS_RTOL,
                                       atol=IMPLEMENTATIONS_RTOL * np.abs(one["q"]).max())
            np.testing.assert_allclose(c["e"][i], one["e"][0], rtol=IMPLEMENTATIONS_RTOL)


@pytest.mark.parametrize("control", [(False, True), (True, False), (False, False), (True, True)])
def test_compiled_update_triaxial_equals_the_numpy_reference(control):
    """One increment from sheared states on the yield surface, every combination of stress/strain control: the kernel
    and the numpy reference give the same stress, state and strain (IMPLEMENTATIONS_RTOL)."""
    params = sample_prior({k: SYNTHETIC_BOUNDS[k] for k in ("phi_mu", "k_p", "A_d")}, 5, seed=2)
    start = SIMSAND(**params).triaxial_test(0.7, 200.0, [0.01])
    sig = np.stack([start["axial_stress"][:, 0], start["radial_stress"][:, 0]], axis=1)
    results = []
    for integrator in ("compiled", "numpy"):
        model = SIMSAND(**params, triaxial_integrator=integrator)
        state = model.initial_state(200.0 * np.array([[1.0, 1, 1, 0, 0, 0]]).repeat(5, axis=0), 0.7)
        state["void_ratio"] = start["e"][:, 0].copy()
        Mp, _ = model.friction_ratios(start["p"][:, 0], state["void_ratio"], 1.0)
        eta = start["q"][:, 0] / start["p"][:, 0]
        state["eps_dp"] = params["k_p"] * eta / (Mp - eta)
        load = np.where(control, [5.0, 0.0], [2e-3, -5e-4]) * np.ones((5, 1))
        results.append(model.update_triaxial(sig, state, load, control, active=np.arange(5) != 4))
    (s_c, st_c, d_c, f_c), (s_n, st_n, d_n, f_n) = results
    np.testing.assert_array_equal(f_c, f_n)
    np.testing.assert_allclose(s_c, s_n, rtol=IMPLEMENTATIONS_RTOL)
    np.testing.assert_allclose(d_c, d_n, rtol=IMPLEMENTATIONS_RTOL, atol=IMPLEMENTATIONS_RTOL * np.abs(d_n).max())
    for k in ("void_ratio", "eps_dp", "substep"):
        np.testing.assert_allclose(st_c[k], st_n[k], rtol=IMPLEMENTATIONS_RTOL)
    np.testing.assert_array_equal(s_c[4], sig[4])  # inactive point unchanged


# ----------------------------------------------------------------------------------------------- robustness
@pytest.mark.parametrize("bounds, seed", [(SYNTHETIC_BOUNDS, 0), (TOYOURA_BOUNDS, 1)])
def test_prior_boxes_integrate_or_fail_cleanly(bounds, seed):
    """Batched drained tests over prior samples: every point either gives finite curves or is flagged failed
    (uncontrollable drained path); no exception escapes with on_failure='nan'."""
    params = sample_prior(bounds, 200, seed)
    model = SIMSAND(**params)
    ea = np.linspace(0.005, 0.25, 50)
    for e0, p0 in ((0.6, 800.0), (0.8, 25.0)):
        c = model.triaxial_test(e0, p0, ea, on_failure="nan")
        ok = ~c["failed"]
        assert np.all(np.isfinite(c["q"][ok])) and np.all(np.isfinite(c["e"][ok]))
        assert np.all(np.isnan(c["q"][~ok][:, -1]))
        assert ok.mean() > 0.5


def test_uncontrollable_drained_path_raises_integration_error_naming_the_point():
    """phi_p near 90 degrees with strong dilatancy: the drained path loses control; the batch point is named."""
    bad = dict(TRUE, e_ref=1.137, lambda_c=0.0411, xi=0.3509, phi_mu=45.8, k_p=0.0019, A_d=1.8452, n_p=8.2357,
               n_d=5.33)
    params = {k: np.array([TRUE[k], bad[k]]) for k in TRUE}
    with pytest.raises(IntegrationError) as info:
        SIMSAND(**params).triaxial_test(0.6, 800.0, np.linspace(0.0025, 0.25, 100))
    assert info.value.point == 1


def test_raised_failure_names_the_point_that_fails_first():
    """With on_failure="raise" the IntegrationError names the point whose curve fails at the earliest target (ties:
    the lowest index), as the NaN onsets of on_failure="nan" show; here that is not the lowest failed index."""
    params = sample_prior(SYNTHETIC_BOUNDS, 12, seed=4)
    params = {k: (np.append(v, v[2]) if np.ndim(v) else v) for k, v in params.items()}  # point 12 repeats point 2
    ea = np.linspace(0.0025, 0.25, 100)
    c = SIMSAND(**params).triaxial_test(0.6, 800.0, ea, on_failure="nan")
    onset = np.where(c["failed"], np.argmax(np.isnan(c["q"]), axis=1), ea.size)
    assert c["failed"][0] and np.flatnonzero(onset == onset.min()).tolist() == [2, 12]
    with pytest.raises(IntegrationError) as info:
        SIMSAND(**params).triaxial_test(0.6, 800.0, ea)
    assert info.value.point == 2


def test_undrained_loose_liquefies_to_the_tension_cutoff_without_failure():
    """Very loose undrained sample: p' collapses (static liquefaction) and is held at p_min >= 0 without error."""
    model = SIMSAND(**dict(TRUE, e_ref=0.75, n_p=4.0, A_d=2.0))
    c = model.triaxial_test(0.95, 100.0, np.linspace(0.001, 0.2, 100), drained=False)
    assert np.all(np.isfinite(c["p"])) and c["p"][0].min() >= model.p_min - 1e-9
    assert c["p"][0, -1] < 10.0 and c["excess_pore_pressure"][0, -1] > 90.0
    np.testing.assert_allclose(c["volumetric_strain"][0], 0.0, atol=1e-15)


def test_zero_increment_leaves_a_slightly_drifted_state_unchanged():
    """A zero strain increment at a state marginally outside the yield surface (drift left by a previous
    correction) returns the same stress without error (the generic driver freezes points this way)."""
    model = SIMSAND(**TRUE)
    stress = triaxial_stress(500.0, 300.0)
    p, q = mean_stress(stress)[0], deviatoric_stress(stress)[0]
    Mp, _ = model.friction_ratios(p, 0.65, 1.0)
    eta = q / p
    state = {"void_ratio": np.array([0.65]), "void_ratio_initial": np.array([0.65]),
             "eps_dp": np.atleast_1d(0.003 * eta / (Mp - eta) * (1 - 1e-5)), "substep": np.ones(1)}
    new, new_state, _ = model.update(stress, state, np.zeros((1, 6)), 0.0)
    np.testing.assert_array_equal(new, stress)
    assert new_state["eps_dp"][0] == state["eps_dp"][0]


def test_stress_controlled_isotropic_compression_in_the_triaxial_space():
    """Both triaxial components stress-controlled (general mixed-control solve): an isotropic load step from
    100 to 400 kPa is elastic and its volumetric strain is the integral of dp'/K(p', e) (scipy, independent)."""
    model = SIMSAND(**TRUE, stol=1e-6)
    e0 = 0.7
    state = model.initial_state(100.0 * np.array([[1.0, 1, 1, 0, 0, 0]]), e0)
    sig, state, deps, failed = model.update_triaxial(np.array([[100.0, 100.0]]), state, np.array([[300.0, 300.0]]),
                                                     stress_control=(True, True))
    np.testing.assert_allclose(sig[0], [400.0, 400.0], rtol=1e-12)
    assert deps[0, 0] == pytest.approx(deps[0, 1], rel=1e-12) and not failed[0]

    def strain_rate(p, ev):  # d eps_v/dp' = 1/K(p', e(eps_v))
        e = e0 - (1 + e0) * ev
        return 1.0 / (100.0 * P_AT * (2.97 - e) ** 2 / (1 + e) * (p / P_AT) ** 0.6)

    ev_ref = solve_ivp(strain_rate, (100.0, 400.0), [0.0], rtol=1e-11, atol=1e-14).y[0, -1]
    assert deps[0, 0] + 2 * deps[0, 1] == pytest.approx(ev_ref, rel=1e-5)
    assert state["eps_dp"][0] == 0.0
