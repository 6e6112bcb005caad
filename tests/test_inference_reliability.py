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

from inference import SamplerError, SerialExecutor, UniformPrior, tmcmc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

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
