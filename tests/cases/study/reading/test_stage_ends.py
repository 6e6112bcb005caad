"""A record at the end of its stage (cases.study.reading.stage_records, cases.study.stages.sequence.stage_spans):
within END_TOLERANCE (1e-6) of the stage's range beyond a known end it is taken at that end; further out it is refused
at load, naming the file, the line, the test, the stage and the value (it used to pass the load and fail every
solve with "a record lies outside the stage")."""
from __future__ import annotations

import pytest
from test_stage_choices import RECORDS
from test_study_programme import CIU, MCC, _programme, study

from cases import calibrate
from cases.study.reading.records import load_test
from inference import DataError


def _refused(tmp_path, records, message, tests=CIU):
    with pytest.raises(DataError) as err:
        load_test(_programme(tmp_path, records, tests))
    assert str(err.value).startswith(str(tmp_path / "ciu.csv")) and message in str(err.value), str(err.value)


def test_a_shear_record_at_its_end_within_the_tolerance_is_taken_there(tmp_path):
    # to_axial_strain = 10 %: the tolerance is 1e-6 x 10 % = 1e-5 %
    test, _ = load_test(_programme(tmp_path, RECORDS.replace("3,,,,5.0,80,30", "3,,,,10.000009,80,30")))
    assert list(test.curves["q@shear3"].x) == [1.0, 2.0, 10.0]


def test_a_shear_record_beyond_its_end_is_refused_at_load(tmp_path):
    _refused(tmp_path, RECORDS.replace("3,,,,5.0,80,30", "3,,,,10.5,80,30"),
             "line 7: test 'CIU', stage 'shear3': record axial_strain = 10.5 % lies outside the stage, 0 to 10 % "
             "(to_axial_strain 10 %), by more than the rounding tolerance 1e-05 % (1e-06 of its range)")


def test_a_consolidation_record_beyond_its_target_is_refused_and_one_at_it_kept(tmp_path):
    # consolidation1 from p0 = 25 to 200 kPa (range 175: tolerance 1.75e-4 kPa)
    test, _ = load_test(_programme(tmp_path, RECORDS.replace("1,86400,200,", "1,86400,200.0001,")))
    assert list(test.curves["void_ratio@consolidation1"].x) == [100.0, 200.0]
    _refused(tmp_path, RECORDS.replace("1,86400,200,", "1,86400,201,"),
             "line 3: test 'CIU', stage 'consolidation1': record p = 201 kPa lies outside the stage, 25 to 200 kPa "
             "(its target p 200 kPa)")


def test_a_hold_record_after_its_duration_is_refused(tmp_path):
    # the swelling stage lasts 3600 s: a record 100 s after its end, by its time since the stage start
    records = "stage,stage_time_s,void_ratio\n2,600,1.11\n2,3700,1.12\n"
    _refused(tmp_path, records, "line 3: test 'CIU', stage 'swelling': record time = 3700 s lies outside the stage, "
                                "0 to 3600 s (its duration 3600 s)")


def test_a_record_beyond_its_stage_exits_2_before_any_solve(tmp_path, capsys):
    path = study(tmp_path, MCC + CIU)
    (tmp_path / "ciu.csv").write_text(RECORDS.replace("3,,,,5.0,80,30", "3,,,,10.5,80,30"))
    out = tmp_path / "out"
    assert calibrate.main([str(path), "--quick", "--processes", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "stage 'shear3': record axial_strain = 10.5 % lies outside the stage" in err, err
    assert not out.exists()
