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
from cases.study.programme import split_key

__all__ = ["curves_figure", "model_at_records", "recorded_mean_stress", "stress_path_panels",
           "stress_paths_figure"]


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


def model_at_records(recorded, key, map_raw, dense):
    """The MAP's q, p' (``mean_stress``) and excess pore pressure at the records of the q curve ``key`` (``q`` or
    ``q@<stage>``) of the test ``recorded``: {quantity: values}, all from the solution between the records
    (``dense`` {(test, key): (x, y)}, interpolated to the records) when it has q and p', else from ``map_raw``
    {key: values at the records}; None when neither gives p'."""
    _, stage = split_key(key)
    suffix = "" if stage is None else f"@{stage}"
    x = recorded.curves[key].x
    names = {"q": key, "mean_stress": f"mean_stress{suffix}", "excess_pore_pressure": f"excess_pore_pressure{suffix}",
             "u": f"u{suffix}"}
    if all((recorded.name, names[k]) in dense for k in ("q", "mean_stress")):
        out = {}
        for quantity, name in names.items():
            if (recorded.name, name) in dense:
                xs, ys = dense[recorded.name, name]
                order = np.argsort(xs)
                out[quantity] = np.interp(x, np.asarray(xs)[order], np.asarray(ys)[order])
        return out
    if not {names["q"], names["mean_stress"]} <= set(map_raw):
        return None
    return {quantity: np.asarray(map_raw[name], float) for quantity, name in names.items() if name in map_raw}


def recorded_mean_stress(recorded, key, model, drained: bool):
    """p' (kPa) at the records of the q curve ``key`` of a triaxial test, or None when the records do not give it:
    the recorded p' of its stage when there is one; else from the recorded q (and excess pore pressure u of an
    undrained stage) on the stage's total stress path, dp = dq/3 at constant cell pressure, from the same state as the
    model (a test's initial state, or a stage that starts at the stress its target sets): p'_rec = p'_MAP +
    (q_rec - q_MAP)/3 - (u_rec - u_MAP), the MAP's values ``model`` (:func:`model_at_records`; u = 0 when
    ``drained``)."""
    _, stage = split_key(key)
    suffix = "" if stage is None else f"@{stage}"
    curves = recorded.curves
    if f"p{suffix}" in curves:
        return curves[f"p{suffix}"].y
    shift = (curves[key].y - model["q"]) / 3.0
    for name in ("excess_pore_pressure", "u"):
        if f"{name}{suffix}" in curves and name in model:
            return model["mean_stress"] + shift - (curves[f"{name}{suffix}"].y - model[name])
    return model["mean_stress"] + shift if drained else None


def stress_path_panels(observations, map_raw, dense=None) -> list:
    """The panels of :func:`stress_paths_figure`: (recorded test, q curve key, the MAP at its records
    (:func:`model_at_records`)) of each q curve whose MAP gives p'."""
    dense = dense or {}
    panels = []
    for t in observations:
        for key in t.curves:
            if split_key(key)[0] == "q":
                model = model_at_records(t, key, map_raw.get(t.name, {}), dense)
                if model is not None:
                    panels.append((t, key, model))
    return panels


def stress_paths_figure(observations, map_raw, drained, dense=None):
    """The q-p' paths of the triaxial tests and stages of ``observations`` (the records) whose MAP gives p'
    (:func:`model_at_records`: ``map_raw`` {test: {key: values at the records}}, ``dense`` {(test, key): (x, y)}):
    the MAP (a line where ``dense`` has it) and the records (:func:`recorded_mean_stress`; ``drained`` {(test, stage
    name or None): bool}); a panel per q curve, at most four side by side. Returns the figure, or None when no curve
    has a path."""
    dense = dense or {}
    panels = stress_path_panels(observations, map_raw, dense)
    if not panels:
        return None
    fig, axes = panel_grid(len(panels), 4.0, 3.6)
    for ax, (t, key, model) in zip(axes, panels):
        stage = split_key(key)[1]
        p_key = "mean_stress" if stage is None else f"mean_stress@{stage}"
        line = ((dense[t.name, p_key][1], dense[t.name, key][1])
                if (t.name, p_key) in dense and (t.name, key) in dense else None)
        _draw_map(ax, line, model["mean_stress"], model["q"])
        p_rec = recorded_mean_stress(t, key, model, drained.get((t.name, stage), False))
        if p_rec is not None:
            ax.plot(p_rec, t.curves[key].y, "o", ms=3, mfc="none", color="C3", label="recorded")
        else:
            ax.plot([], [], " ", label="recorded p' unknown (no p' or u recorded)")
        ax.set_xlabel(quantity_label("mean_stress"))
        ax.set_ylabel(quantity_label("q"))
        ax.set_title(panel_title(t.name, key), fontsize=9)
        ax.legend(fontsize=7)
    return fig
