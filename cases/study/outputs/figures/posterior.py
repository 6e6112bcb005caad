"""Figures of the posterior sample: the marginals zoomed to the posterior, the pairs (corner) plot, the stages.

``post`` is an ``inference.Posterior``; ``marks`` {label: {parameter: value}} are reference values (generating,
published) drawn on every figure beside the MAP; ``units`` {parameter: unit} label the axes."""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import FIXED, NARROW_PANEL_TICKS, draw, lean_ticks, panel_grid, pyplot
from cases.study.outputs.figures.labels import parameter_label

__all__ = ["zoom", "marginals_figure", "pairs_figure", "stages_figure", "write_posterior_figures"]

_LINES = ("--", ":", "-.", (0, (5, 1, 1, 1)))
_MARKERS = ("s", "^", "D", "v")


def zoom(values, margin: float = 0.15) -> tuple:
    """The axis range of a posterior sample: its span widened by ``margin`` of it on each side (a collapsed sample,
    by 1 % of its value or 1e-12)."""
    lo, hi = float(np.min(values)), float(np.max(values))
    pad = margin * (hi - lo) if hi > lo else max(0.01 * abs(lo), 1e-12)
    return lo - pad, hi + pad


def _bins(values) -> int:
    """Histogram bins of a sample: about its square root, 8 to 30."""
    return int(np.clip(np.sqrt(len(values)), 8, 30))


def _marks_of(marks, name):
    """(label, value, style index) of the reference values of ``name``."""
    return [(label, values[name], k) for k, (label, values) in enumerate((marks or {}).items())
            if values and values.get(name) is not None]


def marginals_figure(post, marks=None, units=None):
    """One histogram per parameter of the final-stage samples, the axis zoomed to the posterior (:func:`zoom`), the
    MAP and the ``marks`` as vertical lines; a reference value outside the zoomed axis is named in the legend with
    its value instead. Returns the figure."""
    fig, axes = panel_grid(len(post.names), 3.4, 2.7, ticks=NARROW_PANEL_TICKS)
    for i, (ax, name) in enumerate(zip(axes, post.names)):
        ax.hist(post.samples[:, i], bins=_bins(post.samples[:, i]), density=True, color="0.75", histtype="stepfilled",
                label="posterior samples")
        ax.axvline(post.map_theta[i], color="C3", lw=1.5, label="MAP")
        lo, hi = zoom(post.samples[:, i])
        for label, value, k in _marks_of(marks, name):
            if lo <= value <= hi:
                ax.axvline(value, color=f"C{k}", ls=_LINES[k % 4], lw=1.2, label=label)
            else:
                ax.plot([], [], color=f"C{k}", ls=_LINES[k % 4], label=f"{label}: {value:.4g} (off the axis)")
        ax.set_xlim(lo, hi)
        ax.set_xlabel(parameter_label(name, units or {}))
        ax.set_ylabel("probability density")
        ax.legend(fontsize=6)
    return fig


def pairs_figure(post, marks=None, units=None):
    """The pairs (corner) plot: histograms on the diagonal, below it every pair of parameters as the posterior
    samples with the MAP (star) and the ``marks``; axes zoomed to the posterior (a ridge such as M against sigma'_p0
    shows as a line of samples). Only the lower triangle's axes exist, on a fixed grid (no layout pass: the panels
    share their outer labels). Returns the figure."""
    plt = pyplot()
    d = len(post.names)
    units = units or {}
    size = max(1.9, min(2.6, 12.0 / d))
    fig = plt.figure(figsize=(size * d, size * d), label=FIXED)
    # margins in inches: the outer tick and axis labels on the left and at the bottom, the title at the top
    w = size * d
    grid = fig.add_gridspec(d, d, left=0.75 / w, right=1 - 0.1 / w, bottom=0.65 / w, top=1 - 0.5 / w,
                            wspace=0.08, hspace=0.08)
    ranges = [zoom(post.samples[:, i]) for i in range(d)]
    for row in range(d):
        for col in range(row + 1):
            ax = fig.add_subplot(grid[row, col])
            lean_ticks(ax, NARROW_PANEL_TICKS)
            x = post.samples[:, col]
            if col == row:
                ax.hist(x, bins=_bins(x), color="0.7", histtype="stepfilled")
                ax.axvline(post.map_theta[col], color="C3", lw=1.2)
                for _, value, k in _marks_of(marks, post.names[col]):
                    ax.axvline(value, color=f"C{k}", ls=_LINES[k % 4], lw=1.2)
                ax.set_yticks([])
            else:
                ax.plot(x, post.samples[:, row], ".", ms=2, color="C0", alpha=0.5)
                ax.plot(post.map_theta[col], post.map_theta[row], "*", ms=10, color="C3", mec="k", mew=0.5)
                for label, value, k in _marks_of(marks, post.names[col]):
                    if post.names[row] in (marks[label] or {}) and marks[label][post.names[row]] is not None:
                        ax.plot(value, marks[label][post.names[row]], _MARKERS[k % 4], ms=6, mfc="none",
                                color=f"C{k}", mew=1.2)
                ax.set_ylim(ranges[row])
            ax.set_xlim(ranges[col])
            if row == d - 1:
                ax.set_xlabel(parameter_label(post.names[col], units))
            else:   # tick labels hidden, not emptied: the cheaper way to the same picture
                ax.tick_params(labelbottom=False)
            if col == 0 and row > 0:
                ax.set_ylabel(parameter_label(post.names[row], units))
            elif col != row:
                ax.tick_params(labelleft=False)
    handles = [plt.Line2D([], [], ls="", marker=".", color="C0", label="posterior samples"),
               plt.Line2D([], [], ls="", marker="*", ms=10, color="C3", mec="k", label="MAP")]
    handles += [plt.Line2D([], [], ls="", marker=_MARKERS[k % 4], mfc="none", color=f"C{k}", label=label)
                for k, label in enumerate(marks or {}) if marks[label]]
    fig.legend(handles=handles, loc="upper right", bbox_to_anchor=(1 - 0.1 / w, 1 - 0.5 / w), fontsize=8)
    return fig


def stages_figure(post, units=None):
    """Each parameter's samples against the stage index (how the population narrows from the prior, stage 0, to
    the posterior, beta = 1). Returns the figure."""
    fig, axes = panel_grid(len(post.names), 3.2, 2.6, ticks=NARROW_PANEL_TICKS)
    spread = np.concatenate([j + np.linspace(-0.3, 0.3, len(theta)) for j, theta in enumerate(post.stage_samples)])
    for i, (ax, name) in enumerate(zip(axes, post.names)):
        ax.plot(spread, np.concatenate([theta[:, i] for theta in post.stage_samples]), ".", ms=1, color="C0")
        ax.set_xlabel("stage j")
        ax.set_ylabel(parameter_label(name, units or {}))
    return fig


def write_posterior_figures(out, post, marks=None, units=None, title=None, draw=draw):
    """marginals.png, pairs.png and stages.png of ``post`` in the folder ``out``, each under ``title``; ``draw``
    draws them (:func:`cases.study.outputs.figures.canvas.draw`: now, or a ``FigureQueue`` that keeps them)."""
    draw(marginals_figure, (post, marks, units), out / "marginals.png", title, 120)
    draw(pairs_figure, (post, marks, units), out / "pairs.png", title)
    draw(stages_figure, (post, units), out / "stages.png", title)
