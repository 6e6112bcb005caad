"""The model-form controls of the independent generator (validation/independent/controls.py): each convention option
against a closed form, the exact strain-path cavity expansion against Gibson & Anderson and Lame, the size of each
variant's difference, and the shipped control cases (regenerated, hiding the variant)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import tomllib
from scipy.optimize import brentq

from validation.independent.controls import APPLIES, CONTROLS, case_ids, difference, records, write_controls
from validation.independent.integrator import Control, Point, run_stage
from validation.independent.models import ClayState, ElastoplasticClay
from validation.independent.programmes import k0_nc
from validation.independent.sbp_exact import strain_path_expansion
from validation.independent.sbp_material import invariants

DATA = Path(__file__).resolve().parents[2] / "validation" / "data" / "independent"
LAM, KAP, M, NU = 0.25, 0.05, 1.2, 0.25


def _isotropic(model, p_end=1000.0):
    """Rows (p', v) of drained isotropic compression on the normal compression line from 50 kPa, and v0."""
    point = Point(model, ClayState(50.0, 0.0, 2.2, 50.0, 0.0, 2.2))
    rate = (p_end - 50.0) / 86400.0
    run_stage(point, Control(("stress", rate), ("stress", rate), 86400.0))
    rows = np.array(point.rows)
    return rows[:, 3], rows[:, 5] + 1.0


@pytest.mark.parametrize("convention", ["e-lnp", "lnv-lnp", "v-initial"])
def test_normal_compression_line_of_each_convention(convention):
    # e-ln p': v = v0 - lambda ln(p/p0); ln v-ln p' (Butterfield): ln v = ln v0 - lambda* ln(p/p0); v held at v0:
    # the natural volumetric strain eps_v = -ln(v/v0) = (lambda/v0) ln(p/p0)
    options = {"e-lnp": {}, "lnv-lnp": {"compression": "lnv-lnp"}, "v-initial": {"specific_volume": "initial"}}
    p, v = _isotropic(ElastoplasticClay(M, LAM, KAP, NU, **options[convention]))
    x = np.log(p / 50.0)
    closed = {"e-lnp": 2.2 - LAM * x, "lnv-lnp": 2.2 * np.exp(-LAM * x), "v-initial": 2.2 * np.exp(-LAM / 2.2 * x)}
    np.testing.assert_allclose(2.2 - v, 2.2 - closed[convention], rtol=2e-3, atol=1e-6)


@pytest.mark.parametrize("elasticity", ["nu", "G"])
def test_elastic_shear_and_swelling_with_constant_nu_or_constant_G(elasticity):
    # inside the surface at constant p': eps_q = q / (3 G) with G = 3 K (1 - 2 nu) / (2 (1 + nu)), K = v p'/kappa
    # (constant nu) or the given G; isotropic unloading keeps the swelling slope kappa with either
    model = ElastoplasticClay(M, LAM, KAP, NU, **({"elasticity": "G", "G": 1234.0} if elasticity == "G" else {}))
    point = Point(model, ClayState(100.0, 0.0, 2.1, 400.0, 0.0, 2.1))
    run_stage(point, Control(("stress", 40.0 / 3 / 3600), ("stress", -20.0 / 3 / 3600), 3600.0))
    G = 1234.0 if elasticity == "G" else 3 * (2.1 * 100.0 / KAP) * (1 - 2 * NU) / (2 * (1 + NU))
    eps_q = 2.0 / 3.0 * (point.eps_a - point.eps_r)
    assert point.state.p == pytest.approx(100.0, rel=1e-9)
    assert eps_q == pytest.approx(point.state.q / (3.0 * G), rel=1e-6)
    point = Point(model, ClayState(400.0, 0.0, 2.1, 400.0, 0.0, 2.1))
    run_stage(point, Control(("stress", -300.0 / 3600), ("stress", -300.0 / 3600), 3600.0))
    rows = np.array(point.rows)
    assert -np.polyfit(np.log(rows[:, 3]), rows[:, 5], 1)[0] == pytest.approx(KAP, rel=2e-3)
    assert np.max(np.abs(rows[:, 3] - rows[:, 4])) < 1e-9


def test_k0_conventions():
    # Jaky: K0 = 1 - sin phi', sin phi' = 3 M / (6 + M) (triaxial compression); the MCC flow rule's K0 as the
    # one-dimensional compression of the generator's clay reaches it
    assert k0_nc("jaky") == pytest.approx(1.0 - math.sin(math.asin(3 * M / (6 + M))))
    g = KAP * 2 * (1 + NU) / (9 * (1 - 2 * NU))
    eta = brentq(lambda h: h * g + (LAM - KAP) * 2 * h / (M * M - h * h) - 2 * LAM / 3, 1e-9, M - 1e-9)
    assert k0_nc("mcc") == pytest.approx((3 - eta) / (3 + 2 * eta), rel=1e-9)
    point = Point(ElastoplasticClay(M, LAM, KAP, NU), ClayState(50.0, 0.0, 2.2, 50.0, 0.0, 2.2))
    run_stage(point, Control(("strain", 1e-6), ("strain", 0.0), 0.4 / 1e-6))
    assert point.sigma_r / point.sigma_a == pytest.approx(k0_nc("mcc"), rel=2e-3)
    assert k0_nc("given") == 0.55


class Tresca:
    """Elastic-perfectly plastic von Mises with q_y = sqrt(3) s_u (Tresca's s_u in the plane-strain cavity), in the
    cavity solver's material protocol."""

    viscous = False

    def __init__(self, G, s_u, nu=0.3):
        self.G, self.K, self.qy = G, 2 * G * (1 + nu) / (3 * (1 - 2 * nu)), math.sqrt(3.0) * s_u

    def moduli(self, pts):
        return np.full(pts.size.size, self.K), np.full(pts.size.size, self.G)

    def yield_value(self, pts):
        return invariants(pts.sigma)[1] - self.qy

    def gradient(self, pts):
        direction = invariants(pts.sigma)[2]
        zero = np.zeros(len(direction))
        return direction, zero, zero

    def harden(self, pts, dev_p):
        return pts.size


def test_strain_path_cavity_expansion_against_gibson_anderson_and_lame():
    # large strain: p - sigma_h0 = s_u (1 + ln(G/s_u) + ln(dV/V)), dV/V = 1 - (a0/a)^2 (Gibson & Anderson 1961;
    # -> s_u (1 + ln(G/s_u)) as a/a0 grows); elastic: p - sigma_h0 = 2 G (a - a0)/a0 at small strain; the wall
    # pore pressure is the total radial stress less the effective one
    G, su = 2000.0, 20.0
    rows = strain_path_expansion(Tresca(G, su), (100.0, 100.0, 100.0), 1.0, 2.0, 1.0, 50.0, 1e-3, 2.0,
                                 max_strain=2e-3)
    for eps in (0.1, 0.5, 2.0):
        k = np.argmin(np.abs(rows[:, 1] - eps))
        a = 1.0 + rows[k, 1]
        closed = su * (1 + math.log(G / su) + math.log(1 - 1 / a ** 2))
        assert rows[k, 2] - 150.0 == pytest.approx(closed, rel=2e-3)
        assert rows[k, 3] - 50.0 == pytest.approx(rows[k, 2] - 150.0 - su, rel=2e-3)   # sigma'_r = 100 + s_u
    limit = su * (1 + math.log(G / su))
    assert 0.0 < limit - (rows[-1, 2] - 150.0) < 0.025 * limit                     # a = 3 a0: 2.1 % below the limit
    rows = strain_path_expansion(Tresca(G, 1e6), (100.0, 100.0, 100.0), 1.0, 2.0, 1.0, 50.0, 1e-3, 1e-3,
                                 max_strain=1e-4)
    assert rows[-1, 2] - 150.0 == pytest.approx(2 * G * 1e-3, rel=2e-3)
    assert abs(rows[-1, 3] - 50.0) < 1e-2 * 2 * G * 1e-3


#: measured sizes (RMS relative difference of the noise-free records, %) the variants must keep: a few %, not gross
SIZES = {("crs_load", "v_initial", "sigma_v_kPa"): (1.5, 4.0), ("crs_load", "lnv", "sigma_v_kPa"): (1.5, 4.0),
         ("crs_load", "k0_jaky", "sigma_v_kPa"): (0.5, 3.0), ("crs_load", "coarse_explicit", "sigma_v_kPa"): (0.1, 2.0),
         ("ciu", "constant_G", "q_kPa"): (0.5, 3.0), ("ciu", "sparse_log", "q_kPa"): (0.2, 2.0),
         ("crs_load", "reference", "sigma_v_kPa"): (0.0, 0.0)}


@pytest.mark.parametrize("cell", list(SIZES))
def test_each_variant_differs_from_the_reference_by_a_few_percent(cell):
    programme, variant, column = cell
    lo, hi = SIZES[cell]
    assert lo <= 100 * difference(programme, variant)[column] <= hi


def _shipped(case, name):
    rows = [line for line in (DATA / case / f"{name}.csv").read_text().splitlines() if not line.startswith("#")]
    return np.array([[float(x) if x else np.nan for x in line.split(",")] for line in rows[1:]])


def _controls_key():
    return {c: v for c, v in json.loads((DATA / "KEY.json").read_text()).items() if "model_form" in v}


def test_shipped_control_cases_match_the_key_and_name_no_variant():
    key, letters = _controls_key(), case_ids()
    assert sorted(key) == sorted(f"{p}_{letters[p, m]}_s{s}" for p, ms in APPLIES.items() for m in ms
                                 for s in (1, 2, 3))
    effect_cases = {c for c, v in json.loads((DATA / "KEY.json").read_text()).items() if "model_form" not in v}
    assert not effect_cases & set(key)
    words = ("control", "convention", "model_form", "model-form", "variant", "jaky", "explicit", "exact",
             "butterfield", "poisson", "initial specific", "reference") + tuple(CONTROLS)
    for case, truth in key.items():
        assert truth["effect"] == "none" and truth["model_form"] in CONTROLS
        study_text = (DATA / case / "study.toml").read_text()
        study = tomllib.loads(study_text)
        assert study["model"]["name"] == "ModifiedCamClay"
        for t in study["tests"]:
            text = (DATA / case / t["file"]).read_text().lower()
            assert "synthetic (independent generator)" in text
            assert not any(w.lower() in text or w.lower() in study_text.lower() for w in words), (case, t["file"])


@pytest.mark.parametrize("programme,variant,seed,test_index", [("crs_ur", "v_initial", 2, 0),
                                                               ("ciu", "constant_G", 3, 2),
                                                               ("il", "sparse_log", 1, 0)])
def test_shipped_control_records_regenerate(programme, variant, seed, test_index):
    from validation.independent.controls import _tests
    case = f"{programme}_{case_ids()[programme, variant]}_s{seed}"
    rec = records(programme, variant, seed, test_index)
    shipped = _shipped(case, _tests(programme)[test_index].name)
    assert shipped.shape == (len(rec["stage"]), len(rec))
    for j, column in enumerate(rec):
        np.testing.assert_allclose(shipped[:, j], rec[column], rtol=2e-4, atol=1e-3, equal_nan=True)


@pytest.mark.slow
def test_written_controls_are_byte_identical_to_the_shipped_ones(tmp_path):
    key = write_controls(tmp_path)
    for case in key:
        for path in (tmp_path / case).iterdir():
            assert path.read_bytes() == (DATA / case / path.name).read_bytes(), (case, path.name)


def test_confusion_selects_the_model_form_controls_and_tabulates_them_on_their_own(tmp_path):
    from validation.independent.confusion import case_order, load_key, outcome, write_tables
    key = load_key(DATA)
    forms = case_order(key, controls="model-form")
    effects = case_order(key)
    assert sorted(forms) == sorted(_controls_key()) and not set(forms) & set(effects)
    assert sorted(case_order(key, controls="all")) == sorted(forms + effects)
    rows = [outcome(case, key[case], tmp_path) for case in forms[:3] + effects[:2]]
    write_tables(rows, tmp_path, {"written": "now"})
    text = (tmp_path / "confusion.md").read_text()
    assert f"none ({key[forms[0]]['model_form']})" in text and "model-form controls clean 0/0" in text
