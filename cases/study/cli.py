"""The command line every runnable study shares, turned into a :class:`~cases.study.runner.RunSettings` record.

    python -m cases.<name> [--quick] [--method de|o|both] [--samples N] [--seed S] [--runs R] [--out DIR] [--resume]
                           [--dispatch dynamic|spmd] [--processes P]

It runs unchanged under ``mpirun -n K`` (see :mod:`cases.study.runner`); without mpirun the local process pool is
used (``--processes``, default one per core). A case adds its own options with ``add(parser)``; nothing below this
layer sees the argparse namespace.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from .runner import PROPOSALS, RunSettings

__all__ = ["arguments", "run_settings", "pairs"]


def arguments(description, argv=None, quick_help="small preset", add=None) -> argparse.Namespace:
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


def run_settings(args: argparse.Namespace) -> RunSettings:
    """The common options of a parsed command line as a settings record."""
    return RunSettings(quick=args.quick, method=args.method, samples=args.samples, seed=args.seed, runs=args.runs,
                       out=args.out, resume=args.resume, dispatch=args.dispatch, processes=args.processes)


def pairs(items, what, cast=float) -> dict:
    """``NAME=VALUE`` command-line items -> {name: cast(value)}; exits with a message naming the option ``what``."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"{what}: {item!r} must look like NAME=VALUE")
        try:
            out[key] = cast(value)
        except ValueError:
            raise SystemExit(f"{what}: {item!r}: {value!r} is not a valid value") from None
    return out
