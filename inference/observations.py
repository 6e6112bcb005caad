"""Recorded test data: tests -> curves -> (abscissa, values), with units checked when read from CSV.

CSV convention: lines starting with ``#`` are metadata (``# key: value``, read as written; a file of generated data
says so there, e.g. ``# synthetic: true``). The first other line is the header. Columns are separated by ``,``, or by
``;`` as a spreadsheet saves a CSV in a comma-decimal locale: decided per file from the header line. In a ``;`` file
the numbers may use a decimal comma (``1,25``) or a decimal point, one of the two in the whole file. A column name
carries its unit as a suffix ``name_unit`` (``eps_a_pct``, ``q_kPa``, ``t_s``), in brackets ``name [unit]`` or in
parentheses ``name (unit)``; blanks inside a name become ``_`` (``axial strain (%)`` is quantity ``axial_strain`` in
``%``). A column without a unit is dimensionless. Known units (:data:`_UNITS`): kPa, kN/m2, Pa, MPa (stress, to kPa);
s, min, h, d (time, to s); % or pct (strain, kept in %); m, cm, mm (length, to m); ``-`` (dimensionless); the caller
says which unit it wants and gets a clear error otherwise. A unit of other common practice (psi, ksf, bar, kgf/cm2,
ft, ...: :data:`_FOREIGN`) is refused with its conversion factor, never converted. Files are UTF-8 (a byte-order
mark, as Excel's "CSV UTF-8" writes, is skipped), with any line ends; numbers may be quoted; a row of empty cells (a
spreadsheet's blank row) is skipped. A file is refused as a whole, naming the file, the line, the column and the
value, when it is another encoding, has the same column (or the same quantity in two units) twice, a unit not known,
both decimal marks, or a value that is not finite or outside the physical range of its unit.
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["DataError", "Curve", "Test", "Observations", "read_text", "read_csv_rows", "split_unit",
           "read_csv_table", "converted"]


class DataError(ValueError):
    """Invalid recorded data: the message names the file, the field and the value."""


#: unit -> (dimension, factor to the base unit of that dimension: kPa, s, %, m)
_UNITS = {
    "kPa": ("stress", 1.0), "kN/m2": ("stress", 1.0), "kN/m²": ("stress", 1.0), "Pa": ("stress", 1e-3),
    "MPa": ("stress", 1e3),
    "s": ("time", 1.0), "min": ("time", 60.0), "h": ("time", 3600.0), "d": ("time", 86400.0),
    "pct": ("percent", 1.0), "%": ("percent", 1.0),
    "m": ("length", 1.0), "mm": ("length", 1e-3), "cm": ("length", 1e-2),
    "-": ("dimensionless", 1.0),
}
#: units of other practice a recording may be in, refused: unit -> (known unit to convert to, that unit per one of
#: these); the factors are exact from the definitions (lbf = 4.4482216152605 N, in = 0.0254 m, ft = 0.3048 m,
#: kgf = 9.80665 N, short ton = 2000 lb, atm = 101.325 kPa), rounded to 7 digits in the message
_FOREIGN = {
    "psi": ("kPa", 6.894757293), "ksi": ("MPa", 6.894757293), "psf": ("kPa", 0.04788025898),
    "ksf": ("kPa", 47.88025898), "tsf": ("kPa", 95.76051797), "kgf/cm2": ("kPa", 98.0665),
    "kg/cm2": ("kPa", 98.0665), "kgf/cm²": ("kPa", 98.0665), "kg/cm²": ("kPa", 98.0665), "t/m2": ("kPa", 9.80665),
    "t/m²": ("kPa", 9.80665), "bar": ("kPa", 100.0), "mbar": ("kPa", 0.1), "atm": ("kPa", 101.325),
    "in": ("mm", 25.4), "ft": ("m", 0.3048),
    "sec": ("s", 1.0), "ms": ("s", 1e-3), "hr": ("h", 1.0), "hour": ("h", 1.0), "day": ("d", 1.0), "days": ("d", 1.0),
}
_UNIT_IN_BRACKETS = re.compile(r"^\s*(.*?)\s*(?:\[\s*(.*?)\s*\]|\(\s*(.*?)\s*\))\s*$")
#: a number written with a decimal comma / a decimal point (quoted or not, with or without an exponent)
_COMMA_NUMBER = re.compile(r"^\s*[+-]?(?:\d+,\d*|,\d+)(?:[eE][+-]?\d+)?\s*$")
_POINT_NUMBER = re.compile(r"^\s*[+-]?(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?\s*$")
#: physical range of a value in a unit's dimension (base units kPa, s, %, m): a value outside is a wrong unit or a
#: corrupted record, refused before anything is computed from it
_RANGES = {"stress": (-1e6, 1e6, "|stress| <= 1e6 kPa (1 GPa)"), "time": (0.0, 1e10, "0 <= time <= 1e10 s"),
           "percent": (-100.0, 100.0, "|strain| <= 100 %"), "length": (-1e4, 1e4, "|length| <= 1e4 m")}


def split_unit(column: str) -> tuple:
    """(quantity, unit) of a column name: ``q_kPa``, ``q [kPa]`` and ``q (kPa)`` give ("q", "kPa"), ``axial strain
    (%)`` gives ("axial_strain", "%") (blanks in a name become ``_``); a name without a known or foreign unit suffix
    gives (name, "-"). The unit is returned as written: :func:`read_csv_rows` refuses one not in :data:`_UNITS`."""
    m = _UNIT_IN_BRACKETS.match(column)
    if m:
        unit = m.group(2) if m.group(2) is not None else m.group(3)
        return _name(m.group(1)), (unit or "-")
    name = _name(column)
    for unit in sorted((*_UNITS, *_FOREIGN), key=len, reverse=True):
        if unit.isidentifier() and name.endswith("_" + unit) and len(name) > len(unit) + 1:
            return name[: -len(unit) - 1], unit
    return name, "-"


def _name(text: str) -> str:
    return "_".join(text.split())


def _unit_refusal(unit: str):
    """Why ``unit`` is not read (None when it is in :data:`_UNITS`): a unit of other practice with its conversion to
    a known one, or an unknown unit with the known ones (and the known unit it differs from only in case)."""
    if unit in _UNITS:
        return None
    foreign = {u.lower(): u for u in _FOREIGN}.get(unit.lower())
    if foreign is not None:
        target, factor = _FOREIGN[foreign]
        if factor == 1.0:
            return f"unit {unit!r} is not supported: write it as {target!r}"
        return f"unit {unit!r} is not supported: convert to {target} (1 {unit} = {factor:.7g} {target})"
    same = [u for u in _UNITS if u.lower() == unit.lower()]
    hint = f"did you mean {same[0]!r}? " if same else ""
    return f"unit {unit!r} is not a known unit; {hint}known: {', '.join(_UNITS)}"


def read_text(path, save_as='"CSV UTF-8"') -> str:
    """The text of a CSV file: UTF-8 with or without a byte-order mark (Excel's "CSV UTF-8"), any line ends (LF,
    CRLF, CR) turned into LF. DataError naming the file for a missing file, a folder, or another encoding (whose
    message says to save the file as ``save_as``)."""
    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: file not found")
    if not path.is_file():
        raise DataError(f"{path}: not a file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise DataError(f"{path}: not UTF-8 (looks like UTF-16, Excel's \"Unicode text\"): save it as {save_as}")
    if b"\x00" in raw:
        raise DataError(f"{path}: not UTF-8 (looks like binary: NUL bytes), not a CSV text file")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        controls = sum(b < 32 and b not in (9, 10, 13) for b in raw)
        looks = "binary" if controls > len(raw) // 100 else "Latin-1 / Windows-1252"
        raise DataError(f"{path}, line {line}: not UTF-8 (looks like {looks}: byte 0x{raw[exc.start]:02x}); save it "
                        f"as {save_as}") from None
    return text.replace("\r\n", "\n").replace("\r", "\n")


def read_csv_rows(path) -> tuple[dict, list, list]:
    """The parts of a CSV with ``#`` metadata lines: (metadata, column names, [(line number, cells)]), the cells
    as strings with a decimal comma turned into a point (``1,25`` -> ``1.25``).

    The separator is ``;`` when the header has more cells split at ``;`` than at ``,``, else ``,``; in a ``;`` file
    the decimal mark is the comma when any cell is a number with a comma, else the point. Refused with a DataError
    naming the file and the line: another encoding than UTF-8 (:func:`read_text`), no header or no data rows, a row
    with another number of cells than the header, a column without a name, the same column twice, a unit not in
    :data:`_UNITS`, a file separated by tabs, a number with a decimal point in a file of decimal commas.
    """
    meta, rows, header, sep = {}, [], None, ","
    for lineno, line in enumerate(read_text(path).split("\n"), start=1):
        if not line.strip():
            continue
        if line.lstrip().startswith("#"):
            body = line.lstrip()[1:].strip()
            if ":" in body:
                k, v = body.split(":", 1)
                meta[k.strip()] = v.strip()
            continue
        if header is None:
            sep = _separator(path, lineno, line)
            header = [c.strip() for c in next(csv.reader([line], delimiter=sep))]
            _check_header(path, lineno, header)
            continue
        cells = next(csv.reader([line], delimiter=sep))
        if not any(c.strip() for c in cells):
            continue
        if len(cells) != len(header):
            raise DataError(f"{path}, line {lineno}: {len(cells)} values for {len(header)} columns {header}")
        rows.append((lineno, cells))
    if header is None or not rows:
        raise DataError(f"{path}: no header or no data rows")
    if sep == ";":
        rows = _decimal_points(path, header, rows)
    return meta, header, rows


def _separator(path, lineno, line) -> str:
    """The column separator of a file from its header line: ';' (a spreadsheet's CSV in a comma-decimal locale) or
    ','; tabs are refused."""
    commas, semicolons = (len(next(csv.reader([line], delimiter=d))) for d in (",", ";"))
    if semicolons > commas:
        return ";"
    if commas == 1 and "\t" in line:
        raise DataError(f"{path}, line {lineno}: columns separated by tabs: {line.strip()!r}; separate them by ',' "
                        "or ';'")
    return ","


def _decimal_points(path, header, rows) -> list:
    """The rows of a ';' file with decimal commas turned into points; a DataError naming the file, the line, the
    column and the value for a decimal point in a file whose numbers use the comma."""
    first = next(((n, j, c) for n, cells in rows for j, c in enumerate(cells) if _COMMA_NUMBER.match(c)), None)
    if first is None:
        return rows
    n0, j0, c0 = first
    out = []
    for lineno, cells in rows:
        for j, c in enumerate(cells):
            if _POINT_NUMBER.match(c):
                raise DataError(f"{path}, line {lineno}, column {header[j]!r}: value {c.strip()!r} has a decimal "
                                f"point, while this file writes decimals with a comma (line {n0}, column "
                                f"{header[j0]!r}: {c0.strip()!r}); use one decimal mark in the file")
        out.append((lineno, [c.replace(",", ".") if _COMMA_NUMBER.match(c) else c for c in cells]))
    return out


def _check_header(path, lineno, header):
    seen = {}
    for j, col in enumerate(header):
        if not col:
            raise DataError(f"{path}, line {lineno}: column {j + 1} of {header} has no name")
        quantity, unit = split_unit(col)
        refusal = _unit_refusal(unit)
        if refusal:
            raise DataError(f"{path}, line {lineno}, column {col!r}: {refusal}")
        if quantity in seen:
            other = header[seen[quantity]]
            what = (f"column {col!r} appears twice" if other == col else
                    f"columns {other!r} and {col!r} are the same quantity {quantity!r} in two units")
            raise DataError(f"{path}, line {lineno}: {what} (columns {seen[quantity] + 1} and {j + 1}); keep one")
        seen[quantity] = j


def read_csv_table(path) -> tuple[dict, dict]:
    """Read a CSV with ``#`` metadata lines (:func:`read_csv_rows`). Returns (metadata, {quantity: (unit, values)}).

    Raises DataError naming the file, the line, the column and the offending value for a non-numeric or non-finite
    entry, or a value outside the physical range of its unit (:data:`_RANGES`: a wrong unit or a corrupted record).
    Numbers may be quoted ("1.5"); a ';' file's may have decimal commas (:func:`read_csv_rows`).
    """
    path = Path(path)
    meta, header, rows = read_csv_rows(path)
    table = {}
    for j, col in enumerate(header):
        quantity, unit = split_unit(col)
        dimension, factor = _UNITS[unit]
        lo, hi, rule = _RANGES.get(dimension, (-np.inf, np.inf, ""))
        values = np.empty(len(rows))
        for i, (lineno, cells) in enumerate(rows):
            raw = cells[j].strip()
            try:
                values[i] = float(raw)
            except ValueError:
                values[i] = np.nan
            if not np.isfinite(values[i]):
                comma = " (a decimal comma is read in a file separated by ';')" if "," in raw else ""
                raise DataError(f"{path}, line {lineno}, column {col!r}: value {raw!r} is not a finite number{comma}")
            if not lo <= values[i] * factor <= hi:
                raise DataError(f"{path}, line {lineno}, column {quantity!r} in {unit}: value {raw} is outside the "
                                f"physical range ({rule})")
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
                bad = arr[~np.isfinite(arr)][0]
                raise DataError(f"curve {self.y_name}: field {label} has a non-finite value {bad}")


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
