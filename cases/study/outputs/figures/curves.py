"""Figures of the recorded curves against the calibrated model: one panel per curve (records, the MAP, the 95 %
posterior predictive band) in a wrapped grid, and the stress paths q-p' of the triaxial tests.

``observations`` are the records (``inference.Observations``); ``map_simulated``
{(test, curve): MAP values at the recorded abscissae}; ``dense`` {(test, key): (x, y)} the MAP between the records
(:mod:`cases.study.outputs.figures.dense`), drawn as a line where present, else the MAP is drawn as markers at the
records. Units kPa, %, s; compression positive."""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import panel_grid
from cases.study.outputs.figures.labels import abscissa_label, panel_title, quantity_label

__all__ = ["curves_figure", "recorded_mean_stress", "stress_paths_figure"]


def _draw_map(ax, line, x, y):
    """The MAP of one panel: a line through ``line`` (x, y) when the model was evaluated between the records, else
    (None) markers at the records (``x``, ``y``)."""
    if line is not None:
        ax.plot(*line, "C0-", lw=1.5, label="MAP")
    else:
        ax.plot(x, y, "C0x", ms=5, label="MAP (at the records)")


def curves_figure(observations, map_simulated, bands, dense=None):
    """One panel per recorded curve, at most four side by side: the records, the MAP and the 95 % posterior
    predictive band (``bands`` {(test, curve): inference.diagnosis PredictiveBand}) with the share of the records
    inside it; a time axis spanning more than two decades is logarithmic. Returns the figure."""
    dense = dense or {}
    panels = [(t.name, key, curve) for t in observations for key, curve in t.curves.items()]
    fig, axes = panel_grid(len(panels))
    for ax, (test, key, curve) in zip(axes, panels):
        band = bands[test, key]
        ax.fill_between(curve.x, band.lower, band.upper, color="C0", alpha=0.25, lw=0, label="95 % predictive")
        _draw_map(ax, dense.get((test, key)), curve.x, map_simulated[test, key])
        ax.plot(curve.x, curve.y, "o", ms=3, mfc="none", color="C3", label="recorded")
        ax.text(0.98, 0.03, f"{100 * band.coverage:.0f} % of the records in the band", transform=ax.transAxes,
                ha="right", va="bottom", fontsize=7, color="0.3")
        ax.set_xlabel(abscissa_label(curve.x_name, curve.x_unit))
        ax.set_ylabel(quantity_label(key, curve.y_unit))
        ax.set_title(panel_title(test, key), fontsize=9)
        if curve.x_name in ("time", "stage_time") and curve.x.min() > 0 and curve.x.max() > 100 * curve.x.min():
            ax.set_xscale("log")   # creep, relaxation, consolidation: records logged at growing intervals
    axes[0].legend(fontsize=7)
    return fig


def recorded_mean_stress(recorded, map_raw, drained: bool):
    """p' (kPa) at the records of a triaxial test (flat, one abscissa for every curve), or None when the records do
    not give it: the recorded p' when there is one; else from the recorded q (and excess pore pressure u of an
    undrained test) on the test's total stress path, dp = dq/3 at constant cell pressure, from the same initial
    state as the model: p'_rec = p'_MAP + (q_rec - q_MAP)/3 - (u_rec - u_MAP), the MAP's values ``map_raw``
    {quantity: values at the records} (u = 0 when drained)."""
    curves = recorded.curves
    if "p" in curves:
        return curves["p"].y
    shift = (curves["q"].y - map_raw["q"]) / 3.0
    if drained:
        return map_raw["mean_stress"] + shift
    for name in ("excess_pore_pressure", "u"):
        if name in curves and name in map_raw:
            return map_raw["mean_stress"] + shift - (curves[name].y - map_raw[name])
    return None


def stress_paths_figure(observations, map_raw, drained, dense=None):
    """The q-p' paths of the triaxial tests of ``observations`` (the records) whose MAP gives p' (``map_raw``
    {test: {quantity: values at the records}} with ``q`` and ``mean_stress``): the MAP (a line where ``dense`` has it)
    and the records
    (:func:`recorded_mean_stress`; ``drained`` {test: bool}); a panel per test, at most four side by side. Returns
    the figure, or None when no test has a path."""
    dense = dense or {}
    tests = [t for t in observations if "q" in t.curves and {"q", "mean_stress"} <= set(map_raw.get(t.name, {}))]
    if not tests:
        return None
    fig, axes = panel_grid(len(tests), 4.0, 3.6)
    for ax, t in zip(axes, tests):
        raw = {k: np.asarray(v, float) for k, v in map_raw[t.name].items() if not isinstance(v, tuple)}
        line = ((dense[t.name, "mean_stress"][1], dense[t.name, "q"][1])
                if (t.name, "q") in dense and (t.name, "mean_stress") in dense else None)
        _draw_map(ax, line, raw["mean_stress"], raw["q"])
        p_rec = recorded_mean_stress(t, raw, drained.get(t.name, False))
        if p_rec is not None:
            ax.plot(p_rec, t.curves["q"].y, "o", ms=3, mfc="none", color="C3", label="recorded")
        else:
            ax.plot([], [], " ", label="recorded p' unknown (no p' or u recorded)")
        ax.set_xlabel(quantity_label("mean_stress"))
        ax.set_ylabel(quantity_label("q"))
        ax.set_title(t.name, fontsize=9)
        ax.legend(fontsize=7)
    return fig
