"""A stage's ``curves`` (the recorded curves that enter the likelihood), ``abscissa`` (what its records are
against) and ``e_end`` (the void ratio measured at its end, in place of the test's e0) in the study file
(cases.study.reading.staged_tests, cases.study.reading.stage_records): read, used, and refused with one line naming
the file, the test, the stage and the value; a noisy record of the default abscissa is refused at load instead of
turning the stage to time unasked."""
from __future__ import annotations

import pytest
from test_study_programme import CIU, MCC, _programme, refused, study

from cases import calibrate
from cases.study.reading.records import load_test
from cases.study.reading.schema import load_study
from inference import DataError

RECORDS = """stage,time_s,p_kPa,void_ratio,axial_strain_pct,q_kPa,excess_pore_pressure_kPa
1,40000,100,1.2,,,
1,86400,200,1.1,,,
2,87000,100,1.12,,,
3,,,,1.0,50,10
3,,,,2.0,70,20
3,,,,5.0,80,30
"""
SHEAR = 'kind = "shear"\ndrainage = "undrained"'


def _shear_with(field):
    return CIU.replace(SHEAR, f"{SHEAR}\n{field}")


def test_curves_keep_the_named_curves_of_the_stage(tmp_path):
    test, _ = load_test(_programme(tmp_path, RECORDS, _shear_with('curves = ["excess_pore_pressure"]')))
    assert set(test.curves) == {"void_ratio@consolidation1", "void_ratio@swelling", "excess_pore_pressure@shear3"}


@pytest.mark.parametrize("curves, message", [
    ('["excess_pore_presure"]', "tests['CIU'].stages[2].curves = ['excess_pore_presure']: 'excess_pore_presure' is "
                                "not a curve of an triaxial programme; did you mean 'excess_pore_pressure'? expected "
                                "among axial_strain, q, p, axial_stress, radial_stress, excess_pore_pressure, "
                                "volumetric_strain, void_ratio"),
    ('["void_ratio"]', "tests['CIU'].stages[2].curves = ['void_ratio']: 'void_ratio' is not a curve of this "
                       "undrained shear stage (recorded against axial_strain; it controls or holds"),
    ('["axial_strain"]', "'axial_strain' is not a curve of this undrained shear stage"),
    ('["q", "q"]', "tests['CIU'].stages[2].curves = ['q', 'q']: 'q' is given twice"),
    ("[]", "tests['CIU'].stages[2].curves = []: expected a non-empty list of curve names"),
])
def test_bad_curves_are_refused(tmp_path, curves, message):
    refused(study(tmp_path, MCC + _shear_with(f"curves = {curves}")), message)


def test_a_chosen_curve_not_recorded_in_the_stage_is_refused(tmp_path):
    spec = _programme(tmp_path, RECORDS, _shear_with('curves = ["p"]'))
    with pytest.raises(DataError, match=r"ciu.csv: curve 'p' of stage 'shear3' of CIU \(its curves\) is not recorded "
                                        "in the stage"):
        load_test(spec)


NOISY = RECORDS.replace("1,86400,200,1.1,,,", "1,60000,98,1.15,,,\n1,86400,200,1.1,,,")


def test_a_noisy_default_abscissa_is_refused_at_load_naming_the_line(tmp_path):
    with pytest.raises(DataError, match=r"ciu.csv, line 3, column 'p': value 98 after 100: stage 'consolidation1' of "
                                        r"CIU is recorded against p, .* give the stage abscissa = \"time\""):
        load_test(_programme(tmp_path, NOISY))


def test_a_chosen_time_abscissa_takes_the_noisy_stage_against_time(tmp_path):
    tests = CIU.replace('kind = "consolidation"\np = 200.0', 'kind = "consolidation"\np = 200.0\nabscissa = "time"')
    test, _ = load_test(_programme(tmp_path, NOISY, tests))
    c = test.curves["void_ratio@consolidation1"]
    assert (c.x_name, list(c.x), list(c.y)) == ("time", [40000.0, 60000.0, 86400.0], [1.2, 1.15, 1.1])


def test_a_chosen_abscissa_missing_at_a_record_is_refused(tmp_path):
    records = RECORDS.replace("3,,,,2.0,70,20", "3,,,,,70,20")
    with pytest.raises(DataError, match=r"ciu.csv, line 6: stage 'shear3' of CIU is recorded against axial_strain "
                                        r"\(its abscissa\), which this record lacks"):
        load_test(_programme(tmp_path, records, _shear_with('abscissa = "axial_strain"')))


def test_an_abscissa_the_kind_does_not_take_is_refused(tmp_path):
    refused(study(tmp_path, MCC + _shear_with('abscissa = "p"')),
            "tests['CIU'].stages[2].abscissa = 'p': expected one of axial_strain, time")


def test_a_bad_choice_exits_2_with_one_line(tmp_path, capsys):
    path = study(tmp_path, MCC + _shear_with('curves = ["qq"]'))
    (tmp_path / "ciu.csv").write_text(RECORDS)
    assert calibrate.main([str(path), "--quick", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "tests['CIU'].stages[2].curves = ['qq']: 'qq' is not a curve" in err, err
    assert not (tmp_path / "out").exists()


def test_the_study_file_reads_e_end_in_place_of_e0(tmp_path):
    text = MCC + CIU.replace("e0 = 1.4\n", "").replace('kind = "consolidation"\np = 200.0',
                                                       'kind = "consolidation"\np = 200.0\ne_end = 1.1')
    t = load_study(study(tmp_path, text), check_files=False).tests[0]
    assert t.initial.e0 is None and [s.e_end for s in t.stages] == [1.1, None, None]


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace('p = 200.0', 'p = 200.0\ne_end = 1.1'),
     "tests['CIU'].stages[0].e_end = 1.1: the initial state gives e0 as well"),
    (lambda t: t.replace("e0 = 1.4\n", "").replace('p = 200.0', 'p = 200.0\ne_end = 1.1')
     .replace('p = 50.0', 'p = 50.0\ne_end = 1.2'),
     "tests['CIU'].stages[1].e_end = 1.2: the void ratio is already given at the end of stage 'consolidation1'"),
    (lambda t: t.replace("e0 = 1.4\n", "").replace("to_axial_strain = 10.0\n", "e_end = 1.0\n"),
     "tests['CIU'].stages[2].e_end = 1.0: the end of stage 'shear3' follows from the material's response"),
    (lambda t: t.replace("e0 = 1.4\n", ""), "tests['CIU'].e0 is missing: ModifiedCamClay needs the void ratio at the "
     "start of each test (e0) or where it was measured (a stage's e_end)"),
    (lambda t: t.replace('p = 200.0', 'p = 200.0\ne_end = -1'), "tests['CIU'].stages[0].e_end = -1: must be > 0"),
])
def test_bad_e_end_is_refused(tmp_path, edit, message):
    refused(study(tmp_path, MCC + edit(CIU)), message)


def test_a_triaxial_crs_stage_records_the_radial_stress(tmp_path):
    tests = ('\n[[tests]]\nname = "K0"\nfile = "ciu.csv"\napparatus = "triaxial"\n'
             'initial = { e0 = 1.4, sigma_v0 = 20.0, K0 = 0.6 }\n'
             'stages = [{ kind = "crs", strain_rate = 1e-6, to_axial_strain = 5.0 }]\n')
    spec = _programme(tmp_path, "axial_strain_pct,sigma_v_kPa,sigma_r [kPa],volumetric_strain_pct\n"
                      "1,40,25,1\n5,100,62,5\n", tests)
    test, _ = load_test(spec)
    assert set(test.curves) == {"axial_stress", "radial_stress"}  # the volumetric strain equals the axial: held
    assert list(test.curves["radial_stress"].y) == [25.0, 62.0]

