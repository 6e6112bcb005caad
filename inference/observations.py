"""Recorded test data: tests -> curves -> (abscissa, values), with units checked when read from CSV.

CSV convention: lines starting with ``#`` are metadata (``# key: value``; a file of generated data says so there,
e.g. ``# synthetic: true``). The first other line is the header; a column name carries its unit either as a suffix
``name_unit`` (``eps_a_pct``, ``q_kPa``, ``t_s``) or in brackets ``name [unit]``. A column without a unit is
dimensionless. Known conversions: Pa/kPa/MPa to kPa, s/min/h/d to s; strains in % stay in % (the caller says which
unit it wants and gets a clear error otherwise).
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["DataError", "Curve", "Test", "Observations", "read_csv_table"]


class DataError(ValueError):
    """Invalid recorded data: the message names the file, the field and the value."""


#: unit -> (dimension, factor to the base unit of that dimension: kPa, s, %, m)
_UNITS = {
    "kPa": ("stress", 1.0), "Pa": ("stress", 1e-3), "MPa": ("stress", 1e3),
    "s": ("time", 1.0), "min": ("time", 60.0), "h": ("time", 3600.0), "d": ("time", 86400.0),
    "pct": ("percent", 1.0), "%": ("percent", 1.0),
    "m": ("length", 1.0), "mm": ("length", 1e-3), "cm": ("length", 1e-2),
    "-": ("dimensionless", 1.0),
}
_BRACKET = re.compile(r"^\s*(.*?)\s*\[\s*(.*?)\s*\]\s*$")


def _split_unit(column: str):
    m = _BRACKET.match(column)
    if m:
        return m.group(1), (m.group(2) or "-")
    for unit in sorted(_UNITS, key=len, reverse=True):
        if unit.isidentifier() and column.endswith("_" + unit):
            return column[: -len(unit) - 1], unit
    return column, "-"


def read_csv_table(path) -> tuple[dict, dict]:
    """Read a CSV with ``#`` metadata lines. Returns (metadata, {quantity: (unit, values)}).

    Raises DataError naming the file, the column and the offending value for non-numeric or NaN entries.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    meta, rows, header = {}, [], None
    with path.open(newline="") as fh:
        for lineno, line in enumerate(fh, start=1):
            if not line.strip():
                continue
            if line.lstrip().startswith("#"):
                body = line.lstrip()[1:].strip()
                if ":" in body:
                    k, v = body.split(":", 1)
                    meta[k.strip()] = v.strip()
                continue
            cells = next(csv.reader([line]))
            if header is None:
                header = [c.strip() for c in cells]
                continue
            if len(cells) != len(header):
                raise DataError(f"{path}, line {lineno}: {len(cells)} values for {len(header)} columns {header}")
            rows.append((lineno, cells))
    if header is None or not rows:
        raise DataError(f"{path}: no header or no data rows")
    table = {}
    for j, col in enumerate(header):
        quantity, unit = _split_unit(col)
        values = np.empty(len(rows))
        for i, (lineno, cells) in enumerate(rows):
            raw = cells[j].strip()
            try:
                values[i] = float(raw)
            except ValueError:
                values[i] = np.nan
            if not np.isfinite(values[i]):
                raise DataError(f"{path}, line {lineno}, column {col!r}: value {raw!r} is not a finite number")
        table[quantity] = (unit, values)
    return meta, table


def converted(path, quantity, unit, values, wanted):
    """``values`` of column ``quantity`` in ``unit`` converted to the unit ``wanted`` (None: as they are); DataError
    naming the file and the column when the dimensions differ or a unit is unknown."""
    if wanted is None or wanted == unit or (_UNITS.get(wanted, (None,))[0] == "percent" and unit in ("pct", "%")):
        return values
    have, want = _UNITS.get(unit), _UNITS.get(wanted)
    if have is None or want is None or have[0] != want[0]:
        raise DataError(f"{path}: column {quantity!r} is in unit {unit!r}, expected {wanted!r}")
    return values * have[1] / want[1]


@dataclass
class Curve:
    """One recorded curve: values ``y`` (e.g. q in kPa) against abscissa ``x`` (e.g. axial strain in %)."""

    x: np.ndarray
    y: np.ndarray
    x_name: str = "x"
    y_name: str = "y"
    x_unit: str = "-"
    y_unit: str = "-"

    def __post_init__(self):
        self.x = np.asarray(self.x, dtype=float).ravel()
        self.y = np.asarray(self.y, dtype=float).ravel()
        if self.x.shape != self.y.shape or self.x.size == 0:
            raise DataError(f"curve {self.y_name}: abscissa and values must be non-empty and of equal length, "
                            f"got {self.x.size} and {self.y.size}")
        for label, arr in ((self.x_name, self.x), (self.y_name, self.y)):
            if not np.all(np.isfinite(arr)):
                raise DataError(f"curve {self.y_name}: field {label} has a non-finite value {arr[~np.isfinite(arr)][0]}")


@dataclass
class Test:
    """One laboratory or in-situ test: named curves plus its conditions (e0, p'0, rate, ... as metadata)."""

    __test__ = False  # not a pytest test class

    name: str
    curves: dict
    conditions: dict = field(default_factory=dict)
    source: str = ""


class Observations:
    """Tests -> curves. Iteration order is insertion order (the order of Eq. (6))."""

    def __init__(self, tests):
        tests = list(tests.values()) if isinstance(tests, dict) else list(tests)
        names = [t.name for t in tests]
        if len(set(names)) != len(names):
            raise DataError(f"test names must be unique, got {names}")
        if not tests:
            raise DataError("observations need at least one test")
        self.tests = {t.name: t for t in tests}

    def __iter__(self):
        return iter(self.tests.values())

    def __len__(self):
        return len(self.tests)

    def __getitem__(self, name):
        return self.tests[name]

    @property
    def n_points(self) -> int:
        return sum(c.x.size for t in self for c in t.curves.values())

    def fingerprint(self) -> str:
        """A hash of all values, used to refuse a checkpoint made for other data."""
        import hashlib

        h = hashlib.sha256()
        for t in self:
            h.update(t.name.encode())
            for name, c in t.curves.items():
                h.update(name.encode())
                h.update(np.ascontiguousarray(c.x).tobytes())
                h.update(np.ascontiguousarray(c.y).tobytes())
        return h.hexdigest()[:16]

    @classmethod
    def from_csv(cls, files: dict, x: str, curves, units: dict | None = None, conditions: dict | None = None):
        """Read one CSV per test.

        files: {test name: path}; x: the abscissa quantity (e.g. "eps_a"); curves: the value quantities (e.g.
        ["q", "e"]) or {curve name: quantity}; units: {quantity: wanted unit}, converted when possible and an error
        naming file and column otherwise; conditions: {test name: dict} merged over the file's ``#`` metadata.
        """
        units = units or {}
        curves = dict(zip(curves, curves)) if not isinstance(curves, dict) else curves
        tests = []
        for test_name, path in files.items():
            meta, table = read_csv_table(path)
            for q in (x, *curves.values()):
                if q not in table:
                    raise DataError(f"{path}: missing column {q!r} (found {list(table)})")
            xu, xv = table[x]
            xv = converted(path, x, xu, xv, units.get(x))
            cs = {}
            for cname, q in curves.items():
                yu, yv = table[q]
                yv = converted(path, q, yu, yv, units.get(q))
                cs[cname] = Curve(xv, yv, x, q, units.get(x, xu), units.get(q, yu))
            cond = dict(meta)
            cond.update((conditions or {}).get(test_name, {}))
            tests.append(Test(test_name, cs, cond, str(path)))
        return cls(tests)
