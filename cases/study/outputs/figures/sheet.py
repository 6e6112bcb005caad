"""Figures of many small panels drawn as cells of one axes whose units are inches (:class:`Sheet`).

A matplotlib axes makes its ticks as artists of their own (two lines and two texts each, with their font
properties), and the axes and their ticks were nearly all of the drawing time of the posterior's figures (a pairs
plot of 13 parameters is 91 axes). Here a figure is one axes without axis lines, placed over the whole figure with
1 unit = 1 inch; each panel is a :class:`Cell`, a rectangle of that axes with its own linear scale on each side.
The frames and tick marks of every cell are two line collections, the tick values and axis labels plain texts.
Tick values are matplotlib's nice numbers (:func:`nice_ticks`); a power of ten shared by an axis's values is
written once, beside its label."""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import FIXED, TITLE_ROOM, pyplot

__all__ = ["TICK_FONT", "LABEL_FONT", "Cell", "Sheet", "grid", "nice_ticks"]

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


def nice_ticks(lo: float, hi: float, integer: bool = False, edge: float = EDGE):
    """(values, labels, power) of the ticks of an axis over [lo, hi]: matplotlib's nice numbers (at most
    ``NARROW_PANEL_TICKS`` intervals; whole numbers when ``integer``) at least ``edge`` of the range inside it, so
    that the labels of neighbouring cells do not meet; the labels are the values over 10^power, ``power`` 0 for
    values between 0.0001 and 10 000, else the exponent of the largest value."""
    from matplotlib.ticker import MaxNLocator

    edge = edge * (hi - lo)
    values = [float(v) for v in MaxNLocator(nbins=NARROW_PANEL_TICKS, integer=integer).tick_values(lo, hi)
              if lo + edge <= v <= hi - edge]
    top = max((abs(v) for v in values), default=0.0)
    power = int(np.floor(np.log10(top))) if top > 0.0 else 0
    power = power if power < -3 or power > 3 else 0
    return values, [f"{v / 10.0 ** power:.4g}" for v in values], power


class Sheet:
    """A figure of ``width`` x ``height`` inches (``TITLE_ROOM`` at the top for the title that ``canvas.save``
    writes) whose one axes has 1 unit = 1 inch, origin at the bottom left; :meth:`cell` places the panels."""

    def __init__(self, width: float, height: float):
        plt = pyplot()
        self.width, self.height = width, height
        self.fig = plt.figure(figsize=(width, height), label=FIXED)
        self.ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0))
        self.ax.set_xlim(0.0, width)
        self.ax.set_ylim(0.0, height)
        self.ax.set_axis_off()
        self.frames, self.marks = [], []

    def cell(self, left: float, bottom: float, width: float, height: float, x_range, y_range=(0.0, 1.0)) -> "Cell":
        """A panel whose frame spans [left, left + width] x [bottom, bottom + height] inches, its x axis over
        ``x_range`` (lo, hi) and its y axis over ``y_range``."""
        self.frames.append([(left, bottom), (left + width, bottom), (left + width, bottom + height),
                            (left, bottom + height), (left, bottom)])
        return Cell(self, left, bottom, width, height, tuple(map(float, x_range)), tuple(map(float, y_range)))

    def finish(self):
        """The figure, the frames and tick marks of every cell added."""
        from matplotlib.collections import LineCollection

        self.ax.add_collection(LineCollection(self.frames, colors="k", linewidths=0.8))
        self.ax.add_collection(LineCollection(self.marks, colors="k", linewidths=0.6))
        return self.fig


class Cell:
    """One panel of a :class:`Sheet`: :meth:`x` and :meth:`y` take values to the sheet's inches; draw on
    ``cell.ax`` (the sheet's axes) with them."""

    def __init__(self, sheet: Sheet, left, bottom, width, height, x_range, y_range):
        self.sheet, self.ax = sheet, sheet.ax
        self.left, self.bottom, self.width, self.height = left, bottom, width, height
        self.x_range, self.y_range = x_range, y_range

    def x(self, values):
        lo, hi = self.x_range
        return self.left + self.width * (np.asarray(values, dtype=float) - lo) / (hi - lo)

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
        ticks, texts, power = nice_ticks(*self.x_range, integer=integer, edge=edge)
        at = self.x(ticks)
        self.sheet.marks += [[(x, self.bottom), (x, self.bottom + TICK_LENGTH)] for x in at]
        if values:
            for x, text in zip(at, texts):
                self.ax.text(x, self.bottom - TICK_GAP, text, ha="center", va="top", fontsize=TICK_FONT)
        if label is not None:
            self.ax.text(self.left + 0.5 * self.width, self.bottom - X_LABEL_GAP, _with_power(label, power),
                         ha="center", va="top", fontsize=LABEL_FONT)

    def y_axis(self, label: str | None = None, values: bool = True):
        """Tick marks on the left edge (:func:`nice_ticks`); with ``values`` their values left of it and ``label``
        (with the power of ten of the values), rotated, left of them."""
        ticks, texts, power = nice_ticks(*self.y_range)
        at = self.y(ticks)
        self.sheet.marks += [[(self.left, y), (self.left + TICK_LENGTH, y)] for y in at]
        if values:
            for y, text in zip(at, texts):
                self.ax.text(self.left - TICK_GAP, y, text, ha="right", va="center", fontsize=TICK_FONT)
        if label is not None:
            self.ax.text(self.left - Y_LABEL_GAP, self.bottom + 0.5 * self.height, _with_power(label, power),
                         ha="center", va="center", rotation=90, fontsize=LABEL_FONT)

    def note(self, text: str, top: bool = True, **style):
        """A small text in a corner of the cell (top left, else bottom right)."""
        pad = 0.05
        if top:
            self.ax.text(self.left + pad, self.bottom + self.height - pad, text, ha="left", va="top", fontsize=6,
                         **style)
        else:
            self.ax.text(self.left + self.width - pad, self.bottom + pad, text, ha="right", va="bottom", fontsize=6,
                         **style)


def grid(n: int, pitch: tuple, inset: tuple, max_columns: int):
    """(Sheet, the frames' (left, bottom, width, height) in reading order) of ``n`` cells in rows of at most
    ``max_columns``, each in a ``pitch`` (width, height) of inches whose frame is inset by ``inset`` (left, right,
    bottom, top) inches, ``TITLE_ROOM`` above the rows."""
    cols = max(1, min(n, max_columns))
    rows = max(1, -(-n // cols))
    pw, ph = pitch
    left, right, bottom, top = inset
    sheet = Sheet(pw * cols, ph * rows + TITLE_ROOM)
    frames = []
    for k in range(n):
        row, col = divmod(k, cols)
        frames.append((col * pw + left, (rows - 1 - row) * ph + bottom, pw - left - right, ph - bottom - top))
    return sheet, frames


def _with_power(label: str, power: int) -> str:
    return label + (f" x 1e{power}" if power else "")
