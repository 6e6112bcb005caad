"""An example study's recordings re-saved as a spreadsheet in a comma-decimal locale saves them (';' separators,
decimal commas, ``name (unit)`` headers with blanks, byte-order mark, CRLF) load to exactly the same arrays, hence the
same likelihood (and, slow, the same ln Z of a small fixed-seed run); option values written with a unit are refused
naming the unit expected, one line, exit status 2."""
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cases.study.cli import UsageError
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from cases.study.routes import sand as sand_route

ROOT = Path(__file__).resolve().parents[4]
EXAMPLES = ROOT / "cases" / "examples"
SUFFIX = re.compile(r"^(.*)_(pct|kPa|MPa|s)$")


def spreadsheet_text(text: str) -> str:
    """A recording CSV as a comma-decimal spreadsheet saves it: ``axial strain (%);q (kPa);...``, ``0,5;40,25``."""
    lines, header_done = [], False
    for line in text.splitlines():
        if line.startswith("#"):
            lines.append(line)
        elif not header_done:
            cells = []
            for name in line.split(","):
                m = SUFFIX.match(name)
                base, unit = (m.group(1), {"pct": "%"}.get(m.group(2), m.group(2))) if m else (name, None)
                cells.append(base.replace("_", " ") + (f" ({unit})" if unit else ""))
            lines.append(";".join(cells))
            header_done = True
        else:
            lines.append(";".join(c.replace(".", ",") if _number(c) else c for c in line.split(",")))
    return "\r\n".join(lines) + "\r\n"


def _number(cell):
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _resaved_study(tmp_path, example):
    """A copy of ``example`` (a study file) whose CSVs are re-saved by :func:`spreadsheet_text`."""
    study = load_study(EXAMPLES / example)
    text = (EXAMPLES / example).read_text()
    for test in study.tests:
        original = test.file.read_text()
        copy = tmp_path / test.file.name
        copy.write_bytes(b"\xef\xbb\xbf" + spreadsheet_text(original).encode())
        assert ";" in copy.read_text() and original != copy.read_text()
        text = text.replace(f'"{test.file.relative_to(EXAMPLES).as_posix()}"', f'"{copy.name}"')
    path = tmp_path / example
    path.write_text(text)
    return path


@pytest.mark.parametrize("example", ["triaxial_undrained.toml", "ciu_ocr.toml", "oedometer_crs.toml", "sbp.toml"])
def test_resaved_recordings_give_the_same_arrays(tmp_path, example):
    original = load_study(EXAMPLES / example)
    resaved = load_study(_resaved_study(tmp_path, example))
    assert all(t.file.parent == tmp_path for t in resaved.tests)
    obs, times = load_observations(original.tests)
    obs_r, times_r = load_observations(resaved.tests)
    assert obs_r.fingerprint() == obs.fingerprint()
    for test in obs:
        assert list(obs_r[test.name].curves) == list(test.curves)
        for name, curve in test.curves.items():
            assert np.array_equal(obs_r[test.name].curves[name].x, curve.x)
            assert np.array_equal(obs_r[test.name].curves[name].y, curve.y)
        _same(times_r[test.name], times[test.name])


def _same(a, b):
    """``a`` and ``b`` equal to the bit: None, arrays and numbers, and tuples, lists or dicts of them."""
    assert type(a) is type(b)
    if isinstance(a, dict):
        assert list(a) == list(b)
        for k in a:
            _same(a[k], b[k])
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _same(x, y)
    elif a is not None:
        assert np.array_equal(a, b, equal_nan=True)


def test_resaved_recordings_give_the_same_likelihood(tmp_path):
    values = []
    for path in (EXAMPLES / "triaxial_undrained.toml", _resaved_study(tmp_path, "triaxial_undrained.toml")):
        study = load_study(path)
        obs, times = load_observations(study.tests)
        problem = StudyProblem(study, obs, times, quick=True)
        prior = problem.prior(study.free, study.log_uniform)
        like = problem.make_likelihood(obs, study.switches)
        like.bind(prior.names)
        theta = [0.5 * (b.lower + b.upper) for b in prior.bounds]
        values.append(like.evaluate_many([theta])[0][0])
    assert np.isfinite(values[0]) and values[1] == values[0]


def _run(args, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", *map(str, args)], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_resaved_recordings_give_the_same_evidence(tmp_path):
    """``cases.calibrate`` on the example and on its re-saved copy: equal ln Z (summary.json), 16 particles, seed 3."""
    evidence = []
    for name, path in (("original", EXAMPLES / "triaxial_undrained.toml"),
                       ("resaved", _resaved_study(tmp_path, "triaxial_undrained.toml"))):
        out = tmp_path / name
        done = _run(["cases.calibrate", path, "--quick", "--samples", "16", "--seed", "3", "--processes", "1",
                     "--out", out], tmp_path)
        assert done.returncode == 0, done.stderr
        evidence.append(json.loads((out / "summary.json").read_text())["log_evidence"])
    assert evidence[1] == evidence[0]


def test_a_rate_in_percent_is_refused_naming_1_per_s_from_the_command_line(tmp_path):
    done = _run(["cases.burswood_sbp", "--rates", "fast=0.167%"], tmp_path)
    assert done.returncode == 2
    assert done.stderr == ("error: --rates fast=0.167%: give the cavity strain rate as a number in 1/s (0.167 %/s = "
                           "0.00167 1/s: write 0.00167)\n")


@pytest.mark.parametrize("spec, message", [
    ("f.csv:0.735:100kPa", "--undrained f.csv:0.735:100kPa: give the p'0 P0_KPA as a number in kPa (100 kPa = 100 kPa: "
                           "write 100)"),
    ("f.csv:0.735:0.1MPa", "--undrained f.csv:0.735:0.1MPa: give the p'0 P0_KPA as a number in kPa (0.1 MPa = 100 "
                           "kPa: write 100)"),
    ("f.csv:73.5%:100", "--undrained f.csv:73.5%:100: give the initial void ratio E0 as a plain number (73.5 % = "
                        "0.735: write 0.735)"),
])
def test_toyoura_undrained_conditions_with_a_unit_name_the_unit_expected(spec, message):
    with pytest.raises(UsageError) as err:
        sand_route.parse_undrained(spec)
    assert str(err.value) == message


def test_spreadsheet_text_is_what_a_spreadsheet_writes():
    text = spreadsheet_text("# t: 1\naxial_strain_pct,q_kPa,void_ratio,stage\n0.5,40.25,1,shear.1\n")
    assert text == "# t: 1\r\naxial strain (%);q (kPa);void ratio;stage\r\n0,5;40,25;1;shear.1\r\n"
