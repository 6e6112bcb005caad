"""cases.burswood_sbp (cases/studies/burswood_sbp.toml through cases.study.routes.sbp) on a tiny mesh: recordings, bad
input, a small calibration serial and under mpirun -n 2."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from cases import burswood_sbp
from cases.study.reading.presets import Preset
from cases.study.reading.records import load_sbp_recordings
from cases.study.reading.schema import load_study
from cases.study.routes import sbp as sbp_route
from inference.observations import DataError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STUDY = load_study(burswood_sbp.STUDY)
GENERATING = STUDY.references["generating"].values
RATES = {t.name: t.strain_rate for t in STUDY.tests}
BOUNDS = {**STUDY.free, "sigma_eps": STUDY.sigma_bounds}
TINY = Preset(radial_cells=8, layers=1, increments=10, outer="fixed", outer_radius_a0=200.0)
TINY_ARGS = ["--radial-cells", "8", "--layers", "1", "--increments", "10"]


@pytest.fixture(scope="module")
def tiny_records(tmp_path_factory):
    """Synthetic records from the tiny FE itself (no discretization mismatch), 5 % noise, 12 points per test."""
    d = tmp_path_factory.mktemp("records")
    return sbp_route.generate_recordings(STUDY, d, noise=0.05, seed=7, preset=TINY, n_points=12)


def test_noise_free_recordings_equal_the_forward_model(tmp_path):
    """The generator writes what the forward model computes (9 significant digits), labelled synthetic."""
    paths = sbp_route.generate_recordings(STUDY, tmp_path, noise=0.0, preset=TINY, n_points=12)
    obs = load_sbp_recordings(paths, pore_pressure=True)
    forward = sbp_route.sbp_forward(STUDY, TINY, curves=("cavity_pressure", "pore_pressure"))
    sim = forward(GENERATING)
    for t in obs:
        assert t.conditions["synthetic"].startswith("NOT MEASURED DATA")
        assert float(t.conditions["strain_rate_per_s"]) == RATES[t.name]
        for cname, c in t.curves.items():
            x, y = sim[t.name][cname]
            np.testing.assert_allclose(c.y, np.interp(c.x, x, y), rtol=1e-8)
    # the slower test is weaker (viscosity dominates partial drainage for these parameters, docs/reference.md section 7)
    assert obs["slow"].curves["cavity_pressure"].y[-1] < obs["fast"].curves["cavity_pressure"].y[-1]


def test_one_layer_equals_four_layers():
    """Plane strain, top and bottom fixed vertically: the problem is 1D in r, so the quick preset's single layer
    of cells gives the paper mesh's 4-layer answer (the hourglass modes are not excited by a z-uniform field), to the
    Newton tolerance of the solver (relative residual 1e-6 per dof)."""
    one = sbp_route.sbp_forward(STUDY, TINY).results(GENERATING)
    four = sbp_route.sbp_forward(STUDY, Preset(radial_cells=8, layers=4, increments=10, outer_radius_a0=200.0)).results(
        GENERATING)
    for name in one:
        np.testing.assert_allclose(one[name].cavity_pressure, four[name].cavity_pressure, rtol=1e-6)
        np.testing.assert_allclose(one[name].cavity_pore_pressure, four[name].cavity_pore_pressure, rtol=1e-6)


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize("body, message", [
    ("cavity_strain_pct,cavity_pressure_kPa\n1,100\n0.5,110\n",
     "line 3, column 'cavity_strain': value 0.5 does not increase"),
    ("cavity_strain,cavity_pressure_kPa\n0.01,100\n0.02,110\n", "'cavity_strain' is in unit '-', expected '%'"),
    ("strain_pct,cavity_pressure_kPa\n1,100\n2,110\n", "column 'strain'"),
    ("cavity_strain_pct,cavity_pressure_kPa\n1,100\n2,-5\n", "line 3, column 'cavity_pressure': value -5 must be > 0"),
    ("cavity_strain_pct,cavity_pressure_kPa\n1,100\n12,110\n", "value 12 % exceeds 10 %"),
    ("cavity_strain_pct,cavity_pressure [psi]\n1,100\n2,110\n", "unit 'psi'"),
])
def test_bad_recordings_name_file_column_and_value(tmp_path, body, message):
    path = _write(tmp_path / "bad.csv", body)
    with pytest.raises(DataError, match=message) as err:
        load_sbp_recordings({"fast": path})
    assert "bad.csv" in str(err.value)


def test_user_recordings_in_mpa_and_percent_are_converted(tmp_path):
    path = _write(tmp_path / "f.csv", "cavity_strain [%],cavity_pressure [MPa]\n1,0.1\n2,0.12\n")
    obs = load_sbp_recordings({"fast": path})
    np.testing.assert_allclose(obs["fast"].curves["cavity_pressure"].y, [100.0, 120.0])


def test_a_forward_solve_that_raises_is_a_zero_likelihood_particle(tiny_records):
    """A forward solve that raises inside a calibration gives -inf with its reason, never a crash."""
    import inference

    like = inference.Likelihood(load_sbp_recordings(tiny_records), sbp_route.sbp_forward(STUDY, TINY))
    like.bind(tuple(BOUNDS))
    values, reasons = like.evaluate_many(np.array([[1.71, 58.4, 0.02, 0.05], [1.71, -5.0, 0.02, 0.05]]))
    assert np.isfinite(values[0]) and reasons[0] is None
    assert values[1] == -np.inf and "sigma_p0" in reasons[1]


def _run(tmp_path, records, name, *extra, mpi=0, timeout=400):
    out = tmp_path / name
    rec = [f"{k}={v}" for k, v in records.items()]
    cmd = ([] if not mpi else ["mpirun", "-n", str(mpi)]) + [
        sys.executable, "-m", "cases.burswood_sbp", *TINY_ARGS, "--samples", "12", "--seed", "3",
        "--out", str(out), "--recordings", *rec, *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


@pytest.mark.mpi
def test_small_calibration_serial_and_two_ranks_agree_and_move_toward_the_generating_values(tmp_path, tiny_records):
    serial = _run(tmp_path, tiny_records, "serial", "--processes", "1")
    summary = json.loads((serial / "summary.json").read_text())
    for key in ("case", "method", "seed", "n_samples", "n_stages", "n_forward_solves", "wall_s", "ranks",
                "parameters", "sigma_eps", "log_evidence", "J_g_at_map"):
        assert key in summary
    assert summary["synthetic_recordings"] is True
    assert summary["generating"] == GENERATING  # read back from the records' synthetic_parameters header
    for f in ("report.md", "curves.png", "marginals.png", "pairs.png", "stages.png", "posterior.npz", "posterior.nc",
              "progress.log"):
        assert (serial / f).exists(), f
    report = (serial / "report.md").read_text()
    assert "SYNTHETIC" in report and "Generating values inside the 95 % posterior interval" in report
    mpi = _run(tmp_path, tiny_records, "mpi", mpi=2)
    a, b = np.load(serial / "posterior.npz"), np.load(mpi / "posterior.npz")
    np.testing.assert_array_equal(a["stage_samples"], b["stage_samples"])
    np.testing.assert_array_equal(a["map_theta"], b["map_theta"])
    assert json.loads((mpi / "summary.json").read_text())["ranks"] == 2
    # the final population moves toward the generating M and sigma'_p0: mean distance in prior-width units below
    # half its expectation under the prior, E|U - t| = (t^2 + (1 - t)^2)/2 for U ~ U(0, 1) and truth at t. (C_alpha_e
    # is left out: 12 points per test with 5 % noise on a 10-increment mesh hardly constrain the rate effect.)
    for i, name in enumerate(("M", "sigma_p0")):
        lo, hi = BOUNDS[name]
        t = (GENERATING[name] - lo) / (hi - lo)
        distance = np.mean(np.abs((a["samples"][:, i] - lo) / (hi - lo) - t))
        assert distance < 0.5 * (t**2 + (1 - t) ** 2) / 2, name


@pytest.mark.slow
@pytest.mark.mpi
def test_killed_mpi_run_resumes_to_the_uninterrupted_answer(tmp_path, tiny_records):
    """The checkpoint/resume demonstration: SIGUSR1 to mpirun mid-run (what the Slurm job forwards before its
    time limit) -> checkpoint and exit 75; rerun with --resume -> the answer of an uninterrupted serial run."""
    import signal
    import time

    reference = _run(tmp_path, tiny_records, "reference", "--processes", "1")
    out = tmp_path / "killed"
    rec = [f"{k}={v}" for k, v in tiny_records.items()]
    cmd = ["mpirun", "-n", "2", sys.executable, "-m", "cases.burswood_sbp", *TINY_ARGS, "--samples", "12",
           "--seed", "3", "--out", str(out), "--recordings", *rec]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 300
    while time.time() < deadline:  # wait until stage 1 is under way
        log = out / "progress.log"
        if log.exists() and "stage   1" in log.read_text():
            break
        time.sleep(0.5)
    proc.send_signal(signal.SIGUSR1)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 75, err[-2000:]
    assert (out / "run.ckpt").exists() and not (out / "posterior.npz").exists()
    _run(tmp_path, tiny_records, "killed", "--resume", mpi=2)
    a, b = np.load(reference / "posterior.npz"), np.load(out / "posterior.npz")
    np.testing.assert_array_equal(a["stage_samples"], b["stage_samples"])
    assert json.loads((reference / "summary.json").read_text())["log_evidence"] == \
        json.loads((out / "summary.json").read_text())["log_evidence"]
