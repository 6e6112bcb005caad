"""TMCMC against posteriors with known evidence, determinism across executors and MPI ranks, failures,
checkpoint/resume.

Tolerances for the evidence come from the spread of repeated seeds measured with ``python -m inference.bench``
(N = 1000): on B1 (d = 4) |bias| <= 0.14 and spread <= 0.13 for both methods; on B2 (d = 10) |bias| <= 0.14 and
spread <= 0.12, minor-mode weight spread <= 0.05. A single run must fall within |bias| + 3 spread (0.55) and the
minor weight within 0.10 +- 3 x 0.05.
"""
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from inference import (CheckpointError, PoolExecutor, SamplerError, SerialExecutor, UniformPrior, tmcmc)
from inference.benchmarks import PROBLEMS, reference_evidence_by_quadrature

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = os.path.join(ROOT, "tests", "scripts", "small_run.py")


def _run(problem, method, seed=0, n=1000, **kw):
    kw = dict(dict(gaussian=dict(proposal="gaussian", scale_adapt=True), de=dict(proposal="de"))[method], **kw)
    return tmcmc(problem.log_like, problem.prior, n_samples=n, executor=SerialExecutor(), seed=seed,
                 vectorized=True, progress=False, **kw)


@pytest.mark.parametrize("method", ["gaussian", "de"])
def test_evidence_and_moments_linear_gaussian(method):
    prob = PROBLEMS["B1"](4)
    post = _run(prob, method)
    assert abs(post.log_evidence - prob.log_evidence) < 0.55
    # posterior moments within Monte-Carlo error: effective sample size taken conservatively as N/10
    n_eff = len(post.samples) / 10
    np.testing.assert_array_less(np.abs(post.samples.mean(0) - prob.mean), 4 * prob.std / math.sqrt(n_eff))
    np.testing.assert_array_less(np.abs(post.samples.std(0) / prob.std - 1), 4 / math.sqrt(2 * n_eff))
    # the MAP (7) is the evaluated sample of largest posterior density: close to the exact posterior mode
    assert np.all(np.abs(post.map_theta - prob.mean) < prob.std)


@pytest.mark.parametrize("method", ["gaussian", "de"])
def test_evidence_and_mode_weight_mixture(method):
    prob = PROBLEMS["B2"](10)
    post = _run(prob, method)
    assert abs(post.log_evidence - prob.log_evidence) < 0.55
    assert abs(prob.minor_mode(post.samples) - 0.1) < 0.15


def _siblings(rho, seed, n_parents=500, copies=2, d=5):
    """Two copies of each start x0 drawn from a 0.1/0.9 mixture of N(+-0.5, 0.1^2) modes, moved to
    x = m + rho (x0 - m) + sqrt(1 - rho^2) 0.1 eps around the mode centre m: within-mode lag correlation rho."""
    rng = np.random.default_rng(seed)
    centre = np.repeat(np.where(rng.random(n_parents) < 0.1, 0.5, -0.5)[:, None] * np.ones(d), copies, axis=0)
    start = centre + np.repeat(0.1 * rng.standard_normal((n_parents, d)), copies, axis=0)
    pos = centre + rho * (start - centre) + math.sqrt(1 - rho**2) * 0.1 * rng.standard_normal(start.shape)
    return {"start": start, "pos": pos}


@pytest.mark.parametrize("rho", [0.2, 0.6, 0.9])
def test_adaptive_sweep_statistic_measures_within_mode_correlation(rho):
    """The stopping statistic recovers the within-mode correlation on a bimodal population (spread of the estimate
    over 50 constructions: std 0.033-0.038, mean within 0.015 of rho; tolerance 4 std), where the plain
    population correlation stays near 1 (0.92 at rho = 0.2)."""
    from inference.tmcmc import _Run
    ch = _siblings(rho, seed=1)
    assert _Run.start_correlation(ch) == pytest.approx(rho, abs=0.15)
    # without siblings (every start distinct) the plain population correlation is used
    distinct = {"start": ch["start"][::2], "pos": ch["pos"][::2]}
    da, db = distinct["start"] - distinct["start"].mean(0), distinct["pos"] - distinct["pos"].mean(0)
    plain = np.mean((da * db).sum(0) / np.sqrt((da * da).sum(0) * (db * db).sum(0)))
    assert plain > 0.8
    assert _Run.start_correlation(distinct) == pytest.approx(plain, rel=1e-12)


def test_benchmark_constants_by_quadrature():
    """The stated ln Z of the 2-D benchmarks, checked by brute-force quadrature (independent of the sampler)."""
    for key in ("B5", "B6"):
        prob = PROBLEMS[key]()
        assert reference_evidence_by_quadrature(prob, n=801) == pytest.approx(prob.log_evidence, abs=2e-3)
    shells = PROBLEMS["B4"](2)
    assert reference_evidence_by_quadrature(shells, n=1201) == pytest.approx(shells.log_evidence, abs=2e-3)


def test_serial_and_pool_executors_give_identical_results():
    prob = PROBLEMS["B6"]()
    kw = dict(n_samples=200, proposal="de", seed=3, progress=False, max_steps=3, vectorized=True)
    a = tmcmc(prob.log_like, prob.prior, executor=SerialExecutor(), **kw)
    with PoolExecutor(2) as pool:
        b = tmcmc(prob.log_like, prob.prior, executor=pool, **kw)
    assert a.log_evidence == b.log_evidence
    np.testing.assert_array_equal(a.samples, b.samples)
    np.testing.assert_array_equal(a.map_theta, b.map_theta)


def _script(tmp_path, name, *args, mpi=0, timeout=120, check=True):
    out = str(tmp_path / f"{name}.npz")
    cmd = ([] if not mpi else ["mpirun", "-n", str(mpi)]) + [sys.executable, SCRIPT, out, *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    if check:
        assert proc.returncode == 0, proc.stderr[-2000:]
    return (np.load(out) if os.path.exists(out) else None), proc


@pytest.mark.mpi
def test_rank_count_independence(tmp_path):
    ref, _ = _script(tmp_path, "serial", "--executor", "serial")
    for ranks, dispatch in ((2, "dynamic"), (3, "spmd"), (3, "dynamic")):
        got, _ = _script(tmp_path, f"mpi{ranks}{dispatch}", "--dispatch", dispatch, mpi=ranks)
        assert int(got["ranks"]) == ranks
        assert float(got["log_evidence"]) == float(ref["log_evidence"])
        np.testing.assert_array_equal(got["stage_samples"], ref["stage_samples"])
        np.testing.assert_array_equal(got["map_theta"], ref["map_theta"])


def test_failed_forward_solves_are_recorded_and_the_run_continues(tmp_path):
    got, _ = _script(tmp_path, "fail", "--executor", "serial", "--fail")
    assert int(got["n_failed"]) > 0
    assert np.all(~((got["samples"][:, 0] > 1.5) & (got["samples"][:, 1] > 1.5)))


def test_failure_reasons_nan_and_timeout():
    prior = UniformPrior({"x": (0, 1), "y": (0, 1)})

    def loglike(theta):
        if theta[0] > 0.97:
            return float("nan")
        if theta[1] > 0.985:
            time.sleep(2.0)
        return -((theta[0] - 0.5) ** 2 + (theta[1] - 0.5) ** 2) / 0.02

    post = tmcmc(loglike, prior, n_samples=200, executor=SerialExecutor(), seed=1, progress=False, timeout=0.2,
                 max_steps=3)
    reasons = {f["reason"].split(":")[0] for f in post.failures}
    assert "log-likelihood evaluated to nan" in reasons
    assert "EvaluationTimeout" in reasons
    assert all(np.isfinite(post.log_like)) and math.isfinite(post.log_evidence)


def test_too_many_failures_stop_with_a_clear_error():
    prior = UniformPrior({"x": (0, 1)})

    def loglike(theta):
        if theta[0] < 0.3:
            raise RuntimeError("diverged")
        return 0.0

    with pytest.raises(SamplerError, match=r"stage 0: \d+ of 100 forward evaluations failed"):
        tmcmc(loglike, prior, n_samples=100, executor=SerialExecutor(), progress=False)


@pytest.mark.mpi
def test_mpi_job_with_failing_workers_ends_without_hanging(tmp_path):
    _, proc = _script(tmp_path, "failall", "--fail-all", mpi=2, timeout=60, check=False)
    assert proc.returncode != 0
    assert "forward evaluations failed" in proc.stderr


@pytest.mark.parametrize("sig,executor", [(signal.SIGTERM, "serial"), (signal.SIGKILL, "serial"),
                                          (signal.SIGTERM, "pool")])
def test_kill_and_resume_gives_the_uninterrupted_result(tmp_path, sig, executor):
    """Killed mid-stage, resumed (with the serial executor), the run ends exactly as the uninterrupted one. With the
    pool, SIGTERM goes to the whole process group, as Slurm sends it."""
    ref, _ = _script(tmp_path, "ref", "--executor", "serial")
    ckpt = str(tmp_path / "run.ckpt")
    out = str(tmp_path / "resumed.npz")
    cmd = [sys.executable, SCRIPT, out, "--executor", executor, "--checkpoint", ckpt, "--sleep", "0.003"]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    deadline = time.time() + 30
    while not os.path.exists(ckpt) and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.4)
    os.killpg(proc.pid, sig)
    proc.wait(timeout=30)
    assert proc.returncode == (75 if sig == signal.SIGTERM else -signal.SIGKILL)
    assert not os.path.exists(out), "the run finished before it was interrupted: make it slower"
    cmd[cmd.index(executor, 3)] = "serial"
    subprocess.run(cmd[:-2] + ["--resume"], cwd=ROOT, check=True, timeout=120, capture_output=True)
    got = np.load(out)
    assert float(got["log_evidence"]) == float(ref["log_evidence"])
    np.testing.assert_array_equal(got["stage_samples"], ref["stage_samples"])
    # a checkpoint of another problem (other proposal) is refused with a clear message
    proc = subprocess.run(cmd[:-2] + ["--resume", "--proposal", "gaussian"], cwd=ROOT, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode != 0 and "CheckpointError" in proc.stderr and "proposal" in proc.stderr


def test_checkpoint_refuses_other_problem(tmp_path):
    prior = UniformPrior({"x": (0, 1)})
    ck = tmp_path / "c.ckpt"
    tmcmc(lambda t: -t[0] ** 2 / 0.1, prior, n_samples=50, executor=SerialExecutor(), checkpoint=ck, progress=False)
    with pytest.raises(CheckpointError, match="prior"):
        tmcmc(lambda t: -t[0] ** 2 / 0.1, UniformPrior({"x": (0, 2)}), n_samples=50, executor=SerialExecutor(),
              checkpoint=ck, resume=True, progress=False)
