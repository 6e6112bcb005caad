"""The SIMSAND studies (cases/studies/simsand_synthetic.toml, toyoura.toml through cases.study.routes.sand) and their
forward model (cases.study.forward.lab)."""
import json
from pathlib import Path

import numpy as np
import pytest

import inference
from cases import simsand_synthetic, toyoura
from cases.study.forward.lab import LabForward
from cases.study.programme import TestSpec
from cases.study.reading.schema import load_study
from cases.study.routes import sand as sand_route
from cases.study.routes.sand_study import conditions_of
from constitutive import SIMSAND

SYN = load_study(simsand_synthetic.STUDY)
TOY = load_study(toyoura.STUDY)
TRUE = SYN.references["generating"].values
TESTS = [(t.name, t.e0, t.p0) for t in SYN.tests]
STRAIN_PCT = tuple(np.round(np.arange(1, 51) * 0.5, 10))
TOY_FILES = {t.name: Path(t.file) for t in TOY.tests}


def _syn(noise, free=None):
    return sand_route.build(SYN, free, noise=noise)


def test_noise_free_data_is_the_forward_model_at_the_true_values():
    """The shipped noise-free CSVs equal SIMSAND's triaxial_test at the true values, run directly (exact up to the
    round-off of the batch size; the CSV keeps 17 digits)."""
    obs = _syn(0.0).all_obs
    ea = np.array(STRAIN_PCT) / 100.0
    for name, e0, p0 in TESTS:
        direct = SIMSAND(**TRUE).triaxial_test(e0, p0, ea)
        t = obs[name]
        np.testing.assert_array_equal(t.curves["q"].x, STRAIN_PCT)
        np.testing.assert_allclose(t.curves["q"].y, direct["q"][0], rtol=1e-9)
        np.testing.assert_allclose(t.curves["e"].y, direct["e"][0], rtol=1e-9)
        assert t.conditions["synthetic"].startswith("true")
        assert float(t.conditions["e0"]) == e0 and float(t.conditions["p0_kPa"]) == p0


def test_likelihood_of_noise_free_data_peaks_at_the_true_values():
    s = _syn(0.0)
    like, prior = s.like, s.prior
    like.bind(prior.names)
    theta = np.array([TRUE[n] for n in prior.names[:-1]] + [0.05])
    assert all(v < 1e-16 for v in like.summary_goodness(theta).values())
    off = theta.copy()
    off[prior.names.index("phi_mu")] = 30.5
    assert like(off) < like(theta) - 10.0


def test_noisy_data_relative_residual_std_is_the_stated_noise():
    """Noisy data / noise-free data - 1 = c - 1 with c ~ N(1, 0.1^2): its std over the 300 points is 0.1 within
    4 standard errors (0.1 / sqrt(2 N)), its mean 0 within 4 standard errors."""
    clean, noisy = _syn(0.0).all_obs, _syn(0.1).all_obs
    r = np.concatenate([noisy[t].curves[c].y / clean[t].curves[c].y - 1.0 for t in clean.tests for c in ("q", "e")])
    assert r.size == 300
    assert abs(r.std(ddof=1) - 0.1) < 4 * 0.1 / np.sqrt(2 * r.size)
    assert abs(r.mean()) < 4 * 0.1 / np.sqrt(r.size)
    assert "seed: " in sand_route.record_files(SYN, 0.1)["T1"].read_text()


def _table(path):
    lines = path.read_text().splitlines()
    rows = [x for x in lines if not x.startswith("#")]
    return [x for x in lines if x.startswith("#")] + rows[:1], np.loadtxt(rows[1:], delimiter=",")


def test_generator_is_reproducible(tmp_path):
    """The generator rewrites the shipped files: same header, same values to a relative 1e-9 (17 digits written;
    the tolerance allows the round-off of another CPU's vector kernels)."""
    files = sand_route.generate_records(SYN, 0.1, out=tmp_path)
    shipped_files = sand_route.record_files(SYN, 0.1)
    for name, path in files.items():
        (head, made), (shipped_head, shipped) = _table(path), _table(shipped_files[name])
        assert head == shipped_head
        np.testing.assert_allclose(made, shipped, rtol=1e-9, atol=0)


def _triaxial(name, e0, p0, drainage):
    return TestSpec(name, "triaxial", drainage=drainage, direction="compression", consolidation="isotropic", p0=p0,
                    e0=e0)


def test_forward_model_batches_tests_and_reports_failures_per_particle():
    """One batched call for all tests equals triaxial_test per test and particle; a particle that loses control is
    an exception with the test named, its neighbours are unaffected."""
    x = (0.5, 1.0, 5.0, 25.0)
    specs = [_triaxial("a", 0.6, 800.0, "drained"), _triaxial("b", 0.8, 25.0, "drained"),
             _triaxial("u", 0.8, 100.0, "undrained")]
    fw = LabForward("SIMSAND", specs, {t.name: np.array(x) / 100 for t in specs},
                    {t.name: ("q", "u") for t in specs},
                    {k: v for k, v in TRUE.items() if k not in ("phi_mu", "e_ref", "n_p")}, grid=x)
    batch = [dict(phi_mu=30.0, e_ref=0.75, n_p=2.0), dict(phi_mu=45.0, e_ref=1.5, n_p=10.0),
             dict(phi_mu=33.0, e_ref=0.8, n_p=1.0)]
    res = fw(batch)
    bad = SIMSAND(**{**fw.fixed, **batch[1]})
    failing = [t.name for t in specs if bad.triaxial_test(t.e0, t.p0, np.array(x) / 100,
                                                          drained=t.drainage == "drained",
                                                          on_failure="nan")["failed"][0]]
    assert failing, "the test needs a parameter set that loses control"
    assert isinstance(res[1], inference.ForwardModelError) and f"test(s) {failing}" in str(res[1])
    for i in (0, 2):
        model = SIMSAND(**{**fw.fixed, **batch[i]})
        for t in specs:
            direct = model.triaxial_test(t.e0, t.p0, np.array(x) / 100, drained=t.drainage == "drained")
            xs, q = res[i][t.name]["q"]
            np.testing.assert_array_equal(xs, (0.0,) + x)
            np.testing.assert_array_equal(q[1:], direct["q"][0])  # the compiled kernel: each point alone
            np.testing.assert_array_equal(res[i][t.name]["u"][1][1:], direct["excess_pore_pressure"][0])


def test_likelihood_does_not_depend_on_how_the_population_is_chunked():
    """A process pool hands each worker a chunk of the population: the synthetic study's log-likelihoods are the same
    bits for one batch and for chunks of 3 and 5, failed (prior) particles included."""
    s = _syn(0.0)
    like, prior = s.like, s.prior
    like.bind(prior.names)
    rng = np.random.default_rng(4)
    true = np.array([TRUE.get(k, 0.02) for k in prior.names])
    thetas = np.vstack([prior.sample(rng, 4), true * rng.uniform(0.97, 1.03, (4, true.size))])
    whole, _ = like.evaluate_many(thetas)
    parts = np.concatenate([like.evaluate_many(thetas[:3])[0], like.evaluate_many(thetas[3:])[0]])
    np.testing.assert_array_equal(whole, parts)
    assert np.isfinite(whole[4:]).all()


def test_toyoura_data_match_source_note():
    """The shipped files give the e0 and p'0 of SOURCE.md; q and e follow its formulas at a spot value."""
    expected = {"test1": (0.996, 100.0), "test2": (0.917, 100.0), "test3": (0.831, 100.0),
                "test4": (0.960, 500.0), "test5": (0.886, 500.0), "test6": (0.810, 500.0)}
    source = (TOY_FILES["test1"].parent / "SOURCE.md").read_text()
    for name, (e0, p0) in expected.items():
        t = sand_route.load_stress_ratio(name, TOY_FILES[name])
        c = conditions_of(t)
        assert (c.e0, c.p0, c.drainage) == (e0, p0, "drained")
        assert f"| {name[-1]} | {TOY_FILES[name].name} | {p0:g} | {e0:.3f} |" in source
        assert t.curves["q"].y[0] == 0.0 and t.curves["q"].x.max() > 25.0
    # TMD1 (test6) first row: eps_a 0, sr 1, eps_v 0.0617 % -> e = 0.81 - 1.81 * 0.000617
    assert (sand_route.load_stress_ratio("test6", TOY_FILES["test6"]).curves["e"].y[0]
            == pytest.approx(0.81 - 1.81 * 0.000617, rel=1e-12))


def test_user_undrained_csv_is_calibrated_with_the_undrained_route(tmp_path):
    f = tmp_path / "u7.csv"
    f.write_text("# e0: 0.735\n# p0_kPa: 100\neps_a_pct,q_kPa,u_kPa\n0.5,100,20\n1.0,150,30\n2.0,200,20\n")
    built = sand_route.build(TOY, undrained=[str(f)])
    cal, fw = built.cal_obs, built.forward
    assert list(cal.tests) == ["test2", "undrained1_u7"]
    spec = {t.name: t for t in fw.tests}["undrained1_u7"]
    assert (spec.e0, spec.p0, spec.drainage) == (0.735, 100.0, "undrained")
    assert set(cal["undrained1_u7"].curves) == {"q", "u"}
    g = tmp_path / "u12.csv"
    g.write_text("eps_a_pct,q_kPa,u_kPa\n0.5,100,20\n")
    with pytest.raises(inference.DataError, match="u12.csv: missing condition 'e0'"):
        sand_route.build(TOY, undrained=[str(g)])
    cal = sand_route.build(TOY, undrained=[f"{g}:0.833:1000"]).cal_obs
    assert conditions_of(cal["undrained1_u12"]).p0 == 1000.0


def _contract(out, case):
    s = json.loads((out / "summary.json").read_text())
    for key in ("case", "method", "seed", "n_samples", "n_stages", "n_forward_solves", "wall_s", "ranks",
                "parameters", "sigma_eps", "log_evidence", "J_g_at_map"):
        assert key in s, key
    assert s["case"] == case and s["stages"][-1]["beta"] == 1.0
    for f in ("posterior.npz", "posterior.nc", "report.md", "curves.png", "stress_paths.png", "marginals.png",
              "pairs.png", "stages.png", "csl.png"):
        assert (out / f).is_file(), f
    return s


def test_tiny_synthetic_run_writes_the_contract(tmp_path):
    out = tmp_path / "syn"
    simsand_synthetic.main(["--noise", "0.1", "--free", "phi_mu", "--samples", "8", "--sweeps", "1", "--processes", "1",
                            "--single-sigma", "--out", str(out)])
    s = _contract(out, "simsand_synthetic")
    assert s["synthetic"] is True and set(s["parameters"]) == {"phi_mu", "sigma_eps"}
    assert "synthetic" in (out / "report.md").read_text().lower()


def test_tiny_toyoura_run_writes_the_contract(tmp_path):
    out = tmp_path / "toy"
    toyoura.main(["--free", "phi_mu", "--samples", "8", "--sweeps", "1", "--processes", "1", "--out", str(out)])
    s = _contract(out, "toyoura")
    assert s["calibration_tests"] == ["test2", "test6"] and "substitutes" in s["substitution"]
    assert set(s["J_g_all_tests"]) == {f"test{i}" for i in range(1, 7)}
    report = (out / "report.md").read_text()
    assert "UNDRAINED tests 7 and 12" in report
    # the study file's [reference] columns beside the posterior
    assert "| paper reference (optimisation), Table 3 | paper DE-TMCMC mean MAP |" in report
    assert "| 32.4 | 32.18 |" in report
    # error groups by quantity by default; the predicted tests scored with the leave-one-test-out model error
    assert s["error_model"] == {"stress": ["q", "u"], "volume": ["e"]}
    assert {"sigma_eps_stress", "sigma_eps_volume"} <= set(s["parameters"])
    predictions = s["predictions"]
    assert {(c["test"], c["curve"]) for c in predictions["curves"]} == {
        (f"test{i}", c) for i in (1, 3, 4, 5) for c in ("q", "e")}
    assert {c["test"] for c in predictions["leave_one_out"]} == {"test2", "test6"}
    assert "## Predictions" in report and (out / "predictions.png").is_file()
