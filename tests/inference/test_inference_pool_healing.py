"""A self-healing pool: a worker that dies is replaced and its evaluations redone, so the run ends with exactly the
answer of an uninterrupted run; an evaluation that keeps taking workers down becomes a failed forward solve.

The workers kill themselves with SIGKILL (as the out-of-memory killer does); POSIX only.
"""
import os
import signal
import time

import numpy as np
import pytest

from inference import PoolExecutor, RunStopped, SerialExecutor, UniformPrior, tmcmc
from inference.executors import Evaluator

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX signals")

PRIOR = UniformPrior({"x": (0, 1), "y": (0, 1)})
OPTIONS = dict(n_samples=200, seed=3, progress=False)


def _misfit(theta):
    return -((theta[0] - 0.3) ** 2 + (theta[1] - 0.6) ** 2) / 0.02


def _killing_once(markers):
    """A log-likelihood whose worker kills itself with SIGKILL the first time (over all workers) a theta meets a
    condition; ``markers`` maps a marker file to its condition; the file records the killed pid."""

    def loglike(theta):
        for marker, condition in markers.items():
            if condition(theta):
                try:
                    fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
                except FileExistsError:
                    continue
                os.write(fd, str(os.getpid()).encode())
                os.close(fd)
                os.kill(os.getpid(), signal.SIGKILL)
        return _misfit(theta)

    return loglike


def test_a_killed_worker_is_replaced_and_the_run_ends_as_if_uninterrupted(tmp_path):
    with PoolExecutor(2) as ex:
        reference = tmcmc(_misfit, PRIOR, executor=ex, **OPTIONS)
    markers = {str(tmp_path / "in-stage-0"): lambda t: t[0] > 0.9,  # the prior's samples
               str(tmp_path / "near-the-mode"): lambda t: abs(t[0] - 0.3) < 0.004 and abs(t[1] - 0.6) < 0.004}
    log = tmp_path / "progress.log"
    with PoolExecutor(2) as ex:
        healed = tmcmc(_killing_once(markers), PRIOR, executor=ex, log=log, **OPTIONS)

    np.testing.assert_array_equal(healed.samples, reference.samples)
    assert healed.log_evidence == reference.log_evidence
    np.testing.assert_array_equal(healed.map_theta, reference.map_theta)
    assert healed.map_log_posterior == reference.map_log_posterior
    assert healed.n_forward_solves == reference.n_forward_solves and healed.failures == []
    lines = log.read_text().splitlines()
    for marker in markers:
        pid = open(marker).read()
        event = [line for line in lines if line.startswith(f"pool worker {pid} ")]
        assert len(event) == 1, lines
        assert "killed by signal 9 (SIGKILL); replaced by worker" in event[0]
        assert event[0].endswith("redone") and "evaluation" in event[0]


def _wait_until_dead(pid, timeout=30.0):
    """Until ``pid`` (a child not yet reaped) is a zombie (Linux /proc), or a second elsewhere."""
    if not os.path.isdir("/proc/self"):
        time.sleep(1.0)
        return
    deadline = time.time() + timeout
    while time.time() < deadline:
        with open(f"/proc/{pid}/stat") as fh:
            stat = fh.read()
        if stat[stat.rindex(")") + 2] == "Z":
            return
        time.sleep(0.01)
    raise AssertionError(f"worker {pid} still alive {timeout} s after SIGKILL")


def test_a_worker_that_dies_between_batches_is_replaced(capsys):
    evaluator = Evaluator(lambda theta: float(os.getpid()))
    thetas = np.zeros((8, 1))
    with PoolExecutor(2) as ex:
        pids = set(ex.evaluate(evaluator, thetas)[0].astype(int))
        victim = pids.pop()
        os.kill(victim, signal.SIGKILL)
        _wait_until_dead(victim)
        values, reasons, ranks = ex.evaluate(evaluator, thetas)
    assert np.all(np.isfinite(values)) and victim not in values.astype(int) and reasons == [None] * 8
    err = capsys.readouterr().err
    # whether the pool notices the death before or after it hands the dead worker a chunk of the new batch depends
    # on the machine's load: both are the same answer, the line says which
    assert f"pool worker {victim} " in err and "replaced by worker" in err
    assert "no evaluation of this batch was in flight" in err or "redone" in err


def _killing_always(x_above):
    def loglike(theta):
        if theta[0] > x_above:
            os.kill(os.getpid(), signal.SIGKILL)
        return _misfit(theta)

    return loglike


def _raising(x_above):
    def loglike(theta):
        if theta[0] > x_above:
            raise RuntimeError("diverged")
        return _misfit(theta)

    return loglike


def test_an_evaluation_that_always_kills_its_worker_is_a_failed_solve(tmp_path):
    options = dict(n_samples=60, seed=3, progress=False, max_failure_fraction=0.5)
    log = tmp_path / "progress.log"
    with PoolExecutor(2) as ex:
        post = tmcmc(_killing_always(0.93), PRIOR, executor=ex, log=log, **options)
    reference = tmcmc(_raising(0.93), PRIOR, executor=SerialExecutor(), **options)

    assert post.log_evidence == reference.log_evidence  # a given-up evaluation is a failed solve like any other
    np.testing.assert_array_equal(post.samples, reference.samples)
    assert len(post.failures) == len(reference.failures) > 0
    for f in post.failures:
        assert f["theta"]["x"] > 0.93
        assert f["reason"].startswith("the forward evaluation took its pool worker down 3 times (last: killed by "
                                      "signal 9 (SIGKILL))")
    given_up = [line for line in log.read_text().splitlines() if "given up after 3 worker deaths" in line]
    assert len(given_up) == len(post.failures)


def test_a_crash_loop_beyond_the_failure_policy_stops_the_run_cleanly():
    with PoolExecutor(2) as ex, pytest.raises(RunStopped, match=r"stage 0: \d+ of 20 forward evaluations failed"
                                              ) as info:
        tmcmc(_killing_always(0.5), PRIOR, executor=ex, n_samples=20, seed=3, progress=False)
    failures = info.value.progress.failures
    assert len(failures) > 2 and all("took its pool worker down 3 times" in f["reason"] for f in failures)
