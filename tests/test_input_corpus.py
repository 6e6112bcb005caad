"""Every bad input is refused clearly, before any solve: a corpus of bad recording CSVs, study files, command lines
and checkpoints given to both entry points (``cases.calibrate STUDY`` and ``cases.burswood_sbp --recordings``). Each
must give exit status 2 and one line on stderr naming the file, field or option and the value, no traceback and
nothing written in --out. Valid variants (CRLF, MPa, quoted numbers, bracket units, byte-order mark) load to the same
values as the plain file. Most cases run in-process through the commands' ``main(argv)``; a handful run as real
subprocesses (a crafted pickle checkpoint that tries to run code among them)."""
import json
import os
import pickle
import shutil
import socket
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import inference
from cases import burswood_sbp, calibrate, simsand_synthetic, toyoura
from cases.study import runner
from cases.study.cli import command
from cases.study.problem import StudyProblem
from cases.study.records import load_observations, load_sbp_recordings
from cases.study.schema import load_study

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "cases" / "examples"

# ------------------------------------------------------------------------------------------------ valid inputs
LAB_CSV = """# a small drained test
axial_strain_pct,q_kPa,void_ratio
0.5,40,0.99
1.0,70,0.98
2.0,95,0.97
4.0,110,0.96
"""
LAB_TOML = """name = "mini"

[model]
name = "ModifiedCamClay"

[model.fixed]
lambda_ = 0.2
kappa = 0.04
nu = 0.3

[model.free]
M = [0.8, 1.8]
ocr = { bounds = [1.0, 4.0], prior = "log-uniform" }

[sigma_eps]
bounds = [0.001, 0.3]

[[tests]]
name = "T1"
file = "t1.csv"
type = "triaxial"
drainage = "drained"
direction = "compression"
consolidation = "isotropic"
p0 = 100.0
e0 = 1.0
strain_rate = 1e-5
"""
SBP_CSV = """# a pressuremeter record
cavity_strain_pct,cavity_pressure_kPa,pore_pressure_kPa,time_s
1.0,100,40,6
2.0,120,42,12
4.0,140,45,24
"""


def _lab(tmp_path, toml=LAB_TOML, csv=LAB_CSV):
    """A lab study folder: study.toml and t1.csv (text or bytes)."""
    (tmp_path / "t1.csv").write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    (tmp_path / "study.toml").write_bytes(toml if isinstance(toml, bytes) else toml.encode())
    return tmp_path / "study.toml"


def _sbp_study(tmp_path, csv=SBP_CSV, edit=lambda t: t):
    """The shipped SBP example study with its record replaced by ``csv``; ``edit`` changes the TOML text."""
    (tmp_path / "data").mkdir(exist_ok=True)
    (tmp_path / "data" / "sbp_fast.csv").write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    text = edit((EXAMPLES / "sbp.toml").read_text())
    (tmp_path / "study.toml").write_text(text)
    return tmp_path / "study.toml"


def _status(main, argv):
    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:
        return exc.code


def refused(main, argv, capsys, out, named, keep=()):
    """Run ``main(argv)`` in-process: exit status 2, one line on stderr holding every part of ``named``, no
    traceback, and nothing in ``out`` but the files ``keep``."""
    capsys.readouterr()
    status = _status(main, argv)
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert status == 2, err
    assert "Traceback" not in err and len(lines) == 1, err
    for part in named:
        assert part in lines[0], lines[0]
    left = sorted(p.name for p in out.iterdir()) if out.exists() else []
    assert left == sorted(keep), left


# ------------------------------------------------------------------------------------------------ bad CSVs, lab
def _rows(*rows, header="axial_strain_pct,q_kPa,void_ratio"):
    return header + "\n" + "\n".join(rows) + "\n"


LAB_CSVS = [
    ("latin-1", "# essai à 20 °C\n".encode("latin-1") + LAB_CSV.encode(), ["not UTF-8", "Latin-1", "line 1"]),
    ("utf-16", LAB_CSV.encode("utf-16"), ["not UTF-8", "UTF-16"]),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00", ["not UTF-8", "binary"]),
    ("binary-no-nul", bytes(range(128, 256)) * 4, ["not UTF-8"]),
    ("empty", "", ["no header or no data rows"]),
    ("comments only", "# nothing here\n# really\n", ["no header or no data rows"]),
    ("header only", "axial_strain_pct,q_kPa\n", ["no header or no data rows"]),
    ("same column twice", _rows("0.5,40,40", "1,70,70", header="axial_strain_pct,q_kPa,q_kPa"),
     ["'q_kPa' appears twice"]),
    ("q in kPa and MPa", _rows("0.5,40,0.04", "1,70,0.07", header="axial_strain_pct,q_kPa,q_MPa"),
     ["'q_kPa' and 'q_MPa'", "same quantity 'q'"]),
    ("q suffix and bracket", _rows("0.5,40,0.04", "1,70,0.07", header="axial_strain_pct,q_kPa,q [MPa]"),
     ["'q_kPa' and 'q [MPa]'"]),
    ("strain twice", _rows("0.5,0.5,40", "1,1,70", header="axial_strain_pct,axial_strain [%],q_kPa"),
     ["same quantity 'axial_strain'"]),
    ("unnamed column", _rows("0.5,40,1", "1,70,2", header="axial_strain_pct,q_kPa,"), ["column 3", "no name"]),
    ("semicolons", "axial_strain_pct;q_kPa\n0,5;40\n1,0;70\n", ["separated by ';'"]),
    ("tabs", "axial_strain_pct\tq_kPa\n0.5\t40\n1.0\t70\n", ["separated by tabs"]),
    ("short row", _rows("0.5,40,0.99", "1.0,70"), ["line 3", "2 values for 3 columns"]),
    ("long row", _rows("0.5,40,0.99", "1.0,70,0.98,5"), ["line 3", "4 values for 3 columns"]),
    ("text value", _rows("0.5,40,0.99", "1.0,abc,0.98"), ["line 3", "'q_kPa'", "'abc'"]),
    ("empty cell", _rows("0.5,40,0.99", "1.0,,0.98"), ["line 3", "'q_kPa'", "''"]),
    ("nan", _rows("0.5,40,0.99", "1.0,nan,0.98"), ["line 3", "'nan'", "not a finite number"]),
    ("inf", _rows("0.5,40,0.99", "1.0,inf,0.98"), ["line 3", "'inf'"]),
    ("minus inf", _rows("0.5,40,0.99", "1.0,-inf,0.98"), ["line 3", "'-inf'"]),
    ("decimal comma", _rows('0.5,40,0.99', '"1,0",70,0.98'), ["line 3", "'1,0'"]),
    ("q 1e308", _rows("0.5,40,0.99", "1.0,1e308,0.98"), ["line 3", "'q' in kPa", "1e308", "physical range"]),
    ("q 2e6 kPa", _rows("0.5,40,0.99", "1.0,2e6,0.98"), ["line 3", "2e6", "1e6 kPa"]),
    ("q 5000 MPa", _rows("0.5,0.04,0.99", "1.0,5000,0.98", header="axial_strain_pct,q [MPa],void_ratio"),
     ["line 3", "'q' in MPa", "5000"]),
    ("strain 140 %", _rows("0.5,40,0.99", "140,70,0.98"), ["line 3", "'axial_strain' in pct", "140"]),
    ("strain -200 %", _rows("-200,40,0.99", "1,70,0.98"), ["line 2", "-200"]),
    ("negative strain", _rows("-0.5,40,0.99", "1.0,70,0.98"), ["line 2", "'axial_strain'", "-0.5"]),
    ("strain goes back", _rows("0.5,40,0.99", "0.4,70,0.98"), ["line 3", "0.4", "does not increase"]),
    ("strain repeated", _rows("0.5,40,0.99", "0.5,70,0.98"), ["line 3", "does not increase"]),
    ("void ratio negative", _rows("0.5,40,0.99", "1.0,70,-0.98"), ["line 3", "'void_ratio'", "-0.98"]),
    ("void ratio zero", _rows("0.5,40,0.99", "1.0,70,0"), ["line 3", "'void_ratio'", "must be > 0"]),
    ("time negative", _rows("0.5,40,0.99,-5", "1.0,70,0.98,10", header="axial_strain_pct,q_kPa,void_ratio,time_s"),
     ["line 2", "'time' in s", "-5"]),
    ("time goes back", _rows("0.5,40,0.99,20", "1.0,70,0.98,10", header="axial_strain_pct,q_kPa,void_ratio,time_s"),
     ["line 3", "'time'", "10"]),
    ("unknown column", _rows("0.5,40,1", "1,70,2", header="axial_strain_pct,q_kPa,deviator_kPa"),
     ["column 'deviator'", "known:"]),
    ("typo q_kpa", _rows("0.5,40", "1,70", header="axial_strain_pct,q_kpa"), ["'q_kpa'", "did you mean 'q_kPa'"]),
    ("typo void_ration", _rows("0.5,40,0.99", "1,70,0.98", header="axial_strain_pct,q_kPa,void_ration"),
     ["'void_ration'", "did you mean 'void_ratio'"]),
    ("typo volumetric", _rows("0.5,40,0.1", "1,70,0.2", header="axial_strain_pct,q_kPa,volumetric_strian_pct"),
     ["did you mean 'volumetric_strain_pct'"]),
    ("typo time", _rows("0.5,40,1", "1,70,2", header="axial_strain_pct,q_kPa,tim_s"), ["did you mean 'time_s'"]),
    ("upper case", _rows("0.5,40", "1,70", header="AXIAL_STRAIN_PCT,q_kPa"), ["did you mean 'axial_strain_pct'"]),
    ("strain without unit", _rows("0.005,40", "0.01,70", header="axial_strain,q_kPa"),
     ["'axial_strain'", "unit '-'", "expected '%'"]),
    ("unit psi", _rows("0.5,4", "1,7", header="axial_strain_pct,q [psi]"), ["column 'q'", "unit 'psi'"]),
    ("stress in seconds", _rows("0.5,40", "1,70", header="axial_strain_pct,q_s"), ["column 'q'", "unit 's'"]),
    ("pore pressure in a drained test", _rows("0.5,40,5", "1,70,6", header="axial_strain_pct,q_kPa,"
                                              "excess_pore_pressure_kPa"), ["'excess_pore_pressure'", "drained"]),
    ("missing q", _rows("0.5,0.99", "1,0.98", header="axial_strain_pct,void_ratio"), ["missing column 'q'"]),
    ("missing strain", _rows("40,0.99", "70,0.98", header="q_kPa,void_ratio"), ["missing column 'axial_strain'"]),
    ("numbers as header", _rows("0.5,40", "1,70", header="0.1,20"), ["column '0.1'"]),
    ("volumetric 150 %", _rows("0.5,40,0.1", "1,70,150", header="axial_strain_pct,q_kPa,volumetric_strain_pct"),
     ["line 3", "150"]),
    ("quoted text", _rows('0.5,40,0.99', '1.0,"12a",0.98'), ["line 3", "'12a'"]),
    ("p zero", _rows("0.5,40,0", "1,70,100", header="axial_strain_pct,q_kPa,p_kPa"), ["line 2", "'p'", "> 0"]),
]


@pytest.mark.parametrize("csv, named", [c[1:] for c in LAB_CSVS], ids=[c[0] for c in LAB_CSVS])
def test_bad_lab_csv_is_refused_by_calibrate(tmp_path, capsys, csv, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_lab(tmp_path, csv=csv), "--quick", "--out", out], capsys, out, ["t1.csv", *named])


# ------------------------------------------------------------------------------------------------ bad CSVs, SBP
def _sbp(*rows, header="cavity_strain_pct,cavity_pressure_kPa,pore_pressure_kPa"):
    return header + "\n" + "\n".join(rows) + "\n"


SBP_CSVS = [
    ("latin-1", "# pression mesurée\n".encode("latin-1") + SBP_CSV.encode(), ["not UTF-8", "Latin-1"]),
    ("utf-16", SBP_CSV.encode("utf-16"), ["UTF-16"]),
    ("binary", bytes(range(256)), ["not UTF-8", "binary"]),
    ("empty", "", ["no header or no data rows"]),
    ("cavity pressure twice", _sbp("1,100,100", "2,120,120",
                                   header="cavity_strain_pct,cavity_pressure_kPa,cavity_pressure_kPa"),
     ["'cavity_pressure_kPa' appears twice"]),
    ("pressure in kPa and MPa", _sbp("1,100,0.1", "2,120,0.12",
                                     header="cavity_strain_pct,cavity_pressure_kPa,cavity_pressure [MPa]"),
     ["same quantity 'cavity_pressure'"]),
    ("typo pore pressure", _sbp("1,100,40", "2,120,42",
                                header="cavity_strain_pct,cavity_pressure_kPa,pore_presure_kPa"),
     ["'pore_presure'", "did you mean 'pore_pressure_kPa'"]),
    ("typo pore unit", _sbp("1,100,40", "2,120,42", header="cavity_strain_pct,cavity_pressure_kPa,pore_pressure_kpa"),
     ["did you mean 'pore_pressure_kPa'"]),
    ("typo cavity pressure", _sbp("1,100", "2,120", header="cavity_strain_pct,cavity_presure_kPa"),
     ["did you mean 'cavity_pressure_kPa'"]),
    ("unknown u", _sbp("1,100,40", "2,120,42", header="cavity_strain_pct,cavity_pressure_kPa,u_kPa"),
     ["column 'u'", "known:"]),
    ("strain 15 %", _sbp("1,100,40", "15,120,42"), ["line 3", "'cavity_strain'", "15", "10 %"]),
    ("strain negative", _sbp("-1,100,40", "2,120,42"), ["line 2", "-1"]),
    ("strain goes back", _sbp("2,100,40", "1,120,42"), ["line 3", "does not increase"]),
    ("pressure negative", _sbp("1,100,40", "2,-120,42"), ["line 3", "'cavity_pressure'", "-120"]),
    ("pressure 1e308", _sbp("1,100,40", "2,1e308,42"), ["line 3", "1e308", "physical range"]),
    ("pore pressure 5e6", _sbp("1,100,40", "2,120,5e6"), ["line 3", "'pore_pressure' in kPa", "5e6"]),
    ("nan", _sbp("1,100,40", "2,NaN,42"), ["line 3", "'NaN'"]),
    ("text", _sbp("1,100,40", "2,high,42"), ["line 3", "'high'"]),
    ("missing pressure", _sbp("1,40", "2,42", header="cavity_strain_pct,pore_pressure_kPa"),
     ["missing column 'cavity_pressure'"]),
    ("strain without unit", _sbp("0.01,100", "0.02,120", header="cavity_strain,cavity_pressure_kPa"),
     ["'cavity_strain'", "unit '-'"]),
    ("unit psi", _sbp("1,14", "2,17", header="cavity_strain_pct,cavity_pressure [psi]"), ["unit 'psi'"]),
    ("row length", _sbp("1,100,40", "2,120"), ["line 3", "2 values for 3 columns"]),
    ("semicolons", "cavity_strain_pct;cavity_pressure_kPa\n1;100\n2;120\n", ["separated by ';'"]),
    ("time negative", _sbp("1,100,-6", "2,120,12", header="cavity_strain_pct,cavity_pressure_kPa,time_s"),
     ["line 2", "'time' in s", "-6"]),
]


@pytest.mark.parametrize("csv, named", [c[1:] for c in SBP_CSVS], ids=[c[0] for c in SBP_CSVS])
def test_bad_sbp_csv_is_refused_by_burswood_recordings(tmp_path, capsys, csv, named):
    path = tmp_path / "fast.csv"
    path.write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    out = tmp_path / "out"
    refused(burswood_sbp.main, ["--quick", "--processes", "1", "--recordings", f"fast={path}", "--out", out],
            capsys, out, ["fast.csv", *named])


@pytest.mark.parametrize("csv, named", [c[1:] for c in SBP_CSVS], ids=[c[0] for c in SBP_CSVS])
def test_bad_sbp_csv_is_refused_by_a_calibrate_study(tmp_path, capsys, csv, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_sbp_study(tmp_path, csv), "--quick", "--out", out], capsys, out,
            ["sbp_fast.csv", *named])


# ------------------------------------------------------------------------------------------------ bad study files
def _edit(old, new):
    def edit(text):
        assert old in text, old
        return text.replace(old, new)
    return edit


LAB_TOMLS = [
    ("not toml", lambda t: "[model\nname = 1", ["not valid TOML"]),
    ("latin-1 toml", lambda t: ("# étude\n" + t).encode("latin-1"), ["line 1", "not UTF-8"]),
    ("binary toml", lambda t: b"\x00\x01\x02\xff\xfe", ["not UTF-8"]),
    ("no model", lambda t: t.replace("[model]\nname", "[modle]\nname"), ["modle", "unknown field"]),
    ("unknown model", _edit('name = "ModifiedCamClay"', 'name = "CamClay"'), ["model.name", "'CamClay'"]),
    ("model name a number", _edit('name = "ModifiedCamClay"', "name = 3"), ["model.name", "3"]),
    ("empty free", lambda t: t.replace('M = [0.8, 1.8]\nocr = { bounds = [1.0, 4.0], prior = "log-uniform" }\n',
                                       "M = 1.2\nocr = 2.0\n").replace("[model.free]\n", "[model.free]\n[x]\n"),
     ["x", "unknown field"]),
    ("bounds reversed", _edit("M = [0.8, 1.8]", "M = [1.8, 0.8]"), ["model.free.M", "[1.8, 0.8]"]),
    ("bounds text", _edit("M = [0.8, 1.8]", 'M = ["low", 1.8]'), ["model.free.M", "low"]),
    ("bounds nan", _edit("M = [0.8, 1.8]", "M = [nan, 1.8]"), ["model.free.M", "nan"]),
    ("bounds inf", _edit("M = [0.8, 1.8]", "M = [0.8, inf]"), ["model.free.M", "inf"]),
    ("bounds three", _edit("M = [0.8, 1.8]", "M = [0.8, 1.2, 1.8]"), ["model.free.M", "[0.8, 1.2, 1.8]"]),
    ("log-uniform from 0", _edit("bounds = [1.0, 4.0]", "bounds = [0.0, 4.0]"), ["model.free.ocr.bounds"]),
    ("prior normal", _edit('prior = "log-uniform"', 'prior = "normal"'), ["model.free.ocr.prior", "'normal'"]),
    ("nu 0.6", _edit("nu = 0.3", "nu = 0.6"), ["[model.fixed]", "0.6"]),
    ("lambda below kappa", _edit("lambda_ = 0.2", "lambda_ = 0.03"), ["kappa", "lambda_"]),
    ("fixed text", _edit("nu = 0.3", 'nu = "0.3"'), ["model.fixed.nu", "'0.3'"]),
    ("unknown parameter", _edit("M = [0.8, 1.8]", "M = [0.8, 1.8]\nphi = [20, 40]"), ["model.free.phi"]),
    ("fixed and free", _edit("nu = 0.3\n", "nu = 0.3\nM = 1.2\n"), ["model.free.M"]),
    ("sigma_eps negative", _edit("bounds = [0.001, 0.3]", "bounds = [-0.1, 0.3]"), ["sigma_eps.bounds", "-0.1"]),
    ("sigma_eps in model", _edit("M = [0.8, 1.8]", "M = [0.8, 1.8]\nsigma_eps = [0.01, 0.2]"),
     ["model.free.sigma_eps"]),
    ("samples 2", _edit("[sigma_eps]", "[sampler]\nsamples = 2\n\n[sigma_eps]"), ["sampler.samples", "2"]),
    ("samples text", _edit("[sigma_eps]", '[sampler]\nsamples = "many"\n\n[sigma_eps]'), ["sampler.samples", "many"]),
    ("max_steps 0", _edit("[sigma_eps]", "[sampler.quick]\nmax_steps = 0\n\n[sigma_eps]"),
     ["sampler.quick.max_steps", "0"]),
    ("radial cells 0", _edit("[sigma_eps]", "[fe]\nradial_cells = 0\n\n[sigma_eps]"), ["fe.radial_cells", "0"]),
    ("increments -5", _edit("[sigma_eps]", "[fe]\nincrements = -5\n\n[sigma_eps]"), ["fe.increments", "-5"]),
    ("layers 1.5", _edit("[sigma_eps]", "[fe]\nlayers = 1.5\n\n[sigma_eps]"), ["fe.layers", "1.5"]),
    ("outer open", _edit("[sigma_eps]", '[fe]\nouter = "open"\n\n[sigma_eps]'), ["fe.outer", "'open'"]),
    ("quick outer radius 0.5", _edit("[sigma_eps]", "[fe.quick]\nouter_radius_a0 = 0.5\n\n[sigma_eps]"),
     ["fe.quick.outer_radius_a0", "0.5", "outside the probe"]),
    ("outer radius 1", _edit("[sigma_eps]", "[fe]\nouter_radius_a0 = 1\n\n[sigma_eps]"),
     ["fe.outer_radius_a0", "1"]),
    ("fe unknown field", _edit("[sigma_eps]", "[fe]\ncells = 10\n\n[sigma_eps]"), ["fe.cells"]),
    ("no tests", lambda t: "tests = []\n" + t[: t.index("[[tests]]")], ["tests = []"]),
    ("unknown type", _edit('type = "triaxial"', 'type = "triax"'), ["tests[0].type", "'triax'"]),
    ("missing file", _edit('file = "t1.csv"', 'file = "nope.csv"'), ["tests[0].file", "'nope.csv'"]),
    ("file is a folder", _edit('file = "t1.csv"', 'file = "."'), ["tests[0].file", "'.'"]),
    ("strain rate 0", _edit("strain_rate = 1e-5", "strain_rate = 0.0"), ["tests[0].strain_rate", "0.0"]),
    ("strain rate negative", _edit("strain_rate = 1e-5", "strain_rate = -1e-5"), ["tests[0].strain_rate", "-1e-05"]),
    ("p0 zero", _edit("p0 = 100.0", "p0 = 0.0"), ["tests[0].p0", "0.0"]),
    ("p0 negative", _edit("p0 = 100.0", "p0 = -100.0"), ["tests[0].p0", "-100.0"]),
    ("field typo", _edit("strain_rate = 1e-5", "straln_rate = 1e-5"), ["tests[0].straln_rate"]),
    ("drainage", _edit('drainage = "drained"', 'drainage = "partly"'), ["tests[0].drainage", "'partly'"]),
    ("same test name", lambda t: t + t[t.index("[[tests]]"):], ["tests[1].name", "'T1'"]),
    ("e0 missing", _edit("e0 = 1.0\n", ""), ["tests[0].e0", "missing"]),
    ("K0 with isotropic", _edit("p0 = 100.0", "p0 = 100.0\nK0 = 0.5"), ["tests[0].K0", "0.5"]),
    ("curves", _edit("strain_rate = 1e-5", 'strain_rate = 1e-5\ncurves = ["q", "u"]'), ["tests[0].curves"]),
    ("synthetic field", lambda t: t + "\n[synthetic]\nnoize = 0.1\n", ["synthetic.noize"]),
]


@pytest.mark.parametrize("edit, named", [c[1:] for c in LAB_TOMLS], ids=[c[0] for c in LAB_TOMLS])
def test_bad_study_file_is_refused(tmp_path, capsys, edit, named):
    out = tmp_path / "out"
    path = _lab(tmp_path, toml=edit(LAB_TOML))
    refused(calibrate.main, [path, "--quick", "--out", out], capsys, out, ["study.toml", *named])


SBP_TOMLS = [
    ("sbp strain rate 0", _edit("strain_rate = 0.00167", "strain_rate = 0.0"), ["tests[0].strain_rate"]),
    ("sbp probe radius", _edit("probe_radius = 0.0415", "probe_radius = 0"), ["tests[0].probe_radius"]),
    ("sbp quick outer radius", _edit("[fe.quick]\nradial_cells = 20\nlayers = 1\nincrements = 20\nouter = \"field\"\n"
                                     "outer_radius_a0 = 200.0", "[fe.quick]\nouter_radius_a0 = 0.5"),
     ["fe.quick.outer_radius_a0", "0.5"]),
    ("sbp increments 0", _edit("increments = 40", "increments = 0"), ["fe.increments", "0"]),
    ("sbp radial cells -1", _edit("radial_cells = 20", "radial_cells = -1"), ["fe.quick.radial_cells", "-1"]),
    ("sbp permeability", _edit("permeability = 3.3e-9", "permeability = -3.3e-9"), ["tests[0].permeability"]),
    ("sbp with MCC", _edit('name = "ANICREEP"', 'name = "SIMSAND"'), ["SIMSAND"]),
]


@pytest.mark.parametrize("edit, named", [c[1:] for c in SBP_TOMLS], ids=[c[0] for c in SBP_TOMLS])
def test_bad_sbp_study_file_is_refused(tmp_path, capsys, edit, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_sbp_study(tmp_path, edit=edit), "--quick", "--out", out], capsys, out,
            ["study.toml", *named])


# ------------------------------------------------------------------------------------------------ bad command lines
CALIBRATE_ARGS = [
    ("seed -1", ["--seed", "-1"], ["--seed", "'-1'"]),
    ("seed text", ["--seed", "one"], ["--seed", "'one'"]),
    ("samples 2", ["--samples", "2"], ["--samples", "'2'"]),
    ("runs 0", ["--runs", "0"], ["--runs", "'0'"]),
    ("processes 0", ["--processes", "0"], ["--processes", "'0'"]),
    ("method", ["--method", "mh"], ["--method", "'mh'"]),
    ("dispatch", ["--dispatch", "fast"], ["--dispatch", "'fast'"]),
    ("noise negative", ["--generate", "--noise", "-0.1"], ["--noise", "'-0.1'"]),
    ("noise nan", ["--generate", "--noise", "nan"], ["--noise", "'nan'"]),
    ("unknown option", ["--sampels", "8"], ["--sampels"]),
    ("generate without synthetic", ["--generate"], ["study.toml", "synthetic.parameters"]),
]


@pytest.mark.parametrize("extra, named", [c[1:] for c in CALIBRATE_ARGS], ids=[c[0] for c in CALIBRATE_ARGS])
def test_bad_calibrate_command_line_is_refused(tmp_path, capsys, extra, named):
    out = tmp_path / "out"
    refused(calibrate.main, [_lab(tmp_path), "--quick", "--out", out, *extra], capsys, out, named)


def test_calibrate_without_a_study_and_with_a_folder_as_study(tmp_path, capsys):
    out = tmp_path / "out"
    refused(calibrate.main, ["--quick", "--out", out], capsys, out, ["study"])
    refused(calibrate.main, [tmp_path, "--quick", "--out", out], capsys, out, [str(tmp_path), "not a file"])
    refused(calibrate.main, [tmp_path / "none.toml", "--out", out], capsys, out, ["none.toml", "not found"])


@pytest.mark.parametrize("entry", ["calibrate", "burswood"])
@pytest.mark.parametrize("where", ["file", "under a file"])
def test_out_naming_an_existing_file_is_refused(tmp_path, capsys, entry, where):
    existing = tmp_path / "taken"
    existing.write_text("mine")
    out = existing if where == "file" else existing / "run"
    argv = ([_lab(tmp_path), "--quick"] if entry == "calibrate" else ["--quick", "--recordings",
                                                                      f"fast={_sbp_file(tmp_path)}"])
    refused(_MAINS[entry], [*argv, "--out", out], capsys, tmp_path / "no-out", ["--out", "taken"])
    assert existing.read_text() == "mine"


def _sbp_file(tmp_path, text=SBP_CSV):
    path = tmp_path / "fast.csv"
    path.write_text(text)
    return path


_MAINS = {"calibrate": calibrate.main, "burswood": burswood_sbp.main}

BURSWOOD_ARGS = [
    ("recordings without =", ["--recordings", "{f}"], ["--recordings", "NAME=VALUE"]),
    ("recordings without name", ["--recordings", "={f}"], ["--recordings", "NAME=VALUE"]),
    ("recordings twice", ["--recordings", "fast={f}", "fast={f}"], ["--recordings", "'fast' is given twice"]),
    ("recordings no rate", ["--recordings", "deep={f}"], ["--recordings", "deep", "--rates"]),
    ("recordings missing file", ["--recordings", "fast={d}/none.csv"], ["none.csv", "not found"]),
    ("recordings a folder", ["--recordings", "fast={d}"], ["not a file"]),
    ("rate 0", ["--recordings", "fast={f}", "--rates", "fast=0"], ["--rates", "fast=0", "> 0"]),
    ("rate negative", ["--recordings", "fast={f}", "--rates", "fast=-0.001"], ["--rates", "fast=-0.001"]),
    ("rate text", ["--recordings", "fast={f}", "--rates", "fast=quick"], ["--rates", "'quick'"]),
    ("rate nan", ["--recordings", "fast={f}", "--rates", "fast=nan"], ["--rates", "'nan'"]),
    ("rate inf", ["--recordings", "fast={f}", "--rates", "fast=inf"], ["--rates", "'inf'"]),
    ("radial cells 0", ["--radial-cells", "0"], ["--radial-cells", "'0'"]),
    ("layers 0", ["--layers", "0"], ["--layers", "'0'"]),
    ("increments -5", ["--increments", "-5"], ["--increments", "'-5'"]),
    ("increments text", ["--increments", "many"], ["--increments", "'many'"]),
    ("increments float", ["--increments", "10.5"], ["--increments", "'10.5'"]),
    ("sweeps -1", ["--sweeps", "-1"], ["--sweeps", "'-1'"]),
    ("max stages 0", ["--max-stages", "0"], ["--max-stages", "'0'"]),
    ("timeout 0", ["--timeout", "0"], ["--timeout", "'0'"]),
    ("timeout -1", ["--timeout", "-1"], ["--timeout", "'-1'"]),
    ("throughput 0", ["--throughput", "0"], ["--throughput", "'0'"]),
    ("fixed nu 0.7", ["--fixed", "nu=0.7"], ["--fixed", "nu=0.7", "nu"]),
    ("fixed unknown", ["--fixed", "phi=30"], ["--fixed", "'phi'"]),
    ("fixed lambda", ["--fixed", "lambda_=0.01"], ["--fixed", "lambda_=0.01"]),
    ("fixed e0", ["--fixed", "e0=-1"], ["--fixed", "e0=-1"]),
    ("fixed inf", ["--fixed", "nu=inf"], ["--fixed", "'inf'"]),
    ("fixed text", ["--fixed", "nu=abc"], ["--fixed", "'abc'"]),
    ("fixed tau 0", ["--fixed", "tau=0"], ["--fixed", "tau=0"]),
    ("seed -1", ["--seed", "-1"], ["--seed", "'-1'"]),
    ("samples 2", ["--samples", "2"], ["--samples", "'2'"]),
    ("runs 0", ["--runs", "0"], ["--runs", "'0'"]),
    ("processes -2", ["--processes", "-2"], ["--processes", "'-2'"]),
    ("method", ["--method", "x"], ["--method", "'x'"]),
    ("unknown option", ["--recordigns", "fast={f}"], ["--recordigns"]),
    ("pore pressure in one record only", ["--recordings", "fast={f}", "slow={p}"],
     ["pressure_only.csv", "no pore_pressure_kPa column", "--pressure-only"]),
]


@pytest.mark.parametrize("extra, named", [c[1:] for c in BURSWOOD_ARGS], ids=[c[0] for c in BURSWOOD_ARGS])
def test_bad_burswood_command_line_is_refused(tmp_path, capsys, extra, named):
    out = tmp_path / "out"
    f = _sbp_file(tmp_path)
    p = tmp_path / "pressure_only.csv"
    p.write_text(_sbp("1,100", "2,120", header="cavity_strain_pct,cavity_pressure_kPa"))
    extra = [a.format(f=f, d=tmp_path, p=p) for a in extra]
    refused(burswood_sbp.main, ["--quick", "--processes", "1", "--out", out, *extra], capsys, out, named)


@pytest.mark.parametrize("main, extra, named", [
    (toyoura.main, ["--undrained", "a.csv:1.0"], ["--undrained", "'a.csv:1.0'"]),
    (toyoura.main, ["--undrained", "none.csv"], ["none.csv", "not found"]),
    (toyoura.main, ["--free", "phi"], ["--free", "phi"]),
    (simsand_synthetic.main, ["--free", "phi_mu,phi"], ["--free", "phi"]),
    (simsand_synthetic.main, ["--noise", "0.3"], ["--noise", "0.3"]),
    (simsand_synthetic.main, ["--seed", "-4"], ["--seed", "'-4'"]),
], ids=["toyoura undrained spec", "toyoura undrained file", "toyoura free", "simsand free", "simsand noise",
        "simsand seed"])
def test_bad_sand_study_command_line_is_refused(tmp_path, capsys, main, extra, named):
    out = tmp_path / "out"
    refused(main, ["--quick", "--processes", "1", "--out", out, *extra], capsys, out, named)


# ------------------------------------------------------------------------------------------------ checkpoints
class _RunsCode:
    """Unpickling this calls os.system: a checkpoint that tries to run code (it must never be unpickled)."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    """A real checkpoint of the lab study (a quick run stopped after one stage), its run folder and study."""
    d = tmp_path_factory.mktemp("genuine")
    study = load_study(_lab(d))
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, quick=True, processes=1)
    like = inference.Likelihood(observations, problem.forward(study.switches), batch=True)
    prior = problem.prior(study.free, study.log_uniform)
    out = d / "stopped"
    with pytest.raises(inference.RunStopped) as stop:
        runner.calibrate(like, prior, runner.RunSettings(quick=True, processes=1), out, 1, 8, max_steps=4,
                         max_stages=1)
    return d, out, stop.value


def _always_fails(theta):
    raise RuntimeError("no solution")


def test_a_stopped_run_keeps_its_progress_and_says_why(genuine, tmp_path, capsys):
    _, out, stop = genuine
    assert "max_stages" in json.loads((out / "progress.json").read_text())["stopped"] and "max_stages" in str(stop)
    assert (out / "failed_solves.jsonl").exists() and (out / "run.ckpt").exists()
    prior = inference.UniformPrior({"a": (0.0, 1.0), "b": (0.0, 1.0)})
    capsys.readouterr()
    with pytest.raises(inference.RunStopped):
        runner.calibrate(_always_fails, prior, runner.RunSettings(processes=1), tmp_path / "failing", 1, 8,
                         executor=inference.SerialExecutor(), progress=False)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("the run stopped: ") and "progress.json" in lines[0]
    failed = (tmp_path / "failing" / "failed_solves.jsonl").read_text().splitlines()
    assert len(failed) == 8 and all("no solution" in json.loads(f)["reason"] for f in failed)
    assert json.loads((tmp_path / "failing" / "progress.json").read_text())["n_failed_solves"] == 8


def _flip(data: bytes, start: int, n: int = 64) -> bytes:
    return data[:start] + bytes(b ^ 0xFF for b in data[start:start + n]) + data[start + n:]


def _zip(path, members):
    with zipfile.ZipFile(path, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)


def _checkpoints(genuine_ckpt, marker):
    real = genuine_ckpt.read_bytes()
    return {
        "pickle that runs code": lambda p: p.write_bytes(pickle.dumps(_RunsCode(marker))),
        "pickle of a list": lambda p: p.write_bytes(pickle.dumps([1, 2, 3])),
        "pickle of a dict": lambda p: p.write_bytes(pickle.dumps({"state": None})),
        "random bytes": lambda p: p.write_bytes(np.random.default_rng(0).bytes(4096)),
        "empty file": lambda p: p.write_bytes(b""),
        "text file": lambda p: p.write_text("resume me\n"),
        "truncated": lambda p: p.write_bytes(real[: len(real) // 2]),
        "64 bytes inverted": lambda p: p.write_bytes(_flip(real, len(real) // 3)),
        "64 bytes inverted at the end": lambda p: p.write_bytes(_flip(real, len(real) - 200)),
        "zip without meta": lambda p: _zip(p, {"a0.npy": b"x"}),
        "npz of pickled objects": lambda p: np.savez(p.with_suffix(".npz"), a=np.array([{"x": 1}], dtype=object))
        or p.with_suffix(".npz").rename(p),
        "a folder": lambda p: p.mkdir(),
    }


CHECKPOINT_CASES = ["pickle that runs code", "pickle of a list", "pickle of a dict", "random bytes", "empty file",
                    "text file", "truncated", "64 bytes inverted", "64 bytes inverted at the end", "zip without meta",
                    "npz of pickled objects", "a folder"]


@pytest.mark.parametrize("case", CHECKPOINT_CASES)
def test_bad_checkpoint_is_refused_and_never_run(tmp_path, capsys, genuine, case):
    marker = tmp_path / "MARKER"
    out = tmp_path / "out"
    out.mkdir()
    _checkpoints(genuine[1] / "run.ckpt", marker)[case](out / "run.ckpt")
    refused(calibrate.main, [_lab(tmp_path), "--quick", "--processes", "1", "--out", out, "--resume"], capsys, out,
            ["run.ckpt"], keep=["run.ckpt"])
    assert not marker.exists()


@pytest.mark.parametrize("extra, named", [
    (["--seed", "2"], ["seed"]),
    (["--samples", "16"], ["n_samples"]),
    (["--method", "o"], ["proposal"]),
], ids=["other seed", "other samples", "other method"])
def test_checkpoint_of_other_settings_names_what_differs(tmp_path, capsys, genuine, extra, named):
    d, stopped, _ = genuine
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(stopped / "run.ckpt", out / "run.ckpt")
    argv = [d / "study.toml", "--quick", "--processes", "1", "--samples", "8", "--seed", "1", "--out", out, "--resume"]
    refused(calibrate.main, argv + extra, capsys, out, ["run.ckpt", "refusing to resume", *named], keep=["run.ckpt"])


def test_checkpoint_of_other_data_is_refused(tmp_path, capsys, genuine):
    """The same study file with one recorded value changed: the checkpoint's data fingerprint differs."""
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy(genuine[1] / "run.ckpt", out / "run.ckpt")
    path = _lab(tmp_path, csv=LAB_CSV.replace("1.0,70", "1.0,71"))
    refused(calibrate.main, [path, "--quick", "--processes", "1", "--samples", "8", "--out", out, "--resume"], capsys,
            out, ["run.ckpt", "refusing to resume"], keep=["run.ckpt"])


@pytest.mark.parametrize("case", ["pickle that runs code", "64 bytes inverted", "zip without meta"])
def test_bad_checkpoint_is_refused_by_burswood(tmp_path, capsys, genuine, case):
    marker = tmp_path / "MARKER"
    out = tmp_path / "out"
    out.mkdir()
    _checkpoints(genuine[1] / "run.ckpt", marker)[case](out / "run.ckpt")
    refused(burswood_sbp.main, ["--quick", "--processes", "1", "--recordings", f"fast={_sbp_file(tmp_path)}",
                                "--out", out, "--resume"], capsys, out, ["run.ckpt"], keep=["run.ckpt"])
    assert not marker.exists()


# ------------------------------------------------------------------------------------------------ the lock on --out
def _lock(out, pid, host=None):
    out.mkdir(parents=True, exist_ok=True)
    (out / runner.LOCK_FILE).write_text(json.dumps({"pid": pid, "host": host or socket.gethostname(),
                                                     "started": "2026-01-01T00:00:00+00:00"}))


def test_a_second_run_on_the_same_out_is_refused_naming_the_first(tmp_path, capsys):
    sleeper = subprocess.Popen(["sleep", "60"])
    try:
        out = tmp_path / "out"
        _lock(out, sleeper.pid)
        refused(calibrate.main, [_lab(tmp_path), "--quick", "--processes", "1", "--out", out], capsys, out,
                [str(out), "in use by another run", f"pid {sleeper.pid}", socket.gethostname(), "2026-01-01"],
                keep=[runner.LOCK_FILE])
        _lock(tmp_path / "other", 1, host="elsewhere")  # another host: its pid cannot be checked, the lock holds
        with pytest.raises(runner.OutputLocked, match="pid 1 on host elsewhere"):
            with runner.out_lock(tmp_path / "other"):
                pass
    finally:
        sleeper.kill()
        sleeper.wait()


def test_a_stale_lock_is_taken_over_with_a_note_and_released(tmp_path, capsys):
    dead = subprocess.Popen(["true"])
    dead.wait()
    out = tmp_path / "out"
    _lock(out, dead.pid)
    with runner.out_lock(out):
        assert json.loads((out / runner.LOCK_FILE).read_text())["pid"] == os.getpid()
        with pytest.raises(runner.OutputLocked, match=f"pid {os.getpid()}"):
            with runner.out_lock(out):
                pass
    assert "taking over the stale lock" in capsys.readouterr().err
    assert sorted(out.iterdir()) == []  # released; the folder existed before, it stays
    with runner.out_lock(tmp_path / "new"):
        assert (tmp_path / "new" / runner.LOCK_FILE).exists()
    assert not (tmp_path / "new").exists()  # made by the lock and left empty: removed


@pytest.mark.parametrize("error, status, words", [
    (RuntimeError("solver state lost"), 2, ["unexpected RuntimeError: solver state lost", "--debug"]),
    (KeyboardInterrupt(), 130, ["interrupted", "--resume"]),
    (inference.CheckpointError("run.ckpt: checksum mismatch"), 2, ["error: run.ckpt: checksum mismatch"]),
], ids=["unexpected", "ctrl-c", "checkpoint"])
def test_the_handler_gives_one_line_or_with_debug_the_traceback(capsys, error, status, words):
    @command
    def main(argv):
        raise error

    assert main([]) == status
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and all(w in lines[0] for w in words), lines
    with pytest.raises(type(error)):
        main(["--debug"])


# ------------------------------------------------------------------------------------------------ friction
def test_the_compile_message_is_said_once_when_a_kernel_cache_is_cold(tmp_path, capsys, monkeypatch):
    from constitutive import ANICREEP, ModifiedCamClay

    assert [f.name for f in runner.kernel_files(ModifiedCamClay)] == ["_mcc_kernel.py"]
    assert [f.name for f in runner.kernel_files(ANICREEP, fe=True)] == ["_anicreep_kernel.py", "_residual_kernel.py"]
    cold = tmp_path / "_cold_kernel.py"
    cold.write_text("")
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(runner, "_announced", False)
    (tmp_path / "__pycache__").mkdir()
    (tmp_path / "__pycache__" / "_warm_kernel.f-1.py311.nbi").write_bytes(b"")
    runner.announce_compilation([tmp_path / "_warm_kernel.py"])
    assert capsys.readouterr().err == ""
    runner.announce_compilation([tmp_path / "_warm_kernel.py", cold])
    runner.announce_compilation([cold])
    assert capsys.readouterr().err == "compiling the constitutive kernels (first run only, about 30 s)...\n"


# ------------------------------------------------------------------------------------------------ valid variants
def _variants(plain: str, renames: dict, scale: dict):
    """Encodings, line ends, quoting and unit spellings of the same records: (name, bytes)."""
    header, *rows = [line for line in plain.splitlines() if not line.startswith("#")]
    quoted = "\n".join([header] + [",".join(f'"{v}"' for v in r.split(",")) for r in rows]) + "\n"
    bracket = plain.replace(header, ",".join(renames.get(c, c) for c in header.split(",")))
    names = header.split(",")
    scaled = ",".join(f"{n[: -len('_kPa')]} [MPa]" if n in scale else n for n in names)
    mpa = "\n".join([scaled] + [",".join(repr(float(v) / 1000) if n in scale else v
                                         for n, v in zip(names, r.split(","))) for r in rows]) + "\n"
    return [("CRLF", plain.replace("\n", "\r\n").encode()), ("BOM", b"\xef\xbb\xbf" + plain.encode()),
            ("BOM and CRLF", b"\xef\xbb\xbf" + plain.replace("\n", "\r\n").encode()), ("quoted", quoted.encode()),
            ("bracket units", bracket.encode()), ("MPa", mpa.encode()), ("spaces", plain.replace(",", ", ").encode()),
            ("old Mac CR", plain.replace("\n", "\r").encode())]


LAB_VARIANTS = _variants(LAB_CSV, {"axial_strain_pct": "axial_strain [%]", "q_kPa": "q [kPa]"}, {"q_kPa"})
SBP_VARIANTS = _variants(SBP_CSV, {"cavity_strain_pct": "cavity_strain [%]", "time_s": "time [s]",
                                   "cavity_pressure_kPa": "cavity_pressure [kPa]"},
                         {"cavity_pressure_kPa", "pore_pressure_kPa"})


def _curves(observations):
    return {(t.name, c): (curve.x, curve.y) for t in observations for c, curve in t.curves.items()}


@pytest.mark.parametrize("csv", [v for _, v in LAB_VARIANTS], ids=[n for n, _ in LAB_VARIANTS])
def test_valid_lab_variants_load_to_the_same_values(tmp_path, csv):
    plain = _curves(load_observations(load_study(_lab(tmp_path / "plain" if (tmp_path / "plain").mkdir() is None
                                                      else None)).tests)[0])
    variant = _curves(load_observations(load_study(_lab(tmp_path, csv=csv)).tests)[0])
    assert plain.keys() == variant.keys()
    for key, (x, y) in plain.items():
        np.testing.assert_allclose(variant[key][0], x, rtol=1e-15)
        np.testing.assert_allclose(variant[key][1], y, rtol=1e-15)  # MPa * 1000: exact to round-off


@pytest.mark.parametrize("csv", [v for _, v in SBP_VARIANTS], ids=[n for n, _ in SBP_VARIANTS])
def test_valid_sbp_variants_load_to_the_same_values(tmp_path, csv):
    plain = _curves(load_sbp_recordings({"fast": _sbp_file(tmp_path)}, pore_pressure=True))
    path = tmp_path / "variant.csv"
    path.write_bytes(csv)
    variant = _curves(load_sbp_recordings({"fast": path}, pore_pressure=True))
    assert plain.keys() == variant.keys()
    for key, (x, y) in plain.items():
        np.testing.assert_allclose(variant[key][0], x, rtol=1e-15)
        np.testing.assert_allclose(variant[key][1], y, rtol=1e-15)


# ------------------------------------------------------------------------------------------------ real processes
def _run(args, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", *map(str, args)], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=120)


def test_a_pickle_checkpoint_never_runs_code_in_a_real_process(tmp_path):
    marker = tmp_path / "MARKER"
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.ckpt").write_bytes(pickle.dumps(_RunsCode(marker)))
    proc = _run(["cases.calibrate", _lab(tmp_path), "--quick", "--processes", "1", "--out", out, "--resume"],
                tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "run.ckpt" in proc.stderr and "Traceback" not in proc.stderr
    assert not marker.exists() and sorted(p.name for p in out.iterdir()) == ["run.ckpt"]


def test_burswood_recordings_in_latin1_in_a_real_process(tmp_path):
    path = tmp_path / "fast.csv"
    path.write_bytes("# mesurée\n".encode("latin-1") + SBP_CSV.encode())
    proc = _run(["cases.burswood_sbp", "--quick", "--recordings", f"fast={path}", "--out", tmp_path / "out"],
                tmp_path)
    assert proc.returncode == 2 and proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1, proc.stderr
    assert "fast.csv" in proc.stderr and "not UTF-8" in proc.stderr and not (tmp_path / "out").exists()


def test_debug_shows_the_traceback(tmp_path):
    study = _lab(tmp_path, toml=LAB_TOML.replace("M = [0.8, 1.8]", "M = [1.8, 0.8]"))
    quiet = _run(["cases.calibrate", study, "--out", tmp_path / "out"], tmp_path)
    loud = _run(["cases.calibrate", study, "--out", tmp_path / "out", "--debug"], tmp_path)
    assert quiet.returncode == 2 and "Traceback" not in quiet.stderr and "model.free.M" in quiet.stderr
    assert loud.returncode != 0 and "Traceback" in loud.stderr and "StudyError" in loud.stderr


def test_a_signalled_run_keeps_its_progress_and_resumes_with_one_wall_time(tmp_path):
    """SIGTERM: exit 75, progress.json and failed_solves.jsonl beside the checkpoint, --resume named; the resumed
    run's stdout wall_s is summary.json's (summed over both sessions)."""
    import signal
    import time

    out = tmp_path / "out"
    argv = [sys.executable, "-m", "cases.calibrate", _lab(tmp_path), "--quick", "--processes", "1", "--samples", "60",
            "--out", out]
    proc = subprocess.Popen(list(map(str, argv)), cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = out / "progress.log"
    deadline = time.monotonic() + 60
    while not (log.exists() and log.read_text().count("stage") >= 2) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 75, err
    assert "--resume" in err and "Traceback" not in err
    assert {"run.ckpt", "progress.json", "failed_solves.jsonl"} <= {p.name for p in out.iterdir()}
    resumed = _run(["cases.calibrate", *map(str, argv[3:]), "--resume"], tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    line = json.loads(resumed.stdout.strip().splitlines()[-1])
    summary = json.loads((out / "summary.json").read_text())
    assert line["wall_s"] == round(summary["wall_s"], 1) and line["wall_s"] >= line["wall_s_this_session"]
    assert not (out / "progress.json").exists() and not (out / runner.LOCK_FILE).exists()

