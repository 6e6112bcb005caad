"""The command line every runnable study shares, turned into a :class:`~cases.study.runner.RunSettings` record, and
the one error handler of every entry point.

    python -m cases.<name> [--quick] [--method de|o|both] [--samples N] [--seed S] [--runs R] [--out DIR] [--resume]
                           [--dispatch dynamic|spmd] [--processes P] [--debug]

It runs unchanged under ``mpirun -n K`` (see :mod:`cases.study.runner`); without mpirun the local process pool is
used (``--processes``, default one per core). A case adds its own options with ``add(parser)``; nothing below this
layer sees the argparse namespace.

Errors: a bad input (command line, study file, recording CSV, checkpoint, model or FE value, an ``--out`` in use)
is one line on stderr naming the option, file, field or column and the value, and the exit status is 2, before any
solve and with nothing written in ``--out`` (:func:`command`); ``--debug`` shows the traceback instead.
"""
from __future__ import annotations

import argparse
import functools
import re
import sys
from pathlib import Path

import inference
from cases.study.checks import StudyError
from cases.study.runner import PROPOSALS, OutputLocked, RunSettings, is_root
from constitutive import ParameterError
from fem import MeshError, ProblemError

__all__ = ["UsageError", "REFUSED", "EXIT_REFUSED", "EXIT_INTERRUPTED", "command", "arguments", "run_settings",
           "pairs", "positive_int", "non_negative_int", "quantity", "unit_hint"]

#: exit status of a refused input or a stopped run; of Ctrl-C (128 + SIGINT)
EXIT_REFUSED, EXIT_INTERRUPTED = 2, 130


class UsageError(ValueError):
    """A bad command-line value: the message names the option and the value."""


#: the errors of a bad input, each with a one-line message naming what is wrong (a plain ValueError too: a value
#: refused by a check below the command line)
REFUSED = (UsageError, StudyError, inference.DataError, inference.CheckpointError, inference.PriorError,
           ParameterError, ProblemError, MeshError, OutputLocked, OSError, ValueError)


def _one_line(exc) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def command(main):
    """Wrap a case's ``main(argv)``: a bad input (:data:`REFUSED`), a stopped run (``inference.SamplerError``,
    whose one-line reason the runner has printed) or any other error returns :data:`EXIT_REFUSED` after one line on
    stderr (rank 0 only under mpirun), Ctrl-C :data:`EXIT_INTERRUPTED`; with ``--debug`` in argv the exception
    propagates with its traceback."""

    @functools.wraps(main)
    def guarded(argv=None, **options):
        argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
        try:
            return main(argv, **options)
        except inference.RunStopped:
            if "--debug" in argv:
                raise
            return EXIT_REFUSED
        except KeyboardInterrupt:
            if "--debug" in argv:
                raise
            if is_root():
                print("interrupted (the last checkpoint, if any, is kept: --resume continues from it)",
                      file=sys.stderr, flush=True)
            return EXIT_INTERRUPTED
        except Exception as exc:  # noqa: BLE001 - the one place that turns every error into one line
            if "--debug" in argv:
                raise
            if is_root():
                known = isinstance(exc, REFUSED + (inference.SamplerError,))
                text = _one_line(exc) if known else (f"unexpected {type(exc).__name__}: {_one_line(exc)} (run again "
                                                     "with --debug for the traceback)")
                print(f"error: {text}", file=sys.stderr, flush=True)
            return EXIT_REFUSED

    return guarded


class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line (status 2)."""

    def error(self, message):
        self.exit(EXIT_REFUSED, f"{self.prog}: error: {' '.join(message.split())} (see --help)\n")


def _integer(minimum):
    def cast(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{text!r}: expected an integer >= {minimum}")
        return value
    cast.__name__ = f"integer >= {minimum}"
    return cast


#: argparse types: an integer >= 1, an integer >= 0
positive_int, non_negative_int = _integer(1), _integer(0)


#: units an option value may be written in -> (the unit it converts to, that unit per one of these)
_OPTION_UNITS = {
    "1/s": ("1/s", 1.0), "/s": ("1/s", 1.0), "%/s": ("1/s", 0.01), "1/min": ("1/s", 1 / 60),
    "%/min": ("1/s", 0.01 / 60), "1/h": ("1/s", 1 / 3600), "%/h": ("1/s", 0.01 / 3600),
    "s": ("s", 1.0), "ms": ("s", 1e-3), "min": ("s", 60.0), "h": ("s", 3600.0), "d": ("s", 86400.0),
    "day": ("s", 86400.0), "kPa": ("kPa", 1.0), "Pa": ("kPa", 1e-3), "MPa": ("kPa", 1e3), "%": ("-", 0.01),
}
_NUMBER_AND_UNIT = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S.*?)\s*$")


def unit_hint(text: str, what: str, unit: str) -> str:
    """Why ``text`` is not a value of ``what`` (e.g. "cavity strain rate") as a plain number in ``unit`` ("1/s", "s",
    "kPa", "-" for a plain number): a number with a unit gets its conversion (``0.167%`` for a rate: 0.167 %/s =
    0.00167 1/s), or the unit expected."""
    plain = "a plain number" if unit == "-" else f"a number in {unit}"
    m = _NUMBER_AND_UNIT.match(text)
    if m is None:
        return f"{text!r} is not a number; give the {what} as {plain}"
    number, given = float(m.group(1)), m.group(2)
    given = "%/s" if given == "%" and unit == "1/s" else given
    target, factor = _OPTION_UNITS.get(given, (None, 1.0))
    if target != unit:
        return f"give the {what} as {plain} (unit {given!r} not understood)"
    value = f"{number * factor:.6g}"
    converted = value if unit == "-" else f"{value} {unit}"
    return f"give the {what} as {plain} ({m.group(1)} {given} = {converted}: write {value})"


def quantity(what: str, unit: str, positive=True):
    """argparse type: a finite number > 0 (``positive``) or >= 0 of ``what`` in ``unit``; a value with a unit is
    refused with its conversion (:func:`unit_hint`)."""
    def cast(text):
        try:
            value = float(text)
        except ValueError:
            hint = unit_hint(text, what, unit)
            raise argparse.ArgumentTypeError(hint if hint.startswith(repr(text)) else f"{text!r}: {hint}") from None
        if not (value > 0 if positive else value >= 0) or value == float("inf"):
            raise argparse.ArgumentTypeError(f"{text!r}: expected a finite number {'>' if positive else '>='} 0 "
                                             f"({what}{'' if unit == '-' else ' in ' + unit})")
        return value
    cast.__name__ = f"{what} in {unit}"
    return cast


def _out_directory(text):
    """argparse type of --out: a folder, existing or to be made (no part of the path an existing file)."""
    path = Path(text)
    for part in (path, *path.parents):
        if part.exists():
            if not part.is_dir():
                raise argparse.ArgumentTypeError(f"{text!r}: {part} is an existing file, not a folder")
            break
    return path


def arguments(description, argv=None, quick_help="small preset", add=None) -> argparse.Namespace:
    """Parse the common options (plus the case's own, added by ``add(parser)``); a bad value exits with status 2
    and one line naming the option and the value."""
    ap = _Parser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument("--method", choices=(*sorted(PROPOSALS), "both"), default="de",
                    help="de: DE-TMCMC, o: O-TMCMC, both: one run of each per seed")
    ap.add_argument("--samples", type=_integer(5), help="particles per stage N_s, >= 5 (default: the preset's)")
    ap.add_argument("--seed", type=non_negative_int, default=1, help="first random seed, >= 0")
    ap.add_argument("--runs", type=positive_int, default=1, help="independent runs with seeds S, S+1, ...")
    ap.add_argument("--out", type=_out_directory, help="output directory")
    ap.add_argument("--resume", action="store_true", help="continue from DIR/run.ckpt")
    ap.add_argument("--dispatch", choices=("dynamic", "spmd"), default="dynamic",
                    help="MPI dispatch under mpirun (spmd = the paper's labindex scheme)")
    ap.add_argument("--processes", type=positive_int, help="local process-pool size without mpirun (default: cores)")
    ap.add_argument("--debug", action="store_true", help="show the traceback of an error")
    if add is not None:
        add(ap)
    return ap.parse_args(argv)


def run_settings(args: argparse.Namespace) -> RunSettings:
    """The common options of a parsed command line as a settings record."""
    return RunSettings(quick=args.quick, method=args.method, samples=args.samples, seed=args.seed, runs=args.runs,
                       out=args.out, resume=args.resume, dispatch=args.dispatch, processes=args.processes)


def pairs(items, what, cast=float, units=None) -> dict:
    """``NAME=VALUE`` command-line items -> {name: cast(value)}; a UsageError naming the option ``what`` and the item
    for a missing '=', an empty name, a name given twice or a value ``cast`` refuses (a float must be finite).
    ``units``: {name: (quantity, unit)} of float values ("" for every name): a value with a unit is refused with the
    unit expected and its conversion (:func:`unit_hint`)."""
    out = {}
    units = units or {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UsageError(f"{what}: {item!r} must look like NAME=VALUE")
        if key in out:
            raise UsageError(f"{what}: {key!r} is given twice")
        try:
            out[key] = cast(value)
        except ValueError:
            expected = units.get(key, units.get(""))
            if expected is not None:
                raise UsageError(f"{what} {item}: {unit_hint(value, *expected)}") from None
            raise UsageError(f"{what}: {item!r}: {value!r} is not a valid value") from None
        if cast is float and not abs(out[key]) < float("inf"):
            raise UsageError(f"{what}: {item!r}: {value!r} is not a finite number")
        if cast is Path and not value.strip():
            raise UsageError(f"{what}: {item!r}: no file named")
    return out
