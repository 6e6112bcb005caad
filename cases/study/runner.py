"""Running a study's calibrations: the run settings record, the runs of one command line, one TMCMC run and its
summary.json.

Every requested run is a method (DE-TMCMC "de" or O-TMCMC "o") and a seed; ``--method both`` puts the methods side by
side in DIR/de and DIR/o, ``--runs R`` puts run r in DIR/seed_<S+r>. Under ``mpirun -n K`` every rank calls
:func:`calibrate`; rank 0 samples and writes, the other ranks run forward solves. One command line holds DIR with a
lock (:func:`out_lock`, DIR/run.lock) while it runs: a second run on the same DIR is refused.

A run that stops before the posterior (``inference.RunStopped``: too many failed solves, no convergence;
``inference.Checkpointed``: SIGTERM/SIGUSR1) leaves DIR/progress.json and DIR/failed_solves.jsonl and one line on
stderr saying why.
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import socket
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

import inference
from inference.executors import mpi_world

__all__ = ["PROPOSALS", "RunSettings", "OutputLocked", "LOCK_FILE", "is_root", "method_name", "run_directories",
           "out_lock", "kernel_files", "uncached", "announce_compilation", "evaluate_once", "calibrate", "run_all",
           "pointwise_terms", "write_summary", "throughput", "POINTWISE_BUDGET_S"]

#: command-line method -> inference.tmcmc proposal
PROPOSALS = {"de": "de", "o": "gaussian"}
#: the lock of an output folder in use (JSON: pid, host, started)
LOCK_FILE = "run.lock"
#: posterior.nc holds each draw's log-likelihood per point when computing it takes less than this (s): a laboratory
#: study's curves, not the FE solves of a pressuremeter study
POINTWISE_BUDGET_S = 10.0


class OutputLocked(RuntimeError):
    """The output folder is in use by another run: the message names it (pid, host, start time)."""


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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def _holder(lock: Path):
    """The run that holds ``lock`` (dict), or None when the lock is stale: its process is gone from this host."""
    try:
        other = json.loads(lock.read_text())
        pid, host, started = int(other["pid"]), str(other["host"]), str(other["started"])
    except (OSError, ValueError, KeyError, TypeError):
        return {"pid": "?", "host": "?", "started": f"unknown (unreadable {lock}; remove it if no run uses the folder)"}
    if host == socket.gethostname() and not _alive(pid):
        return None
    return {"pid": pid, "host": host, "started": started}


def _take_lock(out: Path):
    """Take DIR/run.lock for this process: (lock file, its content, whether the folder was made for it)."""
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    lock = out / LOCK_FILE
    mine = {"pid": os.getpid(), "host": socket.gethostname(),
            "started": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    tmp = out / f".{LOCK_FILE}.{os.getpid()}"
    tmp.write_text(json.dumps(mine))
    try:
        while True:
            try:
                os.link(tmp, lock)  # atomic: fails when the lock exists
                return lock, mine, made
            except FileExistsError:
                other = _holder(lock)
                if other is not None:
                    if made:
                        out.rmdir()
                    raise OutputLocked(f"{out}: in use by another run (pid {other['pid']} on host {other['host']}, "
                                       f"started {other['started']}); wait for it or choose another --out") from None
                print(f"note: {lock}: taking over the stale lock of a run that is gone", file=sys.stderr, flush=True)
                lock.unlink(missing_ok=True)
    finally:
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def out_lock(out):
    """Hold the output folder ``out`` while the block runs: DIR/run.lock (taken by rank 0) names the pid, host and
    start time. Another live run's lock raises :class:`OutputLocked` naming it, on every rank; a stale lock (its pid
    gone from this host) is taken over with a note on stderr. The lock is removed on exit, and the folder too when
    the lock made it and nothing else was written."""
    out, comm, taken, refused = Path(out), mpi_world(), None, None
    if is_root():
        try:
            taken = _take_lock(out)
        except OutputLocked as exc:
            refused = str(exc)
    if comm is not None:
        refused = comm.bcast(refused, root=0)
    if refused:
        raise OutputLocked(refused)
    try:
        yield
    finally:
        if taken is not None:
            lock, mine, made = taken
            with contextlib.suppress(OSError, ValueError, KeyError, TypeError):
                if json.loads(lock.read_text())["pid"] == mine["pid"]:
                    lock.unlink()
            if made:
                with contextlib.suppress(OSError):
                    out.rmdir()  # only when empty


#: the kernel source files whose compilation this process has announced (or found cached)
_announced = set()


def kernel_files(model_class, fe=False) -> list:
    """The compiled-kernel source files a solve of ``model_class`` needs (``_<module>_kernel.py`` and, where there
    is one, ``_<module>_steps.py`` beside the model's module) and, with ``fe``, the FE's
    (``fem/_residual_kernel.py``)."""
    import inspect

    import fem

    source = Path(inspect.getfile(model_class))
    files = [source.with_name(f"_{source.stem}_kernel.py"), source.with_name(f"_{source.stem}_steps.py")]
    if fe:
        files.append(Path(fem.__file__).with_name("_residual_kernel.py"))
    return [f for f in files if f.is_file()]


def uncached(kernels) -> list:
    """The kernel source files of ``kernels`` (:func:`kernel_files`) with no numba cache index (``<module>.*.nbi``
    under NUMBA_CACHE_DIR when it is set, where numba then keeps its cache, else in their ``__pycache__``): those a
    solve would compile first."""
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")

    def cached(module):
        place = Path(cache_dir) if cache_dir else module.parent / "__pycache__"
        return place.is_dir() and any(place.rglob(f"{module.stem}.*.nbi"))

    return [Path(m) for m in kernels if not cached(Path(m))]


def announce_compilation(kernels, warm_up):
    """On rank 0, when one of the kernel source files ``kernels`` (:func:`kernel_files`) not yet seen by this process
    has no cache index (:func:`uncached`): say that the kernels are being compiled, run ``warm_up()`` (one forward
    evaluation, :func:`evaluate_once`, which compiles them and writes the cache) and say how long it took (s, the
    evaluation included). Each file is looked at once
    per process: the diagnosis loop's enriched classes announce the kernels of their own model (ANICREEP, delayed
    swelling) when they are first needed."""
    if not is_root():
        return
    fresh = [Path(m) for m in kernels if Path(m) not in _announced]
    _announced.update(fresh)
    cold = [m.name for m in uncached(fresh)]
    if cold:
        print(f"compiling the constitutive kernels ({', '.join(cold)}; first run only, cached afterwards)...",
              file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        warm_up()
        print(f"compiled: the first forward evaluation took {time.perf_counter() - t0:.1f} s, compilation "
              "included", file=sys.stderr, flush=True)


def evaluate_once(like, prior):
    """One forward evaluation of ``like`` at a prior draw (seed 0), a failure counting as done: what compiles the
    kernels before the sampler starts its workers."""
    like.bind(prior.names)
    like.evaluate_many(prior.sample(np.random.default_rng(0), 1))


def _stopped(stop, out: Path):
    """Save what a stopped run did (progress.json, failed_solves.jsonl) and say why, on one line."""
    stop.progress.save(out)
    # the sampler has said where a signal's checkpoint is; a stop for failures or no convergence is said here
    why = "" if isinstance(stop, inference.Checkpointed) else f"the run stopped: {' '.join(str(stop).split())}; "
    print(f"{why}progress so far in {out / 'progress.json'}, failed solves in {out / 'failed_solves.jsonl'}",
          file=sys.stderr, flush=True)


def calibrate(like, prior, run, out: Path, seed: int, n_samples: int, executor=None, **settings):
    """One TMCMC run (method ``run.method``, resumed when ``run.resume``) with checkpoint and progress log in ``out``;
    ``settings`` go to inference.tmcmc. Returns the Posterior on every rank. A stop (``inference.RunStopped``,
    ``inference.Checkpointed``) is saved in ``out`` and said on stderr (rank 0) before it propagates."""
    out = Path(out)
    if is_root():
        out.mkdir(parents=True, exist_ok=True)
        if run.resume and not (out / "run.ckpt").exists():
            print(f"note: --resume: no checkpoint {out / 'run.ckpt'}, starting from the beginning", file=sys.stderr,
                  flush=True)
    if executor is None:
        executor = inference.default_executor(run.dispatch, run.processes)
    try:
        return inference.tmcmc(like, prior, n_samples=n_samples, proposal=PROPOSALS[run.method], seed=seed,
                               executor=executor, checkpoint=out / "run.ckpt", resume=run.resume,
                               log=out / "progress.log", **settings)
    except (inference.RunStopped, inference.Checkpointed) as stop:
        if is_root():
            _stopped(stop, out)
        raise
    finally:
        executor.close()


def run_all(run, default_out, like, prior, n_samples, settings, finish, kernels=()) -> list:
    """Every run of ``run`` (methods x seeds, :func:`run_directories`): calibrate, then on rank 0
    ``finish(run of one method, seed, out, post) -> summary``, one JSON line per run on stdout (``wall_s`` summed
    over the sessions of a resumed run, as summary.json, and ``wall_s_this_session``) and after it the line
    ``report: DIR/report.md``, all under the lock of the output folder (:func:`out_lock`); with ``kernels``
    (:func:`kernel_files`), the compile message and its measured time when their cache is cold and the run does not
    resume. Returns the summaries (rank 0) or [] (other ranks)."""
    summaries = []
    with out_lock(run.out or default_out):
        if not run.resume:  # a checkpoint is checked first: no message before its refusal
            announce_compilation(kernels, lambda: evaluate_once(like, prior))
        for one, seed, out in run_directories(run, default_out):
            post = calibrate(like, prior, one, out, seed, n_samples, **settings)
            if is_root():
                summaries.append(finish(one, seed, out, post))
                print(json.dumps({"out": str(out), "method": one.method, "seed": seed,
                                  "wall_s": round(post.wall_s, 1),
                                  "wall_s_this_session": round(post.wall_s_this_session, 1),
                                  "n_stages": post.n_stages, "n_forward_solves": post.n_forward_solves,
                                  "log_evidence": round(post.log_evidence, 3),
                                  "map": {k: round(v, 4) for k, v in post.map.items()}}), flush=True)
                print(f"report: {out / 'report.md'}", flush=True)
    return summaries


def pointwise_terms(like, post, map_wall_s):
    """Each posterior draw's log-likelihood per recorded point (``Likelihood.pointwise_log_likelihood``), or None
    when it would take longer than :data:`POINTWISE_BUDGET_S` (the MAP's forward solve, ``map_wall_s``, times the
    draws), when the likelihood has a model-form discrepancy (no pointwise terms) or when a solve fails."""
    if like.discrepancy is not None or map_wall_s * len(post.samples) > POINTWISE_BUDGET_S:
        return None
    try:
        return like.pointwise_log_likelihood(like.simulated_many(post.samples), post.samples)
    except Exception:  # noqa: BLE001 - posterior.nc then holds the total log-likelihood per draw only
        return None


def write_summary(out: Path, case: str, run, seed: int, post, like, extra=None, later=None) -> dict:
    """post.save(out) with the summary fields every case writes (case, method, seed, quick, J_g at MAP,
    sigma_eps) and, in posterior.nc, the records, the MAP's curves at them and, where cheap
    (:func:`pointwise_terms`), each draw's log-likelihood per point; the MAP's curves (for J_g, Eq. (5)) cost one
    forward solve; ``later``: how posterior.nc is written (``inference.Posterior.save``). The checkpoint of the
    finished run is kept: resumed, it gives the run's answer without sampling again (the diagnosis loop resumed after
    a stop redoes none of its finished classes' samplers)."""
    t0 = time.perf_counter()
    try:
        map_simulated = {key: values[0] for key, values in like.simulated_many(post.map_theta).items()}
        jg = {t: float(v) for t, v in like.goodness_of_fit(map_simulated).items()}
    except Exception as exc:  # noqa: BLE001 - report, do not lose the posterior over a diagnostic
        map_simulated, jg = None, {"error": f"{type(exc).__name__}: {exc}"}
    map_wall_s = time.perf_counter() - t0
    pointwise = None if map_simulated is None else pointwise_terms(like, post, map_wall_s)
    fields = {"case": case, "method": method_name(run.method), "seed": int(seed), "quick": bool(run.quick),
              "J_g_at_map": jg, "J_g_wall_s": map_wall_s}
    def sigma_fields(name):
        i = post.names.index(name)
        return {"map": float(post.map_theta[i]), "mean": float(post.samples[:, i].mean()),
                "std": float(post.samples[:, i].std(ddof=1))}

    if len(like.sigma_names) == 1:
        fields["sigma_eps"] = sigma_fields(like.sigma_names[0])
    elif like.sigma_names:  # error groups: {group: ...}
        fields["sigma_eps"] = {g: sigma_fields(n) for g, n in zip(like.groups, like.sigma_names)}
    fields.update(extra or {})
    post.save(out, extra=fields, observations=like.observations, map_simulated=map_simulated, pointwise=pointwise,
              later=later)
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
