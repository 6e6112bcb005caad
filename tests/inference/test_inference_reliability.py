"""Reliability of a run: pool workers die with their parent, every stop keeps what was done, honest progress lines,
one meaning of wall_s.

Process checks read /proc (Linux); they are skipped elsewhere.
"""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from inference import (
    EXIT_CHECKPOINTED,
    Checkpointed,
    RunStopped,
    SamplerError,
    SerialExecutor,
    UniformPrior,
    tmcmc,
    write_failures,
)
from inference.bench import PROBLEMS
from inference.tmcmc.run import remaining_evaluations
from inference.tmcmc.state import StageRecord

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

linux_only = pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="reads /proc (Linux)")

# A run on a pool of 2 workers whose likelihood sleeps (the GIL is free, as in a Python-level forward model).
# Started from the main thread, or from another thread (then the workers' watchdog alone ends them).
POOL_RUN = textwrap.dedent("""
    import sys, threading, time
    sys.path.insert(0, {root!r})
    from inference import PoolExecutor, UniformPrior, tmcmc

    def loglike(theta):
        time.sleep(0.05)
        return -float(theta[0] ** 2)

    def main():
        with PoolExecutor(2) as ex:
            tmcmc(loglike, UniformPrior({{"x": (-1, 1)}}), n_samples=400, executor=ex, progress=False)

    if {in_thread!r}:
        t = threading.Thread(target=main)
        t.start()
        t.join()
    else:
        main()
""")


def _children(pid):
    """Process ids whose parent is ``pid`` (scanning /proc/*/stat)."""
    kids = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # after "pid (comm) ": state, ppid, ...
        if int(fields[1]) == pid:
            kids.append(int(entry))
    return kids


def _alive(pid):
    """True while ``pid`` exists and is not a zombie (a dead process nobody has reaped)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            stat = fh.read()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


@linux_only
@pytest.mark.parametrize("in_thread", [False, True], ids=["death-signal", "watchdog"])
def test_pool_workers_die_when_the_main_process_is_killed(in_thread):
    proc = subprocess.Popen([sys.executable, "-c", POOL_RUN.format(root=ROOT, in_thread=in_thread)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 60
        workers = []
        while len(workers) < 2 and time.time() < deadline:
            time.sleep(0.1)
            workers = _children(proc.pid)
        assert len(workers) == 2, f"the run did not start its 2 pool workers (children: {workers})"
        time.sleep(0.5)  # workers busy in the likelihood
        assert all(_alive(w) for w in workers)
    finally:
        proc.kill()
        proc.wait(timeout=30)
    time.sleep(5.0)
    survivors = [w for w in workers if _alive(w)]
    for w in survivors:  # do not leave them behind if the test fails
        os.kill(w, signal.SIGKILL)
    assert not survivors, f"pool workers {survivors} outlived their killed parent by 5 s"


# ---- every stop keeps what was done

def test_a_stop_for_failed_solves_carries_and_writes_every_failure(tmp_path):
    prior = UniformPrior({"x": (0, 1), "y": (0, 1)})
    failed = []

    def loglike(theta):
        if theta[0] < 0.3:
            failed.append(theta.copy())
            raise RuntimeError("diverged")
        return 0.0

    with pytest.raises(SamplerError, match=r"stage 0: \d+ of 100 forward evaluations failed") as info:
        tmcmc(loglike, prior, n_samples=100, executor=SerialExecutor(), progress=False)
    stop = info.value
    assert isinstance(stop, RunStopped)
    progress = stop.progress
    assert len(progress.failures) == len(failed) > 10
    assert progress.n_forward_solves == 100 and progress.stages == []
    assert progress.stage_under_way["n_failed"] == len(failed) and progress.exponent == 0.0
    progress.save(tmp_path)
    lines = (tmp_path / "failed_solves.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines]
    assert [r["theta"]["x"] for r in records] == [float(t[0]) for t in failed]
    assert all(r["stage"] == 0 and r["reason"].startswith("RuntimeError: diverged") for r in records)
    summary = json.loads((tmp_path / "progress.json").read_text())
    assert summary["n_failed_solves"] == len(failed) and summary["n_forward_solves"] == 100
    assert "forward evaluations failed" in summary["stopped"]


def _interrupting(after):
    """A likelihood that sends SIGTERM to its own process at its ``after``-th call (as Slurm would)."""
    calls = [0]

    def loglike(theta):
        calls[0] += 1
        if calls[0] == after:
            os.kill(os.getpid(), signal.SIGTERM)
        if theta[0] > 0.55:
            raise RuntimeError("diverged")
        return -((theta[0] - 0.4) ** 2 + (theta[1] - 0.6) ** 2) / 0.02

    return loglike


OPTIONS = dict(n_samples=80, seed=4, max_steps=3, checkpoint_evals=10, max_failure_fraction=0.6, progress=False)


def test_a_signal_stop_carries_the_progress_and_the_resumed_run_reports_both_wall_times(tmp_path):
    prior = UniformPrior({"x": (0, 1), "y": (0, 1)})
    ckpt = tmp_path / "run.ckpt"
    reference = tmcmc(_interrupting(-1), prior, executor=SerialExecutor(), **OPTIONS)

    with pytest.raises(Checkpointed) as info:
        tmcmc(_interrupting(300), prior, executor=SerialExecutor(), checkpoint=ckpt, **OPTIONS)
    stop = info.value
    assert isinstance(stop, SystemExit) and stop.code == EXIT_CHECKPOINTED
    progress = stop.progress
    assert progress.checkpoint == str(ckpt) and progress.exponent < 1 and progress.stage_under_way is not None
    assert progress.n_forward_solves >= 80
    for got, ref in zip(progress.stages, reference.stages):  # the finished stages as in the uninterrupted run
        assert (got["beta"], got["log_S"], got["n_evals"]) == (ref["beta"], ref["log_S"], ref["n_evals"])
    # the failures so far, in the order of the uninterrupted run
    assert 0 < len(progress.failures) < len(reference.failures)
    assert progress.failures == reference.failures[:len(progress.failures)]
    progress.save(tmp_path)
    assert json.loads((tmp_path / "progress.json").read_text())["checkpoint"] == str(ckpt)
    assert (tmp_path / "failed_solves.jsonl").exists()

    t0 = time.perf_counter()
    resumed = tmcmc(_interrupting(-1), prior, executor=SerialExecutor(), checkpoint=ckpt, resume=True, **OPTIONS)
    second_call = time.perf_counter() - t0
    # the same numbers as the uninterrupted run (same process, same machine)
    assert resumed.log_evidence == reference.log_evidence
    np.testing.assert_array_equal(resumed.samples, reference.samples)
    np.testing.assert_array_equal(resumed.map_theta, reference.map_theta)
    assert resumed.failures == reference.failures
    # wall_s sums the sessions (the first up to its last checkpoint); wall_s_this_session is the resumed call's
    assert 0 < resumed.wall_s_this_session <= second_call
    assert resumed.wall_s > resumed.wall_s_this_session
    assert resumed.wall_s <= progress.wall_s + second_call
    resumed.save(tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["wall_s"] == resumed.wall_s
    assert summary["wall_s_this_session"] == resumed.wall_s_this_session
    assert not (tmp_path / "progress.json").exists(), "a finished run's summary supersedes the stopped session's"


def test_failed_solves_file_is_written_even_when_nothing_failed(tmp_path):
    prior = UniformPrior({"x": (0, 1)})
    post = tmcmc(lambda t: -t[0] ** 2 / 0.1, prior, n_samples=50, executor=SerialExecutor(), progress=False)
    assert post.failures == []
    post.save(tmp_path)
    assert (tmp_path / "failed_solves.jsonl").read_text() == ""
    assert post.wall_s == post.wall_s_this_session
    assert write_failures(tmp_path / "sub", [{"stage": 1, "theta": {"x": np.float64(0.5)}}]).read_text() == \
        '{"stage": 1, "theta": {"x": 0.5}}\n'


# ---- the ETA of the progress lines

def test_eta_is_unknown_first_then_close_to_the_evaluations_that_followed(tmp_path):
    """Linear-Gaussian benchmark B1 (d = 10), where the steps in ln beta shrink over the first stages and the sweeps
    grow: the estimate, in evaluations, against those the run then made. Measured: a lower bound (0.3-0.8 of
    the truth) while flagged unsettled, within 15 % once settled; the averaged rule it replaces gave 0.2-0.6."""
    prob = PROBLEMS["B1"](10)
    log = tmp_path / "progress.log"
    post = tmcmc(prob.log_like, prob.prior, n_samples=300, executor=SerialExecutor(), seed=1, vectorized=True,
                 progress=False, log=log)
    records = [StageRecord(r["stage"], r["beta"], r["beta2"], n_evals=r["n_evals"]) for r in post.stages]
    lines = [line for line in log.read_text().splitlines() if line.startswith("stage")]
    assert len(lines) == len(records)
    assert "ETA unknown" in lines[0] and "ETA unknown" in lines[1] and "ETA" not in lines[-1]
    settled_seen = 0
    for j in range(2, len(records) - 1):
        estimate, settled = remaining_evaluations(records[:j + 1])
        actual = sum(r.n_evals for r in records[j + 1:])
        assert ("ETA ~" if settled else "ETA >") in lines[j]
        if settled:
            settled_seen += 1
            if j < len(records) - 3:  # one or two stages left: ceil() of a stage count dominates
                assert abs(estimate / actual - 1) < 0.2, (j, estimate, actual)
        else:
            assert estimate <= 1.05 * actual, (j, estimate, actual)
    assert settled_seen >= 5
