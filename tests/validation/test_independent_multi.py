"""The independent generator's multi-effect programmes (validation/independent/multi.py): the creep-rate law's three
additions (inclined ellipse, bonding, delayed swelling; models Eq. 9-10) against their closed forms and limits, the
signatures of both effects in the programmes, the shipped multi-effect cases, and the confusion table's multi set."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import tomllib

from validation.independent.integrator import Control, Point, run_stage
from validation.independent.models import ClayState, ViscousClay, ellipse_size
from validation.independent.multi import _STREAM, CASES, case_ids, generator_effect, multi_tests
from validation.independent.programmes import PROGRAMMES, simulate
from validation.independent.recording import records

DATA = Path(__file__).resolve().parents[2] / "validation" / "data" / "independent"
LAM, KAP, M, NU, C_ALPHA = 0.25, 0.05, 1.2, 0.25, 0.015


def _shipped(case, name):
    rows = [line for line in (DATA / case / f"{name}.csv").read_text().splitlines() if not line.startswith("#")]
    return np.array([[float(x) if x else np.nan for x in line.split(",")] for line in rows[1:]])


def test_without_the_additions_the_law_is_the_plain_viscous_clay_as_shipped():
    # the records of the shipped viscosity cases (written before the additions) regenerate to their printed digits
    key = json.loads((DATA / "KEY.json").read_text())
    for programme in ("relaxation", "ck0u"):
        case = next(c for c, v in key.items() if v["programme"] == programme and v["effect"] == "viscosity"
                    and v["seed"] == 1 and "model_form" not in v and "effects" not in v)
        test = PROGRAMMES[programme][1][0]
        rec = records(test, "viscosity", 1, list(PROGRAMMES).index(programme), 0)
        shipped = _shipped(case, test.name)
        for j, column in enumerate(rec):
            np.testing.assert_allclose(shipped[:, j], rec[column], rtol=1e-4, atol=1e-3, equal_nan=True)


def test_inclined_creep_rate_is_normal_to_the_inclined_ellipse_and_volumetric_on_its_axis():
    alpha = 0.3
    model = ViscousClay(M, LAM, KAP, NU, C_ALPHA, alpha=alpha)
    # on the axis q = alpha p at p = p_p: rate psi/(v tau) (1, 0) (Eq. 6, 9)
    ev, eq = model.creep_rate(ClayState(80.0, alpha * 80.0, 2.2, 80.0))
    assert ev == pytest.approx(model.psi / (2.2 * model.tau), rel=1e-12) and abs(eq) < 1e-12 * ev
    # elsewhere the direction is the gradient of p_eq (Eq. 9: the normal of the inclined ellipse)
    p, q, h = 70.0, 30.0, 1e-5
    grad = [(ellipse_size(p + h, q, M, alpha) - ellipse_size(p - h, q, M, alpha)) / (2 * h),
            (ellipse_size(p, q + h, M, alpha) - ellipse_size(p, q - h, M, alpha)) / (2 * h)]
    ev, eq = model.creep_rate(ClayState(p, q, 2.2, 90.0))
    assert ev / eq == pytest.approx(grad[0] / grad[1], rel=1e-7)


def test_bonding_scales_the_reference_size_and_degrades_with_the_viscoplastic_strain():
    bonded = ViscousClay(M, LAM, KAP, NU, C_ALPHA, a=8.0)
    plain = ViscousClay(M, LAM, KAP, NU, C_ALPHA)
    assert bonded.creep_rate(ClayState(90.0, 20.0, 2.2, 40.0, 1.5)) == pytest.approx(
        plain.creep_rate(ClayState(90.0, 20.0, 2.2, 100.0)), rel=1e-12)
    # isotropic hold (p held: no elastic strain, Eq. 4 with b = 0): chi = chi0 exp(-a eps_v) = chi0 (v/v0)^a
    point = Point(bonded, ClayState(100.0, 0.0, 2.2, 100.0 / 1.5, 0.5))
    run_stage(point, Control(("stress", 0.0), ("stress", 0.0), 10 * 86400.0))
    assert point.state.v < 2.2 * 0.995 and point.state.chi < 0.95 * 0.5
    assert point.state.chi == pytest.approx(0.5 * (point.state.v / 2.2) ** 8.0, rel=1e-4)


def test_delayed_swelling_after_unloading_follows_the_kelvin_closed_form():
    # isotropic unloading 200 -> 50 kPa in 10 s, then p held 3 days: eps_s(t) = eq + (eps_s(0) - eq) exp(-t/tau_s),
    # eq = kappa_s / v0 ln(50/200) (v0: the "initial" convention keeps it constant; the creep at OCR 4 is negligible)
    kappa_s, tau_s = 0.02, 86400.0
    model = ViscousClay(M, LAM, KAP, NU, C_ALPHA, kappa_s=kappa_s, tau_s=tau_s, specific_volume="initial")
    point = Point(model, model.initial_state(200.0, 0.0, 2.2, (200.0, 0.0)))
    run_stage(point, Control(("stress", -15.0), ("stress", -15.0), 10.0))
    n, swell0, t0 = len(point.rows) - 1, point.state.swell, point.time
    run_stage(point, Control(("stress", 0.0), ("stress", 0.0), 3 * 86400.0))
    r = np.array(point.rows[n:])
    t, eps_v = r[:, 0] - t0, r[:, 1] + 2 * r[:, 2] - (r[0, 1] + 2 * r[0, 2])
    eq = kappa_s / 2.2 * math.log(50.0 / 200.0)
    closed = (eq - swell0) * (1.0 - np.exp(-t / tau_s))
    assert eps_v[-1] < 0.9 * eq                                  # it swells (compression positive: eps_v < 0)
    assert np.max(np.abs(eps_v - closed)) < 5e-3 * abs(eq)
    assert point.state.swell - swell0 == pytest.approx(eps_v[-1], rel=1e-3)


def test_no_delayed_swelling_in_first_loading():
    # p' rises monotonically in the first CRS loading: p = p_max, eps_s stays 0, the records equal the viscous clay's
    test = PROGRAMMES["relaxation"][1][0]
    spans, rows = simulate(test, "viscosity+time-dependent swelling")
    _, plain = simulate(test, "viscosity")
    a, b = spans["loading1"]
    assert np.array_equal(np.array(rows[a:b]), np.array(plain[a:b]))


def _hold(test, effect, stage, ramp=0.0):
    """Rows of a stage after its first ``ramp`` s."""
    spans, rows = simulate(test, effect)
    a, b = spans[stage]
    r = np.array(rows[a:b])
    return r[r[:, 0] > r[0, 0] + ramp + 1e-6]


def test_swelling_signatures_after_unloading():
    relax = PROGRAMMES["relaxation"][1][0]
    last = relax.stages[-1].name
    both, visc = (_hold(relax, e, last) for e in ("viscosity+time-dependent swelling", "viscosity"))
    assert both[-1, 3] - both[0, 3] > 10.0 and abs(visc[-1, 3] - visc[0, 3]) < 1.0   # the stress rises, held strain
    il = PROGRAMMES["il"][1][0]
    last = il.stages[-1].name
    both, visc = (_hold(il, e, last, il.stages[-1].fields["ramp_time"])
                  for e in ("viscosity+time-dependent swelling", "viscosity"))
    assert both[-1, 1] - both[0, 1] < -2e-3 and abs(visc[-1, 1] - visc[0, 1]) < 5e-4  # it keeps swelling


def test_rate_steps_raise_the_strength_and_bonding_softens_it():
    test = multi_tests("ratestep")[1][0]
    ends = {}
    for effect in ("viscosity", "viscosity+destructuration", "none"):
        spans, rows = simulate(test, effect)
        r = np.array(rows)
        ends[effect] = np.array([r[spans[s.name][1] - 1, 3] - r[spans[s.name][1] - 1, 4]
                                 for s in test.stages if s.kind == "shear"])
    visc = ends["viscosity"]
    beta = (LAM - KAP) / (C_ALPHA / math.log(10.0))
    assert visc[9] / visc[8] == pytest.approx(10.0 ** (1.0 / beta), rel=0.02)   # 0.01 -> 0.1 %/min, late stages
    assert np.all(np.diff(ends["none"]) > 0.0)                # rate-independent: no steps, it nears critical state
    bonded = ends["viscosity+destructuration"]
    assert bonded[-1] < 0.97 * bonded[3] and bonded[-1] < 0.92 * visc[-1]         # softening
    assert bonded[9] / bonded[8] > 1.04                                            # and the rate steps


def test_shipped_multi_cases_match_the_key_and_hide_the_effects():
    key = {c: v for c, v in json.loads((DATA / "KEY.json").read_text()).items() if "effects" in v}
    names = case_ids()
    assert sorted(key) == sorted(f"{names[p, e]}_s{s}" for p, e in CASES for s in (1, 2, 3))
    words = ("viscos", "anisotrop", "destructur", "swell", "alpha", "chi", "c_alpha", "bond", "kelvin")
    for case, truth in key.items():
        effects = tuple(truth["effects"])
        assert (truth["programme"], effects) in CASES
        assert truth["effect"] == (effects[0] if effects else "none")
        study = tomllib.loads((DATA / case / "study.toml").read_text())
        assert study["model"]["name"] == "ModifiedCamClay"
        for t in study["tests"]:
            text = (DATA / case / t["file"]).read_text().lower()
            assert "synthetic (independent generator)" in text
            assert not any(w in text for w in words), (case, t["file"])


@pytest.mark.parametrize("programme,effects,seed", [("ratestep", ("viscosity", "destructuration"), 2),
                                                    ("relaxation", ("viscosity", "time-dependent swelling"), 3)])
def test_shipped_multi_records_regenerate(programme, effects, seed):
    test = multi_tests(programme)[1][0]
    rec = records(test, generator_effect(effects), seed, _STREAM[programme], 0)
    shipped = _shipped(f"{case_ids()[programme, effects]}_s{seed}", test.name)
    assert shipped.shape == (len(rec["stage"]), len(rec))
    for j, column in enumerate(rec):
        np.testing.assert_allclose(shipped[:, j], rec[column], rtol=2e-4, atol=1e-3, equal_nan=True)


def test_rate_step_study_loads_and_carries_the_excess_pore_pressure_through_the_stages():
    from cases.study.reading.records import load_observations
    from cases.study.reading.schema import load_study
    case = f"{case_ids()['ratestep', ()]}_s1"
    study = load_study(DATA / case / "study.toml")
    observations, _ = load_observations(study.tests)
    (test,) = observations
    shears = [s.name for s in multi_tests("ratestep")[1][0].stages if s.kind == "shear"]
    assert len(shears) == 10 and all(f"q@{s}" in test.curves for s in shears)
    u = [test.curves[f"excess_pore_pressure@{s}"].y for s in shears]
    assert min(u[-1]) > 0.8 * max(u[0])          # from the start of undrained shearing, not of each stage


def test_confusion_multi_set_counts_a_case_detected_when_every_effect_is_confirmed(tmp_path):
    from validation.independent.confusion import case_order, confirmed_effects, load_key, outcome, write_tables
    key = load_key(DATA)
    multi = case_order(key, controls="multi")
    assert sorted(multi) == sorted(c for c, v in key.items() if "effects" in v)
    assert not set(multi) & set(case_order(key, controls="all"))
    assert confirmed_effects({"omitted_physics": "viscosity"}) == ["viscosity"]
    assert confirmed_effects({"omitted_physics": "none"}) == []
    chain = ["viscosity", "time-dependent swelling"]
    assert confirmed_effects({"omitted_physics": "viscosity", "confirmed_chain": chain}) == chain
    case = f"{case_ids()['relaxation', tuple(chain)]}_s1"
    rows = []
    for confirmed in (chain, chain[:1]):
        out = tmp_path / "+".join(confirmed)
        (out / case).mkdir(parents=True)
        (out / case / "loop.json").write_text(json.dumps(
            {"named": chain, "omitted_physics": confirmed[0], "confirmed_chain": confirmed,
             "timing": {"loop_s": 1.0, "calibration_s": 1.0}}))
        (out / case / "diagnosis.json").write_text(json.dumps(
            {"verdict": "misfit", "classes": [], "attribution": [], "candidates": []}))
        rows.append(outcome(case, key[case], out))
    full, partial = rows
    assert full["confirmed_ok"] and full["confirmed_each"] == 2 and not full["false_alarm"] and full["named_ok"]
    assert not partial["confirmed_ok"] and partial["confirmed_each"] == 1 and not partial["false_alarm"]
    write_tables(rows, tmp_path, {"written": "now"})
    text = (tmp_path / "confusion.md").read_text()
    assert "viscosity + time-dependent swelling" in text and "Multi-effect cases fully detected 1/2" in text
