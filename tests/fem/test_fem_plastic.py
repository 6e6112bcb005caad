"""Undrained cavity expansion with plastic soils: Gibson & Anderson (von Mises/Tresca) and the exact strain-path
oracle with Modified Cam Clay (REFERENCE.md section 6). Small strain, as the FE."""
import numpy as np
import pytest

import constitutive as C
import fem
from fem import oracles

A0 = 0.0415
FAST = 0.1 / 60           # 10 % in 60 s; with k = 1e-14 m/s the expansion is undrained (T = c t/a^2 ~ 1e-6)


def undrained_problem(material, n_radial=60, R=200, sigma_v0=50.0, u0=30.0, n_increments=40, **kw):
    mesh = fem.Mesh.cavity_strip(a0=A0, outer_radius=R * A0, n_radial=n_radial, n_vertical=2)
    return fem.pressuremeter(material, mesh=mesh, sigma_v0=sigma_v0, K0=1.0, u0=u0, permeability=1e-14,
                             strain_rate=FAST, n_increments=n_increments, outer="field", monitor_radii=(1.5 * A0,),
                             **kw)


def test_gibson_anderson_von_mises():
    """Pressure rise along the whole curve and excess pore pressures 2 s_u ln(R_p/r) at the wall and at 1.5 a0."""
    G, su = 2000.0, 20.0
    r = fem.solve(undrained_problem(C.VonMises(s_u=su, nu=0.49, G=G), n_radial=120))
    rise, rp = oracles.gibson_anderson(G, su, r.cavity_strain)
    assert np.max(np.abs(r.cavity_pressure - 80.0 - rise)) < 0.01 * rise[-1]          # measured 0.1 %
    assert r.cavity_excess_pore_pressure[-1] == pytest.approx(2 * su * np.log(rp[-1]), rel=0.02)
    u15 = r.monitor_excess_pore_pressure[1.5 * A0][-1]
    assert u15 == pytest.approx(2 * su * np.log(rp[-1] / 1.5), rel=0.01)
    # first yield at 2 G eps_c = s_u: still elastic there
    elastic = r.cavity_strain <= su / (2 * G)
    assert np.allclose(r.cavity_pressure[elastic] - 80.0, 2 * G * r.cavity_strain[elastic], rtol=1e-5)


def test_modified_cam_clay_undrained_strain_path_and_convergence():
    """MCC cavity pressure rise and wall excess pore pressure against the exact undrained strain-path integral;
    the error decreases under mesh refinement (order measured ~1-2)."""
    mcc = C.ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.04, G=2000.0, ocr=1.5)
    s0 = np.array([100.0, 100.0, 100.0, 0.0, 0.0, 0.0])
    e, rise, pex = oracles.undrained_strain_path(mcc, s0, 1.0, 0.1, n_steps=2000)
    err_p, err_u = [], []
    for n in (30, 60, 120):
        r = fem.solve(undrained_problem(mcc, n_radial=n, R=50, sigma_v0=100.0, void_ratio0=1.0, n_increments=20))
        err_p.append(abs(r.cavity_pressure[-1] - 130.0 - rise[-1]))
        err_u.append(abs(r.cavity_excess_pore_pressure[-1] - pex[-1]))
    # measured: pressure 1.09/0.79/0.39 kPa (of 161.8), wall excess pore pressure 6.07/3.45/1.31 kPa (of 127.4)
    assert err_p[0] > err_p[1] > err_p[2] and err_u[0] > err_u[1] > err_u[2]
    assert err_p[-1] < 0.005 * rise[-1]
    assert err_u[-1] < 0.015 * pex[-1]
    assert np.log2(err_u[1] / err_u[2]) > 1.0


def test_strain_path_oracle_reduces_to_lame_and_gibson_anderson():
    """Independent check of the oracle itself: elastic -> 2 G eps; von Mises -> Gibson & Anderson (small strain)."""
    s0 = np.array([50.0, 50.0, 50.0, 0.0, 0.0, 0.0])
    e, rise, _ = oracles.undrained_strain_path(C.LinearElastic(5000.0, 0.3), s0, 1.0, 0.1, n_steps=200)
    assert rise[-1] == pytest.approx(2 * 5000.0 / 2.6 * 0.1, rel=1e-12)
    e, rise, pex = oracles.undrained_strain_path(C.VonMises(s_u=20.0, nu=0.49, G=2000.0), s0, 1.0, 0.1, n_steps=4000)
    ga, rp = oracles.gibson_anderson(2000.0, 20.0, 0.1)
    assert rise[-1] == pytest.approx(float(ga), rel=1e-4)
    assert pex[-1] == pytest.approx(2 * 20.0 * np.log(float(rp)), rel=1e-3)


def test_integration_error_triggers_step_cutting_then_convergence_error():
    """A material that fails above a strain level: the solver cuts the step, then raises fem.ConvergenceError."""

    class Brittle(C.LinearElastic):
        def update(self, stress, state, dstrain, dt, tangent=True):
            if np.abs(dstrain).max() > 1e-9:
                raise C.IntegrationError(0, "strain increment too large")
            return super().update(stress, state, dstrain, dt)

    pb = undrained_problem(Brittle(5000.0, 0.3), n_radial=10, n_increments=2)
    pb.max_cuts = 3
    with pytest.raises(fem.ConvergenceError, match="step cuts"):
        fem.solve(pb)


def test_step_cutting_recovers():
    """A material that fails for increments above a threshold converges after cuts, to the uncut answer and to the
    exact one.

    Tolerance from the conditioning: a step accepted at relative residual rtol carries a solution error of up to
    kappa rtol, kappa the condition number of the (row and column equilibrated) Jacobian, and the cut solve
    accumulates that over its sub-steps (at most 2 x 2^5 = 64 here). The permeability sets kappa: with k = 1e-14 m/s
    (undrained) the mass balance only constrains the volume and kappa ~ 5e9 (measured for this mesh and step), so the
    pore pressure of a cut solve is fixed to ~1e-2 kPa only, by round-off in the banded LU as much as by rtol (it
    differed between OpenBLAS kernels). With k = 1e-9 m/s, kappa ~ 3e5 (measured) and the answer is the same: the
    elastic cavity field is isochoric, so no excess pore pressure arises whatever the permeability. With rtol = 1e-12
    the bound is 64 x 3e5 x 1e-12 ~ 2e-5 (measured error <= 1e-13, with SkylakeX and Haswell OpenBLAS kernels)."""

    class Fussy(C.LinearElastic):
        def update(self, stress, state, dstrain, dt, tangent=True):
            if np.abs(dstrain).max() > 2e-3:
                raise C.IntegrationError(0, "strain increment too large")
            return super().update(stress, state, dstrain, dt)

    exact = 50.0 + 30.0 + 2.0 * 5000.0 / 2.6 * 0.1      # sigma'_h0 + u0 + 2 G eps_c (isochoric field, no excess u)
    bound = 64 * 3e5 * 1e-12
    stats, pressure = {}, {}
    for model in (Fussy(5000.0, 0.3), C.LinearElastic(5000.0, 0.3)):
        mesh = fem.Mesh.cavity_strip(a0=A0, outer_radius=200 * A0, n_radial=20, n_vertical=2)
        pb = fem.pressuremeter(model, mesh=mesh, sigma_v0=50.0, K0=1.0, u0=30.0, permeability=1e-9,
                               strain_rate=FAST, n_increments=2, outer="field")
        pb.rtol = 1e-12
        solver = fem.Solver(pb)
        pressure[type(model).__name__] = solver.solve().cavity_pressure[-1]
        stats[type(model).__name__] = solver.stats["cuts"]
    assert stats["Fussy"] > 0 and stats["LinearElastic"] == 0
    assert pressure["Fussy"] == pytest.approx(pressure["LinearElastic"], rel=bound)
    assert pressure["Fussy"] == pytest.approx(exact, rel=bound)
    assert pressure["LinearElastic"] == pytest.approx(exact, rel=bound)


def test_material_calls_skipped_at_the_predictor_for_rate_independent_models():
    """Iteration 0 of a step sits at the converged state: a rate-independent model is not called there (its answer
    to a zero strain increment is the committed stress); a rate-dependent one is called at every residual but the
    first (the zero increment over the first step, the update that gave the initial tangent)."""

    class Viscous(C.LinearElastic):
        rate_dependent = True

    counts = {}
    for name, mat in (("independent", C.LinearElastic(5000.0, 0.3)), ("dependent", Viscous(5000.0, 0.3))):
        solver = fem.Solver(undrained_problem(mat, n_radial=10, n_increments=5, predictor="tangent"))
        r = solver.solve()
        counts[name] = dict(solver.stats, p=r.cavity_pressure[-1])
    # linear elastic: predictor + one check per step (the initial-tangent call is not a residual evaluation)
    assert counts["independent"]["residuals"] == counts["dependent"]["residuals"] == 10
    assert counts["independent"]["material_calls"] == 5
    assert counts["dependent"]["material_calls"] == 9
    assert counts["independent"]["p"] == counts["dependent"]["p"]


def test_extrapolated_predictor_is_exact_for_a_linear_steady_path():
    """Undrained linear elastic expansion in equal increments: the solution is linear in time, so the extrapolated
    start of every step after the first is the answer (one residual, no correction) and equals the tangent
    predictor's answer."""
    out = {}
    for predictor in ("extrapolate", "tangent"):
        solver = fem.Solver(undrained_problem(C.LinearElastic(5000.0, 0.3), n_radial=10, n_increments=5,
                                              predictor=predictor))
        out[predictor] = (solver.solve().cavity_pressure, dict(solver.stats))
    (p_ex, n_ex), (p_tan, n_tan) = out["extrapolate"], out["tangent"]
    assert n_ex["residuals"] == 2 + 4 and n_tan["residuals"] == 2 * 5
    # two Newton paths to the same undrained answer: each agrees with it to round-off times the condition number of
    # the (equilibrated) Jacobian, ~1e9 here (measured; k = 1e-14 m/s), i.e. ~2e-7 (measured difference 7e-9)
    assert np.allclose(p_ex, p_tan, rtol=1e-6)
    with pytest.raises(fem.ProblemError, match="predictor"):
        undrained_problem(C.LinearElastic(5000.0, 0.3), predictor="linear")


@pytest.mark.parametrize("predictor", ["extrapolate", "tangent"])
def test_full_and_modified_newton_agree(predictor):
    """Full Newton (default) and modified Newton converge to the same curve (MCC, undrained, 30 cells) within the
    convergence tolerance and modified Newton does not factorize more often. With the tangent predictor full Newton
    refactors at every iteration (measured 58 residuals, 19 factorizations against 66 and 1); with the extrapolated
    start every step converges after one correction with the kept factorization, so both need 39 and 1."""
    mcc = C.ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.04, G=2000.0, ocr=1.5)
    out = {}
    for ratio in (0.0, 0.1):
        solver = fem.Solver(undrained_problem(mcc, n_radial=30, R=50, sigma_v0=100.0, void_ratio0=1.0,
                                              n_increments=20, refresh_ratio=ratio, predictor=predictor))
        out[ratio] = (solver.solve(), dict(solver.stats))
    (full, n_full), (modified, n_mod) = out[0.0], out[0.1]
    assert np.allclose(full.cavity_pressure, modified.cavity_pressure, rtol=1e-5)
    assert np.allclose(full.cavity_excess_pore_pressure, modified.cavity_excess_pore_pressure, rtol=1e-4, atol=1e-3)
    assert n_mod["factorizations"] <= n_full["factorizations"]
    with pytest.raises(fem.ProblemError, match="refresh_ratio"):
        undrained_problem(mcc, refresh_ratio=1.0)


def test_rate_dependent_tangent_asked_for_only_before_a_factorization():
    """A rate-dependent material (ANICREEP) is called at every residual, but its tangent is needed only when a
    factorization follows: it is then asked for by a second call at the same trial strain, unless the residual's
    call asked for it already (a factorization due or likely: fem.solver.EAGER_TANGENT_MISS). The curves are bit
    for bit those of a solve that asks for the tangent at every call, with at most one extra call per
    factorization."""
    model = C.ANICREEP(M=1.71, lambda_=0.40, kappa=0.026, nu=0.3, e0=2.0, sigma_p0=58.4, C_alpha_e=0.020,
                       vertical_axis=2)
    mesh = fem.Mesh.cavity_strip(n_radial=20, n_vertical=1)
    out = {}
    for eager in (False, True):
        solver = fem.Solver(fem.pressuremeter(model, mesh=mesh, n_increments=20, save_fields="none"))
        if eager:
            lazy_residual = solver._residual
            solver._residual = lambda *a, **k: lazy_residual(*a, **{**k, "tangent": True})
        out[eager] = (solver.solve(), dict(solver.stats))
    (lazy, n_lazy), (eager, n_eager) = out[False], out[True]
    assert np.array_equal(lazy.cavity_pressure, eager.cavity_pressure)
    assert np.array_equal(lazy.cavity_excess_pore_pressure, eager.cavity_excess_pore_pressure)
    assert n_eager["tangent_calls"] == 0 and 0 < n_lazy["tangent_calls"] <= n_lazy["factorizations"]
    assert n_lazy["material_calls"] == n_eager["material_calls"]
