"""The independent generator's pressuremeter (validation/independent/sbp*.py) against closed forms (Lame and Gibson &
Anderson cavity expansion, Randolph & Wroth dissipation, the undrained critical state of Modified Cam Clay), its grid
and step convergence, the project's coupled FE (a second implementation of the same problem) and the shipped files."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import tomllib

from fem import oracles
from validation.independent.models import ClayState, ElastoplasticClay, ViscousClay
from validation.independent.sbp import EFFECTS, SITE, TESTS, case_ids, records, simulate
from validation.independent.sbp_material import CavityClay, Points, invariants, update
from validation.independent.sbp_solver import GAMMA_W, Cavity, block_solve

DATA = Path(__file__).resolve().parents[2] / "validation" / "data" / "independent"
A0 = 0.0415
G, SU, NU = 2000.0, 20.0, 0.3
M, LAM, KAP = 1.2, 0.25, 0.05


class VonMises:
    """Elastic-perfectly plastic von Mises with q_y = sqrt(3) s_u: Tresca's s_u in the plane-strain cavity (the
    intermediate principal stress stays the mean of the other two); the cavity solver's material protocol."""

    viscous = False

    def __init__(self, s_u=SU):
        self.K, self.qy = 2 * G * (1 + NU) / (3 * (1 - 2 * NU)), np.sqrt(3.0) * s_u

    def moduli(self, pts):
        return np.full(pts.size.size, self.K), np.full(pts.size.size, G)

    def yield_value(self, pts):
        return invariants(pts.sigma)[1] - self.qy

    def gradient(self, pts):
        direction = invariants(pts.sigma)[2]
        zero = np.zeros(len(direction))
        return direction, zero, zero

    def harden(self, pts, dev_p):
        return pts.size


def _cavity(material, k, n=60, sigma=100.0, u0=50.0):
    return Cavity(material, 1.0, A0, sigma, 1.0, u0, k, 1.0, n=n)


def test_block_solver_matches_a_dense_solve():
    rng = np.random.default_rng(3)
    n = 9
    diag = rng.normal(size=(n, 2, 2))
    diag = diag + diag.transpose(0, 2, 1) + np.diag([6.0, -6.0])
    upper = rng.normal(size=(n - 1, 2, 2))
    rhs = rng.normal(size=(n, 2))
    A = np.zeros((2 * n, 2 * n))
    for j in range(n):
        A[2 * j:2 * j + 2, 2 * j:2 * j + 2] = diag[j]
    for j in range(n - 1):
        A[2 * j:2 * j + 2, 2 * j + 2:2 * j + 4] = upper[j]
        A[2 * j + 2:2 * j + 4, 2 * j:2 * j + 2] = upper[j].T
    np.testing.assert_allclose(block_solve(diag, upper, rhs).ravel(), np.linalg.solve(A, rhs.ravel()), atol=1e-12)


@pytest.mark.parametrize("k", [1e-12, 1e-4])
def test_elastic_expansion_is_lame_undrained_and_drained(k):
    # plane-strain elastic cavity: u = u_a a/r (isochoric, so drained = undrained), p - p0 = 2 G eps_c, no excess
    # pore pressure
    c = _cavity(VonMises(s_u=1e9), k)
    c.expand(1.0 if k < 1e-8 else 1e-3, 0.01, max_strain=2e-4)
    r = np.array(c.rows)
    np.testing.assert_allclose(r[:, 2] - 150.0, 2 * G * r[:, 1], rtol=2e-3, atol=1e-9)
    assert np.max(np.abs(r[:, 3] - 50.0)) < 1e-6 * 2 * G * 0.01
    np.testing.assert_allclose(c.u * c.r, c.u[0] * A0, rtol=1e-9)


def test_undrained_tresca_expansion_is_gibson_anderson():
    # p - p0 = s_u (1 + ln(G/s_u) + ln(2 eps_c)) beyond yield, excess pore pressure 2 s_u ln(R_p/r) in the plastic
    # zone, R_p = a sqrt(2 G eps_c / s_u)
    c = _cavity(VonMises(), 1e-12, n=100)
    c.expand(1.0, 0.10, max_strain=2e-4)
    r = np.array(c.rows)
    rise, ratio = oracles.gibson_anderson(G, SU, r[:, 1])
    assert np.max(np.abs(r[:, 2] - 150.0 - rise)) < 0.006 * rise[-1]
    rp = A0 * np.sqrt(2 * G * 0.10 / SU)
    assert ratio[-1] * A0 == pytest.approx(rp)
    inside = c.centre < rp
    np.testing.assert_allclose(c.p[inside] - 50.0, 2 * SU * np.log(rp / c.centre[inside]), atol=0.002 * 2 * SU)
    assert np.max(np.abs(c.p[~inside] - 50.0)) < 1e-3


def test_dissipation_after_undrained_expansion_follows_randolph_wroth():
    # elastic soil during the hold (Randolph & Wroth 1979): the wall excess pore pressure against the Bessel series,
    # T = c_h t / a^2, c_h = k/gamma_w 2 G (1 - nu)/(1 - 2 nu); drained at R* = 200 a (the solver's outer radius)
    k = 1e-9
    ch = k / GAMMA_W * 2 * G * (1 - NU) / (1 - 2 * NU)
    vm = VonMises()
    c = _cavity(vm, k, n=100)
    c.expand(10.0, 0.10, max_strain=2e-4)
    start = len(c.rows) - 1
    vm.qy = np.inf
    c.hold(20 * A0 ** 2 / ch, growth=0.02, first_step=1e-3)
    r = np.array(c.rows[start:])
    T = (r[:, 0] - r[0, 0]) * ch / A0 ** 2
    rp = np.sqrt(2 * G * 0.10 / SU)
    u = (r[:, 3] - 50.0) / (2 * SU * np.log(rp))
    Tq = np.array([0.1, 0.3, 1.0, 3.0, 10.0])
    series = oracles.randolph_wroth(1.0, Tq, rp, 200.0, s_u=SU, n_terms=3000)[:, 0] / (2 * SU * np.log(rp))
    np.testing.assert_allclose(np.interp(Tq, T, u), series, atol=0.006)
    assert u[0] == pytest.approx(1.0, abs=0.02)


def test_mcc_points_reach_the_undrained_critical_state_in_plane_strain():
    # isochoric plane strain from an isotropic p'_0 with p'_c = R0 p'_0: p'_f = p'_0 (R0/2)^Lambda, Lambda =
    # 1 - kappa/lambda (Wood 1990), q_f = M p'_f with sigma'_z = p'_f, so (sigma'_r - sigma'_t)/2 = M p'_f / sqrt(3)
    material = CavityClay(ElastoplasticClay(M, LAM, KAP, 0.25))
    R0 = np.array([1.0, 2.0, 4.0])
    pts = Points(np.full((3, 3), 50.0), 50.0 * R0, np.full(3, 2.2))
    step = np.tile([2e-4, -2e-4, 0.0], (3, 1))
    for _ in range(1500):
        pts = update(material, pts, step, 1.0)
    pf = 50.0 * (R0 / 2.0) ** (1.0 - KAP / LAM)
    s = pts.sigma
    np.testing.assert_allclose((s[:, 0] - s[:, 1]) / 2, M * pf / np.sqrt(3.0), rtol=1e-3)
    np.testing.assert_allclose(s.mean(axis=1), pf, rtol=1e-3)
    np.testing.assert_allclose(s[:, 2], pf, rtol=1e-3)


def test_principal_creep_rate_is_the_triaxial_one():
    model = ViscousClay(M, LAM, KAP, 0.25, 0.015)
    material = CavityClay(model)
    sr, sz = 40.0, 70.0
    pts = Points(np.array([[sr, sr, sz]]), np.array([60.0]), np.array([2.2]))
    ev, eq = model.creep_rate(ClayState((sz + 2 * sr) / 3, sz - sr, 2.2, 60.0))
    np.testing.assert_allclose(material.creep_rate(pts)[0], [ev / 3 - eq / 2, ev / 3 - eq / 2, ev / 3 + eq],
                               rtol=1e-12)


@pytest.mark.slow
def test_grid_and_step_convergence_at_the_site():
    # MCC at the generator's site (k = 1e-10 m/s), 1 %/min to 10 %, then 1 h hold: cavity pressure and wall pore
    # pressure at the default (100 elements, 1e-4 strain per step) within 0.1 % of a refined solution
    def ends(n, max_strain):
        spans, rows = simulate(TESTS[0], "none", n=n, max_strain=max_strain)
        a, b = spans["expansion1"]
        return np.concatenate([rows[b - 1, 2:], rows[-1, 2:]])
    ref = ends(200, 5e-5)
    errors = [np.max(np.abs(ends(n, 1e-4) / ref - 1.0)) for n in (25, 50, 100)]
    assert errors[2] < 1e-3
    assert errors[0] > errors[1] > errors[2]
    assert np.max(np.abs(ends(100, 4e-4) / ends(100, 1e-4) - 1.0)) < 5e-4


def test_viscous_clay_is_stronger_when_faster_and_relaxes_in_the_hold():
    out = {}
    for effect in ("none", "viscosity"):
        for test in TESTS:
            spans, rows = simulate(test, effect, n=40, max_strain=4e-4, growth=0.1)
            a, b = spans["expansion1"]
            out[effect, test.name] = (rows[b - 1, 2], rows[b - 1, 2] - rows[-1, 2])
    p0 = SITE["K0"] * SITE["sigma_v0"] + SITE["u0"]
    gain = (out["viscosity", "SBP_fast"][0] - p0) / (out["viscosity", "SBP_slow"][0] - p0) - 1.0
    control = (out["none", "SBP_fast"][0] - p0) / (out["none", "SBP_slow"][0] - p0) - 1.0
    assert abs(control) < 0.005 < gain < 0.08
    assert out["viscosity", "SBP_fast"][1] > 3 * out["none", "SBP_fast"][1] > 0.0


def test_records_logging_and_noise():
    test = TESTS[1]
    sim = simulate(test, "none", n=40, max_strain=4e-4, growth=0.1)
    a, b = (records(test, "none", s, 1, sim) for s in (1, 2))
    assert tuple(a) == ("stage", "time_s", "stage_time_s", "cavity_strain_pct", "cavity_pressure_kPa",
                        "pore_pressure_kPa")
    assert len(a["time_s"]) != len(b["time_s"]) or np.any(a["time_s"] != b["time_s"])
    for rec in (a, b):
        assert np.all(np.diff(rec["time_s"]) > 0)
        expansion = rec["stage"] == 1
        assert np.all(np.diff(rec["cavity_strain_pct"][expansion]) > 0)
        assert rec["cavity_strain_pct"][expansion][-1] == pytest.approx(10.0)
        assert 30 < expansion.sum() < 60 and 6 < (~expansion).sum() < 20
    exact = np.interp(a["time_s"], sim[1][:, 0], sim[1][:, 2])
    rel = a["cavity_pressure_kPa"] / exact - 1.0
    assert 0.008 < np.std(rel) < 0.025 and abs(np.mean(rel)) < 0.008


def test_shipped_cases_match_the_key_and_hide_the_effect():
    key = {c: v for c, v in json.loads((DATA / "KEY.json").read_text()).items()
           if v["programme"] == "sbp" and "model_form" not in v}
    letters = case_ids()
    assert sorted(key) == sorted(f"sbp_{letters[e]}_s{s}" for e in EFFECTS for s in (1, 2, 3))
    words = ("viscos", "creep", "c_alpha", "relax")
    for case, truth in key.items():
        study = tomllib.loads((DATA / case / "study.toml").read_text())
        assert study["model"]["name"] == "ModifiedCamClay" and truth["effect"] in EFFECTS
        for t in study["tests"]:
            text = (DATA / case / t["file"]).read_text().lower()
            assert "synthetic (independent generator)" in text
            assert not any(w in text for w in words), (case, t["file"])


def _control_case():
    """(case, truth, pc0 of the generating MCC) of the shipped SBP control, noise seed 1."""
    from validation.independent.models import ellipse_size
    key = json.loads((DATA / "KEY.json").read_text())
    case = next(c for c, v in key.items() if v["programme"] == "sbp" and v["effect"] == "none" and v["seed"] == 1
                and "model_form" not in v)
    truth = key[case]["parameters"]
    k0 = truth["K0_nc"]
    return case, truth, ellipse_size(truth["sigma_p"] * (1 + 2 * k0) / 3, truth["sigma_p"] * (1 - k0), truth["M"])


def _project_fe(case, truth, pc0, **preset):
    """(observations, {test: {curve: (x, y)}}) of the project's coupled FE at the generating values."""
    from dataclasses import replace

    from cases.study.forward.study import StudyForward
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study
    study = load_study(DATA / case / "study.toml")
    observations, _ = load_observations(study.tests)
    fe = StudyForward(study, observations, {}, replace(study.preset(True), **preset))
    return observations, fe([{"M": truth["M"], "kappa": truth["kappa"], "pc0": pc0}])[0]


def test_shipped_study_loads_and_the_project_fe_reproduces_the_control_within_the_noise():
    case, truth, pc0 = _control_case()
    observations, out = _project_fe(case, truth, pc0)
    assert [t.name for t in observations] == [t.name for t in TESTS]
    for test in observations:
        assert set(test.curves) == {f"{q}@{s}" for q in ("cavity_pressure", "pore_pressure")
                                    for s in ("expansion1", "hold2")}
        for k, c in test.curves.items():
            x, y = out[test.name][k]
            rel = c.y / np.interp(c.x, x, y) - 1.0
            assert abs(np.mean(rel)) < 0.015 and np.max(np.abs(rel)) < 0.07, (test.name, k)


@pytest.mark.slow
def test_generator_and_project_fe_converge_to_the_same_cavity_curves():
    # two implementations of the same problem (this 1-D solver, the project's CAX4RP-like FE refined): noise-free
    # curves of the control at the generating values agree within 1 % at the yield onset of the wall pore pressure,
    # 0.2 % elsewhere
    case, truth, pc0 = _control_case()
    observations, out = _project_fe(case, truth, pc0, radial_cells=80, increments=100)
    for test, spec in zip(observations, TESTS):
        spans, rows = simulate(spec, "none")
        for k, c in test.curves.items():
            x, y = out[test.name][k]
            a, b = spans[k.split("@")[1]]
            seg = rows[a:b]
            gx = 100 * seg[:, 1] if c.x_name == "cavity_strain" else seg[:, 0] - seg[0, 0]
            gen = np.interp(c.x, gx, seg[:, 2 if k.startswith("cavity") else 3])
            rel = np.abs(gen / np.interp(c.x, x, y) - 1.0)
            assert np.max(rel) < (0.01 if k == "pore_pressure@expansion1" else 0.002), (test.name, k)
            assert np.median(rel) < 0.002, (test.name, k)


@pytest.mark.slow
def test_shipped_records_regenerate():
    key = json.loads((DATA / "KEY.json").read_text())
    case = next(c for c, v in key.items() if v["programme"] == "sbp" and v["seed"] == 2)
    rec = records(TESTS[0], key[case]["effect"], 2, 0)
    rows = [line for line in (DATA / case / f"{TESTS[0].name}.csv").read_text().splitlines()
            if not line.startswith("#")]
    shipped = np.array([[float(x) for x in line.split(",")] for line in rows[1:]])
    assert shipped.shape == (len(rec["stage"]), len(rec))
    for j, column in enumerate(rec):
        np.testing.assert_allclose(shipped[:, j], rec[column], rtol=2e-4, atol=1e-3)


def test_an_sbp_study_with_a_modified_cam_clay_base_builds_its_enriched_classes():
    """The loop enriches an MCC pressuremeter study through the ANICREEP family (its e0 from the test, as the
    family's translation gives it per particle): every enrichable candidate's forward model is built."""
    from cases.study.loop.study_problem import StudyProblem
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study
    from constitutive import physics_catalog
    study = load_study(DATA / "sbp_A_s1" / "study.toml")
    obs, times = load_observations(study.tests)
    problem = StudyProblem(study, obs, times, quick=True)
    candidates = {c["name"]: c for c in problem.candidates()}
    assert candidates["partial drainage"]["enrichment"] is not None  # the coupled FE's permeability enrichment
    for c in candidates.values():
        if c["enrichment"] is not None and not c["in_base"]:
            switches = physics_catalog.enriched_settings(c["name"], problem.base_switches, problem.base_bounds,
                                                         problem.model)[0]
            assert callable(problem.forward(switches)), c["name"]
