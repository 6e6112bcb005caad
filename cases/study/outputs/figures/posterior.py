"""Figures of the posterior sample: the marginals zoomed to the posterior, the pairs (corner) plot, the stages.

``post`` is an ``inference.Posterior``; ``marks`` {label: {parameter: value}} are reference values (generating,
published) drawn on every figure beside the MAP; ``units`` {parameter: unit} label the axes. Each figure's panels
are cells of one axes (:mod:`cases.study.outputs.figures.sheet`)."""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import MAX_COLUMNS, draw, pyplot
from cases.study.outputs.figures.labels import parameter_label
from cases.study.outputs.figures.sheet import Sheet, grid, padded

__all__ = ["zoom", "marginals_figure", "pairs_figure", "stages_figure", "write_posterior_figures"]

_LINES = ("--", ":", "-.", (0, (5, 1, 1, 1)))
_MARKERS = ("s", "^", "D", "v")


def zoom(values, margin: float = 0.15) -> tuple:
    """The axis range of a posterior sample: its span widened by ``margin`` of it on each side
    (:func:`cases.study.outputs.figures.sheet.padded`)."""
    return padded(values, margin=margin)


def _bins(values) -> int:
    """Histogram bins of a sample: about its square root, 8 to 30."""
    return int(np.clip(np.sqrt(len(values)), 8, 30))


def _marks_of(marks, name):
    """(label, value, style index) of the reference values of ``name``."""
    return [(label, values[name], k) for k, (label, values) in enumerate((marks or {}).items())
            if values and values.get(name) is not None]


def _histogram(cell, values, color):
    """The histogram of ``values`` (:func:`_bins`) in ``cell``, one filled step polygon over its x range, the
    tallest bar at 0.9 of the cell's height: the shape of the marginal density, not its scale."""
    counts, edges = np.histogram(values, bins=_bins(values), range=cell.x_range)
    cell.ax.stairs(cell.bottom + 0.9 * cell.height * counts / max(counts.max(), 1), cell.x(edges),
                   baseline=cell.bottom, fill=True, color=color)


def marginals_figure(post, marks=None, units=None):
    """One histogram per parameter of the final-stage samples (heights relative, :func:`_histogram`), the axis
    zoomed to the posterior (:func:`zoom`), the MAP and the ``marks`` as vertical lines; a MAP or reference value
    outside the zoomed axis is named in its panel with its value instead; one legend, under the title. Returns the
    figure."""
    plt = pyplot()
    sheet, frames = grid(len(post.names), (3.0, 2.3), (0.2, 0.15, 0.55, 0.1), MAX_COLUMNS,
                         legend=2 + sum(bool(v) for v in (marks or {}).values()))
    for i, (frame, name) in enumerate(zip(frames, post.names)):
        cell = sheet.cell(*frame, zoom(post.samples[:, i]))
        _histogram(cell, post.samples[:, i], "0.75")
        off = [] if cell.vertical(post.map_theta[i], color="C3", lw=1.5) else [
            f"MAP: {post.map_theta[i]:.4g} (off the axis)"]
        for label, value, k in _marks_of(marks, name):
            if not cell.vertical(value, color=f"C{k}", ls=_LINES[k % 4], lw=1.2):
                off.append(f"{label}: {value:.4g} (off the axis)")
        if off:
            cell.note("\n".join(off))
        cell.x_axis(parameter_label(name, units or {}))
    handles = [plt.matplotlib.patches.Patch(color="0.75", label="posterior samples"),
               plt.Line2D([], [], color="C3", lw=1.5, label="MAP")]
    handles += [plt.Line2D([], [], color=f"C{k}", ls=_LINES[k % 4], lw=1.2, label=label)
                for k, label in enumerate(marks or {}) if marks[label]]
    sheet.legend_row(handles)
    return sheet.finish()


#: the pairs plot: the gap between its panels (a fraction of a panel); its margins (inches) left of the panels and
#: below them (the tick values and labels), right of them and above them (the title)
PAIRS_GAP = 0.08
PAIRS_MARGINS = {"left": 0.75, "bottom": 0.65, "right": 0.1, "top": 0.5}


def pairs_figure(post, marks=None, units=None):
    """The pairs (corner) plot: histograms on the diagonal (heights relative, :func:`_histogram`), below it every
    pair of parameters as the posterior samples with the MAP (star) and the ``marks``; axes zoomed to the posterior
    (a ridge such as M against sigma'_p0 shows as a line of samples). Only the lower triangle; the bottom row and the
    left column carry the tick values and the parameters' names, every panel its tick marks; the samples of every
    panel are one line of markers. Returns the figure."""
    plt = pyplot()
    d = len(post.names)
    units = units or {}
    size = max(1.9, min(2.6, 12.0 / d))
    m = PAIRS_MARGINS
    sheet = Sheet(size * d, size * d)
    pitch_x = (sheet.width - m["left"] - m["right"]) / d
    pitch_y = (sheet.height - m["bottom"] - m["top"]) / d
    ranges = [zoom(post.samples[:, i]) for i in range(d)]

    def cell(row, col):
        return sheet.cell(m["left"] + col * pitch_x, m["bottom"] + (d - 1 - row) * pitch_y,
                          (1.0 - PAIRS_GAP) * pitch_x, (1.0 - PAIRS_GAP) * pitch_y, ranges[col], ranges[row])

    xs, ys, map_x, map_y = [], [], [], []
    marked = {label: ([], []) for label in (marks or {})}
    for row in range(d):
        for col in range(row + 1):
            c = cell(row, col)
            bottom_row, names = row == d - 1, (post.names[col], post.names[row])
            c.x_axis(parameter_label(names[0], units) if bottom_row else None, values=bottom_row)
            if col == row:
                _histogram(c, post.samples[:, col], "0.7")
                c.vertical(post.map_theta[col], color="C3", lw=1.2)
                for _, value, k in _marks_of(marks, names[0]):
                    c.vertical(value, color=f"C{k}", ls=_LINES[k % 4], lw=1.2)
                continue
            c.y_axis(parameter_label(names[1], units) if col == 0 else None, values=col == 0)
            xs.append(c.x(post.samples[:, col]))
            ys.append(c.y(post.samples[:, row]))
            if c.inside_x(post.map_theta[col]) and c.inside_y(post.map_theta[row]):   # else off the panel
                map_x.append(float(c.x(post.map_theta[col])))
                map_y.append(float(c.y(post.map_theta[row])))
            for label, value, _ in _marks_of(marks, names[0]):
                other = (marks[label] or {}).get(names[1])
                if other is not None and c.inside_x(value) and c.inside_y(other):
                    marked[label][0].append(float(c.x(value)))
                    marked[label][1].append(float(c.y(other)))
    if xs:
        sheet.ax.plot(np.concatenate(xs), np.concatenate(ys), ".", ms=2, color="C0", alpha=0.5)
        sheet.ax.plot(map_x, map_y, "*", ms=10, color="C3", mec="k", mew=0.5)
    for k, (mx, my) in enumerate(marked.values()):
        if mx:
            sheet.ax.plot(mx, my, _MARKERS[k % 4], ms=6, mfc="none", color=f"C{k}", mew=1.2)
    handles = [plt.Line2D([], [], ls="", marker=".", color="C0", label="posterior samples"),
               plt.Line2D([], [], ls="", marker="*", ms=10, color="C3", mec="k", label="MAP")]
    handles += [plt.Line2D([], [], ls="", marker=_MARKERS[k % 4], mfc="none", color=f"C{k}", label=label)
                for k, label in enumerate(marks or {}) if marks[label]]
    right, top = sheet.width - m["right"], sheet.height - m["top"]
    sheet.ax.legend(handles=handles, loc="upper right", bbox_to_anchor=(right, top), bbox_transform=sheet.ax.transData,
                    fontsize=8)
    return sheet.finish()


def stages_figure(post, units=None):
    """Each parameter's samples against the stage index (how the population narrows from the prior, stage 0, to
    the posterior, beta = 1), the samples of a stage spread over +-0.3 of its index. Returns the figure."""
    stages = len(post.stage_samples)
    sheet, frames = grid(len(post.names), (3.2, 2.6), (0.85, 0.15, 0.55, 0.1), MAX_COLUMNS)
    spread = np.concatenate([j + np.linspace(-0.3, 0.3, len(theta)) for j, theta in enumerate(post.stage_samples)])
    xs, ys = [], []
    for i, (frame, name) in enumerate(zip(frames, post.names)):
        values = np.concatenate([theta[:, i] for theta in post.stage_samples])
        cell = sheet.cell(*frame, (-0.6, stages - 0.4), zoom(values, 0.05))
        xs.append(cell.x(spread))
        ys.append(cell.y(values))
        cell.x_axis("stage j", integer=True, edge=0.0)   # short labels, far apart: stage 0 ticked
        cell.y_axis(parameter_label(name, units or {}))
    sheet.ax.plot(np.concatenate(xs), np.concatenate(ys), ".", ms=1, color="C0")
    return sheet.finish()


def write_posterior_figures(out, post, marks=None, units=None, title=None, draw=draw):
    """marginals.png, pairs.png and stages.png of ``post`` in the folder ``out``, each under ``title``; ``draw``
    draws them (:func:`cases.study.outputs.figures.canvas.draw`: now, or a ``FigureQueue`` that keeps them)."""
    draw(marginals_figure, (post, marks, units), out / "marginals.png", title, 120)
    draw(pairs_figure, (post, marks, units), out / "pairs.png", title)
    draw(stages_figure, (post, units), out / "stages.png", title)
