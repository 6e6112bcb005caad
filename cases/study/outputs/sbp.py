"""The outputs of a pressuremeter calibration: the records against the FE's MAP curves with the posterior
predictive band, posterior marginals and stages, the MAP's fields around the cavity (VTU and PNG) and the report."""
from __future__ import annotations

import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from cases.study.outputs.figures.canvas import pyplot
from cases.study.outputs.figures.labels import abscissa_label, quantity_label
from cases.study.outputs.figures.posterior import write_posterior_figures
from cases.study.outputs.glossary import glossary_lines
from cases.study.outputs.report import parameter_table
from cases.study.runner import method_name, write_summary
from inference import diagnosis

__all__ = ["SBPCase", "predictive_bands", "plot_sbp_curves", "sbp_report", "write_sbp_outputs"]


@dataclass(frozen=True)
class SBPCase:
    """What a pressuremeter case's outputs name: ``case`` (summary.json), the report's ``title`` and the figures'
    ``short_title``, the calibrated ``model``, reference columns {label: {parameter: value}}, prior ``bounds`` and
    ``units`` per parameter, a note on synthetic recordings and further summary.json fields."""

    case: str
    title: str
    short_title: str
    model: str
    references: dict
    bounds: dict
    units: dict
    synthetic_note: str = ""
    summary_extra: dict | None = None


def predictive_bands(post, like, n_draws, seed):
    """95 % posterior predictive band of the records (inference.diagnosis: the exact mixture of U_sim (1 + eps) over
    ``n_draws`` posterior samples, each with its sigma_eps). Returns ({(test, curve): PredictiveBand}, draws)."""
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(post.samples), size=min(n_draws, len(post.samples)), replace=False)
    sims, sigmas = diagnosis.simulate_samples(like, post.samples[idx])
    return diagnosis.predictive_bands(like, sims, sigmas), len(idx)


def plot_sbp_curves(path, like, map_curves, bands, title):
    """One panel per recorded quantity, every test in it: records, MAP (the FE curve) and the 95 % posterior
    predictive band."""
    plt = pyplot()
    obs = like.observations
    curves = list(next(iter(obs)).curves)
    fig, axes = plt.subplots(1, len(curves), figsize=(5.5 * len(curves), 4.2), squeeze=False)
    for j, cname in enumerate(curves):
        ax = axes[0, j]
        for i, t in enumerate(obs):
            c = t.curves[cname]
            color = f"C{i}"
            band = bands[t.name, cname]
            ax.fill_between(c.x, band.lower, band.upper, color=color, alpha=0.2, lw=0,
                            label=f"{t.name}: 95 % predictive ({100 * band.coverage:.0f} % of records inside)")
            x, y = map_curves[t.name][cname]
            ax.plot(x, y, color=color, lw=1.5, label=f"{t.name}: MAP")
            ax.plot(c.x, c.y, "o", ms=3, mfc="none", color=color, label=f"{t.name}: recorded")
        ax.set_xlabel(abscissa_label("cavity_strain"))
        ax.set_ylabel(quantity_label(cname))
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sbp_report(out, case: SBPCase, method, preset_label, post, summary, like, synthetic, truth, bands_drawn, preset):
    """report.md of one pressuremeter calibration: settings, evidence, parameter table against the case's
    references, generating values and MAP errors of synthetic recordings, the stage table."""
    names = [n for n in post.names if n != "sigma_eps"]
    ref = {"generating (synthetic)": truth, **case.references} if truth else dict(case.references)
    lines = [f"# {case.title}: {method_name(method)} calibration of {case.model}", ""]
    if synthetic:
        lines += ["**The recordings are SYNTHETIC** (see the `# synthetic` lines of their headers" + case.synthetic_note
                  + "). They are not measurements.", ""]
    lines += [f"- tests: {', '.join(f'{t.name} ({t.source})' for t in like.observations)}",
              f"- FE and sampler settings: {preset_label} {json.dumps(asdict(preset))}",
              f"- N_s = {summary['n_samples']}, stages {summary['n_stages']}, forward evaluations "
              f"{summary['n_forward_solves']} (each = {len(like.observations)} FE solves), failed "
              f"{summary['n_failed_solves']}, wall {summary['wall_s']:.1f} s on {summary['ranks']} process(es) "
              f"({summary['executor']})",
              f"- ln Z = {post.log_evidence:.3f}; J_g at MAP: "
              + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                          for k, v in summary["J_g_at_map"].items()), "",
              parameter_table(post, ref, case.units), ""]
    if truth:
        lines.append("Generating values inside the 95 % posterior interval: " + ", ".join(
            f"{n} {'yes' if lo <= truth[n] <= hi else 'NO'}"
            for n in names for lo, hi in [post.credible_interval(n)]))
        lines.append("MAP errors: " + ", ".join(
            f"{n} {100 * (post.map[n] / truth[n] - 1):+.1f} %" for n in names))
        lines.append("")
    lines += ["Figures: curves.png (recorded vs MAP, 95 % posterior predictive band from "
              f"{bands_drawn} posterior draws), marginals.png, pairs.png, stages.png, fields_*.png and "
              "map_fields/*.vtu (MAP solution at 10 % cavity strain). Stage log: progress.log; failed solves: "
              "failed_solves.jsonl.", "",
              "| stage | beta | ln S | acceptance | sweeps | evaluations | failed | wall (s) |",
              "|---|---|---|---|---|---|---|---|"]
    for r in summary["stages"]:
        lines.append(f"| {r.get('stage', '')} | {r['beta']:.4g} | {r.get('log_S', 0):.3f} | "
                     f"{r.get('acceptance', 0):.2f} | "
                     f"{r.get('sweeps', '')} | {r.get('n_evals', '')} | {r.get('n_failed', '')} | "
                     f"{r.get('wall_s', 0):.1f} |")
    lines += ["", *glossary_lines()]
    (Path(out) / "report.md").write_text("\n".join(lines))


def write_sbp_outputs(out, case: SBPCase, run, seed, post, like, forward, preset, preset_label, synthetic, truth):
    """Every output of one pressuremeter calibration (summary.json, figures, MAP fields as VTU and PNG, report.md);
    ``truth`` the generating values of synthetic records (or None). Returns the summary."""
    out = Path(out)
    summary = write_summary(out, case.case, run, seed, post, like, extra={
        "synthetic_recordings": synthetic, "preset": preset_label, "settings_fe": asdict(preset),
        "fixed": forward.fixed, "site": forward.site, "generating": truth, **(case.summary_extra or {})})
    params, _ = like.split(post.map_theta)
    results = forward.results(params, save_fields="phases")
    map_curves = forward.curves_of(results)
    bands, drawn = predictive_bands(post, like, 24 if run.quick else 40, seed)
    tag = "SYNTHETIC recordings" if synthetic else "recordings"
    plot_sbp_curves(out / "curves.png", like, map_curves, bands,
                    f"{case.short_title}, {method_name(run.method)}: {tag} vs MAP and posterior predictive")
    write_posterior_figures(out, post, {"generating": truth, **case.references} if truth else case.references,
                            case.units, f"{case.short_title} posterior ({tag})")
    for name, res in results.items():
        res.write_vtu(out / "map_fields", prefix=f"{name}")
        try:
            res.plot(str(out / f"fields_{name}.png"))
        except Exception as exc:  # noqa: BLE001 - a missing OpenGL stack must not lose the calibration
            print(f"[{case.case}] field picture not written: {exc}", file=sys.stderr)
    sbp_report(out, case, run.method, preset_label, post, summary, like, synthetic, truth, drawn, preset)
    return summary
