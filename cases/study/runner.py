"""Running a study's calibrations: the run settings record, the runs of one command line, one TMCMC run and its
summary.json.

Every requested run is a method (DE-TMCMC "de" or O-TMCMC "o") and a seed; ``--method both`` puts the methods side by
side in DIR/de and DIR/o, ``--runs R`` puts run r in DIR/seed_<S+r>. Under ``mpirun -n K`` every rank calls
:func:`calibrate`; rank 0 samples and writes, the other ranks run forward solves.
"""
from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import inference
from inference.executors import mpi_world

__all__ = ["PROPOSALS", "RunSettings", "is_root", "method_name", "run_directories", "calibrate", "run_all",
           "write_summary", "throughput"]

#: command-line method -> inference.tmcmc proposal
PROPOSALS = {"de": "de", "o": "gaussian"}


@dataclass(frozen=True)
class RunSettings:
    """What the command line asks of the runs: preset, method ("de", "o" or "both"), particles per stage (None: the
    preset's), first seed, number of seeds, output directory (None: the case's default), resume from the checkpoint,
    MPI dispatch ("dynamic" or "spmd") and local process-pool size (None: one per core)."""

    quick: bool = False
    method: str = "de"
    samples: int | None = None
    seed: int = 1
    runs: int = 1
    out: Path | None = None
    resume: bool = False
    dispatch: str = "dynamic"
    processes: int | None = None


def is_root() -> bool:
    """True on the process that samples and writes (rank 0, or the only process without mpirun)."""
    comm = mpi_world()
    return comm is None or comm.Get_rank() == 0


def method_name(method: str) -> str:
    return {"de": "DE-TMCMC", "o": "O-TMCMC"}[method]


def _with_method(run, method: str):
    if dataclasses.is_dataclass(run):
        return dataclasses.replace(run, method=method)
    return type(run)(**{**vars(run), "method": method})  # a namespace that also holds a case's own options


def run_directories(run, default_out: Path) -> list:
    """(run settings of one method, seed, directory) of each requested run: every method of ``run.method`` x every
    seed."""
    out = Path(run.out or default_out)
    methods = sorted(PROPOSALS) if run.method == "both" else [run.method]
    runs = []
    for method in methods:
        base = out / method if len(methods) > 1 else out
        for r in range(run.runs):
            seed = run.seed + r
            runs.append((_with_method(run, method), seed, base if run.runs == 1 else base / f"seed_{seed}"))
    return runs


def calibrate(like, prior, run, out: Path, seed: int, n_samples: int, executor=None, **settings):
    """One TMCMC run (method ``run.method``, resumed when ``run.resume``) with checkpoint and progress log in ``out``;
    ``settings`` go to inference.tmcmc. Returns the Posterior on every rank."""
    out = Path(out)
    if is_root():
        out.mkdir(parents=True, exist_ok=True)
    if executor is None:
        executor = inference.default_executor(run.dispatch, run.processes)
    try:
        return inference.tmcmc(like, prior, n_samples=n_samples, proposal=PROPOSALS[run.method], seed=seed,
                               executor=executor, checkpoint=out / "run.ckpt", resume=run.resume,
                               log=out / "progress.log", **settings)
    finally:
        executor.close()


def run_all(run, default_out, like, prior, n_samples, settings, finish) -> list:
    """Every run of ``run`` (methods x seeds, :func:`run_directories`): calibrate, then on rank 0
    ``finish(run of one method, seed, out, post) -> summary`` and one JSON line per run on stdout. Returns the
    summaries (rank 0) or [] (other ranks)."""
    summaries = []
    for one, seed, out in run_directories(run, default_out):
        t0 = time.perf_counter()
        post = calibrate(like, prior, one, out, seed, n_samples, **settings)
        if is_root():
            summaries.append(finish(one, seed, out, post))
            print(json.dumps({"out": str(out), "method": one.method, "seed": seed,
                              "wall_s": round(time.perf_counter() - t0, 1), "n_stages": post.n_stages,
                              "n_forward_solves": post.n_forward_solves, "log_evidence": round(post.log_evidence, 3),
                              "map": {k: round(v, 4) for k, v in post.map.items()}}), flush=True)
    return summaries


def write_summary(out: Path, case: str, run, seed: int, post, like, extra=None) -> dict:
    """post.save(out) with the summary fields every case writes (case, method, seed, quick, J_g at MAP,
    sigma_eps); J_g (Eq. 5) at MAP costs one forward solve. The checkpoint of the finished run is removed."""
    t0 = time.perf_counter()
    try:
        jg = {t: float(v) for t, v in like.summary_goodness(post.map_theta).items()}
    except Exception as exc:  # noqa: BLE001 - report, do not lose the posterior over a diagnostic
        jg = {"error": f"{type(exc).__name__}: {exc}"}
    fields = {"case": case, "method": method_name(run.method), "seed": int(seed), "quick": bool(run.quick),
              "J_g_at_map": jg, "J_g_wall_s": time.perf_counter() - t0}
    def sigma_fields(name):
        i = post.names.index(name)
        return {"map": float(post.map_theta[i]), "mean": float(post.samples[:, i].mean()),
                "std": float(post.samples[:, i].std(ddof=1))}

    if len(like.sigma_names) == 1:
        fields["sigma_eps"] = sigma_fields(like.sigma_names[0])
    elif like.sigma_names:  # error groups: {group: ...}
        fields["sigma_eps"] = {g: sigma_fields(n) for g, n in zip(like.groups, like.sigma_names)}
    fields.update(extra or {})
    post.save(out, extra=fields)
    checkpoint = Path(out) / "run.ckpt"
    if checkpoint.exists():  # the run finished: its answer is in posterior.npz / summary.json
        checkpoint.unlink()
    return json.loads((Path(out) / "summary.json").read_text())


def throughput(like, prior, run, n: int, case: str):
    """Forward evaluations per second for n prior draws (seed 0) with the run's executor (1 process with
    ``--processes 1``, the pool, or the MPI ranks); one JSON line on rank 0."""
    like.bind(prior.names)
    evaluator = inference.Evaluator(like)
    thetas = prior.sample(np.random.default_rng(0), n)
    executor = inference.default_executor(run.dispatch, run.processes)
    if executor.is_root:
        t0 = time.perf_counter()
        values, _, _ = executor.evaluate(evaluator, thetas)
        wall = time.perf_counter() - t0
        if isinstance(executor, inference.MPIExecutor):
            executor.finish(("ok", None))
        print(json.dumps({"case": case, "benchmark": "throughput", "executor": executor.name,
                          "processes": executor.ranks,
                          "n": n, "wall_s": round(wall, 2), "evaluations_per_s": round(n / wall, 3),
                          "fe_solves_per_s": round(len(like.observations) * n / wall, 3),
                          "failed": int(np.sum(~np.isfinite(values)))}), flush=True)
    else:
        executor.serve(evaluator)
    executor.close()
