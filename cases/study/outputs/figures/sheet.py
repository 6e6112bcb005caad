"""Figures of many small panels drawn as cells of one axes whose units are inches (:class:`Sheet`).

A matplotlib axes makes its ticks as artists of their own (two lines and two texts each, with their font
properties), and the axes and their ticks were nearly all of the drawing time of the figures of many panels (a pairs
plot of 13 parameters is 91 axes). Here a figure is one axes without axis lines, placed over the whole figure with
1 unit = 1 inch; each panel is a :class:`Cell`, a rectangle of that axes with its own linear scale on each side (or a
logarithmic abscissa). Nothing is clipped to a cell: what is drawn in it must lie in its ranges.
The frames and tick marks of every cell are two line collections, the tick values and axis labels plain texts.
Tick values are matplotlib's nice numbers (:func:`nice_ticks`); a power of ten shared by an axis's values is
written once, beside its label."""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import FIXED, MAX_COLUMNS, PANEL_MARGINS, PANEL_TICKS, TITLE_ROOM, pyplot

__all__ = ["TICK_FONT", "LABEL_FONT", "LEGEND_ROW", "Cell", "Sheet", "grid", "legend_columns", "nice_ticks", "padded",
           "panel_sheet"]

#: the most intervals between a cell's ticks (matplotlib's ``nbins``): its tick values are long beside its width
NARROW_PANEL_TICKS = 4
#: font sizes (points) of the tick values and of the axis labels
TICK_FONT, LABEL_FONT = 7, 9
#: the length of a tick mark, inches
TICK_LENGTH = 0.05
#: from a cell's edge (inches): its tick values; its axis label (below it; the centre of the rotated label left of it)
TICK_GAP, X_LABEL_GAP, Y_LABEL_GAP = 0.04, 0.22, 0.62
#: no tick within this fraction of an axis's range from its ends (:func:`nice_ticks`)
EDGE = 0.06
#: a row of legend entries under the title: its height and the width of one entry (inches)
LEGEND_ROW, LEGEND_ENTRY = 0.22, 1.7


def nice_ticks(lo: float, hi: float, integer: bool = False, edge: float = EDGE, bins: int = NARROW_PANEL_TICKS,
               log: bool = False):
    """(values, labels, power) of the ticks of an axis over [lo, hi]: matplotlib's nice numbers (at most ``bins``
    intervals; whole numbers when ``integer``; the decades on a ``log`` axis) at least ``edge`` of the range inside
    it, so that the labels of neighbouring cells do not meet; the labels are the values over 10^power, ``power`` 0
    for values between 0.0001 and 10 000 and on a log axis, else the exponent of the largest value."""
    from matplotlib.ticker import MaxNLocator

    if log:
        a, b = np.log10(lo), np.log10(hi)
        decades = np.arange(np.ceil(a + edge * (b - a)), np.floor(b - edge * (b - a)) + 1)
        values = [float(10.0 ** k) for k in decades]
        return values, [f"{v:g}" for v in values], 0
    edge = edge * (hi - lo)
    values = [float(v) for v in MaxNLocator(nbins=bins, integer=integer).tick_values(lo, hi)
              if lo + edge <= v <= hi - edge]
    top = max((abs(v) for v in values), default=0.0)
    power = int(np.floor(np.log10(top))) if top > 0.0 else 0
    power = power if power < -3 or power > 3 else 0
    return values, [f"{v / 10.0 ** power:.4g}" for v in values], power


class Sheet:
    """A figure of ``width`` x ``height`` inches (``TITLE_ROOM`` at the top for the title that ``canvas.save``
    writes) whose one axes has 1 unit = 1 inch, origin at the bottom left; :meth:`cell` places the panels, whose
    axes carry at most ``bins`` intervals between ticks."""

    def __init__(self, width: float, height: float, bins: int = NARROW_PANEL_TICKS):
        plt = pyplot()
        self.width, self.height, self.bins = width, height, bins
        self.fig = plt.figure(figsize=(width, height), label=FIXED)
        self.ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0))
        self.ax.set_xlim(0.0, width)
        self.ax.set_ylim(0.0, height)
        self.ax.set_axis_off()
        self.frames, self.marks, self.labelled = [], [], set()

    def cell(self, left: float, bottom: float, width: float, height: float, x_range, y_range=(0.0, 1.0),
             x_log: bool = False) -> "Cell":
        """A panel whose frame spans [left, left + width] x [bottom, bottom + height] inches, its x axis over
        ``x_range`` (lo, hi; logarithmic when ``x_log``) and its y axis over ``y_range``."""
        self.frames.append([(left, bottom), (left + width, bottom), (left + width, bottom + height),
                            (left, bottom + height), (left, bottom)])
        return Cell(self, left, bottom, width, height, tuple(map(float, x_range)), tuple(map(float, y_range)),
                    x_log)

    def once(self, label: str) -> str | None:
        """``label`` the first time it is asked for, None after: each entry of the legend once, whichever panel
        draws it first."""
        if label in self.labelled:
            return None
        self.labelled.add(label)
        return label

    def legend_row(self, handles=None):
        """``handles`` (default: every artist drawn with a label, :meth:`once`) as rows of legend entries under the
        title, from the left edge, as many side by side as the width holds (:func:`grid` with ``legend`` leaves the
        room)."""
        handles = self.ax.get_legend_handles_labels()[0] if handles is None else handles
        self.ax.legend(handles=handles, loc="upper left", ncol=min(len(handles), legend_columns(self.width)),
                       fontsize=7, frameon=False, bbox_transform=self.ax.transData,
                       bbox_to_anchor=(0.1, self.height - TITLE_ROOM))

    def finish(self):
        """The figure, the frames and tick marks of every cell added."""
        from matplotlib.collections import LineCollection

        self.ax.add_collection(LineCollection(self.frames, colors="k", linewidths=0.8))
        self.ax.add_collection(LineCollection(self.marks, colors="k", linewidths=0.6))
        return self.fig


class Cell:
    """One panel of a :class:`Sheet`: :meth:`x` and :meth:`y` take values to the sheet's inches; draw on
    ``cell.ax`` (the sheet's axes) with them."""

    def __init__(self, sheet: Sheet, left, bottom, width, height, x_range, y_range, x_log=False):
        self.sheet, self.ax = sheet, sheet.ax
        self.left, self.bottom, self.width, self.height = left, bottom, width, height
        self.x_range, self.y_range, self.x_log = x_range, y_range, x_log

    def x(self, values):
        lo, hi = self.x_range
        values = np.asarray(values, dtype=float)
        if self.x_log:   # a value <= 0 goes to -inf or NaN, which matplotlib leaves out, as on its own log axes
            with np.errstate(divide="ignore", invalid="ignore"):
                return self.left + self.width * np.log(values / lo) / np.log(hi / lo)
        return self.left + self.width * (values - lo) / (hi - lo)

    def y(self, values):
        lo, hi = self.y_range
        return self.bottom + self.height * (np.asarray(values, dtype=float) - lo) / (hi - lo)

    def inside_x(self, value) -> bool:
        return self.x_range[0] <= value <= self.x_range[1]

    def inside_y(self, value) -> bool:
        return self.y_range[0] <= value <= self.y_range[1]

    def x_axis(self, label: str | None = None, values: bool = True, integer: bool = False, edge: float = EDGE):
        """Tick marks on the bottom edge (:func:`nice_ticks` with ``integer`` and ``edge``); with ``values`` their
        values below it and ``label`` (with the power of ten of the values) under them."""
        ticks, texts, power = nice_ticks(*self.x_range, integer, edge, self.sheet.bins, self.x_log)
        at = self.x(ticks)
        self.sheet.marks += [[(x, self.bottom), (x, self.bottom + TICK_LENGTH)] for x in at]
        if values:
            for x, text in zip(at, texts):
                self.ax.text(x, self.bottom - TICK_GAP, text, ha="center", va="top", fontsize=TICK_FONT)
        if label is not None:
            self.ax.text(self.left + 0.5 * self.width, self.bottom - X_LABEL_GAP, _with_power(label, power),
                         ha="center", va="top", fontsize=LABEL_FONT)

    def y_axis(self, label: str | None = None, values: bool = True, edge: float = EDGE):
        """Tick marks on the left edge (:func:`nice_ticks` with ``edge``); with ``values`` their values left of it
        and ``label`` (with the power of ten of the values), rotated, left of them."""
        ticks, texts, power = nice_ticks(*self.y_range, edge=edge, bins=self.sheet.bins)
        at = self.y(ticks)
        self.sheet.marks += [[(self.left, y), (self.left + TICK_LENGTH, y)] for y in at]
        if values:
            for y, text in zip(at, texts):
                self.ax.text(self.left - TICK_GAP, y, text, ha="right", va="center", fontsize=TICK_FONT)
        if label is not None:
            self.ax.text(self.left - Y_LABEL_GAP, self.bottom + 0.5 * self.height, _with_power(label, power),
                         ha="center", va="center", rotation=90, fontsize=LABEL_FONT)

    def title(self, text: str):
        """``text`` centred above the cell."""
        self.ax.text(self.left + 0.5 * self.width, self.bottom + self.height + TICK_GAP, text, ha="center",
                     va="bottom", fontsize=LABEL_FONT)

    def vertical(self, value, **style) -> bool:
        """A line across the cell at ``value`` of its x axis (``style``: matplotlib's line keywords); nothing, and
        False, when ``value`` lies outside the axis (the sheet clips nothing to a cell)."""
        if not self.inside_x(value):
            return False
        x = float(self.x(value))
        self.ax.plot([x, x], [self.bottom, self.bottom + self.height], **style)
        return True

    def note(self, text: str, top: bool = True, **style):
        """A small text in a corner of the cell (top left, else bottom right; ``style``: matplotlib's text keywords,
        font size 6 unless given)."""
        pad = 0.05
        style = {"fontsize": 6, **style}
        if top:
            self.ax.text(self.left + pad, self.bottom + self.height - pad, text, ha="left", va="top", **style)
        else:
            self.ax.text(self.left + self.width - pad, self.bottom + pad, text, ha="right", va="bottom", **style)


def legend_columns(width: float) -> int:
    """How many legend entries stand side by side on a sheet ``width`` inches wide."""
    return max(1, int((width - 0.2) // LEGEND_ENTRY))


def grid(n: int, pitch: tuple, inset: tuple, max_columns: int, bins: int = NARROW_PANEL_TICKS, legend: int = 0):
    """(Sheet, the frames' (left, bottom, width, height) in reading order) of ``n`` cells in rows of at most
    ``max_columns``, each in a ``pitch`` (width, height) of inches whose frame is inset by ``inset`` (left, right,
    bottom, top) inches, ``TITLE_ROOM`` above the rows and under it the rows of ``legend`` entries
    (:meth:`Sheet.legend_row`); ``bins`` as :class:`Sheet`."""
    cols = max(1, min(n, max_columns))
    rows = max(1, -(-n // cols))
    pw, ph = pitch
    left, right, bottom, top = inset
    legend_rows = -(-legend // legend_columns(pw * cols))
    sheet = Sheet(pw * cols, ph * rows + TITLE_ROOM + (legend_rows * LEGEND_ROW + 0.08 if legend else 0.0), bins)
    frames = []
    for k in range(n):
        row, col = divmod(k, cols)
        frames.append((col * pw + left, (rows - 1 - row) * ph + bottom, pw - left - right, ph - bottom - top))
    return sheet, frames


def panel_sheet(n: int, pitch: tuple, max_columns: int = MAX_COLUMNS, legend: int = 3):
    """:func:`grid` of ``n`` panels of curves, each in a ``pitch`` (width, height) of inches with ``PANEL_MARGINS``
    around its frame (tick and axis labels, its title), ``PANEL_TICKS`` intervals between ticks and room for
    ``legend`` entries under the title."""
    m = PANEL_MARGINS
    return grid(n, pitch, (m["left"], m["right"], m["bottom"], m["top"]), max_columns, PANEL_TICKS, legend)


def padded(values, log: bool = False, margin: float = 0.05) -> tuple:
    """The range of an axis over ``values`` (NaN ignored) widened by ``margin`` of it on each side (in the
    logarithm on a ``log`` axis), as matplotlib's automatic limits; a single value by 1 % of it (by 1 when 0)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v) & ((v > 0) if log else True)]
    lo, hi = (float(v.min()), float(v.max())) if v.size else (1.0, 10.0)
    if log:
        a, b = np.log10(lo), np.log10(hi)
        pad = margin * (b - a) if b > a else 0.5
        return 10.0 ** (a - pad), 10.0 ** (b + pad)
    pad = margin * (hi - lo) if hi > lo else (0.01 * abs(lo) or 1.0)
    return lo - pad, hi + pad


def _with_power(label: str, power: int) -> str:
    return label + (f" x 1e{power}" if power else "")
