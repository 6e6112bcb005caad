"""Figures of the recorded curves against the calibrated model: one panel per curve, or per group of a stage
programme's curves drawn end to end (:mod:`cases.study.outputs.figures.panels`), with the records, the MAP and the
95 % posterior predictive band, in a wrapped grid; and the stress paths q-p' of the triaxial tests, a panel per test.

``observations`` are the records (``inference.Observations``); ``map_simulated``
{(test, curve): MAP values at the recorded abscissae}; ``dense`` {(test, key): (x, y)} the MAP between the records
(:mod:`cases.study.outputs.figures.dense`), drawn as a line where present, else the MAP is drawn as markers at the
records. Units kPa, %, s; compression positive."""
from __future__ import annotations

import numpy as np

from cases.study.outputs.figures.canvas import logarithmic_time
from cases.study.outputs.figures.labels import abscissa_label, quantity_label
from cases.study.outputs.figures.panels import Panel, curve_panels
from cases.study.outputs.figures.sheet import padded, panel_sheet
from cases.study.programme import split_key

__all__ = ["curves_figure", "model_at_records", "recorded_mean_stress", "stress_path_panels",
           "stress_paths_figure"]


def _shifted(line, offset):
    """A dense MAP line (x, y) moved by ``offset`` along x; None stays None."""
    return None if line is None else (np.asarray(line[0]) + offset, line[1])


def curves_figure(observations, map_simulated, bands, dense=None, panels=None):
    """One panel per recorded curve, or per group of a stage programme's curves drawn end to end (``panels``,
    :func:`cases.study.outputs.figures.panels.curve_panels`; None: a panel per curve), at most four side by side: the
    records, the MAP and the 95 % posterior predictive band (``bands`` {(test, curve): inference.diagnosis
    PredictiveBand}) with the share of the records inside it, a faint line where a stage continues the one before
    it on the axial strain of its shear; a time axis spanning more than two decades is logarithmic
    (:func:`cases.study.outputs.figures.canvas.logarithmic_time`), ticked at its decades. The panels are cells of
    one axes (:mod:`cases.study.outputs.figures.sheet`), each scaled to what it draws; one legend, under the
    title. Returns the figure."""
    dense = dense or {}
    panels = panels or curve_panels(observations)
    sheet, frames = panel_sheet(len(panels), (4.2, 3.2))
    for frame, panel in zip(frames, panels):
        test = panel.test
        drawn = []   # per member: (x, band, MAP line or None, MAP at the records, records, offset)
        for key, offset in panel.members:
            curve = observations[test].curves[key]
            drawn.append((curve.x + offset, bands[test, key], _shifted(dense.get((test, key)), offset),
                          map_simulated[test, key], curve.y, offset))
        first = observations[test].curves[panel.keys[0]]
        log = logarithmic_time(first.x_name, first.x)
        xs = [v for x, _, line, *_ in drawn for v in (x, () if line is None else line[0])]
        ys = [v for _, band, line, at, y, _ in drawn
              for v in (band.lower, band.upper, at if line is None else line[1], y)]
        cell = sheet.cell(*frame, padded(np.concatenate(xs), log), padded(np.concatenate(ys)), x_log=log)
        for x, band, line, at, y, offset in drawn:
            sheet.ax.fill_between(cell.x(x), cell.y(band.lower), cell.y(band.upper), color="C0", alpha=0.25, lw=0,
                                  label=sheet.once("95 % predictive"))
            if line is not None:   # the MAP between the records
                sheet.ax.plot(cell.x(line[0]), cell.y(line[1]), "C0-", lw=1.5, label=sheet.once("MAP"))
            else:
                sheet.ax.plot(cell.x(x), cell.y(at), "C0x", ms=5, label=sheet.once("MAP (at the records)"))
            sheet.ax.plot(cell.x(x), cell.y(y), "o", ms=3, mfc="none", color="C3", label=sheet.once("recorded"))
            if offset:   # where a stage continues the one before on a shifted axis
                cell.vertical(offset, color="0.75", lw=0.5, zorder=0)
        cell.note(f"{100 * panel.coverage(bands):.0f} % of the records in the band", top=False, color="0.3",
                  fontsize=7)
        # the panels stand apart (PANEL_MARGINS): ticks up to their ends
        cell.x_axis(abscissa_label(first.x_name, first.x_unit), edge=0.0)
        cell.y_axis(quantity_label(panel.keys[0], first.y_unit), edge=0.0)
        cell.title(panel.title)
    sheet.legend_row()
    return sheet.finish()


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
    """The panels of :func:`stress_paths_figure`, one per test: (recorded test, [(q curve key, the MAP at its records
    (:func:`model_at_records`))]) of the test's q curves (its stages') whose MAP gives p'."""
    dense = dense or {}
    panels = []
    for t in observations:
        paths = [(key, model) for key in t.curves if split_key(key)[0] == "q"
                 for model in [model_at_records(t, key, map_raw.get(t.name, {}), dense)] if model is not None]
        if paths:
            panels.append((t, paths))
    return panels


def stress_paths_figure(observations, map_raw, drained, dense=None):
    """The q-p' paths of the triaxial tests of ``observations`` (the records), every stage whose MAP gives p'
    (:func:`model_at_records`: ``map_raw`` {test: {key: values at the records}}, ``dense`` {(test, key): (x, y)}) in
    its test's panel: the MAP (a line where ``dense`` has it) and the records (:func:`recorded_mean_stress`;
    ``drained`` {(test, stage name or None): bool}); at most four panels side by side, cells of one axes
    (:mod:`cases.study.outputs.figures.sheet`), one legend under the title, a panel's stages without a recorded p'
    named in it. Returns the figure, or None when no curve has a path."""
    dense = dense or {}
    panels = stress_path_panels(observations, map_raw, dense)
    if not panels:
        return None
    sheet, frames = panel_sheet(len(panels), (4.0, 3.6))
    for frame, (t, paths) in zip(frames, panels):
        drawn, unknown = [], []   # per stage: (MAP line (p, q) or None, MAP at the records (p, q), records or None)
        for key, model in paths:
            stage = split_key(key)[1]
            p_key = "mean_stress" if stage is None else f"mean_stress@{stage}"
            line = ((dense[t.name, p_key][1], dense[t.name, key][1])
                    if (t.name, p_key) in dense and (t.name, key) in dense else None)
            p_rec = recorded_mean_stress(t, key, model, drained.get((t.name, stage), False))
            if p_rec is None:
                unknown.append(stage)
            drawn.append((line, (model["mean_stress"], model["q"]),
                          None if p_rec is None else (p_rec, t.curves[key].y)))
        shown = [pq for line, at, rec in drawn for pq in (at if line is None else line, rec) if pq is not None]
        cell = sheet.cell(*frame, padded(np.concatenate([p for p, _ in shown])),
                          padded(np.concatenate([q for _, q in shown])))
        for line, at, rec in drawn:
            if line is not None:
                sheet.ax.plot(cell.x(line[0]), cell.y(line[1]), "C0-", lw=1.5, label=sheet.once("MAP"))
            else:
                sheet.ax.plot(cell.x(at[0]), cell.y(at[1]), "C0x", ms=5, label=sheet.once("MAP (at the records)"))
            if rec is not None:
                sheet.ax.plot(cell.x(rec[0]), cell.y(rec[1]), "o", ms=3, mfc="none", color="C3",
                              label=sheet.once("recorded"))
        if unknown:
            where = "" if unknown == [None] else f" in {len(unknown)} of {len(paths)} stages"
            cell.note(f"recorded p' unknown{where} (no p' or u recorded)", fontsize=7)
        cell.x_axis(quantity_label("mean_stress"), edge=0.0)
        cell.y_axis(quantity_label("q"), edge=0.0)
        cell.title(Panel(t.name, tuple((key, 0.0) for key, _ in paths)).title)
    sheet.legend_row()
    return sheet.finish()
