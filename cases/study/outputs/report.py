"""What a calibrated study shows: parameter tables, the loop's figure and the Markdown report of one calibrated class
with its figures (:mod:`cases.study.outputs.figures`: curves, stress paths, marginals, pairs, stages).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cases.study.outputs.calibration_warnings import calibration_warnings, warnings_section
from cases.study.outputs.figures.canvas import draw, logarithmic_time
from cases.study.outputs.figures.curves import curves_figure, stress_path_panels, stress_paths_figure
from cases.study.outputs.figures.labels import abscissa_label, quantity_label
from cases.study.outputs.figures.panels import curve_panels, stage_axes
from cases.study.outputs.figures.posterior import write_posterior_figures
from cases.study.outputs.figures.sheet import padded, panel_sheet
from cases.study.outputs.glossary import glossary_lines
from cases.study.runner import method_name
from inference import diagnosis

__all__ = ["parameter_table", "runs_table", "loop_figure", "plot_loop", "write_outputs"]

#: the loop figure: the room (inches) between a panel's records and its residual below them
STACK_GAP = 0.2


def _fmt(v):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-"
    a = abs(v)
    return f"{v:.4g}" if (a >= 1e-3 or a == 0) else f"{v:.3e}"


def parameter_table(post, reference: dict | None = None, units: dict | None = None) -> str:
    """Markdown table: MAP, mean, std, 95 % interval per parameter, then reference columns
    ``{column label: {name: value}}`` (true values, the paper's table...)."""
    reference = reference or {}
    units = units or {}
    q = post.quantiles()
    head = ["parameter", "MAP", "mean", "std", "95 % interval"] + list(reference)
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in post.names:
        label = f"{n} ({units[n]})" if units.get(n) else n
        cells = [label, _fmt(post.map[n]), _fmt(post.mean[n]), _fmt(post.std[n]),
                 f"[{_fmt(q[n][0])}, {_fmt(q[n][2])}]"]
        cells += [_fmt(col.get(n)) for col in reference.values()]
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows)


def runs_table(summaries: list, names, reference: dict | None = None) -> str:
    """Markdown table over independent runs, one column pair per method (side by side): average MAP and its
    spread (std over runs) per parameter, then reference columns; then ln Z and forward solves per method."""
    reference = reference or {}
    methods = sorted({s["method"] for s in summaries})
    by = {m: [s for s in summaries if s["method"] == m] for m in methods}
    head = ["parameter"] + [f"{m}: {h}" for m in methods for h in ("average MAP", "spread of MAP")] + list(reference)
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for n in names:
        cells = [n]
        for m in methods:
            maps = np.array([s["parameters"][n]["map"] for s in by[m]])
            cells += [_fmt(float(maps.mean())), _fmt(float(maps.std(ddof=1)) if maps.size > 1 else None)]
        rows.append("| " + " | ".join(cells + [_fmt(col.get(n)) for col in reference.values()]) + " |")
    rows.append("")
    for m in methods:
        ev = np.array([s["log_evidence"] for s in by[m]])
        solves = np.array([s["n_forward_solves"] for s in by[m]])
        wall = np.array([s["wall_s"] for s in by[m]])
        rows.append(f"- {m}: {ev.size} run(s); ln Z mean {ev.mean():.3f}, spread "
                    f"{ev.std(ddof=1) if ev.size > 1 else 0:.3f}; forward evaluations {solves.mean():.0f} per run; "
                    f"wall {wall.mean():.0f} s per run")
    return "\n".join(rows)


def write_outputs(out, method: str, post, like, cls, study, synthetic: bool, truth: dict | None, summary: dict,
                  map_raw: dict, dense: dict, draw=draw):
    """report.md (with the calibration warnings of :mod:`cases.study.outputs.calibration_warnings`, also printed on
    stdout as ``warning: ...``), curves.png, stress_paths.png (triaxial tests), marginals.png, pairs.png, stages.png
    of one calibrated class of ``study``; ``cls`` the class record (MAP and posterior-sample curves), ``truth`` the
    values synthetic recordings were made from (or None), ``summary`` the class's summary.json content
    (``runner.write_summary``), ``map_raw`` the MAP's forward result {test: {quantity: values at the records}},
    ``dense`` the MAP between the records (:func:`cases.study.outputs.figures.dense.dense_curves`); ``draw`` draws the
    figures (:func:`cases.study.outputs.figures.canvas.draw`: now, or a ``FigureQueue`` that keeps them)."""
    out = Path(out)
    tag = "SYNTHETIC recordings" if synthetic else "recordings"
    bands = diagnosis.predictive_bands(like, cls["sample_simulated"], cls["sample_sigma"])
    title = f"{study.name}: {cls['name']}, {method_name(method)} ({tag})"
    panels = curve_panels(like.observations, stage_axes(study.tests))
    draw(curves_figure, (like.observations, cls["map_simulated"], bands, dense, panels), out / "curves.png", title)
    drained = {(t.name, s.name if t.staged and len(t.stages) > 1 else None): s.drainage == "drained"
               for t in study.tests for s in (t.stages if t.staged else [t])}
    paths = bool(stress_path_panels(like.observations, map_raw, dense))
    if paths:
        draw(stress_paths_figure, (like.observations, map_raw, drained, dense), out / "stress_paths.png", title)
    units = {n: r.unit for n, r in study.spec.ranges.items()}
    write_posterior_figures(out, post, {"generating (synthetic)": truth} if truth else None, units, title, draw)
    lines = [f"# {study.name}: {method_name(method)} calibration of {cls['name']}", ""]
    if synthetic:
        lines += ["**The recordings are SYNTHETIC** (their `# synthetic` header lines say how they were made); they "
                  "are not measurements.", ""]
    if study.description:
        lines += [study.description, ""]
    lines += [f"- study file: {study.path}"]
    lines += [f"- {t.name}: {t.describe()}, curves {', '.join(like.observations[t.name].curves)} ({t.file})"
              for t in study.tests]
    left_out = sum(like.excluded.values())
    lines += [f"- points left out of Eq. (5) as near zero: {left_out} of {left_out + sum(like.n_points.values())} "
              f"(below {100 * like.floor:g} % of each curve's largest |value|"
              + (f"; {100 * like.crossing_floor:g} % on the curves that change sign: "
                 + ", ".join(f"{t}/{c}" for t, c in like.crossing) if like.crossing else "") + ")"]
    lines += [f"- fixed: {json.dumps(study.fixed)}",
              f"- N_s = {summary['n_samples']}, stages {summary['n_stages']}, forward evaluations "
              f"{summary['n_forward_solves']}, failed {summary['n_failed_solves']}, wall {summary['wall_s']:.1f} s on "
              f"{summary['ranks']} process(es) ({summary['executor']})",
              f"- ln Z = {post.log_evidence:.3f}; J_g at MAP: " + ", ".join(
                  f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in summary["J_g_at_map"].items()),
              "", parameter_table(post, {"generating (synthetic)": truth} if truth else None), ""]
    if truth:
        names = [n for n in post.names if n in truth]
        lines.append("Generating values inside the 95 % posterior interval: " + ", ".join(
            f"{n} {'yes' if lo <= truth[n] <= hi else 'NO'}" for n in names for lo, hi in [post.credible_interval(n)]))
        lines.append("")
    lines += ["Predictive coverage of the records (95 % band): " + ", ".join(
        f"{panel.label} {100 * panel.coverage(bands):.0f} %" for panel in panels), ""]
    lines += warnings_section(cls["warnings"] if "warnings" in cls else
                              calibration_warnings(post, like, cls["map_simulated"]))
    lines += ["Figures: curves.png (records, MAP, 95 % posterior predictive band)"
              + (", stress_paths.png (q-p')" if paths else "") + ", marginals.png, pairs.png, stages.png.",
              "",
              *glossary_lines()]
    (out / "report.md").write_text("\n".join(lines))


def plot_loop(path, like, classes, diag, label, synthetic, draw=draw, panels=None):
    """The loop's figure (:func:`loop_figure`) at ``path``, titled with the data's kind, ``label`` and the verdict;
    ``draw`` draws it (:func:`cases.study.outputs.figures.canvas.draw`: now, or a ``FigureQueue`` that keeps it)."""
    tag = "SYNTHETIC data" if synthetic else "recordings"
    draw(loop_figure, (like, classes, diag, panels), path,
         f"{tag} ({label}): {diag.verdict}; omitted physics: {diag.omitted_physics}", 100)


def loop_figure(like, classes, diag, panels=None):
    """Per recorded curve, or per group of a stage programme's curves drawn end to end (``panels``,
    :func:`cases.study.outputs.figures.panels.curve_panels`; None: a panel per curve): data with the base (dashed)
    and enriched (solid) MAP, and below it on the same abscissa the base class's relative residual with the mismatch
    regions shaded. The enriched class drawn is the confirmed one, else the physics class (not the model-form class)
    of largest ln Z. A time axis spanning more than two decades is logarithmic, as in the curves' figure (the panels
    are cells of one axes, :mod:`cases.study.outputs.figures.sheet`). ``classes``: the loop's [ModelClass], the base
    class first; ``diag``: its final Diagnosis. Returns the figure."""
    from matplotlib.patches import Rectangle

    panels = panels or curve_panels(like.observations)
    sheet, frames = panel_sheet(len(panels), (4.2, 5.6))
    base, enriched = classes[0], None
    physics = [c for c in classes[1:] if c.role == "enriched"]
    if physics:
        confirmed = [c for c in physics if c.candidate == diag.omitted_physics]
        enriched = confirmed[0] if confirmed else max(physics, key=lambda c: c.log_evidence)
    ax = sheet.ax
    for (left, bottom, width, height), panel in zip(frames, panels):
        t = panel.test
        members = []   # (x, records, base MAP, enriched MAP or None, residual %, offset, key)
        for c, offset in panel.members:
            curve = like.observations[t].curves[c]
            members.append((curve.x + offset, curve.y, base.map_simulated[t, c],
                            None if enriched is None else enriched.map_simulated[t, c],
                            100 * (curve.y / base.map_simulated[t, c] - 1.0), offset, c))
        curve = like.observations[t].curves[panel.keys[0]]
        log = logarithmic_time(curve.x_name, curve.x)
        x_range = padded(np.concatenate([x for x, *_ in members]), log)
        each = (height - STACK_GAP) / 2
        top = sheet.cell(left, bottom + each + STACK_GAP, width, each, x_range, padded(np.concatenate(
            [v for _, y, b, e, *_ in members for v in (y, b, () if e is None else e)])), x_log=log)
        low = sheet.cell(left, bottom, width, each, x_range,
                         padded(np.concatenate([[0.0], *(r for *_, r, _, _ in members)])), x_log=log)
        for x, y, b, e, r, offset, c in members:
            ax.plot(top.x(x), top.y(y), "o", ms=3, mfc="none", color="C3", label=sheet.once("recorded"))
            ax.plot(top.x(x), top.y(b), "k--", lw=1, label=sheet.once("base MAP"))
            if e is not None:
                ax.plot(top.x(x), top.y(e), "C0-", lw=1.3, label=sheet.once(f"{enriched.candidate} MAP"))
            ax.plot(low.x(x), low.y(r), "o-", ms=3, lw=0.6, color="C3")
            for reg in diag.mismatch_regions:
                if reg.test == t and reg.curve == c:
                    x0, x1 = np.clip(low.x([reg.x_start + offset, reg.x_end + offset]), low.left, low.left + width)
                    ax.add_patch(Rectangle((x0, low.bottom), x1 - x0, each, color="C3", alpha=0.15, lw=0))
            if offset:   # where a stage continues the one before on a shifted axis
                for cell in (top, low):
                    cell.vertical(offset, color="0.75", lw=0.5, zorder=0)
        ax.plot([low.left, low.left + width], [float(low.y(0.0))] * 2, color="k", lw=0.6)
        top.title(panel.title)
        top.x_axis(values=False, edge=0.0)
        top.y_axis(quantity_label(panel.keys[0], curve.y_unit), edge=0.0)
        low.x_axis(abscissa_label(curve.x_name, curve.x_unit), edge=0.0)
        low.y_axis("base residual U_obs/U_sim - 1 (%)", edge=0.0)
    sheet.legend_row()
    return sheet.finish()
