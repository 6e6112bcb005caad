"""Where the figures are drawn: pyplot on the off-screen Agg backend, a grid of panels that wraps (at most
``MAX_COLUMNS`` columns, so that many curves make more rows, not a row of thousands of pixels), and figures drawn now
(:func:`draw`) or kept and drawn later side by side on a process pool (:class:`FigureQueue`)."""
from __future__ import annotations

import math
import time

import numpy as np

from inference import PoolExecutor

__all__ = ["FIXED", "MAX_COLUMNS", "PANEL_MARGINS", "TITLE_ROOM", "FigureQueue", "draw", "pyplot", "panel_grid",
           "save"]

#: the most panels side by side
MAX_COLUMNS = 4


def pyplot():
    """matplotlib.pyplot on the off-screen Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


#: the room around each panel of a :func:`panel_grid` (inches): tick and axis labels on the left and at the bottom,
#: the panel's title at the top
PANEL_MARGINS = {"left": 0.9, "right": 0.15, "bottom": 0.6, "top": 0.35}
#: the room for a figure's title above the grid (inches)
TITLE_ROOM = 0.4
#: the mark of a figure whose panels are placed on a fixed grid already (:func:`save` lays out the others)
FIXED = "fixed grid"


def panel_grid(n: int, width: float = 4.2, height: float = 3.2, max_columns: int = MAX_COLUMNS, stack: int = 1,
               gap: float = 0.45):
    """A figure of ``n`` panels, each in a cell of ``width`` x ``height`` inches (its axes inside the cell's
    ``PANEL_MARGINS``), in rows of at most ``max_columns``, with ``TITLE_ROOM`` above: (figure, the ``n`` axes in
    reading order). ``stack`` > 1 splits each cell's axes into that many axes of equal height, one above the other
    and ``gap`` inches apart (room for the upper ones' tick labels): each panel is then a tuple of axes, top first.
    The panels are placed on this fixed grid, so :func:`save` needs no layout pass."""
    plt = pyplot()
    cols = max(1, min(n, max_columns))
    rows = max(1, math.ceil(n / cols))
    fig_w, fig_h = width * cols, height * rows + TITLE_ROOM
    fig = plt.figure(figsize=(fig_w, fig_h), label=FIXED)
    m = PANEL_MARGINS
    inner_w, inner_h = width - m["left"] - m["right"], height - m["bottom"] - m["top"]
    each = (inner_h - (stack - 1) * gap) / stack
    axes = []
    for k in range(n):
        row, col = divmod(k, cols)
        left = col * width + m["left"]
        bottom = fig_h - TITLE_ROOM - (row + 1) * height + m["bottom"]
        cell = [fig.add_axes((left / fig_w, (bottom + (stack - 1 - i) * (each + gap)) / fig_h, inner_w / fig_w,
                              each / fig_h)) for i in range(stack)]
        axes.append(cell[0] if stack == 1 else tuple(cell))
    return fig, axes


def save(fig, path, title: str | None = None, dpi: int = 110):
    """Title ``fig``, lay it out (matplotlib's tight layout, unless its panels are placed on a fixed grid already:
    a figure labelled ``FIXED``), write it to ``path`` and close it."""
    plt = pyplot()
    if title:
        fig.suptitle(title, fontsize=10, y=1 - 0.08 / fig.get_figheight(), va="top")
    if fig.get_label() != FIXED:
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / fig.get_figheight()) if title else None)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def draw(make, args, path, title: str | None = None, dpi: int = 110):
    """Draw the figure ``make(*args)`` now and :func:`save` it to ``path`` under ``title`` (nothing when ``make``
    returns None)."""
    fig = make(*args)
    if fig is not None:
        save(fig, path, title, dpi)


class _Drawing:
    """The kept figures as an evaluator of the executors' protocol: each row of ``rows`` is the index of one figure,
    drawn by the worker that gets it (values 0, no failure reasons)."""

    vectorized = False
    loglike = None

    def __init__(self, jobs: list):
        self.jobs = jobs

    def __call__(self, rows):
        for row in rows:
            write, args = self.jobs[int(row[0])]
            write(*args)
        return np.zeros(len(rows)), [None] * len(rows)


class FigureQueue:
    """Figures kept to be drawn later, side by side. Called as :func:`draw` is, it keeps the figure's maker, its
    arguments, path, title and resolution; :meth:`keep` keeps any other file's writer that nothing reads before the
    end (a class's posterior.nc); :meth:`draw_all` draws and writes what was kept on the workers of a local process
    pool (``inference.PoolExecutor``: forked with the figures' data in memory, one figure a task, workers that die
    with their parent), or here, one after the other, on any other executor. A figure is the same wherever it is
    drawn."""

    def __init__(self):
        self.jobs = []

    def __call__(self, make, args, path, title: str | None = None, dpi: int = 110):
        self.jobs.append((draw, (make, args, path, title, dpi)))

    def keep(self, write, *args):
        """Keep ``write(*args)`` (a file's writer) to be called with the figures."""
        self.jobs.append((write, args))

    def draw_all(self, executor=None) -> float:
        """Draw the kept figures (on ``executor``'s workers when it is a process pool) and forget them; returns the
        wall time (s). On a pool the last kept is drawn first (a loop keeps its own figures, of every curve, last:
        the largest start first and the small ones fill in, so the workers finish together), with pyplot imported
        before the workers are forked."""
        t0 = time.perf_counter()
        jobs, self.jobs = self.jobs, []
        if isinstance(executor, PoolExecutor) and len(jobs) > 1:
            pyplot()
            executor.evaluate(_Drawing(jobs), np.arange(len(jobs) - 1, -1, -1, dtype=float)[:, None])
        else:
            for write, args in jobs:
                write(*args)
        return time.perf_counter() - t0
