"""Tests a general-route study predicts but does not calibrate on (``role = "predict"``, docs/reference.md section
10): SYNTHETIC constant-rate-of-strain oedometer tests of the shipped oedometer_crs example's clay (viscous
ANICREEP, 2 % noise) at 0.36 and 3.6 %/h calibrated, a third at 1.1 %/h predicted. Oracle: the records come from the
calibrated model class itself, so the predicted test's 95 % band (parameters, noise, the leave-one-out model error)
holds nearly all its points and its predictive mean lies within the noise of them. And a pressuremeter test predicted
from another (the independent generator's plain clay, SYNTHETIC)."""
import json
import math
from pathlib import Path

import pytest

from cases import calibrate as cal
from cases.study.synthetic.generate import generate

ROOT = Path(__file__).resolve().parents[4]
EXAMPLES = ROOT / "cases" / "examples"
SBP_PAIR = ROOT / "validation" / "data" / "independent" / "sbp_B_s1"
MID = ('\n[[tests]]\nname = "CRS_mid"\nrole = "predict"\nfile = "data/oedometer_crs_mid.csv"\n'
       'type = "oedometer_crs"\nsigma_v0 = 20.0\nK0 = 0.6\nstrain_rate = 3.0e-6\n')


def test_a_predicted_crs_test_is_scored_with_its_band(tmp_path):
    study = tmp_path / "crs.toml"
    study.write_text((EXAMPLES / "oedometer_crs.toml").read_text() + MID)
    generate(study)
    out = tmp_path / "out"
    assert cal.main([str(study), "--quick", "--processes", "1", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["calibration_tests"] == ["CRS_slow", "CRS_fast"] and summary["predicted_tests"] == ["CRS_mid"]
    assert set(summary["J_g_at_map"]) == {"CRS_slow", "CRS_fast"}   # the predicted test is not calibrated on
    (row,) = summary["predictions"]["curves"]
    assert row["test"] == "CRS_mid" and row["model"]["coverage"] >= 0.85 and row["point_error"] < 0.04
    assert {c["test"] for c in summary["predictions"]["leave_one_out"]} == {"CRS_slow", "CRS_fast"}
    # (P2) by hand: the rates are the only condition that differs; ln rate scaled by its range ln 10, each left-out
    # test 1 from the other, the predicted one log10(3) from the slow test: a^2 = excess d / d_k
    error = summary["predictions"]["model_error"]
    assert list(error["distance"].values()) == [pytest.approx(1.0)]
    (excess,) = error["excess_variance"].values()
    assert row["distance"] == pytest.approx(math.log10(3.0))
    assert row["amplitude"] == pytest.approx(math.sqrt(excess * math.log10(3.0)))
    assert all((out / "leave_one_out" / t / "progress.log").is_file() for t in ("CRS_slow", "CRS_fast"))
    report = (out / "report.md").read_text()
    assert "## Predictions" in report and "| CRS_mid |" in report and (out / "predictions.png").is_file()


@pytest.mark.slow
def test_a_predicted_pressuremeter_test_is_scored_and_says_why_it_has_no_model_error(tmp_path):
    """The independent generator's plain clay (sbp_B_s1: expansion to 10 % cavity strain and a 1-hour hold at 1 and
    at 0.1 %/min; its own 1-D coupled solver, 1.5 % noise): calibrated on the fast test through the FE, the slow one
    predicted. Modified Cam Clay is the generator's clay, so the band holds nearly every pressure and the mean lies
    within the noise; with one calibration test no leave-one-out amplitude exists and the report says so."""
    text = (SBP_PAIR / "study.toml").read_text().replace('file = "SBP_', f'file = "{SBP_PAIR.as_posix()}/SBP_')
    study = tmp_path / "sbp.toml"
    study.write_text(text.replace('name = "SBP_slow"\n', 'name = "SBP_slow"\nrole = "predict"\n'))
    out = tmp_path / "out"
    assert cal.main([str(study), "--quick", "--processes", "1", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["calibration_tests"] == ["SBP_fast"] and summary["predicted_tests"] == ["SBP_slow"]
    rows = summary["predictions"]["curves"]
    assert {r["curve"] for r in rows} == {"cavity_pressure@expansion1", "pore_pressure@expansion1",
                                          "cavity_pressure@hold2", "pore_pressure@hold2"}
    for row in rows:
        assert row["test"] == "SBP_slow" and row["amplitude"] == 0.0
        assert row["noise"]["coverage"] >= 0.85 and row["point_error"] < 0.03
    assert summary["predictions"]["leave_one_out"] == []
    assert "needs at least two calibration tests" in (out / "report.md").read_text()
