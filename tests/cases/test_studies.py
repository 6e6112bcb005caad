"""The shipped study files (cases/studies/) and the study schema's ``[reference]`` and ``[runner]`` tables."""
from pathlib import Path

import pytest

from cases import burswood_sbp, calibrate, simsand_synthetic, toyoura
from cases.study.checks import StudyError
from cases.study.reading.schema import load_study
from cases.study.routes import sand

STUDIES = Path(calibrate.__file__).parent / "studies"


@pytest.mark.parametrize("name, route, tests", [
    ("burswood_sbp", "sbp", ["fast", "slow"]),
    ("toyoura", "sand", [f"test{i}" for i in range(1, 7)]),
    ("simsand_synthetic", "sand", ["T1", "T2", "T3"]),
])
def test_each_shipped_study_file_loads(name, route, tests):
    study = load_study(STUDIES / f"{name}.toml")
    assert study.name == name and study.runner["route"] == route
    assert [t.name for t in study.tests] == tests
    assert all(Path(t.file).is_file() for t in study.tests)
    assert study.references, "every shipped study shows its paper or generating values"


def test_the_entry_points_run_the_shipped_study_files():
    assert {m.STUDY.name for m in (burswood_sbp, toyoura, simsand_synthetic)} == {
        p.name for p in STUDIES.glob("*.toml")}


def test_reference_table_is_read_in_file_order():
    study = load_study(toyoura.STUDY)
    refs = study.references
    assert list(refs) == ["paper_reference", "paper_de_mean", "paper_de_std", "paper_o"]
    assert refs["paper_reference"].source == "paper reference (optimisation), Table 3"
    assert refs["paper_reference"].values["phi_mu"] == 32.40 and refs["paper_reference"].figures
    assert refs["paper_de_mean"].values["sigma_eps"] == 0.057
    assert not refs["paper_de_std"].figures


def _edited(tmp_path, old, new, source=toyoura.STUDY):
    text = Path(source).read_text()
    assert old in text
    path = tmp_path / "study.toml"
    path.write_text(text.replace(old, new).replace('"../data/', f'"{Path(source).parent.parent / "data"}/'))
    return path


@pytest.mark.parametrize("old, new, field, value", [
    ("phi_mu = 32.40", "phi = 32.40", "reference.paper_reference.phi", "32.4"),
    ("phi_mu = 32.40", 'phi_mu = "32.4"', "reference.paper_reference.phi_mu", "'32.4'"),
    ('source = "paper DE-TMCMC std"', "", "reference.paper_de_std.source", None),
    ('route = "sand"', 'route = "fem"', "runner.route", "'fem'"),
    ('hold_at = "paper_reference"', 'hold_at = "paper"', "runner.hold_at", "'paper'"),
    ('role = "predict"   ', 'role = "held out"', "tests['test1'].role", "'held out'"),
    ('name = "test6"\n', 'name = "test6"\nrole = "predict"\n', "runner.substitutes", "['test6']"),
])
def test_bad_reference_or_runner_field_names_file_field_and_value(tmp_path, old, new, field, value):
    path = _edited(tmp_path, old, new)
    with pytest.raises(StudyError) as err:
        load_study(path)
    message = str(err.value)
    assert str(path) in message and field in message
    if value is not None:
        assert f"= {value}" in message


def test_predicted_tests_are_the_roles_and_a_bad_role_is_one_line(tmp_path, capsys):
    assert [t.name for t in load_study(toyoura.STUDY).tests if t.role == "predict"] == ["test1", "test3", "test4",
                                                                                         "test5"]
    path = _edited(tmp_path, 'role = "predict"   ', 'role = "forecast"')
    assert calibrate.main([path, "--quick", "--processes", "1", "--out", tmp_path / "out"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tests['test1'].role = 'forecast': expected one of calibrate, predict" in err[0]


def test_a_predicted_test_on_the_pressuremeter_route_or_no_calibrated_test_is_refused(tmp_path):
    burswood = (STUDIES / "burswood_sbp.toml").read_text().replace('file = "../', f'file = "{STUDIES.parent}/')
    first = burswood.index("[[tests]]")
    path = tmp_path / "sbp.toml"
    path.write_text(burswood[:first] + burswood[first:].replace("name = ", 'role = "predict"\nname = ', 1))
    with pytest.raises(StudyError, match=r"\.role = 'predict': the pressuremeter route \(\[runner\] route = "
                                         r'"sbp"\) predicts no test'):
        load_study(path)
    path = _edited(tmp_path, 'name = "test2"\n', 'name = "test2"\nrole = "predict"\n')
    text = path.read_text().replace('name = "test6"\n', 'name = "test6"\nrole = "predict"\n').replace(
        'substitutes = ["test6"]', "")
    path.write_text(text)
    with pytest.raises(StudyError, match="at least one must be calibrated"):
        load_study(path)


def test_bad_reference_is_refused_by_the_command_line_with_exit_2(tmp_path, capsys):
    path = _edited(tmp_path, "phi_mu = 32.40", "phi = 32.40")
    out = tmp_path / "out"
    assert calibrate.main([path, "--quick", "--processes", "1", "--out", out]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0] and "reference.paper_reference.phi = 32.4" in err[0]
    assert not out.exists()


def test_an_option_of_another_route_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    assert calibrate.main([toyoura.STUDY, "--pressure-only", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "--pressure-only" in err and "route = 'sand'" in err and not out.exists()
    with pytest.raises(SystemExit) as exit_status:  # an entry point offers its own route's options only
        toyoura.main(["--pressure-only", "--out", out])
    assert exit_status.value.code == 2 and "--pressure-only" in capsys.readouterr().err


def test_single_sigma_and_error_groups_together_are_refused(tmp_path, capsys):
    out = tmp_path / "out"
    assert toyoura.main(["--single-sigma", "--error-groups", "--processes", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--single-sigma and --error-groups: choose one error model" in err[0]
    assert not out.exists()


def test_sand_studies_default_to_error_groups_by_quantity_or_the_study_files_own(tmp_path):
    shipped = sand.default_error_model(load_study(toyoura.STUDY))
    assert shipped.groups == {"stress": ("q", "u"), "volume": ("e",)} and shipped.bounds == (0.0, 1.0)
    path = _edited(tmp_path, "bounds = [0.0, 1.0]\n\n[sampler]",
                   'bounds = [0.0, 1.0]\ngroups = { load = ["q"], pores = ["e"] }\n\n[sampler]')
    assert sand.default_error_model(load_study(path)).groups == {"load": ("q",), "pores": ("e",)}
