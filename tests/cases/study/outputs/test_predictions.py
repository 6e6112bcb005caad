"""The Predictions of a study (cases.study.outputs.predictions; docs/reference.md section 10, (P1)-(P4)) on a
posterior without parameter spread, where the band of (P1) is a normal's: U (1 +- z sqrt(sigma^2 + a^2)), and the
coverage, interval score and CRPS follow in closed form."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

import inference
from cases.study.outputs.predictions import prediction_lines, score_predictions
from inference.prediction import ModelError

X = np.linspace(0.5, 10.0, 40)
U = 100.0 + 10.0 * X                                   # kPa, the simulated curve at a = 1
OFFSETS = np.resize([0.0, 0.05, -0.07, 0.09, -0.12, 0.2, -0.01, 0.03], X.size)   # relative errors of the records


def _study():
    y = U * (1.0 + OFFSETS)
    obs = inference.Observations([inference.Test("held_out", {"q": inference.Curve(X, y, "eps_a", "q", "pct",
                                                                                   "kPa")})])
    like = inference.Likelihood(obs, lambda p: {"held_out": {"q": p["a"] * U}}, sigma="sigma_eps", floor=0.0)
    post = SimpleNamespace(samples=np.tile([1.0, 0.03], (50, 1)), names=("a", "sigma_eps"))
    return like, post, y


def test_bands_and_scores_are_the_normal_closed_form():
    like, post, y = _study()
    (row,) = score_predictions(like, post, ["held_out"], {("held_out", "q"): 0.04})
    z = stats.norm.ppf(0.975)
    for label, sd in (("noise", 0.03), ("model", math.hypot(0.03, 0.04))):
        band = row[label]
        assert band["lower"] == pytest.approx(U * (1 - z * sd), rel=1e-7)
        assert band["upper"] == pytest.approx(U * (1 + z * sd), rel=1e-7)
        inside = np.abs(OFFSETS) <= z * sd
        assert band["coverage"] == pytest.approx(inside.mean())
        assert band["mean_width"] == pytest.approx(np.mean(2 * z * sd * U), rel=1e-7)
        excess = np.maximum(np.abs(y - U) - z * sd * U, 0.0)
        assert band["interval_score"] == pytest.approx(np.mean(2 * z * sd * U + 2 / 0.05 * excess), rel=1e-6)
        s = sd * U
        w = (y - U) / s
        crps = s * (w * (2 * stats.norm.cdf(w) - 1) + 2 * stats.norm.pdf(w) - 1 / math.sqrt(math.pi))
        assert band["crps"] == pytest.approx(crps.mean(), rel=1e-9)
    assert row["point_error"] == pytest.approx(np.sqrt(np.mean((OFFSETS / (1 + OFFSETS)) ** 2)), rel=1e-9)
    assert row["amplitude"] == 0.04
    error = ModelError({"q": 0.04**2}, {"q": 0.8})
    row["distance"] = 0.8
    text = "\n".join(prediction_lines([row], error, []))
    assert "## Predictions" in text and "q 4.00 % at d_k = 0.80" in text
    assert f"| held_out | q (kPa) | {X.size} | 0.80 | 4.00 % | {100 * row['noise']['coverage']:.0f} % |" in text
    assert "With two calibration tests" not in text
    two = [{"test": t, "curve": "q", "distance": 0.8, "coverage_noise": 0.5, "coverage_model": 0.9,
            "amplitude": 0.04} for t in "AB"]
    assert "With two calibration tests each leave-one-out calibration has one test" in \
        "\n".join(prediction_lines([row], error, two))
    assert "With two calibration tests" not in "\n".join(prediction_lines([row], error, two + [
        {**two[0], "test": "C"}]))
