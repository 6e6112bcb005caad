"""Where the figures are drawn: pyplot on the off-screen Agg backend and a grid of panels that wraps (at most
``MAX_COLUMNS`` columns, so that many curves make more rows, not a row of thousands of pixels)."""
from __future__ import annotations

import math

__all__ = ["MAX_COLUMNS", "pyplot", "panel_grid", "save"]

#: the most panels side by side
MAX_COLUMNS = 4


def pyplot():
    """matplotlib.pyplot on the off-screen Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def panel_grid(n: int, width: float = 4.2, height: float = 3.2, max_columns: int = MAX_COLUMNS):
    """A figure of ``n`` panels of ``width`` x ``height`` inches in rows of at most ``max_columns``: (figure, the
    ``n`` axes in reading order); the grid's unused cells are switched off."""
    plt = pyplot()
    cols = max(1, min(n, max_columns))
    rows = max(1, math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows), squeeze=False)
    flat = list(axes.flat)
    for ax in flat[n:]:
        ax.axis("off")
    return fig, flat[:n]


def save(fig, path, title: str | None = None, dpi: int = 110, layout: bool = True):
    """Title ``fig``, lay it out (matplotlib's tight layout; ``layout=False`` for a figure placed on a fixed grid
    already, which saves that pass), write it to ``path`` and close it."""
    plt = pyplot()
    if title:
        fig.suptitle(title, fontsize=10)
    if layout:
        fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / fig.get_figheight()) if title else None)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
