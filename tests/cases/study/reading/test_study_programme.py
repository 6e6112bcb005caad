"""Stage programmes in the study file (cases.study.reading.staged_tests, cases.study.programme) and their records
(cases.study.reading.stage_records): every stage kind parsed, the flat shorthand equal to its explicit programme,
records assigned by a stage column and by time, and the one-line refusal of every bad field naming the file, test,
stage, field and value."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tolerances import FE_RTOL, PRINTED_RTOL

from cases.study.checks import StudyError
from cases.study.programme import InitialState, Stage, TestSpec, condition_features, curve_key, programme_of, split_key
from cases.study.reading.records import load_test
from cases.study.reading.schema import load_study
from cases.study.reading.stage_records import recorded_programme
from cases.study.stages.sequence import stage_times
from inference import DataError

ROOT = Path(__file__).resolve().parents[4]
EXAMPLES = ROOT / "cases" / "examples"

MCC = """
name = "t"
[model]
name = "ModifiedCamClay"
[model.fixed]
nu = 0.3
[model.free]
M = [0.8, 1.6]
lambda_ = [0.1, 0.3]
kappa = [0.01, 0.05]
"""
ANICREEP = """
name = "t"
[model]
name = "ANICREEP"
viscous = true
[model.fixed]
M = 1.2
kappa = 0.03
nu = 0.25
e0 = 2.0
[model.free]
lambda_ = [0.2, 0.6]
sigma_p0 = [20.0, 200.0]
C_alpha_e = [0.002, 0.1]
"""
CIU = """
[[tests]]
name = "CIU"
file = "ciu.csv"
apparatus = "triaxial"
e0 = 1.4
p0 = 25.0
weight = 2.0
[[tests.stages]]
kind = "consolidation"
p = 200.0
[[tests.stages]]
kind = "consolidation"
name = "swelling"
p = 50.0
duration = 3600.0
[[tests.stages]]
kind = "shear"
drainage = "undrained"
strain_rate = 1.0e-5
to_axial_strain = 10.0
"""


def study(tmp_path, text, name="study.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def refused(path, *parts):
    """The StudyError of a study file, checked to name every part."""
    with pytest.raises(StudyError) as err:
        load_study(path, check_files=False)
    message = str(err.value)
    assert message.startswith(f"{path}: ")
    for p in parts:
        assert p in message, message
    return message


# ---- schema: every stage kind


def test_triaxial_programme_stages_initial_state_and_weight(tmp_path):
    t = load_study(study(tmp_path, MCC + CIU), check_files=False).tests[0]
    assert (t.type, t.apparatus, t.staged, t.weight) == ("programme", "triaxial", True, 2.0)
    assert (t.initial.e0, t.initial.p0, t.initial.K0, t.start_p, t.k0) == (1.4, 25.0, 1.0, 25.0, 1.0)
    c1, sw, sh = t.stages
    assert c1 == Stage("consolidation", "consolidation1", duration=86400.0, p=200.0, abscissa="p")
    assert sw == Stage("consolidation", "swelling", duration=3600.0, p=50.0, abscissa="p")
    assert sh == Stage("shear", "shear3", drainage="undrained", direction="compression", strain_rate=1e-5,
                       to_strain=0.10, abscissa="axial_strain")
    assert stage_times(t) == [(0.0, 86400.0), (86400.0, 90000.0), (90000.0, float("inf"))]
    assert [curve_key(t, "q", s) for s in t.stages] == ["q@consolidation1", "q@swelling", "q@shear3"]
    assert split_key("q@shear3") == ("q", "shear3") and split_key("q") == ("q", None)


def test_every_example_programme_parses(tmp_path):
    kinds = set()
    for name in ("ciu_ocr", "oedometer_il_staged", "crs_unload_reload", "relaxation", "sbp_stages"):
        for t in load_study(EXAMPLES / f"{name}.toml", check_files=False).tests:
            assert t.staged and t.stages
            kinds |= {s.kind for s in t.stages}
    assert kinds == {"consolidation", "shear", "load", "crs", "relaxation", "expansion", "hold", "unloading"}


def test_creep_relaxation_crs_sbp_stage_fields(tmp_path):
    text = ANICREEP + """
[[tests]]
file = "o.csv"
apparatus = "oedometer"
[tests.initial]
e0 = 1.9
sigma_v0 = 20.0
K0 = 0.55
preconsolidation = 50.0
[[tests.stages]]
kind = "consolidation"
sigma_v = 100.0
duration = 600.0
[[tests.stages]]
kind = "creep"
duration = 86400.0
[[tests.stages]]
kind = "crs"
strain_rate = -2.0e-6
to_sigma_v = 40.0
[[tests.stages]]
kind = "relaxation"
duration = 3600.0

[[tests]]
file = "tx.csv"
apparatus = "triaxial"
sigma_v0 = 60.0
K0 = 0.6
ocr = 1.5
[[tests.stages]]
kind = "consolidation"
sigma_v = 120.0
K0 = 0.55
[[tests.stages]]
kind = "creep"
drainage = "undrained"
duration = 1000.0
[[tests.stages]]
kind = "shear"
drainage = "drained"
direction = "extension"
strain_rate = 1.0e-6
"""
    o, tx = load_study(study(tmp_path, text), check_files=False).tests
    assert o.initial.preconsolidation == 50.0 and o.initial.e0 == 1.9 and o.initial.K0 == 0.55
    assert [s.kind for s in o.stages] == ["consolidation", "creep", "crs", "relaxation"]
    assert o.stages[0].abscissa == "sigma_v" and o.stages[1].abscissa == "time"
    assert o.stages[2].strain_rate == -2e-6 and o.stages[2].to_sigma_v == 40.0 and o.stages[2].to_strain is None
    # the CRS to a stress ends when the material says: the relaxation's start is not known beforehand
    assert stage_times(o) == [(0.0, 600.0), (600.0, 87000.0), (87000.0, None), (None, float("inf"))]
    assert tx.initial.ocr == 1.5 and tx.stages[0].K0 == 0.55 and tx.stages[1].drainage == "undrained"
    assert tx.stages[2].direction == "extension" and tx.stages[2].to_strain is None
    assert (tx.consolidation, tx.start_p) == ("K0", 60.0 * (1 + 2 * 0.6) / 3)


# ---- the flat shorthand and its explicit programme


FLAT_AND_EXPLICIT = [
    ("""type = "triaxial"
drainage = "undrained"
direction = "extension"
consolidation = "K0"
sigma_v0 = 150.0
K0 = 0.6
e0 = 0.95
strain_rate = 2.0e-6""", """apparatus = "triaxial"
initial = { e0 = 0.95, sigma_v0 = 150.0, K0 = 0.6 }
[[tests.stages]]
kind = "shear"
drainage = "undrained"
direction = "extension"
strain_rate = 2.0e-6"""),
    ("""type = "oedometer_crs"
sigma_v0 = 20.0
K0 = 0.6
e0 = 2.1
strain_rate = 1.0e-6""", """apparatus = "oedometer"
e0 = 2.1
sigma_v0 = 20.0
K0 = 0.6
[[tests.stages]]
kind = "crs"
strain_rate = 1.0e-6"""),
    ("""type = "oedometer_creep"
sigma_v0 = 20.0
K0 = 0.6
e0 = 2.1
stage_stress = [40.0, 80.0]
stage_duration = 86400.0
load_time = 1.0""", """apparatus = "oedometer"
e0 = 2.1
sigma_v0 = 20.0
K0 = 0.6
[[tests.stages]]
kind = "load"
sigma_v = 40.0
duration = 86400.0
[[tests.stages]]
kind = "load"
sigma_v = 80.0
ramp_time = 1.0
duration = 86400.0"""),
]


@pytest.mark.parametrize("flat, explicit", FLAT_AND_EXPLICIT)
def test_flat_shorthand_equals_its_programme(tmp_path, flat, explicit):
    head = MCC + '[[tests]]\nname = "T"\nfile = "t.csv"\n'
    a = load_study(study(tmp_path, head + flat, "flat.toml"), check_files=False).tests[0]
    b = load_study(study(tmp_path, head + explicit, "explicit.toml"), check_files=False).tests[0]
    assert a.type != "programme" and b.type == "programme"
    assert (a.apparatus, a.initial, a.stages) == (b.apparatus, b.initial, b.stages)
    assert programme_of(a) is a  # already expanded when read


def test_flat_sbp_equals_its_programme():
    flat = load_study(EXAMPLES / "sbp.toml", check_files=False).tests[0]
    (expansion,) = flat.stages
    assert expansion == Stage("expansion", "expansion1", strain_rate=0.00167, to_strain=0.10,
                              abscissa="cavity_strain")
    assert (flat.apparatus, flat.initial.sigma_v0, flat.initial.K0, flat.initial.u0) == ("sbp", 31.0, 0.9, 38.8)


def test_shipped_flat_examples_keep_their_records_and_curve_names():
    s = load_study(EXAMPLES / "oedometer_creep.toml")
    test, times = load_test(s.tests[0])
    assert list(test.curves) == ["axial_strain"] and times is not None
    assert [x.name for x in s.tests[0].stages] == ["load1", "load2", "load3"]


# ---- records


def _programme(tmp_path, csv_text, tests=CIU):
    path = study(tmp_path, MCC + tests)
    (tmp_path / "ciu.csv").write_text(csv_text)
    return load_study(path).tests[0]


def test_records_by_stage_column_numbers_and_names(tmp_path):
    spec = _programme(tmp_path, """# a CIU programme
stage,time_s,p_kPa,void_ratio,axial_strain_pct,q_kPa,excess_pore_pressure_kPa
1,40000,100,1.2,,,
consolidation1,86400,200,1.1,,,
swelling,88000,100,1.12,,,
3,,,,1.0,50,10
shear3,,,,2.0,70,20
3,,,,5.0,80,30
""")
    test, times = load_test(spec)
    assert set(test.curves) == {"void_ratio@consolidation1", "void_ratio@swelling", "q@shear3",
                                "excess_pore_pressure@shear3"}
    c = test.curves["void_ratio@consolidation1"]
    assert (c.x_name, list(c.x), list(c.y)) == ("p", [100.0, 200.0], [1.2, 1.1])
    # swelling recorded once: its control variable p' is its abscissa (a single point is monotone)
    assert test.curves["void_ratio@swelling"].x_name == "p"
    shear = test.curves["q@shear3"]
    assert (shear.x_name, list(shear.x), list(shear.y)) == ("axial_strain", [1.0, 2.0, 5.0], [50.0, 70.0, 80.0])
    assert list(times["void_ratio@swelling"]) == [88000.0] and np.all(np.isnan(times["q@shear3"]))
    staged = recorded_programme(spec, test)
    assert [s.curves for s in staged.stages] == [("void_ratio",), ("void_ratio",), ("q", "excess_pore_pressure")]
    assert [s.abscissa for s in staged.stages] == ["p", "p", "axial_strain"]


def test_records_by_time_ranges_and_time_abscissa(tmp_path):
    spec = _programme(tmp_path, """time_s,void_ratio,axial_strain_pct,q_kPa
0,1.40,,
3600,1.30,,
86400,1.10,,
87000,1.11,,
90000,1.12,,
90100,,0.1,30
90500,,0.5,55
""")
    test, times = load_test(spec)
    # p' not recorded: the consolidation stages are plotted against the time since their start
    c1, sw, sh = (test.curves[k] for k in ("void_ratio@consolidation1", "void_ratio@swelling", "q@shear3"))
    assert (c1.x_name, list(c1.x)) == ("time", [0.0, 3600.0, 86400.0])
    assert (sw.x_name, list(sw.x), list(sw.y)) == ("time", [600.0, 3600.0], [1.11, 1.12])
    assert (sh.x_name, list(sh.x)) == ("axial_strain", [0.1, 0.5])
    assert list(times["void_ratio@swelling"]) == [87000.0, 90000.0]


def test_one_stage_programme_keeps_plain_curve_names(tmp_path):
    tests = """
[[tests]]
name = "CIU"
file = "ciu.csv"
apparatus = "triaxial"
e0 = 1.4
p0 = 25.0
[[tests.stages]]
kind = "shear"
drainage = "drained"
strain_rate = 1.0e-5
"""
    spec = _programme(tmp_path, "axial_strain_pct,q_kPa,volumetric_strain_pct,excess_pore_pressure_kPa\n"
                      "1,20,0.1,0\n2,30,0.3,0\n", tests)
    test, _ = load_test(spec)
    assert list(test.curves) == ["q", "volumetric_strain"]  # no excess pore pressure in a drained stage


BAD_RECORDS = [
    ("stage,p_kPa,void_ratio\n4,100,1.2\n", "line 2, column 'stage': value '4' is not a stage of CIU"),
    ("stage,p_kPa,void_ratio\nswelling,100,1.2\n1,200,1.1\n",
     "line 3, column 'stage': stage 'consolidation1' after stage 'swelling'"),
    ("p_kPa,void_ratio\n100,1.2\n", "line 2: a record of the 3-stage test CIU needs a 'stage' column"),
    ("stage,void_ratio\n2,1.2\n2,1.3\n", "stage 'swelling' (consolidation) of CIU has records but no abscissa"),
    ("stage,stage_time_s,void_ratio\n1,5,1.2\n1,3,1.3\n",
     "line 3: stage 'consolidation1' of CIU: the time since the stage start must be >= 0 and increase"),
    ("stage,p_kPa,void_ratio\n1,100,abc\n", "line 2, column 'void_ratio': value 'abc' is not a finite number"),
    ("stage,p_kPa,torsion\n1,100,1\n", "column 'torsion' is not a column of an triaxial programme"),
    ("time_s,p_kPa\n10,-5\n", "line 2, column 'p_kPa': value -5 must be > 0"),
]


@pytest.mark.parametrize("csv_text, message", BAD_RECORDS)
def test_bad_programme_records_name_file_line_and_stage(tmp_path, csv_text, message):
    spec = _programme(tmp_path, csv_text)
    with pytest.raises(DataError) as err:
        load_test(spec)
    assert str(err.value).startswith(str(tmp_path / "ciu.csv")) and message in str(err.value), str(err.value)


def test_time_after_an_open_ended_stage_needs_a_stage_column(tmp_path):
    tests = """
[[tests]]
name = "O"
file = "ciu.csv"
apparatus = "oedometer"
e0 = 1.4
sigma_v0 = 20.0
K0 = 0.6
[[tests.stages]]
kind = "crs"
strain_rate = 1.0e-6
to_sigma_v = 100.0
[[tests.stages]]
kind = "relaxation"
duration = 3600.0
"""
    spec = _programme(tmp_path, "time_s,axial_strain_pct,sigma_v_kPa\n10,0.001,25\n200000,10,90\n", tests)
    with pytest.raises(DataError, match="line 2, column 'time': value 10 s is after the start of stage 'crs1' "
                                        r"\(0 s\), whose end follows from the material's response: give a 'stage' "
                                        "column"):
        load_test(spec)


# ---- bad input in the study file: file, test, stage, field, value


BAD_FIELDS = [
    ('kind = "consolidation"\np = 200.0', 'kind = "torsion"',
     "tests['CIU'].stages[0].kind = 'torsion': supported for apparatus 'triaxial': consolidation, shear, creep, "
     "relaxation, crs"),
    ('kind = "consolidation"\np = 200.0', 'kind = "load"\nsigma_v = 200.0\nduration = 60.0',
     "tests['CIU'].stages[0].kind = 'load': supported for apparatus 'triaxial'"),
    ('strain_rate = 1.0e-5', 'strain_rate = 0',
     "tests['CIU'].stages[2].strain_rate = 0: must be != 0 (1/s)"),
    ('drainage = "undrained"', 'drainage = "partial"',
     "tests['CIU'].stages[2].drainage = 'partial': expected one of drained, undrained"),
    ('to_axial_strain = 10.0', 'to_axial_strain = -3.0',
     "tests['CIU'].stages[2].to_axial_strain = -3.0: a negative axial strain is reached in extension"),
    ('to_axial_strain = 10.0', 'to_axial_strain = 150.0',
     "tests['CIU'].stages[2].to_axial_strain = 150.0: a strain in % must be <= 100"),
    ('to_axial_strain = 10.0', 'to_axial_strain = 10.0\nspeed = 3',
     "tests['CIU'].stages[2].speed = 3: unknown field; expected one of kind, name, abscissa, curves, e_end, drainage, "
     "strain_rate"),
    ('name = "swelling"', 'name = "consolidation1"',
     "tests['CIU'].stages[1].name = 'consolidation1': stage names must be unique within a test"),
    ('name = "swelling"', 'name = "a@b"', "tests['CIU'].stages[1].name = 'a@b': a stage name has no '@'"),
    ('duration = 3600.0', 'duration = -1.0', "tests['CIU'].stages[1].duration = -1.0: must be > 0"),
    ('kind = "consolidation"\np = 200.0', 'kind = "consolidation"\np = 200.0\nK0 = 0.5',
     "tests['CIU'].stages[0].K0 = 0.5: an isotropic consolidation (p) has no K0"),
    ('kind = "consolidation"\np = 200.0', 'kind = "consolidation"\nsigma_v = 200.0',
     "tests['CIU'].stages[0].K0 is missing (a triaxial consolidation to sigma_v"),
    ('kind = "consolidation"\np = 200.0', 'kind = "consolidation"',
     "tests['CIU'].stages[0]: a consolidation stage goes to p (isotropic, triaxial) or to sigma_v"),
    ('weight = 2.0', 'weight = 0', "tests['CIU'].weight = 0: must be > 0"),
    ('p0 = 25.0', 'p0 = 25.0\nK0 = 0.5', "tests['CIU'].K0 = 0.5: not used with p0"),
    ('p0 = 25.0', 'sigma_v0 = 25.0', "tests['CIU'].K0 is missing (apparatus 'triaxial' starts from p0 (isotropic) or "
     "sigma_v0 and K0)"),
    ('p0 = 25.0', 'p0 = 25.0\nocr = 0.5', "tests['CIU'].ocr = 0.5: must be >= 1"),
    ('p0 = 25.0', 'p0 = 25.0\npreconsolidation = 10.0', "tests['CIU'].preconsolidation = 10.0: must be >= the initial "
     "vertical effective stress 25 kPa"),
    ('p0 = 25.0', 'p0 = 25.0\nocr = 2.0\npreconsolidation = 60.0',
     "tests['CIU'].preconsolidation = 60.0: give ocr or preconsolidation, not both"),
    ('p0 = 25.0', 'p0 = 25.0\nu0 = 10.0',
     "tests['CIU'].u0 = 10.0: the in situ pore pressure is a field of an sbp test"),
    ('e0 = 1.4\n', '', "tests['CIU'].e0 is missing: ModifiedCamClay needs the void ratio"),
    ('apparatus = "triaxial"', 'apparatus = "triaxial"\ntype = "triaxial"',
     "tests['CIU'].type = 'triaxial': a test with an apparatus and [[tests.stages]] has no type"),
    ('apparatus = "triaxial"', 'apparatus = "shear box"',
     "tests['CIU'].apparatus = 'shear box': expected one of triaxial, oedometer, sbp"),
    ('strain_rate = 1.0e-5', 'strain_rate = 1.0e-5\ndirection = "sideways"',
     "tests['CIU'].stages[2].direction = 'sideways': expected one of compression, extension"),
    ('e0 = 1.4', 'e0 = -1.4', "tests['CIU'].e0 = -1.4: must be > 0"),
    ('p0 = 25.0', 'p0 = "25"', "tests['CIU'].p0 = '25': expected a finite number"),
    ('e0 = 1.4\np0 = 25.0', 'initial = { e0 = 1.4, p0 = 25.0, pc = 3.0 }',
     "tests['CIU'].initial.pc = 3.0: unknown field; expected one of e0, p0, sigma_v0, K0, ocr, preconsolidation, u0"),
    ('e0 = 1.4\np0 = 25.0', 'e0 = 1.4\ninitial = { p0 = 25.0 }',
     "tests['CIU'].e0 = 1.4: the initial state is given in [tests.initial]: give it there or in the test's table"),
    ('p = 200.0', 'p = 0.0', "tests['CIU'].stages[0].p = 0.0: must be > 0"),
    ('kind = "consolidation"\np = 200.0', 'kind = "consolidation"\np = 200.0\ndrainage = "undrained"',
     "tests['CIU'].stages[0].drainage = 'undrained': unknown field; expected one of kind, name, abscissa, curves, "
     "e_end, p, sigma_v, K0, duration"),
    ('kind = "consolidation"\np = 200.0', 'name = "x"\np = 200.0', "tests['CIU'].stages[0].kind is missing"),
    ('name = "swelling"', 'name = "2"', "tests['CIU'].stages[1].name = '2': a stage name has no '@' and is not a "
     "number"),
    ('strain_rate = 1.0e-5', 'strain_rate = 1.0e-5\nduration = 60.0',
     "tests['CIU'].stages[2].duration = 60.0: unknown field"),
    ('drainage = "undrained"', 'drainge = "undrained"',
     "tests['CIU'].stages[2].drainge = 'undrained': unknown field; did you mean 'drainage'? expected one of kind, "
     "name, abscissa, curves, e_end, drainage, strain_rate"),
    ('drainage = "undrained"', 'drainage = "undrianed"',
     "tests['CIU'].stages[2].drainage = 'undrianed': did you mean 'undrained'? expected one of drained, undrained"),
    ('e0 = 1.4\np0 = 25.0', 'initial = { e0 = 1.4, p_0 = 25.0 }',
     "tests['CIU'].initial.p_0 = 25.0: unknown field; did you mean 'p0'?"),
]


@pytest.mark.parametrize("good, bad, message", BAD_FIELDS)
def test_bad_programme_field_is_refused_naming_test_stage_field_and_value(tmp_path, good, bad, message):
    assert good in CIU
    refused(study(tmp_path, MCC + CIU.replace(good, bad, 1)), message)


def test_oedometer_and_sbp_specific_refusals(tmp_path):
    oed = ANICREEP + """
[[tests]]
file = "o.csv"
apparatus = "oedometer"
sigma_v0 = 20.0
K0 = 0.6
[[tests.stages]]
kind = "load"
sigma_v = 40.0
ramp_time = 600.0
duration = 300.0
"""
    refused(study(tmp_path, oed, "a.toml"), "tests['o'].stages[0].ramp_time = 600.0: must be < the stage's duration")
    refused(study(tmp_path, oed.split("[[tests.stages]]")[0], "no_stages.toml"), "tests['o'].stages is missing")
    refused(study(tmp_path, oed.split("[[tests.stages]]")[0] + "stages = []\n", "empty.toml"),
            "tests['o'].stages = []: expected one or more [[tests.stages]] tables")
    refused(study(tmp_path, oed.replace('kind = "load"', 'kind = "creep"\ndrainage = "undrained"')
                  .replace("sigma_v = 40.0\nramp_time = 600.0\n", ""), "b.toml"),
            "tests['o'].stages[0].drainage = 'undrained': an oedometer creep stage is drained")
    crs = oed.replace('kind = "load"\nsigma_v = 40.0\nramp_time = 600.0\nduration = 300.0',
                      'kind = "crs"\nstrain_rate = -1e-6\nto_axial_strain = 5.0')
    refused(study(tmp_path, crs, "c.toml"), "tests['o'].stages[0].to_axial_strain = 5.0: not reached at strain_rate "
            "-1e-06 1/s")
    refused(study(tmp_path, crs.replace("to_axial_strain = 5.0", "to_axial_strain = 5.0\nto_sigma_v = 50.0"),
                  "d.toml"), "tests['o'].stages[0].to_sigma_v = 50.0: the stage ends at to_axial_strain: give one end")
    refused(study(tmp_path, crs.replace("strain_rate = -1e-6", "strain_rate = 0"), "e.toml"),
            "tests['o'].stages[0].strain_rate = 0: must be != 0")
    refused(study(tmp_path, oed.replace("sigma_v0 = 20.0", "p0 = 20.0"), "f.toml"),
            "tests['o'].p0 = 20.0: an oedometer test starts from sigma_v0 and K0")
    sbp = (EXAMPLES / "sbp_stages.toml").read_text().replace('file = "data/', 'file = "')
    refused(study(tmp_path, sbp.replace('kind = "expansion"\nname = "expansion"\nstrain_rate = 0.00167    # 1/s\n'
                                        'to_cavity_strain = 5.0   # %', 'kind = "hold"\nduration = 10.0'), "g.toml"),
            "tests['SBP_hold'].stages[0].kind = 'hold': the first stage of a pressuremeter test is an expansion")
    refused(study(tmp_path, sbp.replace("to_cavity_strain = 2.0", "to_cavity_strain = 6.0"), "h.toml"),
            "tests['SBP_hold'].stages[2].to_cavity_strain = 6.0: an unloading goes below the current cavity strain 5 %")
    refused(study(tmp_path, sbp.replace("to_cavity_strain = 5.0", "to_cavity_strain = 12.0"), "j.toml"),
            "tests['SBP_hold'].stages[0].to_cavity_strain = 12.0: an expansion goes above the current cavity strain "
            "0 % and at most to 10 %")
    refused(study(tmp_path, sbp.replace("probe_radius = 0.0415    # m\n", ""), "i.toml"),
            "tests['SBP_hold'].probe_radius is missing")
    simsand = MCC.replace('"ModifiedCamClay"', '"SIMSAND"')
    assert "ocr" not in simsand


def test_flat_type_refuses_programme_fields(tmp_path):
    flat = MCC + """
[[tests]]
file = "t.csv"
type = "triaxial"
drainage = "undrained"
direction = "compression"
consolidation = "isotropic"
p0 = 100.0
e0 = 1.0
strain_rate = 1e-5
ocr = 2.0
"""
    refused(study(tmp_path, flat), "tests['t'].ocr = 2.0: ocr is a field of a stage programme")
    refused(study(tmp_path, flat.replace("ocr = 2.0", "weight = -1"), "w.toml"), "tests['t'].weight = -1: must be > 0")


def test_cli_exit_status_2_names_the_stage(tmp_path):
    path = study(tmp_path, MCC + CIU.replace('kind = "shear"', 'kind = "torsion"'))
    (tmp_path / "ciu.csv").write_text("stage,p_kPa,void_ratio\n1,100,1.2\n")
    r = subprocess.run([sys.executable, "-m", "cases.calibrate", str(path), "--quick", "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2, r.stderr
    assert "tests['CIU'].stages[2].kind = 'torsion': supported for apparatus 'triaxial'" in r.stderr
    assert not (tmp_path / "o").exists()


# ---- the shipped SYNTHETIC programme examples


STAGED_EXAMPLES = ("ciu_ocr", "oedometer_il_staged", "crs_unload_reload", "relaxation", "sbp_stages")


def _records(path):
    """(header lines, column names, values (n, k), NaN where not recorded) of a record CSV."""
    lines = path.read_text().splitlines()
    rows = [line for line in lines if line and not line.startswith("#")]
    return ([line for line in lines if line.startswith("#")], rows[0],
            np.array([[float(v) for v in row.split(",")] for row in rows[1:]]))


@pytest.mark.parametrize("name", STAGED_EXAMPLES)
def test_shipped_programme_examples_are_labelled_and_equal_the_generator(tmp_path, name):
    """Every file says SYNTHETIC; the generator rewrites the same header, columns, stages and unrecorded cells, and
    the same numbers to the 9 digits they are printed with (a flipped last digit is at most rel 1e-8), FE values to
    the Newton tolerance (FE_RTOL)."""
    import shutil

    from cases.study.reading.records import load_observations
    from cases.study.synthetic.generate import generate

    assert name in (EXAMPLES / "SOURCE.md").read_text()
    shutil.copy(EXAMPLES / f"{name}.toml", tmp_path)
    paths = generate(tmp_path / f"{name}.toml", directory=tmp_path / "out")
    s = load_study(EXAMPLES / f"{name}.toml")
    for t in s.tests:
        head, cols, values = _records(paths[t.name])
        ref_head, ref_cols, ref = _records(t.file)
        assert ref_head[0].startswith("# synthetic: NOT MEASURED DATA")
        assert (head, cols) == (ref_head, ref_cols) and values.shape == ref.shape, t.name
        np.testing.assert_array_equal(np.isnan(values), np.isnan(ref), err_msg=t.name)
        np.testing.assert_allclose(values[:, 0], ref[:, 0], rtol=0, atol=0, err_msg=t.name)  # the stage numbers
        np.testing.assert_allclose(values, ref, rtol=FE_RTOL if t.apparatus == "sbp" else PRINTED_RTOL, atol=0,
                                   err_msg=t.name)
    obs, _ = load_observations(s.tests)
    for t in s.tests:  # every stage recorded, under <quantity>@<stage>
        assert {split_key(k)[1] for k in obs[t.name].curves} == {x.name for x in t.stages}, t.name


def test_condition_features_of_a_staged_programme_by_hand():
    # the features of (P2)'s state space: initial state, per stage kind the largest target stress, the mean log
    # rate and duration, drainage and direction; a flat test's the same as its programme's
    spec = TestSpec("t", "programme", apparatus="triaxial",
                    initial=InitialState(e0=1.1, sigma_v0=50.0, K0=0.5, ocr=2.0),
                    stages=(Stage("consolidation", "c1", duration=3600.0, p=200.0),
                            Stage("consolidation", "c2", duration=36000.0, p=100.0),
                            Stage("shear", "s1", drainage="undrained", direction="extension", strain_rate=1e-6),
                            Stage("shear", "s2", drainage="undrained", direction="extension", strain_rate=1e-4)))
    got = condition_features(spec)
    assert got == {"apparatus": "triaxial", "stages": "consolidation consolidation shear shear", "e0": 1.1,
                   "ln p0": pytest.approx(np.log(50.0 * 2.0 / 3.0)), "ln ocr": pytest.approx(np.log(2.0)),
                   "ln consolidation stress": pytest.approx(np.log(200.0)),
                   "ln consolidation duration": pytest.approx(0.5 * np.log(3600.0 * 36000.0)),
                   "consolidation drainage": "drained",
                   "ln shear rate": pytest.approx(np.log(1e-5)), "shear drainage": "undrained",
                   "shear direction": "extension"}
    crs = TestSpec("u", "oedometer_crs", sigma_v0=20.0, K0=0.6, strain_rate=-1e-6)
    assert condition_features(crs) == condition_features(programme_of(crs))
    assert condition_features(crs)["crs direction"] == "negative rate"
