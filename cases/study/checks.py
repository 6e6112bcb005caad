"""Reading a study file and checking its values: every error names the TOML file, the table and field, and the bad
value."""
from __future__ import annotations

import difflib
import math
from pathlib import Path

from inference import DataError
from inference.observations import read_text

__all__ = ["StudyError", "Checker", "read_toml", "fe_value", "did_you_mean"]


class StudyError(ValueError):
    """An invalid study file: the message names the TOML file, the table and field, and the value."""


def read_toml(path) -> dict:
    """The parsed TOML file (tomllib, or the tomli package on Python 3.10): UTF-8, a byte-order mark skipped;
    StudyError naming the file otherwise."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise StudyError(f"{path}: reading a study file needs Python >= 3.11 (tomllib) or the 'tomli' package "
                             "(pip install tomli)") from None
    path = Path(path)
    if not path.exists():
        raise StudyError(f"{path}: study file not found")
    if not path.is_file():
        raise StudyError(f"{path}: not a file (a study file is a TOML file)")
    try:
        text = read_text(path, save_as="UTF-8")  # the one decoder of input files (UTF-8, with or without a BOM)
    except DataError as exc:
        raise StudyError(str(exc)) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{path}: not valid TOML: {exc}") from None


def did_you_mean(word, allowed) -> str:
    """``"did you mean 'closest'? "`` for the allowed name closest to a misspelt ``word`` (difflib's ratio >= 0.75:
    one or two letters off, not merely a shared stem), else ``""``: the start of an error message's hint."""
    close = difflib.get_close_matches(str(word), [str(a) for a in allowed], n=1, cutoff=0.75)
    return f"did you mean {close[0]!r}? " if close else ""


class Checker:
    """Error messages that name the TOML file, the table.field and the value."""

    def __init__(self, path):
        self.path = Path(path)

    def fail(self, where, value, why):
        raise StudyError(f"{self.path}: {where} = {value!r}: {why}")

    def table(self, value, where, allowed=None, required=()):
        if not isinstance(value, dict):
            self.fail(where, value, "expected a table")
        if allowed is not None:
            for k in value:
                if k not in allowed:
                    self.fail(f"{where}.{k}" if where else k, value[k],
                              f"unknown field; {did_you_mean(k, allowed)}expected one of {', '.join(allowed)}")
        for k in required:
            if k not in value:
                raise StudyError(f"{self.path}: {where}.{k} is missing" if where else f"{self.path}: {k} is missing")
        return value

    def number(self, value, where, positive=False, non_negative=False):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(where, value, "expected a finite number")
        if positive and not value > 0:
            self.fail(where, value, "must be > 0")
        if non_negative and value < 0:
            self.fail(where, value, "must be >= 0")
        return float(value)

    def integer(self, value, where, minimum):
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            self.fail(where, value, f"expected an integer >= {minimum}")
        return int(value)

    def text(self, value, where, choices=None):
        if not isinstance(value, str) or not value.strip():
            self.fail(where, value, "expected a non-empty string")
        if choices is not None and value not in choices:
            self.fail(where, value, f"{did_you_mean(value, choices)}expected one of {', '.join(choices)}")
        return value

    def flag(self, value, where):
        if not isinstance(value, bool):
            self.fail(where, value, "expected true or false")
        return value

    def bounds(self, value, where, kind="uniform"):
        """[lower, upper] or {bounds = [lower, upper], prior = "uniform" | "log-uniform"} -> (lo, hi, kind)."""
        if isinstance(value, dict):
            self.table(value, where, ("bounds", "prior"), ("bounds",))
            kind = self.text(value.get("prior", kind), f"{where}.prior", ("uniform", "log-uniform"))
            value, where = value["bounds"], f"{where}.bounds"
        if not isinstance(value, list) or len(value) != 2:
            self.fail(where, value, "expected [lower, upper] or {bounds = [lower, upper], prior = \"log-uniform\"}")
        lo, hi = (self.number(v, where) for v in value)
        if not lo < hi:
            self.fail(where, value, "lower bound must be < upper bound")
        if kind == "log-uniform" and lo <= 0:
            self.fail(where, value, "a log-uniform prior needs a lower bound > 0")
        return lo, hi, kind


def fe_value(ck: Checker, key: str, value, where: str):
    """One field of [fe] or [fe.quick], checked: ``outer`` "fixed" or "field"; ``outer_radius_a0`` (the outer
    boundary in probe radii a0) a number > 1, outside the probe; the mesh sizes and increments integers >= 1."""
    if key == "outer":
        return ck.text(value, where, ("fixed", "field"))
    if key == "outer_radius_a0":
        radius = ck.number(value, where, positive=True)
        if not radius > 1.0:
            ck.fail(where, value, "the outer boundary must lie outside the probe: > 1 (in probe radii a0)")
        return radius
    return ck.integer(value, where, 1)
