"""Draws on which the base model cannot follow the programme (Modified Cam Clay with M below the stress ratio
eta = 3 (1 - K0)/(1 + 2 K0) = 0.75 of a K0 = 0.5 consolidation path: its integration fails) count as zero likelihood
with their reason (cases.study.routes.dispatch, cases.study.outputs.calibration_warnings): the study's calibration
goes on with a warning; only when every draw fails does it stop, with exit status 2 and the reasons on one line."""
from __future__ import annotations

import json

from corpus_inputs import LAB_TOML

from cases import calibrate

#: the corpus's Modified Cam Clay study (tests/corpus_inputs.py) with ocr = 1, M free, and a K0 programme
STUDY = LAB_TOML[: LAB_TOML.index("[[tests]]")].replace(
    'M = [0.8, 1.8]\nocr = { bounds = [1.0, 4.0], prior = "log-uniform" }', "M = PRIOR").replace(
    "nu = 0.3", "nu = 0.3\nocr = 1.0") + """
[sampler.quick]
samples = 16
max_steps = 2
predictive_draws = 4
[[tests]]
name = "CK0D"
file = "t.csv"
apparatus = "triaxial"
initial = { e0 = 1.0, sigma_v0 = 50.0, K0 = 0.5 }
stages = [{ kind = "consolidation", sigma_v = 200.0, K0 = 0.5, duration = 3600.0 },
          { kind = "shear", drainage = "drained", strain_rate = 1e-5, to_axial_strain = 4.0 }]
"""
RECORDS = """stage,sigma_v_kPa,void_ratio,axial_strain_pct,q_kPa
1,100,0.95,,
1,200,0.90,,
2,,,0.5,120
2,,,1.0,140
2,,,4.0,160
"""


def _run(tmp_path, capsys, prior):
    (tmp_path / "t.csv").write_text(RECORDS)
    (tmp_path / "study.toml").write_text(STUDY.replace("PRIOR", prior))
    out = tmp_path / "out"
    status = calibrate.main([str(tmp_path / "study.toml"), "--quick", "--processes", "1", "--out", str(out)])
    return status, capsys.readouterr(), out


def test_draws_the_base_cannot_follow_are_zero_likelihood_with_a_warning(tmp_path, capsys):
    status, printed, out = _run(tmp_path, capsys, "[0.5, 1.5]")
    assert status == 0, printed.err
    failed = [json.loads(line) for line in (out / "failed_solves.jsonl").read_text().splitlines()]
    assert failed and all(f["theta"]["M"] < 0.75 for f in failed)
    assert all("stage consolidation1" in f["reason"] for f in failed)
    warning = [line for line in printed.out.splitlines() + printed.err.splitlines() if "count as zero" in line]
    assert warning and f"{len(failed)} of " in warning[0] and "most frequent reason" in warning[0], printed


def test_a_prior_no_draw_of_which_can_follow_the_programme_stops_with_the_reasons(tmp_path, capsys):
    status, printed, _ = _run(tmp_path, capsys, "[0.5, 0.7]")
    lines = [line for line in printed.err.splitlines() if line.strip()]
    assert status == 2 and len(lines) == 1, printed.err
    assert "stage 0: 16 of 16 forward evaluations failed" in lines[0]
    assert "stage consolidation1" in lines[0] and "'M': 0." in lines[0]
