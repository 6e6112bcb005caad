"""Modified Cam Clay: undrained closed form (docs/reference.md section 4), exact NCL/kappa lines, consistent tangent
against finite differences, robustness over wide parameter ranges, parameter validation."""
import numpy as np
import pytest

from constitutive import IntegrationError, ModifiedCamClay, ParameterError
from constitutive import labtests as lt
from constitutive.invariants import deviatoric_stress, mean_stress

# docs/reference.md section 4 check case
M, LAM, KAP, V, P0, R0, G = 1.2, 0.2, 0.04, 2.0, 100.0, 1.5, 2000.0


def closed_form(eta):
    """p'/p'_0 and eps_q (elastic q/(3G) + plastic from first yield) of the undrained MCC test (docs/reference.md
    section 4)."""
    Lam = (LAM - KAP) / LAM
    ratio = (R0 / (1 + eta**2 / M**2)) ** Lam
    eta_y = M * np.sqrt(R0 - 1)
    g = lambda x: np.log((M + x) / (M - x)) - 2 * np.arctan(x / M)  # noqa: E731
    eps_p = KAP * Lam / (V * M) * (g(eta) - g(eta_y))
    return ratio, eta * ratio * P0 / (3 * G) + eps_p


def test_closed_form_reproduces_published_check_values():
    """The formula coded in this test reproduces the check values of docs/reference.md section 4 (guards the oracle
    itself)."""
    r, e = closed_form(np.array([1.0, 1.15]))
    np.testing.assert_allclose(r, [0.90709, 0.82134], atol=5e-6)
    np.testing.assert_allclose(e, [0.021473, 0.039610], atol=5e-7)


def _undrained(n_steps):
    m = ModifiedCamClay(M=M, lambda_=LAM, kappa=KAP, G=G, ocr=R0)
    c = lt.undrained_triaxial(m, V - 1.0, P0, np.linspace(0, 0.06, n_steps + 1)[1:])
    eta = c["q"][0] / c["p"][0]
    return eta, c["p"][0] / P0, c["axial_strain"][0], c


def test_undrained_triaxial_closed_form():
    """p'/p'_0 follows the closed form exactly (the exponential p', p'_c laws are exact at constant volume);
    eps_q converges at first order and, Richardson-extrapolated, matches the check values."""
    results = {}
    for n in (300, 600):
        eta, ratio, eps_q, c = _undrained(n)
        yielded = eta > M * np.sqrt(R0 - 1) + 1e-9
        np.testing.assert_allclose(ratio[yielded], closed_form(eta[yielded])[0], rtol=1e-10)
        # isochoric: eps_q = eps_a; total radial stress constant, u = p_total - p0 - (p' - p0)
        np.testing.assert_allclose(c["excess_pore_pressure"][0], c["q"][0] / 3 - (c["p"][0] - P0), rtol=1e-8)
        results[n] = np.interp([1.0, 1.15], eta, eps_q)
        err = results[n] - closed_form(np.array([1.0, 1.15]))[1]
        assert np.all(np.abs(err) < 0.2 * closed_form(np.array([1.0, 1.15]))[1] * 300 / n)
    e300 = results[300] - closed_form(np.array([1.0, 1.15]))[1]
    e600 = results[600] - closed_form(np.array([1.0, 1.15]))[1]
    order = np.log2(e300 / e600)
    np.testing.assert_allclose(order, 1.0, atol=0.1)
    extrapolated = 2 * results[600] - results[300]
    np.testing.assert_allclose(extrapolated, [0.021473, 0.039610], atol=1e-6)


def test_ncl_and_swelling_line_exact_for_any_step():
    """Isotropic loading of NC clay follows e = e0 - lambda ln(p'/p'0), unloading e = e_max - kappa ln(p'/p'_max),
    independently of the step size (exact integration of the e-ln p' laws)."""
    m = ModifiedCamClay(M=M, lambda_=LAM, kappa=KAP, nu=0.3)
    for substeps in (1, 7):
        c = lt.isotropic_compression(m, 1.2, 50.0, [200.0, 400.0, 100.0, 20.0], substeps=substeps)
        e, p = c["e"][0], c["p"][0]  # p' reached, as recorded
        np.testing.assert_allclose(p, [200.0, 400.0, 100.0, 20.0], atol=1e-6)  # 28 steps x 1e-10 x 401 kPa
        # e and p' are related through the local Newton solution (tolerance 1e-11 on the scaled residuals), so the
        # laws hold to ~1e-11 relative whatever the step, not to round-off (measured 4e-14)
        np.testing.assert_allclose(e[:2], 1.2 - LAM * np.log(p[:2] / 50.0), rtol=1e-10)
        np.testing.assert_allclose(e[2:], e[1] - KAP * np.log(p[2:] / p[1]), rtol=1e-10)


@pytest.mark.parametrize("elastic", [{"G": 2000.0}, {"nu": 0.3}])
def test_consistent_tangent_matches_finite_differences(elastic):
    rng = np.random.default_rng(3)
    n = 8
    m = ModifiedCamClay(M=rng.uniform(0.8, 1.5, n), lambda_=0.2, kappa=0.04, ocr=rng.uniform(1, 4, n), **elastic)
    stress = np.tile([100.0, 80.0, 90.0, 10.0, -5.0, 3.0], (n, 1))
    state = m.initial_state(stress, 1.0)
    deps = rng.normal(scale=0.005, size=(n, 6))
    deps[:, :3] += rng.uniform(-0.005, 0.01, (n, 1))
    deps[0] *= 1e-3  # elastic
    _, new, C = m.update(stress, state, deps, 1.0)
    assert np.any(new["pc"] > state["pc"])  # some points plastic
    h = 1e-7
    for j in range(6):
        dp, dm = deps.copy(), deps.copy()
        dp[:, j] += h
        dm[:, j] -= h
        fd = (m.update(stress, state, dp, 1.0)[0] - m.update(stress, state, dm, 1.0)[0]) / (2 * h)
        np.testing.assert_allclose(C[:, :, j], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_large_increments_end_on_the_yield_surface_and_robust_over_wide_ranges():
    rng = np.random.default_rng(4)
    n = 200
    lam = rng.uniform(0.01, 0.5, n)
    m = ModifiedCamClay(M=rng.uniform(0.5, 2.0, n), lambda_=lam, kappa=lam * rng.uniform(0.05, 0.5, n),
                        nu=rng.uniform(0.0, 0.45, n), ocr=np.exp(rng.uniform(0, np.log(20), n)))
    stress = np.tile([100.0, 100.0, 100.0, 0, 0, 0], (n, 1))
    state = m.initial_state(stress, rng.uniform(0.4, 2.5, n))
    deps = rng.normal(scale=0.05, size=(n, 6))  # up to ~15 % strain in one increment
    s, new, _ = m.update(stress, state, deps, 1.0)
    plastic = new["pc"] != state["pc"]
    f = deviatoric_stress(s) ** 2 + m.M**2 * mean_stress(s) * (mean_stress(s) - new["pc"])
    assert plastic.sum() > n // 2
    np.testing.assert_allclose(f[plastic] / new["pc"][plastic] ** 2, 0.0, atol=1e-9)
    assert np.all(f[~plastic] <= 1e-9 * new["pc"][~plastic] ** 2)


def test_drivers_over_wide_parameter_ranges():
    """Drained and undrained triaxial to 25 % in 2 % steps over wide ranges. Wet-side (ocr <= 2) points must all
    complete; heavily overconsolidated points may fail only where first yield on the dry side softens faster than
    elastic unloading (snap-back under axial strain control, no continuous solution): those are flagged, not hidden."""
    rng = np.random.default_rng(5)
    n = 50
    lam = rng.uniform(0.01, 0.5, n)
    ocr = np.exp(rng.uniform(0, np.log(20), n))
    m = ModifiedCamClay(M=rng.uniform(0.5, 2.0, n), lambda_=lam, kappa=lam * rng.uniform(0.05, 0.5, n),
                        nu=rng.uniform(0.0, 0.45, n), ocr=ocr)
    e0 = rng.uniform(0.4, 2.5, n)
    for driver in (lt.drained_triaxial, lt.undrained_triaxial):
        c = driver(m, e0, 100.0, np.linspace(0, 0.25, 13)[1:], on_failure="nan")
        assert not np.any(c["failed"] & (ocr <= 2.0))
        assert c["failed"].sum() <= n // 10
        assert np.all(np.isfinite(c["q"][~c["failed"]]))
        assert np.all(np.isnan(c["q"][c["failed"], -1]))


def test_bad_parameters_raise():
    ok = dict(M=1.2, lambda_=0.2, kappa=0.04, G=2000.0)
    for change, name in [({"kappa": 0.2}, "kappa"), ({"kappa": 0.3}, "kappa"), ({"M": 0.0}, "M"),
                         ({"M": -1.0}, "M"), ({"G": -5.0}, "G"), ({"kappa": 0.0}, "kappa"), ({"ocr": 0.5}, "ocr"),
                         ({"G": None, "nu": 0.5}, "nu"), ({"pc0": -1.0}, "pc0")]:
        with pytest.raises(ParameterError, match=name):
            ModifiedCamClay(**{**ok, **change})
    with pytest.raises(ParameterError, match="exactly one"):
        ModifiedCamClay(**ok, nu=0.3)
    with pytest.raises(ParameterError, match="void_ratio0"):
        ModifiedCamClay(**ok).initial_state(np.array([100.0, 100, 100, 0, 0, 0]), 0.0)
    with pytest.raises(ParameterError, match="void_ratio0"):
        ModifiedCamClay(**ok).initial_state(np.array([100.0, 100, 100, 0, 0, 0]), -0.3)
    with pytest.raises(ValueError, match="outside the yield surface"):
        ModifiedCamClay(**ok, pc0=50.0).initial_state(np.array([100.0, 100, 100, 0, 0, 0]), 1.0)


def test_integration_error_names_the_point():
    m = ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.04, G=2000.0)
    m.max_iterations = 1  # force the local Newton to fail
    m.max_substep_depth = 0
    stress = np.tile([100.0, 100.0, 100.0, 0, 0, 0], (3, 1))
    deps = np.zeros((3, 6))
    deps[2] = [0.05, -0.02, -0.02, 0, 0, 0]
    with pytest.raises(IntegrationError) as info:
        m.update(stress, m.initial_state(stress, 1.0), deps, 1.0)
    assert info.value.point == 2


def test_rate_dependent_flags():
    """The interface attribute rate_dependent: only viscous ANICREEP depends on dt."""
    from constitutive import ANICREEP, SIMSAND, LinearElastic, VonMises
    assert ModifiedCamClay.rate_dependent is False
    assert LinearElastic.rate_dependent is False and VonMises.rate_dependent is False
    assert SIMSAND.rate_dependent is False
    prm = dict(M=1.2, lambda_=0.2, kappa=0.04, nu=0.3, e0=1.0, sigma_p0=100.0, C_alpha_e=0.01)
    assert ANICREEP(**prm).rate_dependent is True
    assert ANICREEP(**prm, viscous=False).rate_dependent is False


def test_batch_equals_separate_calls_bitwise_and_inputs_untouched():
    """Compiled per-point kernel: a batch gives the bits of one call per point; inputs are not modified."""
    rng = np.random.default_rng(8)
    n = 5
    lam = rng.uniform(0.1, 0.4, n)
    prm = dict(M=rng.uniform(0.8, 1.6, n), lambda_=lam, kappa=lam * 0.2, nu=np.full(n, 0.3))
    m = ModifiedCamClay(**prm, ocr=1.5)
    stress = np.tile([100.0, 80.0, 90.0, 10.0, -5.0, 3.0], (n, 1))
    state = m.initial_state(stress, 1.0)
    deps = rng.normal(scale=5e-3, size=(n, 6))
    keep = stress.copy(), {k: v.copy() for k, v in state.items()}, deps.copy()
    s, st, C = m.update(stress, state, deps, 1.0)
    assert np.array_equal(stress, keep[0]) and np.array_equal(deps, keep[2])
    assert all(np.array_equal(state[k], keep[1][k]) for k in state)
    for i in range(n):
        one = ModifiedCamClay(**{k: v[i] for k, v in prm.items()}, ocr=1.5)
        si, sti, Ci = one.update(stress[i:i + 1], {k: v[i:i + 1] for k, v in state.items()}, deps[i:i + 1], 1.0)
        assert np.array_equal(si[0], s[i]) and np.array_equal(Ci[0], C[i]) and sti["pc"][0] == st["pc"][i]


def _dry_side_margin(M, lam, kap, nu, v, p, q, pc):
    """1 + H/(n:D:n) of MCC at (p', q) on its yield surface (Wood 1990): n = (df/dp', df/dq) = (M^2 (2p' - p'_c),
    2q), D the tangent elasticity (K = v p'/kappa, G from nu), H = -df/dp'_c dp'_c/d eps_v^p df/dp' with
    dp'_c/d eps_v^p = v p'_c/(lambda - kappa): the denominator of the plastic multiplier under strain control."""
    K = v * p / kap
    G = 1.5 * K * (1.0 - 2.0 * nu) / (1.0 + nu)
    fp, fq = M**2 * (2.0 * p - pc), 2.0 * q
    H = M**2 * p * v * pc / (lam - kap) * fp
    return 1.0 + H / (K * fp**2 + 3.0 * G * fq**2)


@pytest.mark.parametrize("lam, kap", [(0.1, 0.09), (0.3, 0.03)])
def test_a_dry_side_point_yields_or_is_refused_as_unstable(lam, kap):
    """A point on the yield surface on the dry side of critical (p' = p'_c/4) loaded by a small axial strain: where
    the plastic multiplier's denominator 1 + H/(n:D:n) is negative (softening faster than the elasticity, lambda -
    kappa = 0.01) no plastic state follows and MCC says so; where it is positive the point yields (p'_c falls:
    dilation) and ends on the surface."""
    M, nu, e, pc, p = 0.8, 0.25, 1.0, 400.0, 100.0
    q = M * np.sqrt(p * (pc - p))
    margin = _dry_side_margin(M, lam, kap, nu, 1.0 + e, p, q, pc)
    m = ModifiedCamClay(M=M, lambda_=lam, kappa=kap, nu=nu, pc0=pc)
    stress = np.array([[p + 2.0 * q / 3.0, p - q / 3.0, p - q / 3.0, 0.0, 0.0, 0.0]])
    deps = np.array([[1e-4, -1e-5, -1e-5, 0.0, 0.0, 0.0]])
    if margin < 0.0:
        with pytest.raises(IntegrationError, match=f"unstable material point.*{margin:.3g} < 0"):
            m.update(stress, m.initial_state(stress, e), deps, 1.0)
        return
    s, new, _ = m.update(stress, m.initial_state(stress, e), deps, 1.0)
    assert new["pc"][0] < pc
    f = deviatoric_stress(s) ** 2 + M**2 * mean_stress(s) * (mean_stress(s) - new["pc"])
    assert abs(f[0]) / new["pc"][0] ** 2 < 1e-9


def test_compression_beyond_the_solids_is_refused():
    """A strain increment that would take the void ratio to or below zero (e_new = e - (1 + e) d eps_v) raises
    IntegrationError naming the point."""
    m = ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.04, nu=0.3)
    stress = np.tile([100.0, 100.0, 100.0, 0, 0, 0], (2, 1))
    deps = np.zeros((2, 6))
    deps[:, 0] = [0.01, 0.2]  # e = 0.2: d eps_v = 0.2 leaves e = -0.04
    with pytest.raises(IntegrationError, match="void ratio") as info:
        m.update(stress, m.initial_state(stress, 0.2), deps, 1.0)
    assert info.value.point == 1
