"""cases.calibrate: the study file (every validation error names file, field and value), the CSV checks, the example
studies (SYNTHETIC data equal to direct driver / FE calls), a tiny end-to-end calibration and the --diagnose loop."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from corpus_inputs import LAB_CSV as CSV
from corpus_inputs import LAB_TOML as TOML
from tolerances import FE_RTOL, PRINTED_RTOL

import inference
from cases import burswood_sbp
from cases import calibrate as cal
from cases.study.checks import StudyError
from cases.study.cli import arguments
from cases.study.loop.study_problem import StudyProblem
from cases.study.reading.records import generating_values, load_observations
from cases.study.reading.schema import Settings, load_study
from cases.study.routes import sbp as sbp_route
from cases.study.synthetic.generate import generate
from constitutive import ANICREEP, SIMSAND, ModifiedCamClay, labtests
from inference.observations import DataError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "cases" / "examples"
VALIDATION_STUDIES = ROOT / "validation" / "studies"
LAB_EXAMPLES = ("triaxial_drained", "triaxial_undrained", "oedometer_crs", "oedometer_creep")
DESIGN_FIELDS = ("case", "method", "seed", "n_samples", "n_stages", "n_forward_solves", "wall_s", "ranks",
                 "parameters", "sigma_eps", "log_evidence", "J_g_at_map")



# ------------------------------------------------------------------------------------------------ a valid study
def _study(tmp_path, toml=TOML, csv=CSV, name="study.toml"):
    (tmp_path / "t1.csv").write_text(csv)
    path = tmp_path / name
    path.write_text(toml)
    return path


def test_a_valid_study_loads(tmp_path):
    s = load_study(_study(tmp_path))
    assert s.model == "ModifiedCamClay" and s.free == {"M": (0.8, 1.8), "ocr": (1.0, 4.0)}
    assert s.log_uniform == ("ocr",) and s.tests[0].start_p == 100.0
    obs, times = load_observations(s.tests)
    assert list(obs["T1"].curves) == ["q", "void_ratio"] and times["T1"] is None
    problem = StudyProblem(s, obs, times, quick=True)
    prior = problem.prior(s.free, s.log_uniform)
    assert prior.names == ("M", "sigma_eps", "ocr") and prior.bounds[2].kind == "log-uniform"
    # a laboratory study's specimens are material points: the coupled FE's drainage enrichment is unavailable
    cands = {c["name"]: c for c in problem.candidates()}
    assert cands["partial drainage"]["enrichment"] is None and "material point" in cands["partial drainage"][
        "unavailable"]
    assert cands["viscosity"]["enrichment"]["switches"] == {"viscous": True}


def test_every_class_of_the_loop_tolerates_failed_solves(tmp_path, monkeypatch):
    """The loop's classes, base and enriched alike, stop only when nearly every solve of a stage fails (a prior holds
    regions the programme cannot follow: those draws are zero likelihood)."""
    from cases.study.loop import problem as problem_module

    s = load_study(_study(tmp_path))
    obs, times = load_observations(s.tests)
    problem = StudyProblem(s, obs, times, quick=True)
    seen = []

    def stop(like, prior, run, out, seed, n_samples, **kw):
        seen.append(kw.get("max_failure_fraction"))
        raise RuntimeError("recorded")

    monkeypatch.setattr(problem_module.runner, "calibrate", stop)
    problem.start(obs, None, tmp_path, 1, s.settings(True), "test")
    for candidate in (None, "viscosity"):
        with pytest.raises(RuntimeError, match="recorded"):
            problem.calibrate(candidate)
    assert seen == [problem.failure_fraction] * 2 and problem.failure_fraction == 0.9


def _replace(old, new):
    assert old in TOML, old
    return TOML.replace(old, new)


# (TOML text, field named in the message, value named in the message)
BAD_TOMLS = [
    (_replace('type = "triaxial"', 'type = "triax"'), "tests['T1'].type", "'triax'"),
    (_replace('name = "ModifiedCamClay"', 'name = "CamClay"'), "model.name", "'CamClay'"),
    (_replace('file = "t1.csv"', 'file = "nope.csv"'), "tests['T1'].file", "'nope.csv'"),
    (_replace("nu = 0.3\n", "nu = 0.3\nM = 1.2\n"), "model.free.M", "[0.8, 1.8]"),
    (_replace("M = [0.8, 1.8]", "M = [1.8, 0.8]"), "model.free.M", "[1.8, 0.8]"),
    (_replace("M = [0.8, 1.8]", "M = [0.8, 1.8]\nphi = [20, 40]"), "model.free.phi", "[20, 40]"),
    (_replace("strain_rate = 1e-5", "strain_rate = -1e-5"), "tests['T1'].strain_rate", "-1e-05"),
    (_replace("p0 = 100.0", "p0 = 0.0"), "tests['T1'].p0", "0.0"),
    (_replace("bounds = [1.0, 4.0]", "bounds = [0.0, 4.0]"), "model.free.ocr.bounds", "[0.0, 4.0]"),
    (_replace('prior = "log-uniform"', 'prior = "normal"'), "model.free.ocr.prior", "'normal'"),
    (_replace("strain_rate = 1e-5", "straln_rate = 1e-5"), "tests['T1'].straln_rate", "1e-05"),
    (_replace('drainage = "drained"', 'drainage = "partly"'), "tests['T1'].drainage", "'partly'"),
    (_replace('direction = "compression"', 'direction = "sideways"'), "tests['T1'].direction", "'sideways'"),
    (_replace("p0 = 100.0", "p0 = 100.0\nK0 = 0.5"), "tests['T1'].K0", "0.5"),
    (_replace('consolidation = "isotropic"', 'consolidation = "K0"'), "tests['T1'].sigma_v0", "missing"),
    (_replace("kappa = 0.04\n", "").replace("M = [0.8, 1.8]", "M = [0.8, 1.8]\nkappa = [0.25, 0.3]"),
     "model.free.kappa", "no point of the prior box satisfies kappa < lambda_, lambda_ = 0.2 fixed"),
    (_replace("lambda_ = 0.2", "lambda_ = 0.03"), "[model.fixed]", "'lambda_': 0.03"),
    (_replace("M = [0.8, 1.8]", "M = [0.8, 1.8]\nsigma_eps = [0.01, 0.2]"), "model.free.sigma_eps", "[0.01, 0.2]"),
    (_replace("e0 = 1.0\n", ""), "tests['T1'].e0", "missing"),
    (_replace("nu = 0.3\n", "nu = 0.3\nG = 2000.0\n"), "[model]", "exactly one of G or nu"),
    (_replace("lambda_ = 0.2\n", ""), "[model]", "lambda_ is missing"),
    (_replace('type = "triaxial"', 'type = "sbp"'), "tests['T1'].drainage", "unknown field; expected one of"),
    (_replace("[sigma_eps]", "[sampler]\nsamples = 2\n\n[sigma_eps]"), "sampler.samples", "2"),
    (_replace("strain_rate = 1e-5", 'strain_rate = 1e-5\ncurves = ["excess_pore_pressure"]'), "tests['T1'].curves",
     "['excess_pore_pressure']"),
    (_replace('name = "mini"', 'name = "mini"\nmodle = 1'), "modle", "1"),
    (_replace("[[tests]]", "[model.free.extra]\n[[tests]]"), "model.free.extra", "{}"),
    (TOML + '\n[[tests]]\nname = "T1"\nfile = "t1.csv"\ntype = "oedometer_crs"\nsigma_v0 = 50.0\nK0 = 0.5\n'
            'strain_rate = 1e-6\ne0 = 1.0\n', "tests['T1'].name", "'T1'"),
    (TOML + '\n[[tests]]\nfile = "t1.csv"\ntype = "oedometer_creep"\nsigma_v0 = 50.0\nK0 = 0.5\ne0 = 1.0\n'
            'stage_stress = [100.0]\nstage_duration = 10.0\nload_time = 20.0\n', "tests['t1'].load_time", "20.0"),
    (_replace("nu = 0.3\n", ""), "[model]", "exactly one of G or nu (fixed or free), got none"),
    ("[model\nname = 1", "study.toml", "not valid TOML"),
]


@pytest.mark.parametrize("toml, where, value", BAD_TOMLS, ids=[f"{w} {v}"[:40] for _, w, v in BAD_TOMLS])
def test_every_bad_study_field_is_named_with_file_and_value(tmp_path, toml, where, value):
    path = _study(tmp_path, toml)
    with pytest.raises(StudyError) as err:
        load_study(path)
    msg = str(err.value)
    assert str(path) in msg and where in msg and value in msg, msg


ANICREEP_TOML = """[model]
name = "ANICREEP"
viscous = {viscous}
[model.fixed]
lambda_ = 0.4
kappa = 0.026
nu = 0.3
e0 = 2.0
{fixed}
[model.free]
M = [0.8, 2.0]
sigma_p0 = [20.0, 200.0]
{free}
[[tests]]
file = "t1.csv"
{test}
"""
SBP_TEST = ('type = "sbp"\nsigma_v0 = 31.0\nK0 = 0.9\nu0 = 38.8\npermeability = 3.3e-9\nprobe_radius = 0.0415\n'
            'strain_rate = 0.00167')
CRS_TEST = 'type = "oedometer_crs"\nsigma_v0 = 50.0\nK0 = 0.5\nstrain_rate = 1e-6'


@pytest.mark.parametrize("viscous, fixed, free, test, where, value", [
    ("true", "", "", CRS_TEST, "[model]", "viscous = true needs C_alpha_e"),
    ("false", "", "C_alpha_e = [0.001, 0.1]", CRS_TEST, "model.free.C_alpha_e", "not used when viscous = false"),
    ("false\ndestructuration = true", "chi0 = 5.0\nxi = 9.0", "", CRS_TEST, "[model]",
     "destructuration = true needs xi_d"),
    ("false", "", "", CRS_TEST + "\ne0 = 1.5", "tests['t1'].e0", "1.5"),
    ("1", "", "", CRS_TEST, "model.viscous", "1"),
    ("false", "", "", SBP_TEST.replace("probe_radius = 0.0415", "probe_radius = -0.04"), "tests['t1'].probe_radius",
     "-0.04"),
    ("false", "", "", SBP_TEST.replace("u0 = 38.8", "u0 = -1.0"), "tests['t1'].u0", "-1.0"),
    ("false", "", "M2 = [0.1, 0.2]", CRS_TEST, "model.free.M2", "[0.1, 0.2]"),
    ("false", "", "", CRS_TEST.replace('"oedometer_crs"', '"oedometer"'), "tests['t1'].type", "'oedometer'"),
    ("false", "", "", CRS_TEST.replace("sigma_v0 = 50.0\n", ""), "tests['t1'].sigma_v0", "missing"),
    ("false", "", "", CRS_TEST + "\nsubsteps = 0", "tests['t1'].substeps", "0"),
])
def test_anicreep_and_test_type_errors_name_field_and_value(tmp_path, viscous, fixed, free, test, where, value):
    path = _study(tmp_path, ANICREEP_TOML.format(viscous=viscous, fixed=fixed, free=free, test=test))
    with pytest.raises(StudyError) as err:
        load_study(path)
    msg = str(err.value)
    assert str(path) in msg and where in msg and value in msg, msg


def test_simsand_refuses_the_pressuremeter(tmp_path):
    toml = ("[model]\nname = \"SIMSAND\"\n[model.fixed]\n"
            + "".join(f"{k} = {v}\n" for k, v in dict(nu=0.2, K_0=100, n=0.6, lambda_c=0.03, xi=0.6, phi_mu=30.0,
                                                      k_p=0.003, A_d=1.0, n_p=2.0, n_d=2.0).items())
            + "[model.free]\ne_ref = [0.5, 1.5]\n[[tests]]\nfile = \"t1.csv\"\ne0 = 0.7\n" + SBP_TEST)
    with pytest.raises(StudyError, match=r"tests\['t1'\]\.type = 'sbp': the pressuremeter FE runs"):
        load_study(_study(tmp_path, toml))


# (CSV text, what the message must contain besides the file name)
BAD_CSVS = [
    (CSV.replace("q_kPa", "q_kpa"), ["column 'q_kpa'", "known:"]),
    (CSV.replace(",q_kPa", ",deviator_kPa"), ["column 'deviator'"]),
    (CSV.replace("axial_strain_pct,q_kPa,void_ratio", "axial_strain_pct,void_ratio").replace(",40,", ",")
     .replace(",70,", ",").replace(",95,", ",").replace(",110,", ","), ["missing column 'q'"]),
    (CSV.replace("2.0,95", "2.0,abc"), ["line 5", "column 'q_kPa'", "'abc'"]),
    (CSV.replace("2.0,95", "0.8,95"), ["line 5", "column 'axial_strain'", "0.8"]),
    (CSV.replace("axial_strain_pct", "axial_strain"), ["column 'axial_strain'", "unit '-'"]),
    (CSV.replace("q_kPa", "q [psi]"), ["line 2", "column 'q [psi]'", "unit 'psi' is not supported: convert to kPa"]),
    (CSV.replace("0.5,40", "-0.5,40"), ["line 3", "column 'axial_strain'", "-0.5"]),
    (CSV.replace("0.97", "-0.97"), ["line 5", "column 'void_ratio'", "-0.97"]),
    (CSV.replace("void_ratio", "excess_pore_pressure_kPa"), ["column 'excess_pore_pressure'", "drained"]),
    (CSV.replace("4.0,110", "140.0,110"), ["line 6", "column 'axial_strain'", "140"]),
    (CSV.replace("axial_strain_pct,q_kPa,void_ratio", "axial_strain_pct,q_kPa,void_ratio,time_s")
     .replace("0.99", "0.99,10").replace("0.98", "0.98,20").replace("0.97", "0.97,5").replace("0.96", "0.96,30"),
     ["line 5", "column 'time'", "5"]),
    ("# only a comment\n", ["no header or no data rows"]),
]


@pytest.mark.parametrize("csv, parts", BAD_CSVS, ids=[p[0][:30] for _, p in BAD_CSVS])
def test_bad_csv_names_file_column_and_row(tmp_path, csv, parts):
    study = load_study(_study(tmp_path, csv=csv))
    with pytest.raises(DataError) as err:
        load_observations(study.tests)
    msg = str(err.value)
    assert "t1.csv" in msg and all(p in msg for p in parts), msg


@pytest.mark.parametrize("test, csv, parts", [
    ('type = "triaxial"\ndrainage = "undrained"\ndirection = "extension"\nconsolidation = "isotropic"\np0 = 100.0\n'
     'strain_rate = 1e-5', "axial_strain_pct,q_kPa\n0.5,-40\n1.0,-60\n", ["line 2", "extension", "0.5"]),
    ('type = "triaxial"\ndrainage = "undrained"\ndirection = "extension"\nconsolidation = "isotropic"\np0 = 100.0\n'
     'strain_rate = 1e-5', "axial_strain_pct,q_kPa\n-0.5,-40\n-0.2,-60\n", ["line 3", "does not decrease"]),
    (SBP_TEST, "cavity_strain_pct,cavity_pressure_kPa\n5,100\n12,140\n", ["line 3", "'cavity_strain'", "12"]),
    (SBP_TEST, "cavity_strain_pct,cavity_pressure_kPa\n5,100\n6,-140\n", ["line 3", "'cavity_pressure'", "-140"]),
    ('type = "oedometer_creep"\nsigma_v0 = 20.0\nK0 = 0.6\nstage_stress = [40.0, 80.0]\nstage_duration = 100.0\n'
     'load_time = 1.0', "time_s,axial_strain_pct\n10,1.0\n100.5,1.5\n", ["line 3", "'time'", "100.5"]),
    ('type = "oedometer_creep"\nsigma_v0 = 20.0\nK0 = 0.6\nstage_stress = [40.0, 80.0]\nstage_duration = 100.0\n'
     'load_time = 1.0', "time_s,axial_strain_pct\n10,1.0\n250,1.5\n", ["line 3", "'time'", "250"]),
    (CRS_TEST + '\ncurves = ["axial_stress"]', "axial_strain_pct,q_kPa\n1,10\n2,20\n",
     ["'q'", "not a column of a oedometer_crs test"]),
])
def test_bad_csv_of_each_test_type(tmp_path, test, csv, parts):
    path = _study(tmp_path, ANICREEP_TOML.format(viscous="false", fixed="", free="", test=test), csv=csv)
    with pytest.raises(DataError) as err:
        load_observations(load_study(path).tests)
    msg = str(err.value)
    assert "t1.csv" in msg and all(p in msg for p in parts), msg


def test_nothing_is_written_on_error(tmp_path, capsys):
    path = _study(tmp_path, _replace("M = [0.8, 1.8]", "M = [1.8, 0.8]"))
    out = tmp_path / "out"
    assert cal.main([str(path), "--quick", "--out", str(out)]) == 2
    assert not out.exists()
    assert "model.free.M" in capsys.readouterr().err
    bad_csv = _study(tmp_path, csv=CSV.replace("2.0,95", "0.8,95"))
    assert cal.main([str(bad_csv), "--diagnose", "--out", str(out)]) == 2
    assert not out.exists()


# ------------------------------------------------------------------------------------------------ examples
def test_examples_are_labelled_synthetic_and_documented():
    source = (EXAMPLES / "SOURCE.md").read_text()
    assert "SYNTHETIC" in source
    for name in LAB_EXAMPLES + ("sbp",):
        study = load_study(EXAMPLES / f"{name}.toml")
        assert name in source
        for t in study.tests:
            first = t.file.read_text().splitlines()[0]
            assert first.startswith("# synthetic: NOT MEASURED DATA"), t.file
        obs, _ = load_observations(study.tests)
        assert generating_values(obs) == {k: study.synthetic["parameters"][k] for k in study.free}


def _records(path):
    """(header lines, column names, values (n, k)) of a record CSV."""
    lines = path.read_text().splitlines()
    header = [line for line in lines if line.startswith("#")]
    rows = [line for line in lines if line and not line.startswith("#")]
    return header, rows[0], np.array([[float(v) for v in row.split(",")] for row in rows[1:]])


@pytest.mark.parametrize("name", LAB_EXAMPLES + ("sbp",))
def test_shipped_example_data_equal_the_generator(tmp_path, name):
    """The generator rewrites the shipped records: same header and columns, and the same numbers to the precision
    they are printed with: the abscissa is the shortest round trip of a float that vectorized exp/log may compute
    1 ulp apart on another CPU (rel 1e-12), the values have 9 significant digits (a flipped last digit is at most
    rel 1e-8); FE values to the Newton tolerance (FE_RTOL)."""
    shutil.copy(EXAMPLES / f"{name}.toml", tmp_path)
    paths = generate(tmp_path / f"{name}.toml")
    for t in load_study(EXAMPLES / f"{name}.toml").tests:
        head, cols, values = _records(paths[t.name])
        ref_head, ref_cols, ref_values = _records(t.file)
        assert (head, cols) == (ref_head, ref_cols), t.name
        assert values.shape == ref_values.shape, t.name
        np.testing.assert_allclose(values[:, 0], ref_values[:, 0], rtol=1e-12, atol=0, err_msg=t.name)
        np.testing.assert_allclose(values[:, 1:], ref_values[:, 1:], atol=0, err_msg=t.name,
                                   rtol=FE_RTOL if t.type == "sbp" else PRINTED_RTOL)


def _noise_free(tmp_path, name):
    shutil.copy(EXAMPLES / f"{name}.toml", tmp_path)
    generate(tmp_path / f"{name}.toml", noise=0.0)
    study = load_study(tmp_path / f"{name}.toml")
    obs, times = load_observations(study.tests)
    return study, obs


def _direct(name, study, t, x):
    """The example's curves by a direct call of the laboratory driver (not through cases.calibrate)."""
    gen = study.synthetic["parameters"]
    if name == "triaxial_drained":
        model = SIMSAND(**study.fixed, **gen)
        c = labtests.drained_triaxial(model, t.e0, t.p0, x / 100.0)
        return {"q": c["q"][0], "void_ratio": c["e"][0]}
    if name == "triaxial_undrained":
        model = ModifiedCamClay(**study.fixed, **gen)
        steps = int(np.ceil(np.max(np.abs(np.diff(np.r_[0.0, x / 100.0]))) / 0.0025 - 1e-9))  # <= 0.25 % strain
        p0 = t.p0 if t.consolidation == "isotropic" else t.sigma_v0 * (1 + 2 * t.K0) / 3
        c = labtests.undrained_triaxial(model, t.e0, p0, x / 100.0, k0=1.0 if t.consolidation == "isotropic" else
                                        t.K0, substeps=steps, strain_rate=t.strain_rate)
        return {"q": c["q"][0], "p": c["p"][0], "excess_pore_pressure": c["excess_pore_pressure"][0]}
    model = ANICREEP(**study.fixed, **gen)
    if name == "oedometer_crs":
        steps = int(np.ceil(np.max(np.diff(np.r_[0.0, x / 100.0])) / 0.0025 - 1e-9))
        c = labtests.oedometer_crs(model, study.fixed["e0"], t.sigma_v0, x / 100.0, t.strain_rate, k0=t.K0,
                                   substeps=steps)
        return {"axial_stress": c["axial_stress"][0]}
    c = labtests.oedometer_loading(model, study.fixed["e0"], t.sigma_v0, list(t.stage_stress), t.stage_duration,
                                   n_times=t.n_times, load_time=t.load_time, k0=t.K0)
    np.testing.assert_allclose(c["time"][0], x, rtol=1e-8)  # the records are at the driver's own times (9 digits)
    return {"axial_strain": 100.0 * c["axial_strain"][0]}


@pytest.mark.parametrize("name", LAB_EXAMPLES)
def test_noise_free_example_equals_the_driver_and_the_forward_model_reproduces_it(tmp_path, name):
    study, obs = _noise_free(tmp_path, name)
    forward = StudyProblem(study, obs, {}, quick=False).forward(study.switches)
    gen = study.synthetic["parameters"]
    like = inference.Likelihood(obs, forward, batch=True)
    sim = like.simulated_at_observations(forward([gen])[0])
    for t in study.tests:
        direct = _direct(name, study, t, next(iter(obs[t.name].curves.values())).x)
        for c, curve in obs[t.name].curves.items():
            np.testing.assert_allclose(curve.y, direct[c], rtol=2e-8, err_msg=f"{t.name} {c}: file vs driver")
            np.testing.assert_allclose(sim[t.name, c], curve.y, rtol=2e-8, err_msg=f"{t.name} {c}: forward")
    like.bind([*gen, "sigma_eps"])
    assert max(like.summary_goodness([*gen.values(), 0.02]).values()) < 1e-14


def test_noise_free_sbp_example_equals_the_burswood_forward_model(tmp_path):
    study, obs = _noise_free(tmp_path, "sbp")
    t = study.tests[0]
    gen = study.synthetic["parameters"]
    burswood = load_study(burswood_sbp.STUDY)
    assert sbp_route.site_of(burswood) == t.site
    fixed = {k: v for k, v in study.fixed.items() if k != "C_alpha_e"}
    direct = sbp_route.sbp_forward(burswood, study.preset(False), fixed=fixed, rates={t.name: t.strain_rate},
                                   curves=("cavity_pressure", "pore_pressure"))
    sim = direct({**gen, "C_alpha_e": study.fixed["C_alpha_e"]})
    for c, curve in obs[t.name].curves.items():
        np.testing.assert_allclose(curve.y, np.interp(curve.x, *sim[t.name][c]), rtol=2e-8)
    mine = StudyProblem(study, obs, {}, quick=False).forward(study.switches)([gen])[0]
    for c in obs[t.name].curves:
        np.testing.assert_allclose(mine[t.name][c][1], sim[t.name][c][1], rtol=1e-10)


def test_generate_refuses_a_study_without_generating_values(tmp_path):
    path = _study(tmp_path)
    with pytest.raises(StudyError, match=r"synthetic\.parameters\.M is missing"):
        generate(path)
    assert (tmp_path / "t1.csv").read_text() == CSV
    with pytest.raises(StudyError, match="synthetic.parameters.M is missing"):
        generate(VALIDATION_STUDIES / "concealed_viscosity.toml")  # never overwrites the case's data


def test_concealed_viscosity_study_has_the_case_data_and_forward_model():
    """The study file reads the case's records unchanged and its forward model equals the case's (to the 9
    digits of the recorded strains), for the base and the enriched class."""
    from validation.proofs import rates as cv

    study = load_study(VALIDATION_STUDIES / "concealed_viscosity.toml")
    obs, _ = load_observations(study.tests)
    ref = cv.load_data(cv.DATASETS["concealed"])
    assert [t.name for t in obs] == [t.name for t in ref]
    for a, b in zip(obs, ref):
        for c in b.curves:
            assert np.array_equal(a.curves[c].x, b.curves[c].x) and np.array_equal(a.curves[c].y, b.curves[c].y)
    for switches, extra in ((cv.BASE_SWITCHES, {}), ({"viscous": True, "anisotropy": True}, {"C_alpha_e": 0.02})):
        batch = [{"M": 1.4, "sigma_p0": 90.0, **extra}, {"M": 1.6, "sigma_p0": 120.0, **extra}]
        mine = StudyProblem(study, obs, {}, quick=False).forward(switches)(batch)
        theirs = cv.PROBLEM.forward(switches)(batch)
        for m, r in zip(mine, theirs):
            for t in r:
                for c in r[t]:
                    np.testing.assert_allclose(m[t][c], r[t][c], rtol=1e-8)


def test_covariates_keep_only_informative_between_test_conditions():
    study = load_study(EXAMPLES / "triaxial_undrained.toml")
    obs, times = load_observations(study.tests)
    problem = StudyProblem(study, obs, times, quick=True)
    gen = study.synthetic["parameters"]
    like = inference.Likelihood(obs, problem.forward(study.switches), batch=True)
    cov = problem.curve_covariates(like, problem.map_curves(gen, study.switches))
    # one strain rate and one loading phase: not reported; two directions and two consolidations: reported; records
    # follow the largest recorded |q| of each shear test (a noisy plateau): post-peak strain, within the tests
    assert set(cov) == {"time", "strain level", "stress ratio", "mean effective stress", "stress path direction",
                        "consolidation", "post-peak strain"}
    direction = cov["stress path direction"]
    assert direction["values"][("CIUE", "p")] == "extension" and direction["kind"] == "categorical"
    # compared at equal strain magnitude: the extension test's negative strains on the compression test's axis
    np.testing.assert_array_equal(direction["abscissa"][("CIUE", "p")], np.abs(obs["CIUE"].curves["p"].x))
    assert np.all(direction["abscissa"][("CIUE", "p")] >= 0)


# ------------------------------------------------------------------------------------------------ end to end
@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory):
    """The undrained example with a tiny quick preset: N_s 16, at most 2 sweeps per stage, 8 predictive draws."""
    d = tmp_path_factory.mktemp("tiny")
    text = (EXAMPLES / "triaxial_undrained.toml").read_text()
    quick = "[sampler.quick]\nsamples = 64\nmax_steps = 4\npredictive_draws = 24\n"
    assert quick in text
    (d / "tiny.toml").write_text(text.replace(quick, "[sampler.quick]\nsamples = 16\nmax_steps = 2\n"
                                                     "predictive_draws = 8\n"))
    for t in load_study(d / "tiny.toml", check_files=False).tests:
        (d / "data").mkdir(exist_ok=True)
        shutil.copy(EXAMPLES / "data" / t.file.name, d / "data")
    return d / "tiny.toml"


@pytest.fixture(scope="module")
def tiny_run(tiny_study):
    out = tiny_study.parent / "run"
    assert cal.main([str(tiny_study), "--quick", "--processes", "1", "--out", str(out)]) == 0
    return out


def test_tiny_quick_calibration_writes_the_design_summary_and_moves_toward_the_generating_values(tiny_run):
    summary = json.loads((tiny_run / "summary.json").read_text())
    for key in DESIGN_FIELDS:
        assert key in summary, key
    assert summary["case"] == "calibrate" and summary["study"] == "triaxial_undrained"
    assert summary["synthetic_recordings"] and summary["n_samples"] == 16
    for name in ("curves.png", "stress_paths.png", "marginals.png", "pairs.png", "stages.png", "posterior.npz",
                 "report.md"):
        assert (tiny_run / name).is_file(), name
    assert "SYNTHETIC" in (tiny_run / "report.md").read_text()
    gen = summary["generating"]
    assert gen == {"M": 1.2, "ocr": 1.5}
    prior_mean = {"M": 1.3, "ocr": 3.0 / np.log(4.0)}  # uniform [0.8, 1.8]; log-uniform [1, 4]
    for name, p in summary["parameters"].items():
        if name in gen:
            assert abs(p["mean"] - gen[name]) < 0.25 * abs(prior_mean[name] - gen[name]), (name, p)
    samples = np.load(tiny_run / "posterior.npz")
    assert list(samples["names"]) == ["M", "sigma_eps", "ocr"]


def test_a_finished_run_resumed_gives_its_answer_without_sampling_again(tiny_run, tmp_path):
    """The finished run keeps its checkpoint; --resume on a copy of its folder returns the same posterior (samples,
    ln Z) with no forward solve of the sampler in the new session."""
    assert (tiny_run / "run.ckpt").is_file()
    out = tmp_path / "again"
    shutil.copytree(tiny_run, out)
    before = json.loads((out / "summary.json").read_text())
    assert cal.main([str(tiny_run.parent / "tiny.toml"), "--quick", "--processes", "1", "--out", str(out),
                     "--resume"]) == 0
    after = json.loads((out / "summary.json").read_text())
    assert after["log_evidence"] == before["log_evidence"] and after["n_forward_solves"] == before["n_forward_solves"]
    np.testing.assert_array_equal(np.load(out / "posterior.npz")["samples"],
                                  np.load(tiny_run / "posterior.npz")["samples"])
    log = (out / "progress.log").read_text()
    resumed = log[log.rindex("resuming from"):]   # the new session's lines
    first, *later = resumed.splitlines()
    assert "phase done" in first   # and nothing sampled after it: no stage, no batch of evaluations
    assert not [line for line in later if line.lstrip().startswith("stage ") or "evaluations" in line]


def test_tiny_run_posterior_nc_has_the_groups_and_the_npz_posterior(tiny_run):
    """posterior.nc reads back with arviz: its posterior is the npz's final-stage sample (same mean), observed_data the
    recorded curves of the study's CSVs, posterior_predictive the MAP's curves at them, sample_stats the schedule,
    log_likelihood each draw's terms per point."""
    import arviz as az

    idata = az.from_netcdf(tiny_run / "posterior.nc")
    assert {"posterior", "log_likelihood", "sample_stats", "observed_data", "posterior_predictive"} <= set(
        idata.groups())
    npz = np.load(tiny_run / "posterior.npz")
    for i, name in enumerate(npz["names"]):
        assert float(idata.posterior[str(name)].mean()) == pytest.approx(npz["samples"][:, i].mean(), rel=1e-12)
    np.testing.assert_array_equal(idata.sample_stats["beta"].values, npz["beta"])
    lines = (tiny_run.parent / "data" / "triaxial_undrained_CK0UC.csv").read_text().splitlines()
    recorded = np.array([[float(v) for v in line.split(",")] for line in lines[1:] if not line.startswith("#")
                         and not line.startswith("axial_strain")])
    np.testing.assert_allclose(idata.observed_data["CK0UC:q"].values, recorded[:, 1])
    assert idata.posterior_predictive["CK0UC:q"].shape == (1, 1, recorded.shape[0])
    # a laboratory study is cheap: each draw's log-likelihood per point, summing to the sampler's total (Eq. (6))
    per_point = sum(idata.log_likelihood[v].values[0].sum(axis=1) for v in idata.observed_data.data_vars)
    np.testing.assert_allclose(per_point, idata.log_likelihood["total"].values[0], rtol=1e-10)


def test_pointwise_terms_are_computed_only_within_the_budget():
    """posterior.nc's per-point log-likelihood: asked of the likelihood when the MAP's solve time x the draws stays
    within runner.POINTWISE_BUDGET_S, never with a discrepancy, None when a solve fails."""
    from types import SimpleNamespace

    from cases.study import runner

    post = SimpleNamespace(samples=np.zeros((100, 2)))
    asked = []

    def simulated_many(samples):
        asked.append(len(samples))
        return {"sims": samples}

    like = SimpleNamespace(discrepancy=None, simulated_many=simulated_many,
                           pointwise_log_likelihood=lambda sims, thetas: {"terms": sims["sims"]})
    per_draw = runner.POINTWISE_BUDGET_S / 100
    assert runner.pointwise_terms(like, post, 0.9 * per_draw)["terms"] is post.samples and asked == [100]
    assert runner.pointwise_terms(like, post, 1.1 * per_draw) is None and asked == [100]
    assert runner.pointwise_terms(SimpleNamespace(**{**vars(like), "discrepancy": object()}), post, 0.0) is None

    def fails(samples):
        raise inference.ForwardModelError("diverged")

    assert runner.pointwise_terms(SimpleNamespace(**{**vars(like), "simulated_many": fails}), post, 0.0) is None


def test_tiny_run_report_ends_with_the_glossary_of_its_symbols(tiny_run):
    report = (tiny_run / "report.md").read_text()
    glossary = report[report.index("## Glossary"):]
    for symbol in ("ln Z", "ln S", "J_g", "ESS", "beta", "sigma_eps"):
        assert f"- **{symbol}**: " in glossary, symbol
    assert "ln Z = " in report[:report.index("## Glossary")]


@pytest.mark.parametrize("processes", ["1", "2"])
def test_diagnose_on_the_tiny_run_writes_diagnosis_json(tiny_study, processes, children_left):
    """One process, or a pool with the background drawer of the figures: the same files, no process left."""
    out = tiny_study.parent / f"diag_{processes}"
    assert cal.main([str(tiny_study), "--quick", "--processes", processes, "--out", str(out), "--diagnose"]) == 0
    assert not children_left()
    for name in ("curves.png", "marginals.png", "pairs.png", "stages.png", "diagnosis.png"):
        assert (out / name).is_file(), name
    d = json.loads((out / "diagnosis.json").read_text())
    for key in ("verdict", "omitted_physics", "mismatch_regions", "candidates", "classes", "log_bayes"):
        assert key in d, key
    assert d["classes"][0]["role"] == "base" and d["classes"][0]["name"] == "ModifiedCamClay()"
    # data made by the base class: nothing to adopt (and the catalog has no enrichment of Modified Cam Clay)
    assert d["omitted_physics"] == "none"
    assert (out / "summary.json").is_file() and (out / "diagnosis.md").is_file() and (out / "loop.json").is_file()
    assert json.loads((out / "summary.json").read_text())["model_class"] == "ModifiedCamClay()"
    # the class's posterior.nc, kept to the loop's end and written with its figures: the npz's final stage
    import arviz as az
    npz = np.load(out / "posterior.npz")
    idata = az.from_netcdf(out / "posterior.nc")
    for k, name in enumerate(npz["names"]):
        assert idata.posterior[str(name)].values.ravel() == pytest.approx(npz["samples"][:, k])
    assert not list(out.glob("*.tmp"))


@pytest.mark.slow
def test_concealed_viscosity_study_reproduces_the_case_loop(tmp_path):
    """The concealed-viscosity data written as a study file: cases.calibrate --diagnose gives the case's own loop
    (same likelihood up to the 9 digits of the recorded strains, prior order and covariates): equal log-evidences,
    viscosity named and confirmed."""
    from validation.proofs import rates as cv

    settings = Settings(24, 5, 60)  # the study file's [sampler.quick] with --samples 24
    args = arguments("", ["--samples", "24", "--processes", "1"])
    ref = cv.run_loop(cv.load_data(cv.DATASETS["concealed"]), args, tmp_path / "case", 3, settings,
                      "test").final.to_dict()
    argv = [str(VALIDATION_STUDIES / "concealed_viscosity.toml"), "--quick", "--samples", "24", "--seed", "3",
            "--processes", "1", "--out", str(tmp_path / "study"), "--diagnose"]
    assert cal.main(argv) == 0
    mine = json.loads((tmp_path / "study" / "diagnosis.json").read_text())
    assert mine["omitted_physics"] == ref["omitted_physics"] == "viscosity"
    # the base, the model-form class and every candidate the screening chose, the same in both
    assert len(mine["classes"]) == len(ref["classes"]) >= 3
    for a, b in zip(mine["classes"], ref["classes"]):  # names differ: the study states destructuration=False
        assert (a["role"], a.get("candidate")) == (b["role"], b.get("candidate"))
        assert a["log_evidence"] == pytest.approx(b["log_evidence"], rel=1e-6)
