"""Staged laboratory programmes (cases.study.forward.lab_staged.simulate_programme) against closed forms of the models'
own equations (docs/reference.md section 4).

Tolerances come from the discretization:
- Modified Cam Clay integrates its kappa-lines and the NCL exactly whatever the step (p' and p'_c exponentials with
  v frozen per increment, e updated consistently), so e-ln p' slopes, undrained p'-p'_c relations and held
  stresses/strains are checked to the mixed-control Newton tolerance (1e-10 relative, here 1e-8);
- the undrained critical state is approached asymptotically: after 40 % axial strain q/p' is within 1e-9 of M;
- ANICREEP holds are integrated by backward Euler with time steps growing geometrically (HOLD_STEPS_PER_DECADE per
  decade): a first-order error, measured 2.9 %, 1.6 %, 0.82 %, 0.42 % (creep) and 0.41 %, 0.22 %, 0.11 %, 0.06 %
  (relaxation) of the closed form at 10, 20, 40, 80 steps per decade: the tests take 2.5 % and 0.4 % at the default
  20 and check that doubling the steps halves the error (ratio 0.4-0.6).
"""
from __future__ import annotations

import numpy as np
import pytest

from cases.study.forward import lab_stage_steps
from cases.study.forward.lab_staged import simulate_programme
from cases.study.programme import InitialState, Stage, TestSpec
from constitutive.anicreep import ANICREEP
from constitutive.mcc import ModifiedCamClay

M, LAM, KAP = 1.2, 0.2, 0.04


def programme(apparatus, initial, *stages):
    return TestSpec(name="t", type="programme", apparatus=apparatus, initial=initial, stages=tuple(stages))


def mcc(**kw):
    return ModifiedCamClay(**{"M": M, "lambda_": LAM, "kappa": KAP, "G": 3000.0, "ocr": 1.0, **kw})


@pytest.mark.parametrize("ocr", [1.0, 2.0, 4.0, 8.0])
def test_mcc_undrained_strength_after_unloading(ocr):
    """Isotropic consolidation to p'_c, swelling to p'_0 = p'_c/OCR, undrained compression: p'_f = p'_0 (OCR/2)^Lambda,
    Lambda = 1 - kappa/lambda, q_f = M p'_f (Wood 1990: p'^kappa p'_c^(lambda-kappa) is constant at constant volume,
    p'_c = 2 p'_f at the critical state)."""
    pc = 200.0
    p0 = pc / ocr
    spec = programme("triaxial", InitialState(e0=1.0, p0=50.0),
                     Stage("consolidation", "cons1", p=pc, abscissa="p"),
                     Stage("consolidation", "swell2", p=p0, abscissa="p"),
                     Stage("shear", "shear3", drainage="undrained", strain_rate=1e-5, abscissa="axial_strain",
                           to_strain=0.4))
    x = np.linspace(0.01, 0.4, 40)
    out, failed = simulate_programme(mcc(), spec, {"p@shear3": x, "q@shear3": x, "p@swell2": np.array([p0])}, 1)
    assert not failed[0]
    pf = p0 * (ocr / 2.0) ** (1.0 - KAP / LAM)
    assert out["p@swell2"][0, 0] == pytest.approx(p0, rel=1e-8)
    assert out["p@shear3"][0, -1] == pytest.approx(pf, rel=1e-8)
    assert out["q@shear3"][0, -1] == pytest.approx(M * pf, rel=1e-8)


def test_mcc_drained_consolidation_slopes_and_crs_unloading():
    """Isotropic loading from a normally consolidated state: e - ln p' slope lambda; swelling: kappa (MCC elasticity
    K = (1 + e) p'/kappa integrated exactly). Oedometer: loading to the NCL then CRS unloading at a negative rate:
    elastic, e - ln p' slope kappa."""
    spec = programme("triaxial", InitialState(e0=1.2, p0=50.0),
                     Stage("consolidation", "cons1", p=400.0, abscissa="p"),
                     Stage("consolidation", "swell2", p=40.0, abscissa="p"))
    p_load, p_swell = np.array([60.0, 100.0, 200.0, 400.0]), np.array([300.0, 100.0, 40.0])
    out, failed = simulate_programme(mcc(), spec, {"e@cons1": p_load, "e@swell2": p_swell}, 1)
    assert not failed[0]
    slope_load = -np.diff(out["e@cons1"][0]) / np.diff(np.log(p_load))
    slope_swell = -np.diff(out["e@swell2"][0]) / np.diff(np.log(p_swell))
    np.testing.assert_allclose(slope_load, LAM, rtol=1e-8)
    np.testing.assert_allclose(slope_swell, KAP, rtol=1e-8)

    oed = programme("oedometer", InitialState(e0=1.2, sigma_v0=50.0, K0=0.6),
                    Stage("load", "load1", sigma_v=400.0, ramp_time=3600.0, duration=7200.0),
                    Stage("crs", "crs2", strain_rate=-1e-6, abscissa="time", to_strain=0.0))
    t = np.linspace(0.0, 1.0e4, 11)
    out, failed = simulate_programme(mcc(nu=0.3, G=None), oed, {"e@crs2": t, "p@crs2": t, "axial_strain@crs2": t},
                                     1)
    assert not failed[0]
    assert np.all(np.diff(out["axial_strain@crs2"][0]) < 0.0)  # unloading
    slope = -np.diff(out["e@crs2"][0]) / np.diff(np.log(out["p@crs2"][0]))
    np.testing.assert_allclose(slope, KAP, rtol=1e-8)


@pytest.mark.parametrize("apparatus", ["triaxial", "oedometer"])
def test_rate_independent_holds(apparatus):
    """A rate-independent model (MCC) holds its stress exactly in a relaxation stage and its strain in a creep stage,
    after a loading stage."""
    initial = InitialState(e0=1.0, p0=100.0) if apparatus == "triaxial" else InitialState(e0=1.0, sigma_v0=100.0,
                                                                                          K0=0.7)
    load = (Stage("shear", "load1", strain_rate=1e-5, abscissa="axial_strain", to_strain=0.02)
            if apparatus == "triaxial" else Stage("consolidation", "load1", sigma_v=300.0, abscissa="sigma_v"))
    spec = programme(apparatus, initial, load, Stage("relaxation", "relax2", duration=1e5),
                     Stage("creep", "creep3", duration=1e5))
    t = np.array([0.0, 10.0, 1e3, 1e5])
    keys = [f"{q}@{s}" for q in ("q", "p", "axial_strain", "volumetric_strain") for s in ("relax2", "creep3")]
    out, failed = simulate_programme(mcc(), spec, {k: t for k in keys}, 1)
    assert not failed[0]
    for q in ("q", "p", "axial_strain", "volumetric_strain"):
        for s in ("relax2", "creep3"):
            v = out[f"{q}@{s}"][0]
            np.testing.assert_allclose(v, v[0], rtol=1e-9, atol=1e-9)
    assert out["q@relax2"][0, 0] > 10.0  # the holds are not at a trivial state


def _anicreep_closed_form(p0, sigma_p0, e0, lam, kap, ca, m, tau=86400.0):
    """Isotropic state, anisotropy off (alpha = 0, eta = 0): p'_m^d = p', g = identity/3 x ..., g_p = 1, g_q = 0
    (docs/reference.md section 4 (F), (V)); reference size p'_m^r0 of (F) through the K0_nc state at sigma'_p0 with
    alpha = 0; beta, mu from (V); c_e = (1 + e0)/kappa (E), c_p = (1 + e0)/(lambda - kappa) (H).
    Creep (stresses held, elastic strain zero): d eps_v/dt = mu (p'/p'_m^r0)^beta exp(-beta c_p eps_v)
        => eps_v = ln(1 + t/t0)/(beta c_p), 1/t0 = beta c_p mu (p'_0/p'_m^r0)^beta; late slope de/d ln t = -C_alpha_e.
    Relaxation (all strains held, d eps_v^e = -d eps_v^vp): x = eps_v^vp, p' = p'_0 exp(-c_e x),
        dx/dt = mu (p'_0/p'_m^r0)^beta exp(-beta (c_e + c_p) x)
        => p'(t) = p'_0 (1 + t/t1)^(-C_alpha_e/lambda), 1/t1 = beta (c_e + c_p) mu (p'_0/p'_m^r0)^beta
        (c_e/(beta (c_e + c_p)) = C_alpha_e/lambda)."""
    sin_phi = 3.0 * m / (6.0 + m)
    k0 = 1.0 - sin_phi
    eta_k0 = 3.0 * (1.0 - k0) / (1.0 + 2.0 * k0)
    pk, qk = (1.0 + 2.0 * k0) * sigma_p0 / 3.0, (1.0 - k0) * sigma_p0
    pmr0 = pk + qk**2 / (m**2 * pk)
    beta = (lam - kap) / ca
    mu = ca / ((1.0 + e0) * tau) * m**2 / (m**2 - eta_k0**2)
    ce, cp = (1.0 + e0) / kap, (1.0 + e0) / (lam - kap)
    creep = lambda t: np.log1p(t * beta * cp * mu * (p0 / pmr0) ** beta) / (beta * cp)  # noqa: E731
    relax = lambda t: p0 * (1.0 + t * beta * (ce + cp) * mu * (p0 / pmr0) ** beta) ** (-ca / lam)  # noqa: E731
    return creep, relax


ANI = {"lam": 0.3, "kap": 0.03, "ca": 0.012, "e0": 1.5, "m": 1.2}


def _anicreep_holds():
    """(max error of the creep strain over the curve / its largest value, max error of p' in relaxation / the
    relaxed amount, late creep slope -de/d ln t) of the isotropic holds against ``_anicreep_closed_form``."""
    model = ANICREEP(M=ANI["m"], lambda_=ANI["lam"], kappa=ANI["kap"], nu=0.25, e0=2.0, sigma_p0=100.0,
                     C_alpha_e=ANI["ca"], anisotropy=False)
    creep, relax = _anicreep_closed_form(110.0, 100.0, ANI["e0"], ANI["lam"], ANI["kap"], ANI["ca"], ANI["m"])
    p0 = 110.0
    t = np.geomspace(10.0, 1e7, 19)
    # the test's e0 (1.5) replaces the model's e0 parameter (2.0) for this specimen; p'_0 above the reference size
    tri = programme("triaxial", InitialState(e0=ANI["e0"], p0=p0), Stage("creep", "creep1", duration=1e7))
    out, failed = simulate_programme(model, tri, {"volumetric_strain": t, "q": t, "e": t}, 1)
    assert not failed[0]
    assert np.all(np.abs(out["q"]) <= 1e-12 * p0)  # the stresses are held to the Newton tolerance
    creep_err = np.max(np.abs(out["volumetric_strain"][0] / 100.0 - creep(t))) / creep(t[-1])
    e = out["e"][0]
    late = -(e[-1] - e[-4]) / np.log(t[-1] / t[-4])
    oed = programme("oedometer", InitialState(e0=ANI["e0"], sigma_v0=p0, K0=1.0),
                    Stage("relaxation", "relax1", duration=1e7))
    out, failed = simulate_programme(model, oed, {"p": t, "axial_strain": t}, 1)
    assert not failed[0]
    assert np.all(out["axial_strain"] == 0.0)
    relax_err = np.max(np.abs(out["p"][0] - relax(t))) / (p0 - relax(t[-1]))
    return creep_err, relax_err, late


@pytest.mark.parametrize("knob, coarse, fine, bound", [
    ("HOLD_RATE_CHANGE", 0.1, 0.05, 5e-3),  # adaptive (the default route of a rate-dependent model)
    ("HOLD_STEPS_PER_DECADE", 20, 40, 7e-3),  # the geometric step table
])
def test_anicreep_creep_and_relaxation_closed_forms(knob, coarse, fine, bound, monkeypatch):
    """Creep and relaxation holds of the rate-dependent model from t = 0 to 1e7 s against their closed forms
    (``_anicreep_closed_form``), by both hold steppings. Errors relative to the curve (the creep strain's largest
    value, the relaxed amount of p'): measured 0.42 % / 0.34 % (adaptive, rate change 0.1) and 0.60 % / 0.47 % (20
    steps per decade); both first order in their step parameter (backward Euler)."""
    if knob == "HOLD_STEPS_PER_DECADE":
        monkeypatch.setattr(lab_stage_steps, "ADAPTIVE_HOLDS", False)
    monkeypatch.setattr(lab_stage_steps, knob, coarse)
    creep_err, relax_err, late = _anicreep_holds()
    assert creep_err < bound and relax_err < bound
    assert late == pytest.approx(ANI["ca"], rel=0.01)
    monkeypatch.setattr(lab_stage_steps, knob, fine)
    creep_fine, relax_fine, _ = _anicreep_holds()
    assert 0.4 < creep_fine / creep_err < 0.6
    assert 0.4 < relax_fine / relax_err < 0.6


def test_anicreep_oedometer_creep_on_the_ncl():
    """Anisotropic ANICREEP loaded in the oedometer past sigma'_p0 (on the NCL), then creep: the late-time slope
    de/d ln t tends to -C_alpha_e (docs/reference.md section 4, oracle "one-dimensional creep")."""
    model = ANICREEP(M=1.2, lambda_=0.3, kappa=0.03, nu=0.25, e0=1.5, sigma_p0=80.0, C_alpha_e=0.012)
    spec = programme("oedometer", InitialState(sigma_v0=40.0, K0=0.55),
                     Stage("load", "load1", sigma_v=200.0, ramp_time=3600.0, duration=86400.0),
                     Stage("creep", "creep2", duration=1e8))
    t = np.geomspace(1e5, 1e8, 10)
    out, failed = simulate_programme(model, spec, {"e@creep2": t, "axial_stress@creep2": t}, 1)
    assert not failed[0]
    np.testing.assert_allclose(out["axial_stress@creep2"][0], 200.0, rtol=1e-9)
    e = out["e@creep2"][0]
    late = -(e[-1] - e[-4]) / np.log(t[-1] / t[-4])
    assert late == pytest.approx(0.012, rel=0.03)


def test_batch_equals_single_particles():
    """Three particles with different parameters and a per-test OCR equal one-particle runs (points iterate
    independently in mixed_control: equal to round-off)."""
    lam = np.array([0.15, 0.2, 0.25])
    g = np.array([2000.0, 3000.0, 5000.0])
    spec = programme("triaxial", InitialState(e0=1.0, p0=100.0, ocr=2.0),
                     Stage("consolidation", "cons1", p=150.0, abscissa="p", duration=3600.0),
                     Stage("shear", "shear2", drainage="undrained", strain_rate=1e-5, abscissa="axial_strain",
                           to_strain=0.1),
                     Stage("relaxation", "relax3", duration=1e4))
    x = {"q@shear2": np.linspace(0.005, 0.1, 20), "u@shear2": np.linspace(0.005, 0.1, 20),
         "e@cons1": np.array([120.0, 150.0]), "q@relax3": np.array([1.0, 1e4])}
    batch, failed = simulate_programme(mcc(lambda_=lam, G=g, pc0=500.0, ocr=None), spec, x, 3)
    assert not np.any(failed)
    for i in range(3):
        one, f1 = simulate_programme(mcc(lambda_=lam[i], G=g[i], pc0=500.0, ocr=None), spec, x, 1)
        assert not f1[0]
        for k in x:
            np.testing.assert_allclose(batch[k][i], one[k][0], rtol=1e-12, atol=1e-12)
    # the test's ocr replaces the model's pc0: yield at p'_c = 2 x 100 kPa during the consolidation to 150 kPa is
    # not reached (elastic, e - ln p' slope kappa)
    slope = -(batch["e@cons1"][:, 1] - batch["e@cons1"][:, 0]) / np.log(150.0 / 120.0)
    np.testing.assert_allclose(slope, KAP, rtol=1e-8)


def test_refused_start_and_failed_particle_are_nan():
    """A particle whose preconsolidation lies below the initial stress is refused by MCC: NaN for it only."""
    spec = programme("triaxial", InitialState(e0=1.0, p0=100.0),
                     Stage("shear", "shear1", drainage="drained", abscissa="axial_strain"))
    x = {"q": np.array([0.01, 0.02])}
    out, failed = simulate_programme(mcc(pc0=np.array([150.0, 50.0]), ocr=None), spec, x, 2)
    assert list(failed) == [False, True]
    assert np.all(np.isfinite(out["q"][0])) and np.all(np.isnan(out["q"][1]))


def test_load_ramp_records_and_crs_to_sigma_v():
    """Oedometer (MCC): a load stage recorded during its ramp gives sigma'_v on the linear ramp (stress control, to
    the Newton tolerance); a crs unloading stage ended by to_sigma_v stops at that stress (the crossing located
    within its strain step to 1e-9 in ln sigma'_v: measured 7e-11 relative, tolerance 1e-8), and the next stage
    starts there."""
    spec = programme("oedometer", InitialState(e0=1.2, sigma_v0=50.0, K0=0.6),
                     Stage("load", "load1", sigma_v=250.0, ramp_time=1000.0, duration=5000.0),
                     Stage("crs", "crs2", strain_rate=-1e-6, to_sigma_v=100.0),
                     Stage("creep", "creep3", duration=100.0))
    t = np.array([100.0, 400.0, 1000.0, 3000.0])
    out, failed = simulate_programme(mcc(nu=0.3, G=None), spec, {"axial_stress@load1": t,
                                                                 "axial_stress@creep3": np.array([0.0, 100.0])}, 1)
    assert not failed[0]
    np.testing.assert_allclose(out["axial_stress@load1"][0], [70.0, 130.0, 250.0, 250.0], rtol=1e-9)
    np.testing.assert_allclose(out["axial_stress@creep3"][0], 100.0, rtol=1e-8)


def test_undrained_creep_and_extension_of_a_rate_independent_model():
    """MCC, undrained extension then undrained creep: the creep stage holds q, p' and the excess pore pressure
    (nothing drives them), and an extension shear gives q < 0 with the axial strain decreasing."""
    spec = programme("triaxial", InitialState(e0=1.0, p0=100.0, ocr=1.5),
                     Stage("shear", "shear1", drainage="undrained", direction="extension", abscissa="axial_strain",
                           to_strain=0.02),
                     Stage("creep", "creep2", drainage="undrained", duration=1e4))
    x = np.array([0.005, 0.01, 0.02])
    t = np.array([0.0, 10.0, 1e4])
    keys = {"q@shear1": x, "axial_strain@shear1": x, "q@creep2": t, "p@creep2": t, "u@creep2": t}
    out, failed = simulate_programme(mcc(), spec, keys, 1)
    assert not failed[0]
    assert np.all(out["q@shear1"][0] < 0.0)
    np.testing.assert_allclose(out["axial_strain@shear1"][0], -100.0 * x, rtol=1e-12)
    for k in ("q@creep2", "p@creep2", "u@creep2"):
        np.testing.assert_allclose(out[k][0], out[k][0, 0], rtol=1e-9, atol=1e-9)


def test_drained_stage_after_undrained_dissipates_the_excess_pore_pressure():
    """Undrained shear then a drained creep stage (total stresses held): the excess pore pressure dissipates, p'
    rises by it, q is unchanged and excess_pore_pressure returns to zero (to the Newton tolerance)."""
    spec = programme("triaxial", InitialState(e0=1.0, p0=100.0),
                     Stage("shear", "shear1", drainage="undrained", abscissa="axial_strain", to_strain=0.01),
                     Stage("creep", "creep2", duration=100.0))
    x, t = np.array([0.01]), np.array([100.0])
    out, failed = simulate_programme(mcc(), spec, {"q@shear1": x, "p@shear1": x, "u@shear1": x, "q@creep2": t,
                                                   "p@creep2": t, "u@creep2": t}, 1)
    assert not failed[0]
    assert out["u@shear1"][0, 0] > 10.0
    assert out["q@creep2"][0, 0] == pytest.approx(out["q@shear1"][0, 0], rel=1e-9)
    assert out["p@creep2"][0, 0] == pytest.approx(out["p@shear1"][0, 0] + out["u@shear1"][0, 0], rel=1e-9)
    assert out["u@creep2"][0, 0] == 0.0


def _equal_to_one_test_calls(model, specs, abscissae, n, monkeypatch):
    """simulate_programmes of the tests together against one call per test: the largest difference relative to
    each curve's magnitude (at least 1: kPa, %, void ratio), and the number of mixed_control calls made together."""
    from cases.study.forward.lab_staged import simulate_programmes
    from constitutive import labtests
    calls = []
    real = labtests.mixed_control
    monkeypatch.setattr(labtests, "mixed_control", lambda *a, **k: calls.append(1) or real(*a, **k))
    together = simulate_programmes(model, specs, abscissae, n)
    n_calls = len(calls)
    worst = 0.0
    for spec, x, (out, failed, _) in zip(specs, abscissae, together):
        one, one_failed = simulate_programme(model, spec, x, n)
        assert not np.any(failed) and not np.any(one_failed)
        for k in x:
            assert np.all(np.isfinite(out[k])) and np.all(np.isfinite(one[k]))
            worst = max(worst, np.max(np.abs(out[k] - one[k])) / max(np.max(np.abs(one[k])), 1.0))
    return worst, n_calls


def test_programmes_sharing_a_stage_structure_equal_one_test_calls(monkeypatch):
    """CIU series (MCC, three particles): OCR 2, 4, 8 share consolidation - swelling - undrained shear with their own
    swelling targets, durations, shear rates, end strains and record points, OCR 1 (consolidation - shear) waits
    during the swelling round (three calls for the four tests); ANICREEP oedometer programmes (load - creep - crs to
    sigma'_v) with their own initial states, loads, ramps, durations, rates and targets; triaxial tests where one
    waits with an excess pore pressure while the other's drained creep runs: together they equal one test per call
    to 1e-10 (each point takes the steps it takes alone)."""
    ciu = [programme("triaxial", InitialState(e0=1.45, p0=25.0, ocr=1.0),
                     Stage("consolidation", "cons", p=200.0),
                     Stage("shear", "shear", drainage="undrained", strain_rate=2.8e-6, to_strain=0.15,
                           abscissa="axial_strain"))]
    x_ciu = [{"q@shear": np.linspace(0.001, 0.15, 20), "e@cons": np.array([200.0])}]
    for j, (ocr, rate, end) in enumerate([(2.0, 2.8e-6, 0.15), (4.0, 1e-5, 0.12), (8.0, 5e-6, 0.2)]):
        ciu.append(programme("triaxial", InitialState(e0=1.45, p0=25.0, ocr=1.0),
                             Stage("consolidation", "cons", p=200.0, duration=86400.0 * (j + 1)),
                             Stage("consolidation", "swell", p=200.0 / ocr, abscissa="p"),
                             Stage("shear", "shear", drainage="undrained", strain_rate=rate, to_strain=end,
                                   abscissa="axial_strain")))
        x_ciu.append({"q@shear": np.geomspace(1e-4, end, 13 + 5 * j), "u@shear": np.linspace(0.002, end, 7 + j),
                      "e@swell": 200.0 / np.array([1.5, ocr][:j + 1])})
    model = mcc(M=np.array([1.0, 1.2, 1.4]), lambda_=np.array([0.15, 0.2, 0.25]), kappa=0.03, G=None, nu=0.3)
    worst, n_calls = _equal_to_one_test_calls(model, ciu, x_ciu, 3, monkeypatch)
    assert worst <= 1e-10
    assert n_calls == 3

    ani = ANICREEP(M=1.2, lambda_=np.array([0.25, 0.3]), kappa=0.03, nu=0.25, e0=1.5, sigma_p0=80.0,
                   C_alpha_e=np.array([0.008, 0.012]))
    oed, x_oed = [], []
    for j, (s0, load, ramp, rate, target) in enumerate([(40.0, 200.0, 3600.0, 1e-6, 400.0),
                                                        (30.0, 150.0, 60.0, 3e-6, 600.0),
                                                        (50.0, 300.0, 10.0, 1e-7, 350.0)]):
        oed.append(programme("oedometer", InitialState(e0=1.4 + 0.05 * j, sigma_v0=s0, K0=0.55),
                             Stage("load", "load", sigma_v=load, ramp_time=ramp, duration=86400.0 * (1 + j)),
                             Stage("creep", "creep", duration=1e5 * (j + 1)),
                             Stage("crs", "crs", strain_rate=rate, to_sigma_v=target, abscissa="time")))
        x_oed.append({"e@load": np.geomspace(1.0, 86400.0 * (1 + j), 8 + j), "e@creep": np.geomspace(10.0, 1e5, 6),
                      "axial_stress@crs": np.linspace(100.0, 2000.0 * (j + 1), 5)})
    worst, _ = _equal_to_one_test_calls(ani, oed, x_oed, 2, monkeypatch)
    assert worst <= 1e-10

    shear = Stage("shear", "shear1", drainage="undrained", strain_rate=1e-5, to_strain=0.02, abscissa="axial_strain")
    waits = [programme("triaxial", InitialState(e0=1.0, p0=100.0), shear, Stage("creep", "creep2", duration=1e4),
                       Stage("shear", "shear3", drainage="undrained", strain_rate=1e-5, to_strain=0.03,
                             abscissa="axial_strain")),
             programme("triaxial", InitialState(e0=1.1, p0=80.0), shear,
                       Stage("shear", "shear3", drainage="undrained", strain_rate=2e-5, to_strain=0.05,
                             abscissa="axial_strain"))]
    x = np.linspace(0.002, 0.02, 5)
    x_waits = [{"u@shear1": x, "u@creep2": np.array([1.0, 1e4]), "q@shear3": x, "u@shear3": x},
               {"u@shear1": x, "q@shear3": x, "u@shear3": x, "p@shear3": x}]
    worst, n_calls = _equal_to_one_test_calls(mcc(), waits, x_waits, 1, monkeypatch)
    assert worst <= 1e-10
    assert n_calls == 3


def test_a_triaxial_crs_is_the_oedometer_crs_with_its_radial_stress():
    """Strain-controlled K0 consolidation in a triaxial cell (every strain controlled, the radial one at zero): the
    axial stress of the oedometer's crs, and the radial stress as a curve whose ratio to it tends to the model's
    normally consolidated K0 (MCC: sigma'_r/sigma'_a rises from the initial 0.6 and levels off)."""
    stage = Stage("crs", "crs1", strain_rate=1e-6, to_strain=0.08, abscissa="axial_strain")
    x = np.array([0.02, 0.05, 0.08])
    cell, _ = simulate_programme(mcc(), programme("triaxial", InitialState(sigma_v0=50.0, K0=0.6, e0=1.2), stage),
                                 {"axial_stress": x, "radial_stress": x}, 1)
    oedometer, _ = simulate_programme(mcc(), programme("oedometer", InitialState(sigma_v0=50.0, K0=0.6, e0=1.2),
                                                       stage), {"axial_stress": x}, 1)
    np.testing.assert_allclose(cell["axial_stress"], oedometer["axial_stress"], rtol=1e-12)
    ratio = cell["radial_stress"][0] / cell["axial_stress"][0]
    assert np.all(np.diff(ratio) > 0) and ratio[-1] - ratio[-2] < ratio[1] - ratio[0] and 0.6 < ratio[-1] < 0.7
