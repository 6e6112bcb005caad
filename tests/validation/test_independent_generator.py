"""The independent generator (validation/independent/) against closed forms, its own sub-step convergence, its import
independence from the calibrated implementation, and the shipped files."""
from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest
import tomllib
from scipy.optimize import brentq

from validation.independent.integrator import Control, Point, run_stage
from validation.independent.models import ClayState, ElastoplasticClay, ViscousClay
from validation.independent.programmes import EFFECTS, PROGRAMMES, simulate
from validation.independent.recording import COLUMNS, SEEDS, records

PACKAGE = Path(__file__).resolve().parents[2] / "validation" / "independent"
DATA = Path(__file__).resolve().parents[2] / "validation" / "data" / "independent"
LAM, KAP, M, NU = 0.25, 0.05, 1.2, 0.25
PROJECT = {"constitutive", "fem", "inference", "cases"}


def test_shares_no_code_with_the_calibrated_implementation():
    """No module of the generator imports the project's packages (constitutive, fem, inference, cases.study): only
    itself (relative imports), numpy and the standard library."""
    for path in PACKAGE.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level > 0:
                    continue
                names = [node.module]
            else:
                continue
            for n in names:
                assert n.split(".")[0] not in PROJECT, f"{path.name} imports {n}"


def _undrained(model, pc, ocr, to_strain=0.6, **steps):
    point = Point(model, ClayState(pc, 0.0, 2.2, pc))
    if ocr > 1:
        rate = (pc / ocr - pc) / 86400.0
        run_stage(point, Control(("stress", rate), ("stress", rate), 86400.0), **steps)
    p0 = point.state.p
    run_stage(point, Control(("strain", 1e-6), ("strain", -0.5e-6), to_strain / 1e-6), **steps)
    return p0, point


@pytest.mark.parametrize("ocr", [1.0, 2.0, 4.0])
def test_mcc_undrained_strength_after_overconsolidation(ocr):
    # Wood (1990): p'_f = p'_0 (OCR/2)^Lambda, Lambda = 1 - kappa/lambda, q_f = M p'_f
    p0, point = _undrained(ElastoplasticClay(M, LAM, KAP, NU), 200.0, ocr)
    pf = p0 * (ocr / 2.0) ** (1.0 - KAP / LAM)
    assert point.state.p == pytest.approx(pf, rel=2e-3)
    assert point.state.q == pytest.approx(M * pf, rel=2e-3)


@pytest.mark.parametrize("effect", ["none", "destructuration"])
def test_isotropic_compression_and_swelling_slopes(effect):
    # NCL slope lambda (intrinsic, once bonding has gone), swelling slope kappa: de/d ln p'
    model = ElastoplasticClay(M, LAM, KAP, NU, a=20.0 if effect != "none" else 0.0, b=0.0)
    point = Point(model, ClayState(50.0, 0.0, 2.2, 50.0, 0.5 if effect != "none" else 0.0))
    run_stage(point, Control(("stress", 950.0 / 86400), ("stress", 950.0 / 86400), 86400.0))
    rows = np.array(point.rows)
    late = rows[:, 3] > 600.0
    slope = np.polyfit(np.log(rows[late, 3]), rows[late, 5], 1)[0]
    assert -slope == pytest.approx(LAM, rel=5e-3)
    n = len(point.rows)
    run_stage(point, Control(("stress", -900.0 / 86400), ("stress", -900.0 / 86400), 86400.0))
    rows = np.array(point.rows[n:])
    slope = np.polyfit(np.log(rows[:, 3]), rows[:, 5], 1)[0]
    assert -slope == pytest.approx(KAP, rel=5e-3)


@pytest.mark.parametrize("alpha", [0.0, 0.3])
def test_k0_of_the_inclined_ellipse_in_one_dimensional_compression(alpha):
    # constant eta under 1-D compression: eps_q = 2/3 eps_v with elastic + associated plastic strains:
    # eta kappa 2(1+nu)/(9(1-2nu)) + (lambda-kappa) 2(eta-alpha)/(M^2-eta^2) = 2 lambda/3
    point = Point(ElastoplasticClay(M, LAM, KAP, NU, alpha=alpha), ClayState(50.0, 0.0, 2.2, 50.0))
    run_stage(point, Control(("strain", 1e-6), ("strain", 0.0), 0.4 / 1e-6))
    g = KAP * 2 * (1 + NU) / (9 * (1 - 2 * NU))
    eta = brentq(lambda h: h * g + (LAM - KAP) * 2 * (h - alpha) / (M * M - h * h) - 2 * LAM / 3, alpha + 1e-9,
                 M - 1e-9)
    assert point.state.q / point.state.p == pytest.approx(eta, rel=2e-3)
    k0 = point.sigma_r / point.sigma_a
    assert k0 == pytest.approx((3 - eta) / (3 + 2 * eta), rel=2e-3)


def test_rate_independent_models_hold_stress_in_relaxation_and_strain_in_creep():
    for effect in ("none", "anisotropy", "destructuration"):
        test = PROGRAMMES["relaxation"][1][0]
        spans, rows = simulate(test, effect)
        r = np.array(rows)
        holds = [s.name for s in test.stages if s.kind == "relaxation"]
        assert len(holds) == 5
        for hold in holds:
            a, b = spans[hold]
            assert np.ptp(r[a:b, 3]) <= 1e-9 * r[a, 3], (effect, hold)
        il = PROGRAMMES["il"][1][0]
        spans, rows = simulate(il, effect)
        r = np.array(rows)
        for stage in il.stages:
            a, b = spans[stage.name]
            hold = r[a:b][r[a:b, 0] > r[a, 0] + 10.0 + 1e-6]
            assert np.ptp(hold[:, 1]) <= 1e-12, (effect, stage.name)


def test_viscous_creep_follows_the_closed_form_and_secondary_compression_slope():
    # isotropic hold: e(t) = e_0 - psi ln(1 + R0^beta t / tau), psi = C_alpha_e / ln 10 (Eq. 8 of models)
    c_alpha = 0.015
    model = ViscousClay(M, LAM, KAP, NU, c_alpha)
    point = Point(model, ClayState(100.0, 0.0, 2.2, 100.0))
    run_stage(point, Control(("stress", 100.0 / 3600), ("stress", 100.0 / 3600), 3600.0))
    n, e0, ratio, t0 = len(point.rows) - 1, point.state.v - 1.0, point.state.p / point.state.size, point.time
    run_stage(point, Control(("stress", 0.0), ("stress", 0.0), 30 * 86400.0))
    r = np.array(point.rows[n:])
    t, e = r[:, 0] - t0, r[:, 5]
    closed = e0 - model.psi * np.log1p(ratio ** model.beta * t / model.tau)
    assert np.max(np.abs(e - closed)) < 2e-3 * (e0 - e[-1])
    late = t > 10 * 86400.0
    slope = -np.polyfit(np.log10(t[late]), e[late], 1)[0]
    assert slope == pytest.approx(c_alpha, rel=0.03)


def test_viscous_undrained_strength_rises_per_decade_of_strain_rate():
    strengths = []
    for rate in (1e-6, 1e-5):
        point = Point(ViscousClay(M, LAM, KAP, NU, 0.015), ClayState(200.0, 0.0, 2.2, 200.0))
        run_stage(point, Control(("stress", 0.0), ("stress", 0.0), 86400.0))
        run_stage(point, Control(("strain", rate), ("strain", -rate / 2), 0.15 / rate))
        r = np.array(point.rows)
        strengths.append(np.max(r[:, 3] - r[:, 4]))
    gain = strengths[1] / strengths[0] - 1.0
    assert 0.04 < gain < 0.10


def test_substep_convergence_is_first_order_and_small_at_the_default():
    # drained compression of a bonded specimen (chi0 = 1) to 5 % axial strain: q against a fine reference
    def q_at(max_strain):
        point = Point(ElastoplasticClay(M, LAM, KAP, NU, a=8.0, b=0.4), ClayState(150.0, 0.0, 2.2, 100.0, 1.0))
        run_stage(point, Control(("strain", 1e-6), ("stress", 0.0), 0.05 / 1e-6), max_strain=max_strain)
        return point.state.q
    ref = q_at(2.5e-6)
    errors = [abs(q_at(h) - ref) for h in (8e-5, 4e-5, 2e-5)]
    assert errors[2] < 1e-3 * abs(ref)
    assert errors[0] > errors[1] > errors[2]


def test_records_columns_logging_and_noise():
    test = PROGRAMMES["ciu"][1][0]
    a = records(test, "none", 1, 0, 0)
    b = records(test, "none", 2, 0, 0)
    assert tuple(a) == COLUMNS["triaxial"]
    assert len(a["time_s"]) != len(b["time_s"]) or np.any(a["time_s"] != b["time_s"])
    for rec in (a, b):
        for stage in np.unique(rec["stage"]):
            t = rec["time_s"][rec["stage"] == stage]
            assert np.all(np.diff(t) > 0)


def test_shipped_cases_match_the_key_and_hide_the_effect():
    key = {c: v for c, v in json.loads((DATA / "KEY.json").read_text()).items()
           if v["programme"] in PROGRAMMES and "model_form" not in v and "effects" not in v}
    assert len(key) == len(PROGRAMMES) * len(EFFECTS) * len(SEEDS)
    words = ("viscos", "anisotrop", "destructur", "alpha", "chi", "c_alpha", "bond")
    for case, truth in key.items():
        folder = DATA / case
        study = tomllib.loads((folder / "study.toml").read_text())
        assert study["model"]["name"] == "ModifiedCamClay"
        for t in study["tests"]:
            text = (folder / t["file"]).read_text().lower()
            assert "synthetic (independent generator)" in text
            assert not any(w in text for w in words), (case, t["file"])
        assert truth["effect"] in EFFECTS and truth["programme"] in PROGRAMMES


def test_shipped_records_regenerate():
    key = json.loads((DATA / "KEY.json").read_text())
    case = next(c for c, v in key.items() if v["programme"] == "ck0u" and v["seed"] == 2 and "model_form" not in v
                and "effects" not in v)
    truth = key[case]
    test = PROGRAMMES["ck0u"][1][1]
    rec = records(test, truth["effect"], 2, list(PROGRAMMES).index("ck0u"), 1)
    rows = [line for line in (DATA / case / f"{test.name}.csv").read_text().splitlines()
            if not line.startswith("#")]
    shipped = np.array([[float(x) if x else np.nan for x in line.split(",")] for line in rows[1:]])
    assert shipped.shape == (len(rec["stage"]), len(rec))
    for j, column in enumerate(rec):
        np.testing.assert_allclose(shipped[:, j], rec[column], rtol=2e-4, atol=1e-3, equal_nan=True)


@pytest.mark.parametrize("programme", list(PROGRAMMES))
def test_study_files_load_through_the_study_schema(programme):
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study
    key = json.loads((DATA / "KEY.json").read_text())
    case = next(c for c, v in key.items() if v["programme"] == programme and v["seed"] == 1)
    study = load_study(DATA / case / "study.toml")
    observations, _ = load_observations(study.tests)
    assert [t.name for t in observations] == [t.name for t in PROGRAMMES[programme][1]]
    for test in observations:
        assert test.curves


@pytest.mark.parametrize("programme", ["ciu", "crs"])
def test_negative_control_is_reproduced_by_the_calibrated_mcc(programme):
    # the project's own MCC programme forward at the generating values reproduces the plain-MCC records within
    # the noise (no bias): the two implementations agree, and the control carries no hidden effect
    from cases.study.forward.lab_staged import simulate_programme
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study
    from cases.study.reading.stage_records import recorded_programme
    from constitutive.registry import build_model
    from validation.independent.models import ellipse_size
    key = json.loads((DATA / "KEY.json").read_text())
    case = next(c for c, v in key.items() if v["programme"] == programme and v["effect"] == "none"
                and v["seed"] == 1 and "model_form" not in v)
    truth = key[case]["parameters"]
    k0 = truth["K0_nc"]
    pc0 = ellipse_size(truth["sigma_p"] * (1 + 2 * k0) / 3, truth["sigma_p"] * (1 - k0), truth["M"])
    model = build_model("ModifiedCamClay", {"M": truth["M"], "lambda_": truth["lambda_"], "kappa": truth["kappa"],
                                            "nu": truth["nu"], "pc0": pc0}, {})
    study = load_study(DATA / case / "study.toml")
    observations, _ = load_observations(study.tests)
    for spec, test in zip(study.tests, observations):
        spec = recorded_programme(spec, test)
        abscissae = {k: c.x / 100.0 if c.x_name == "axial_strain" else c.x for k, c in test.curves.items()}
        out, failed = simulate_programme(model, spec, abscissae, 1)
        assert not failed[0]
        for k, c in test.curves.items():
            if k.split("@")[0] in ("q", "p", "axial_stress"):
                big = np.abs(c.y) > 20.0
                rel = out[k][0][big] / c.y[big] - 1.0
                assert abs(np.mean(rel)) < 0.01 and np.max(np.abs(rel)) < 0.08, (spec.name, k)


def test_identifiability_control_is_its_own_plain_clay_and_a_bonded_clay_is_not():
    from validation.independent.identifiability import CLAY as PLAIN
    from validation.independent.identifiability import plain_residual, records_with_effect
    clay = {k: PLAIN[k] for k in ("M", "lambda_", "kappa", "sigma_p")}
    assert np.max(np.abs(plain_residual("relaxation", records_with_effect("relaxation", "none", 1), clay))) == 0.0
    bonded = plain_residual("relaxation", records_with_effect("relaxation", "destructuration", 1), clay)
    assert np.sqrt(np.mean(bonded ** 2)) > 1.0          # the bonded clay's records differ from the plain clay's


def test_identifiability_against_an_effect_is_zero_on_its_own_records_and_sees_a_second_effect():
    # the clay fitted against holds viscosity (C_alpha_e free): at the generating values it reproduces the viscous
    # clay's own records exactly, and the records of viscosity with delayed swelling on the relaxation programme
    # (strain held after unloading: the stress rises) differ from it by far more than the noise
    from validation.independent.identifiability import CLAY as PLAIN
    from validation.independent.identifiability import plain_residual, records_with_effect
    clay = {**{k: PLAIN[k] for k in ("M", "lambda_", "kappa", "sigma_p")}, "C_alpha_e": 0.015}
    own = plain_residual("relaxation", records_with_effect("relaxation", "viscosity", 1), clay, "viscosity")
    assert np.max(np.abs(own)) == 0.0
    both = records_with_effect("relaxation", "viscosity+time-dependent swelling", 1)
    assert np.sqrt(np.mean(plain_residual("relaxation", both, clay, "viscosity") ** 2)) > 1.0
    # the plain clay's parameters alone cannot take the viscous clay's place: C_alpha_e of the fitted clay matters
    slower = plain_residual("relaxation", records_with_effect("relaxation", "viscosity", 1),
                            {**clay, "C_alpha_e": 0.010}, "viscosity")
    assert np.sqrt(np.mean(slower ** 2)) > 1.0


@pytest.mark.slow
def test_identifiability_fit_recovers_the_generating_clay_from_a_distant_start():
    # the control's records are the plain clay's own: least squares from 10-20 % off must return the generating
    # values (an independent oracle: the values the records were made with) and E ~ 0. E/2 is compared with a
    # threshold of 20 units, so the search's own shortfall must be a small fraction of one unit (E < 0.1); the
    # finite-difference Jacobian of the generator's sub-stepped integrator (steps 1e-4) limits the values to about
    # 1e-3 (M, the least sensitive in one-dimensional compression: 2e-3 measured)
    from validation.independent.identifiability import best_plain_fit
    fit = best_plain_fit("relaxation", "none", 1, start={"M": 1.32, "lambda_": 0.28, "kappa": 0.056, "sigma_p": 118.0})
    assert fit["E"] < 0.1
    for name, value in (("M", 1.2), ("lambda_", 0.25), ("kappa", 0.05), ("sigma_p", 100.0)):
        assert fit["values"][name] == pytest.approx(value, rel=5e-3), name


@pytest.mark.slow
def test_identifiability_fit_against_viscosity_recovers_the_viscous_clay():
    # the viscous clay's own records, fitted against the viscous clay from 10-20 % off: E ~ 0 and the generating
    # values back, C_alpha_e included (the same oracle and the same tolerance as the plain clay's above; measured:
    # C_alpha_e 1.5e-3 off, M 1.3e-3, the others below 1e-4)
    from validation.independent.identifiability import best_plain_fit
    fit = best_plain_fit("relaxation", "viscosity", 1, against="viscosity",
                         start={"M": 1.32, "lambda_": 0.28, "kappa": 0.056, "sigma_p": 118.0, "C_alpha_e": 0.018})
    assert fit["E"] < 0.1
    for name, value in (("M", 1.2), ("lambda_", 0.25), ("kappa", 0.05), ("sigma_p", 100.0), ("C_alpha_e", 0.015)):
        assert fit["values"][name] == pytest.approx(value, rel=5e-3), name
