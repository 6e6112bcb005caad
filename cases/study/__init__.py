"""What every runnable study shares: the command line of DESIGN.md, the calibration call, and the outputs.

Command line (DESIGN.md "Runnable contracts"), the same for every case:
    python -m cases.<name> [--quick] [--method de|o|both] [--samples N] [--seed S] [--runs R] [--out DIR] [--resume]
                           [--dispatch dynamic|spmd] [--processes P]
It runs unchanged under ``mpirun -n K``: every rank calls :func:`calibrate`, rank 0 samples and writes, the other
ranks run forward solves. ``--method both`` runs DE-TMCMC and O-TMCMC for each seed (side by side in DIR/de and
DIR/o). Without mpirun the local process pool is used (``--processes``, default one per core).

Outputs of one run in DIR (``--runs R`` puts run r in DIR/seed_<S+r>):
- ``summary.json``: case, method, seed, n_samples, n_stages, n_forward_solves, wall_s, ranks, parameters
  {name: {map, mean, std, q2.5, median, q97.5}}, sigma_eps, log_evidence, J_g at MAP per test, stage records;
- ``posterior.npz`` (numpy only) and ``failed_solves.jsonl`` (one line per zero-likelihood particle and reason);
- ``progress.log`` (the sampler's stage-by-stage lines), ``run.ckpt`` while running (``--resume`` continues it);
- figures: ``marginals.png`` (posterior histograms with reference values marked), ``stages.png`` (samples per stage).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import inference
from inference.executors import mpi_world

__all__ = ["arguments", "is_root", "method_name", "calibrate", "run_all", "write_summary", "parameter_table",
           "runs_table", "plot_marginals", "plot_stages", "run_directories", "pyplot", "generating_values", "write_records"]

PROPOSALS = {"de": "de", "o": "gaussian"}


def arguments(description, argv=None, quick_help="small preset", add=None):
    """Parse the common options (plus the case's own, added by ``add(parser)``)."""
    ap = argparse.ArgumentParser(description=description,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument("--method", choices=(*sorted(PROPOSALS), "both"), default="de",
                    help="de: DE-TMCMC, o: O-TMCMC, both: one run of each per seed")
    ap.add_argument("--samples", type=int, help="particles per stage N_s (default: the preset's)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--runs", type=int, default=1, help="independent runs with seeds S, S+1, ...")
    ap.add_argument("--out", type=Path, help="output directory")
    ap.add_argument("--resume", action="store_true", help="continue from DIR/run.ckpt")
    ap.add_argument("--dispatch", choices=("dynamic", "spmd"), default="dynamic",
                    help="MPI dispatch under mpirun (spmd = the paper's labindex scheme)")
    ap.add_argument("--processes", type=int, help="local process-pool size without mpirun (default: cores)")
    if add is not None:
        add(ap)
    args = ap.parse_args(argv)
    if args.samples is not None and args.samples < 5:
        ap.error(f"--samples {args.samples}: DE-TMCMC needs at least 5 particles")
    if args.runs < 1:
        ap.error(f"--runs {args.runs}: need at least 1")
    return args


def is_root() -> bool:
    comm = mpi_world()
    return comm is None or comm.Get_rank() == 0


def method_name(method: str) -> str:
    return {"de": "DE-TMCMC", "o": "O-TMCMC"}[method]


def run_directories(args, default_out: Path):
    """(run arguments, seed, directory) of each requested run: every method of ``--method`` x every seed."""
    out = Path(args.out or default_out)
    methods = sorted(PROPOSALS) if args.method == "both" else [args.method]
    runs = []
    for method in methods:
        base = out / method if len(methods) > 1 else out
        for r in range(args.runs):
            seed = args.seed + r
            runs.append((argparse.Namespace(**{**vars(args), "method": method}), seed,
                         base if args.runs == 1 else base / f"seed_{seed}"))
    return runs


def calibrate(like, prior, args, out: Path, seed: int, n_samples: int, executor=None, **settings):
    """One TMCMC run with checkpoint and progress log in ``out``; returns the Posterior on every rank."""
    out = Path(out)
    if is_root():
        out.mkdir(parents=True, exist_ok=True)
    if executor is None:
        executor = inference.default_executor(args.dispatch, args.processes)
    try:
        return inference.tmcmc(like, prior, n_samples=n_samples, proposal=PROPOSALS[args.method], seed=seed,
                               executor=executor, checkpoint=out / "run.ckpt", resume=args.resume,
                               log=out / "progress.log", **settings)
    finally:
        executor.close()


def run_all(args, default_out, like, prior, n_samples, settings, finish):
    """Every run of the command line (methods x seeds, :func:`run_directories`): calibrate, then on rank 0
    ``finish(run_args, seed, out, post) -> summary`` and one JSON line per run on stdout. Returns the summaries
    (rank 0) or [] (other ranks)."""
    summaries = []
    for run_args, seed, out in run_directories(args, default_out):
        t0 = time.perf_counter()
        post = calibrate(like, prior, run_args, out, seed, n_samples, **settings)
        if is_root():
            summaries.append(finish(run_args, seed, out, post))
            print(json.dumps({"out": str(out), "method": run_args.method, "seed": seed,
                              "wall_s": round(time.perf_counter() - t0, 1), "n_stages": post.n_stages,
                              "n_forward_solves": post.n_forward_solves, "log_evidence": round(post.log_evidence, 3),
                              "map": {k: round(v, 4) for k, v in post.map.items()}}), flush=True)
    return summaries


def write_records(path, header, columns: dict, exact=()) -> Path:
    """One CSV of records: ``# `` header lines, the column names, then the rows, 9 significant digits except the
    columns named in ``exact`` (shortest round trip); written to ``<path>.tmp`` and moved into place."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    shortest = [c in exact for c in columns]
    with tmp.open("w") as fh:
        fh.writelines(f"# {h}\n" for h in header)
        fh.write(",".join(columns) + "\n")
        for row in zip(*columns.values()):
            fh.write(",".join(repr(float(v)) if s else f"{v:.9g}" for s, v in zip(shortest, row)) + "\n")
    tmp.replace(path)
    return path


def generating_values(observations, names=None):
    """The parameters synthetic records were generated from: the JSON object at the start of their
    ``# synthetic_parameters:`` header (text after it is a note), equal in every test, or None (no such header,
    tests that disagree, unreadable JSON, or other names than ``names`` when given)."""
    found = {t.conditions.get("synthetic_parameters") for t in observations}
    if len(found) != 1 or None in found:
        return None
    try:
        values, _ = json.JSONDecoder().raw_decode(next(iter(found)).strip())
    except json.JSONDecodeError:
        return None
    if not isinstance(values, dict) or (names is not None and set(values) != set(names)):
        return None
    return values


def write_summary(out: Path, case: str, args, seed: int, post, like, extra=None) -> dict:
    """post.save(out) with the DESIGN.md summary fields; J_g (Eq. 5) at MAP costs one forward solve."""
    t0 = time.perf_counter()
    try:
        jg = {t: float(v) for t, v in like.summary_goodness(post.map_theta).items()}
    except Exception as exc:  # noqa: BLE001 - report, do not lose the posterior over a diagnostic
        jg = {"error": f"{type(exc).__name__}: {exc}"}
    fields = {"case": case, "method": method_name(args.method), "seed": int(seed), "quick": bool(args.quick),
              "J_g_at_map": jg, "J_g_wall_s": time.perf_counter() - t0}
    name = like.sigma if isinstance(like.sigma, str) else None
    if name:
        i = post.names.index(name)
        fields["sigma_eps"] = {"map": float(post.map_theta[i]), "mean": float(post.samples[:, i].mean()),
                               "std": float(post.samples[:, i].std(ddof=1))}
    fields.update(extra or {})
    post.save(out, extra=fields)
    checkpoint = Path(out) / "run.ckpt"
    if checkpoint.exists():  # the run finished: its answer is in posterior.npz / summary.json
        checkpoint.unlink()
    return json.loads((Path(out) / "summary.json").read_text())


def _fmt(v):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-"
    a = abs(v)
    return f"{v:.4g}" if (a >= 1e-3 or a == 0) else f"{v:.3e}"


def parameter_table(post, reference: dict | None = None, units: dict | None = None) -> str:
    """Markdown table: MAP, mean, std, 95 % interval per parameter, then reference columns
    ``{column label: {name: value}}`` (true values, the paper's table...)."""
    reference = reference or {}
    units = units or {}
    q = post.quantiles()
    head = ["parameter", "MAP", "mean", "std", "95 % interval"] + list(reference)
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in post.names:
        label = f"{n} ({units[n]})" if units.get(n) else n
        cells = [label, _fmt(post.map[n]), _fmt(post.mean[n]), _fmt(post.std[n]),
                 f"[{_fmt(q[n][0])}, {_fmt(q[n][2])}]"]
        cells += [_fmt(col.get(n)) for col in reference.values()]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)


def runs_table(summaries: list, names, reference: dict | None = None) -> str:
    """Markdown table over independent runs, one column pair per method (side by side): average MAP and its
    spread (std over runs) per parameter, then reference columns; then ln Z and forward solves per method."""
    reference = reference or {}
    methods = sorted({s["method"] for s in summaries})
    by = {m: [s for s in summaries if s["method"] == m] for m in methods}
    head = ["parameter"] + [f"{m}: {h}" for m in methods for h in ("average MAP", "spread of MAP")] + list(reference)
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in names:
        cells = [n]
        for m in methods:
            maps = np.array([s["parameters"][n]["map"] for s in by[m]])
            cells += [_fmt(float(maps.mean())), _fmt(float(maps.std(ddof=1)) if maps.size > 1 else None)]
        rows.append("| " + " | ".join(cells + [_fmt(col.get(n)) for col in reference.values()]) + " |")
    rows.append("")
    for m in methods:
        ev = np.array([s["log_evidence"] for s in by[m]])
        solves = np.array([s["n_forward_solves"] for s in by[m]])
        wall = np.array([s["wall_s"] for s in by[m]])
        rows.append(f"- {m}: {ev.size} run(s); ln Z mean {ev.mean():.3f}, spread "
                    f"{ev.std(ddof=1) if ev.size > 1 else 0:.3f}; forward evaluations {solves.mean():.0f} per run; "
                    f"wall {wall.mean():.0f} s per run")
    return "\n".join(rows)


def pyplot():
    """matplotlib.pyplot on the off-screen Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_marginals(post, path, marks: dict | None = None, bounds: dict | None = None, title: str | None = None):
    """Histogram of each parameter's final-stage samples; ``marks`` {label: {name: value}} drawn as lines;
    ``title`` above the panels (say "synthetic" there when the data are)."""
    plt = pyplot()
    d = len(post.names)
    cols = min(d, 4)
    rows = -(-d // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.6 * rows), squeeze=False)
    styles = ["-", "--", ":", "-."]
    for ax, (i, n) in zip(axes.flat, enumerate(post.names)):
        ax.hist(post.samples[:, i], bins=30, density=True, color="0.75")
        ax.axvline(post.map_theta[i], color="C3", lw=1.5, label="MAP")
        for k, (label, values) in enumerate((marks or {}).items()):
            if n in values:
                ax.axvline(values[n], color=f"C{k}", ls=styles[k % 4], lw=1.2, label=label)
        if bounds and n in bounds:
            ax.set_xlim(bounds[n])
        ax.set_xlabel(n)
        ax.set_yticks([])
    for ax in list(axes.flat)[d:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_stages(post, path):
    """Samples of each parameter against the stage index (how the population narrows)."""
    plt = pyplot()
    d = len(post.names)
    fig, axes = plt.subplots(1, d, figsize=(2.6 * d, 2.6), squeeze=False)
    for i, (ax, n) in enumerate(zip(axes[0], post.names)):
        for j, th in enumerate(post.stage_samples):
            ax.plot(np.full(len(th), j) + np.linspace(-0.3, 0.3, len(th)), th[:, i], ".", ms=1, color="C0")
        ax.set_xlabel("stage")
        ax.set_title(n, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
