"""Sampler benchmarks with known evidence (docs/reference.md section 8, the problems of `inference.bench`) and
dispatch overheads, as JSON lines.

    python -m inference.bench [--quick] [--seeds 10] [--samples 1000] [--problems B1,B2] [--methods ...]
        [--set max_steps=12 --set corr_threshold=0.3 ...]   # tmcmc keyword overrides
    python -m inference.bench --overhead        # sampler overhead per stage (N = 2000, d = 10)
    mpirun -n 2 python -m inference.bench --dispatch   # MPI dispatch overhead and parallel efficiency
    python -m inference.bench --discrepancy     # the model-form discrepancy's (D2) per curve length

Each line of the evidence benchmark: problem, method, log-evidence bias, spread (std over seeds) and RMSE, errors of
posterior means and standard deviations (where exact values are known), minor-mode weight (B2-B4), likelihood calls,
acceptance, sweeps per stage, stages and wall time per run.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from ..discrepancy import CurveDiscrepancy, reduced_rank_basis
from ..executors import SerialExecutor
from ..tmcmc import tmcmc
from . import PROBLEMS

#: named sampler configurations: the paper's rules and the variants measured against them
METHODS = {
    "O-TMCMC/ching-chen": dict(proposal="gaussian", chains="ching-chen"),
    "O-TMCMC/adaptive": dict(proposal="gaussian", scale_adapt=True),
    "O-TMCMC/mixture": dict(proposal="gaussian", covariance="mixture"),
    "DE-TMCMC/paper": dict(proposal="de", de_variant="paper"),
    "DE-TMCMC/symmetric": dict(proposal="de", de_variant="symmetric"),
    "DE-TMCMC/redblue": dict(proposal="de", de_variant="redblue"),
}

_DEFAULT_ARGS = {"B1": (4,), "B2": (10,), "B3": (2,), "B4": (2,), "B5": (), "B6": ()}


def evidence_benchmark(problem_key, method, seeds, n_samples, **overrides):
    prob = PROBLEMS[problem_key](*_DEFAULT_ARGS[problem_key])
    errors, means, stds, minor, calls, acc, walls, sweeps, stages = [], [], [], [], [], [], [], [], []
    for seed in range(seeds):
        kw = dict(METHODS[method])
        kw.update(overrides)
        t0 = time.perf_counter()
        post = tmcmc(prob.log_like, prob.prior, n_samples=n_samples, executor=SerialExecutor(), seed=seed,
                     vectorized=True, progress=False, **kw)
        walls.append(time.perf_counter() - t0)
        errors.append(post.log_evidence - prob.log_evidence)
        calls.append(post.n_forward_solves)
        acc.append(np.nanmean([r["acceptance"] for r in post.stages[1:]]))
        sweeps.append(np.mean([r["sweeps"] for r in post.stages[1:]]))
        stages.append(post.n_stages)
        if prob.mean is not None:
            means.append(np.max(np.abs(post.samples.mean(0) - prob.mean)))
            stds.append(np.max(np.abs(post.samples.std(0, ddof=1) / prob.std - 1.0)))
        if prob.minor_mode is not None:
            minor.append(prob.minor_mode(post.samples))
    e = np.array(errors)
    line = {
        "benchmark": "evidence", "problem": prob.name, "method": method, "n_samples": n_samples, "seeds": seeds,
        "ln_Z_exact": prob.log_evidence, "ln_Z_bias": float(e.mean()), "ln_Z_spread": float(e.std(ddof=1)) if
        seeds > 1 else 0.0, "ln_Z_rmse": float(np.sqrt(np.mean(e**2))), "calls_mean": float(np.mean(calls)),
        "acceptance_mean": float(np.mean(acc)), "sweeps_per_stage": float(np.mean(sweeps)),
        "stages_mean": float(np.mean(stages)),
        "wall_s_per_run": float(np.mean(walls)),
    }
    if means:
        line["max_abs_mean_error"] = float(np.mean(means))
        line["max_rel_std_error"] = float(np.mean(stds))
    if minor:
        line["minor_mode_weight"] = float(np.mean(minor))
        line["minor_mode_weight_spread"] = float(np.std(minor, ddof=1)) if seeds > 1 else 0.0
        line["minor_mode_weight_exact"] = prob.minor_weight
    if overrides:
        line["overrides"] = overrides
    return line


def overhead_benchmark(n_samples=2000, d=10, sweeps=(1, 6)):
    """Sampler time per stage with a free log-likelihood (forward model excluded), with one sweep per stage and
    the cost of each further sweep (from the runs with sweeps[0] and sweeps[1] sweeps per stage)."""
    prob = PROBLEMS["B1"](d)
    out = []
    for method in ("O-TMCMC/adaptive", "O-TMCMC/mixture", "DE-TMCMC/redblue"):
        per_stage = []
        for n_steps in sweeps:
            t0 = time.perf_counter()
            post = tmcmc(prob.log_like, prob.prior, n_samples=n_samples, executor=SerialExecutor(), seed=0,
                         vectorized=True, progress=False, n_steps=n_steps, **METHODS[method])
            wall = time.perf_counter() - t0
            # subtract the likelihood's own time, measured separately on the same number of points
            thetas = prob.prior.sample(np.random.default_rng(0), post.n_forward_solves)
            t1 = time.perf_counter()
            prob.log_like(thetas)
            per_stage.append((wall - time.perf_counter() + t1) / (post.n_stages + 1))
        out.append({"benchmark": "sampler_overhead", "method": method, "n_samples": n_samples, "d": d,
                    "n_stages": post.n_stages, "sweeps_per_stage": sweeps[0], "overhead_s_per_stage": per_stage[0],
                    "overhead_s_per_extra_sweep": (per_stage[1] - per_stage[0]) / (sweeps[1] - sweeps[0])})
    return out


def _sleep_like(seconds):
    def log_like(theta):
        t_end = time.perf_counter() + seconds
        while time.perf_counter() < t_end:  # busy wait: a CPU-bound stand-in for a forward solve
            pass
        return -0.5 * float(np.sum(np.asarray(theta) ** 2))

    return log_like


def dispatch_benchmark(model_seconds=0.05, n_eval=200):
    """Run under mpirun: time n_eval evaluations of a busy-waiting model with each dispatch mode."""
    from .executors import Evaluator, MPIExecutor, mpi_world

    comm = mpi_world()
    ev = Evaluator(_sleep_like(model_seconds))
    thetas = np.random.default_rng(0).normal(size=(n_eval, 3))
    lines = []
    if comm is None:
        t0 = time.perf_counter()
        SerialExecutor().evaluate(ev, thetas)
        wall = time.perf_counter() - t0
        return [{"benchmark": "dispatch", "mode": "serial", "ranks": 1, "model_s": model_seconds, "n_eval": n_eval,
                 "wall_s": wall, "overhead_ms_per_eval": 1e3 * (wall / n_eval - model_seconds)}]
    ev0 = Evaluator(_sleep_like(0.0))
    for mode in ("dynamic", "spmd"):
        ex = MPIExecutor(comm, mode=mode)
        for evaluator, label in ((ev0, "zero"), (ev, "busy")):
            if ex.is_root:
                t0 = time.perf_counter()
                ex.evaluate(evaluator, thetas if label == "busy" else np.tile(thetas, (10, 1)))
                wall = time.perf_counter() - t0
                ex.finish(("ok", None))
                n = n_eval if label == "busy" else 10 * n_eval
                ideal = n * (model_seconds if label == "busy" else 0.0) / ex.ranks
                line = {"benchmark": "dispatch", "mode": mode, "ranks": ex.ranks, "model_s":
                        model_seconds if label == "busy" else 0.0, "n_eval": n, "wall_s": wall}
                if label == "busy":
                    line["parallel_efficiency_vs_ideal"] = ideal / wall
                else:
                    line["overhead_ms_per_eval"] = 1e3 * wall / n
                lines.append(line)
            else:
                ex.serve(evaluator)
    return lines


def _parse_override(text):
    key, sep, value = text.partition("=")
    if not sep:
        raise SystemExit(f"--set {text!r}: use KEY=VALUE")
    try:
        return key, json.loads(value)
    except json.JSONDecodeError:
        return key, value


def discrepancy_benchmark(lengths=(0.05, 0.3), records=(100, 300, 1000, 3000, 10000), rows=16, repeat=3):
    """Per curve length and length scale: the time of (D2) per parameter set (best of ``repeat`` calls over
    ``rows`` sets, after a warm-up call) and how it is taken (exact Cholesky factor, or the reduced-rank expansion
    (D3) with its number of functions)."""
    rng = np.random.default_rng(0)
    for n in records:
        curve = CurveDiscrepancy(np.linspace(0.0, 1.0, n), 1, n, 3.0)
        residuals = rng.normal(0.0, 0.02, (rows, n))
        for length in lengths:
            args = (residuals, np.full(rows, 0.02), np.full(rows, 0.02), np.full(rows, length))
            curve.log_density(*args)
            best = float("inf")
            for _ in range(repeat):
                t0 = time.perf_counter()
                curve.log_density(*args)
                best = min(best, time.perf_counter() - t0)
            m = reduced_rank_basis(max(length, curve.floor), n)[1]
            yield {"benchmark": "discrepancy (D2)", "records": n, "length": length,
                   "taken": f"reduced rank, {m} functions" if m else "exact",
                   "ms_per_parameter_set": round(1e3 * best / rows, 4)}


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m inference.bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="B1, B2 and B6, 3 seeds, 1000 samples")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--problems", default="B1,B2,B3,B4,B5,B6")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="tmcmc keyword override for every method, VALUE read as JSON (else a string)")
    ap.add_argument("--overhead", action="store_true", help="only the sampler overhead per stage")
    ap.add_argument("--dispatch", action="store_true", help="only the MPI dispatch benchmark (under mpirun)")
    ap.add_argument("--discrepancy", action="store_true", help="only the model-form discrepancy per curve length")
    args = ap.parse_args(argv)
    if args.discrepancy:
        for line in discrepancy_benchmark():
            print(json.dumps(line), flush=True)
        return 0
    if args.dispatch:
        for line in dispatch_benchmark():
            print(json.dumps(line), flush=True)
        return 0
    if args.overhead:
        for line in overhead_benchmark():
            print(json.dumps(line), flush=True)
        return 0
    problems, seeds, samples = args.problems.split(","), args.seeds, args.samples
    methods = args.methods.split(",")
    if args.quick:
        problems, seeds, samples = ["B1", "B2", "B6"], 3, 1000
        methods = ["O-TMCMC/adaptive", "DE-TMCMC/paper", "DE-TMCMC/redblue"]
    unknown = [m for m in methods if m not in METHODS] + [p for p in problems if p not in PROBLEMS]
    if unknown:
        ap.error(f"unknown methods/problems {unknown}; methods: {list(METHODS)}; problems: {list(PROBLEMS)}")
    overrides = dict(_parse_override(kv) for kv in args.set)
    print(json.dumps({"benchmark": "info", "note": "DE-TMCMC and O-TMCMC on posteriors with known log-evidence "
                      "(docs/reference.md section 8); errors over seeds 0.." + str(seeds - 1)}), flush=True)
    for p in problems:
        for m in methods:
            print(json.dumps(evidence_benchmark(p, m, seeds, samples, **overrides)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
