"""A small TMCMC run used by the MPI, determinism and kill-and-resume tests.

python tests/scripts/small_run.py OUT.npz [--proposal de|gaussian] [--dispatch dynamic|spmd]
    [--executor auto|serial|pool] [--checkpoint FILE] [--resume] [--sleep S] [--fail] [--batched]

--batched: the log-likelihood says it takes batches (``batch = True``, as an ``inference.Likelihood`` with a batched
forward model), so the executors hand it chunks of parameter vectors (each still evaluated alone by the evaluator).
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from inference import PoolExecutor, SerialExecutor, UniformPrior, tmcmc  # noqa: E402
from inference.executors import mpi_world  # noqa: E402


class Banana:
    """A 3-parameter curved posterior; optionally slow (busy wait) and failing in a corner of the box."""

    def __init__(self, sleep=0.0, fail=False, fail_all=False):
        self.sleep, self.fail, self.fail_all = sleep, fail, fail_all

    def __call__(self, theta):
        if self.sleep:
            t_end = time.perf_counter() + self.sleep
            while time.perf_counter() < t_end:
                pass
        x, y, z = theta
        if self.fail_all:
            raise RuntimeError("forward solve diverged everywhere")
        if self.fail and x > 1.5 and y > 1.5:
            raise RuntimeError("forward solve diverged (test corner)")
        return -0.5 * (x**2 / 0.5 + (y - 0.5 * x**2) ** 2 / 0.1 + (z - 0.3) ** 2 / 0.2)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--proposal", default="de")
    ap.add_argument("--dispatch", default="dynamic")
    ap.add_argument("--executor", default="auto")
    ap.add_argument("--samples", type=int, default=60)
    ap.add_argument("--checkpoint")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--sleep", type=float, default=0.0)
    ap.add_argument("--fail", action="store_true")
    ap.add_argument("--fail-all", action="store_true")
    ap.add_argument("--batched", action="store_true")
    a = ap.parse_args()
    prior = UniformPrior({"x": (-2, 2), "y": (-2, 3), "z": (-1, 1)})
    ex = {"auto": None, "serial": SerialExecutor(), "pool": PoolExecutor(2)}[a.executor]
    loglike = Banana(a.sleep, a.fail, a.fail_all)
    loglike.batch = a.batched
    post = tmcmc(loglike, prior, n_samples=a.samples, proposal=a.proposal, seed=7,
                 executor=ex, dispatch=a.dispatch, checkpoint=a.checkpoint, resume=a.resume, checkpoint_evals=5,
                 progress=False, max_steps=4)
    comm = mpi_world()
    if comm is None or comm.Get_rank() == 0:
        np.savez(a.out, samples=post.samples, log_like=post.log_like, log_evidence=post.log_evidence,
                 map_theta=post.map_theta, ranks=post.ranks, n_failed=len(post.failures),
                 stage_samples=np.stack(post.stage_samples))


if __name__ == "__main__":
    main()
