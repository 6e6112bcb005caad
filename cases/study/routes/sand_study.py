"""Triaxial studies of a sand from isotropic states (the paper's sections 3.1-3.2): test conditions from recorded data,
the SIMSAND forward model on a strain grid, the posterior predictive, and the figures (curves, CSL, MAP spread over
runs).

Curves calibrated (docs/reference.md section 1): drained tests q(eps_a) and e(eps_a); undrained tests q(eps_a) and the
excess pore pressure u(eps_a) (the paper's Fig. 13 choice). Axial strain is in percent in data files and figures, a
fraction inside the model. Compression positive, kPa.

Conditions of a test are read from its CSV ``#`` metadata (or given by the caller): ``e0`` (void ratio at the start
of shearing), ``p0_kPa`` (isotropic p'_0 in kPa) and ``drained`` (true/false).

The forward model is :class:`cases.study.forward.lab.LabForward` with SIMSAND: every test of a batch in one batched
call per drainage type (SIMSAND's own triaxial integrator), simulated on a strain grid from 0 and interpolated by the
likelihood to the recorded strains. A particle whose integration fails in any test is a zero-likelihood particle
with its reason, never a crash.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import inference
from cases.study.forward.lab import LabForward
from cases.study.outputs.figures.canvas import pyplot, save
from cases.study.outputs.figures.curves import stress_paths_figure
from cases.study.outputs.figures.labels import abscissa_label, quantity_label
from cases.study.outputs.figures.posterior import write_posterior_figures
from cases.study.outputs.figures.sheet import padded, panel_sheet
from cases.study.outputs.report import runs_table
from cases.study.programme import TestSpec
from cases.study.reading.reference import is_error_parameter
from constitutive import SIMSAND
from constitutive.registry import model_spec
from inference import DataError

__all__ = ["MAX_FAILURE_FRACTION", "conditions_of", "sand_forward", "parameters", "free_subset", "add_options",
           "is_error_parameter", "predictive", "volume_change_table", "plot_curves", "plot_stress_paths", "plot_csl",
           "plot_map_spread", "write_figures", "run_line", "sampler_settings", "write_runs", "CURVES"]

#: observed curves per drainage type (test curve name -> CSV quantity)
CURVES = {True: {"q": "q", "e": "e"}, False: {"q": "q", "u": "u"}}
#: failed forward evaluations allowed per stage: part of SIMSAND's prior box gives drained paths that lose control
#: (notes/simsand.md), zero-likelihood particles that vanish as the population concentrates
MAX_FAILURE_FRACTION = 0.5


def _flag(value, path, field):
    text = str(value).strip().lower()
    if text in ("true", "1", "yes", "drained"):
        return True
    if text in ("false", "0", "no", "undrained"):
        return False
    raise DataError(f"{path}: field {field!r} = {value!r} is not true/false")


def conditions_of(test: inference.Test) -> TestSpec:
    """The triaxial test record (compression from an isotropic p'0) of an observed test's conditions (``e0``,
    ``p0_kPa``, ``drained``), errors naming the file."""
    cond, where = test.conditions, test.source or test.name
    values = {}
    for key in ("e0", "p0_kPa"):
        if key not in cond:
            raise DataError(f"{where}: missing condition {key!r} (a '# {key}: value' header line or an option)")
        try:
            values[key] = float(cond[key])
        except (TypeError, ValueError):
            raise DataError(f"{where}: condition {key!r} = {cond[key]!r} is not a number") from None
    if not 0.0 < values["e0"] < 2.97:
        raise DataError(f"{where}: condition 'e0' = {values['e0']} outside (0, 2.97)")
    if not values["p0_kPa"] > 0.0:
        raise DataError(f"{where}: condition 'p0_kPa' = {values['p0_kPa']} must be > 0")
    drained = _flag(cond.get("drained", "true"), where, "drained")
    x = np.unique(np.concatenate([c.x for c in test.curves.values()]))
    if x.min() < 0:
        raise DataError(f"{where}: axial strain {x.min()} % < 0 (compression tests only)")
    return TestSpec(test.name, "triaxial", source_of(test), where, drainage="drained" if drained else "undrained",
                    direction="compression", consolidation="isotropic", p0=values["p0_kPa"], e0=values["e0"])


def source_of(test):
    return Path(test.source) if test.source else None


def sand_forward(observations, fixed: dict, grid_pct=None) -> LabForward:
    """The SIMSAND forward model of the observed tests (:func:`conditions_of`) with ``fixed`` parameter values,
    simulated on ``grid_pct`` (axial strains in %; default: every recorded strain) from 0."""
    tests = [conditions_of(t) for t in observations]
    strains = {t.name: np.unique(np.concatenate([c.x for c in t.curves.values()])) / 100.0 for t in observations}
    if grid_pct is None:
        grid_pct = np.unique(np.concatenate([np.unique(np.concatenate([c.x for c in t.curves.values()]))
                                             for t in observations]))
    curves = {t.name: tuple(CURVES[spec.drainage == "drained"]) for t, spec in zip(observations, tests)}
    return LabForward("SIMSAND", tests, strains, curves, fixed, grid=grid_pct)


def parameters(forward: LabForward, params: dict) -> dict:
    """Full SIMSAND parameter dict: the forward model's fixed values updated with ``params`` (a sample's error
    parameters, sigma_eps or sigma_eps_<group>, if present, are left out)."""
    full = {**forward.fixed, **{k: v for k, v in params.items() if not is_error_parameter(k)}}
    missing = set(SIMSAND.parameter_names) - set(full)
    if missing:
        raise ValueError(f"SIMSAND parameters neither free nor fixed: {sorted(missing)}")
    return full


def free_subset(free, bounds: dict) -> list:
    """The parameters to identify: ``free`` (a subset of ``bounds``' names) or all of them."""
    free = list(bounds) if not free else list(free)
    unknown = set(free) - set(bounds)
    if unknown:
        raise ValueError(f"--free: unknown parameters {sorted(unknown)}; choose among {list(bounds)}")
    return free


def add_options(ap, bounds: dict, held: str):
    """The options of a SIMSAND study: ``--free`` (a subset of ``bounds``, the others ``held``) and ``--sweeps``."""
    ap.add_argument("--free", type=lambda s: [x.strip() for x in s.split(",") if x.strip()],
                    help=f"comma-separated subset of {','.join(bounds)} to identify (others {held})")
    ap.add_argument("--sweeps", type=int, help="fixed number of MCMC sweeps per stage (default: adaptive, "
                                              "capped by the preset)")


def run_line(summary: dict) -> str:
    """The run's size, cost and evidence in one line of a report."""
    return (f"N_s = {summary['n_samples']}, stages = {summary['n_stages']}, forward solves = "
            f"{summary['n_forward_solves']} (failed {summary['n_failed_solves']}), wall {summary['wall_s']:.1f} s on "
            f"{summary['ranks']} process(es), ln Z = {summary['log_evidence']:.3f}")


def write_figures(out, observations, forward, post, title, marks, csl_lines, csl_title, end_label,
                  reference=None, predict=(), marginals_title=None, sigmas=None):
    """curves.png (:func:`plot_curves`, ``sigmas`` as :func:`predictive`), marginals.png, pairs.png and stages.png
    (``marks`` {label: values}; :func:`cases.study.outputs.figures.posterior.write_posterior_figures`),
    stress_paths.png (:func:`plot_stress_paths`) and csl.png
    (the CSL of ``csl_lines`` {label: parameter dict}, ``"MAP"`` added, with the end states of the drained
    records)."""
    out = Path(out)
    plot_curves(out / "curves.png", observations, forward, post, title, reference=reference, predict=predict,
                sigmas=sigmas)
    units = {n: r.unit for n, r in model_spec("SIMSAND").ranges.items()}
    write_posterior_figures(out, post, marks, units, marginals_title)
    plot_stress_paths(out / "stress_paths.png", observations, forward, post, title)
    end = {f"{t.name} {end_label}": (conditions_of(t).p0 + t.curves["q"].y[-1] / 3.0, t.curves["e"].y[-1])
           for t in observations if "e" in t.curves}
    plot_csl(out / "csl.png", {"MAP": parameters(forward, post.map), **csl_lines}, end, title=csl_title)


def predictive(forward: LabForward, post, n_draws=200, seed=0, sigmas=None, amplitude=None):
    """Posterior predictive of Eq. (1): U = c U_num(b), c ~ N(1, sigma^2), over ``n_draws`` final-stage samples
    (one batched forward call). ``sigmas``: {curve: error parameter} with error groups (Eq. 6g), e.g.
    {"q": "sigma_eps_stress", "e": "sigma_eps_volume"}; a curve not named takes sigma_eps, or no noise when the
    posterior has no sigma_eps. ``amplitude``: {(test, curve): a_k}, the model-error term of (P1) (docs/reference.md
    section 10) added to the relative variance, c ~ N(1, sigma^2 + a_k^2), for tests without data (predictions). Returns
    ({test: {curve: (q2.5, q50, q97.5) arrays}}, {test: grid}, MAP curves)."""
    rng = np.random.default_rng(seed)
    names = list(post.names)
    idx = rng.choice(len(post.samples), size=min(n_draws, len(post.samples)), replace=False)
    draws = post.samples[idx]

    def sigma_of(curve):
        name = (sigmas or {}).get(curve, "sigma_eps")
        return draws[:, names.index(name)] if name in names else np.zeros(len(draws))

    rows = np.vstack([draws, post.map_theta])
    soil = {n: rows[:, k] for k, n in enumerate(names) if not is_error_parameter(n)}
    raw, failed = forward.simulate(soil)
    values, _ = forward.particle_values(soil)
    table = forward.arrays(raw, values, names=lambda t: ("q", "e", "u", "p"))
    band, at_map, grids = {}, {}, {}
    for t in forward.tests:
        band[t.name], at_map[t.name] = {}, {}
        for k, (strain, v) in table[t.name].items():
            grids[t.name] = strain
            relative = np.sqrt(sigma_of(k) ** 2 + (amplitude or {}).get((t.name, k), 0.0) ** 2)
            sims = v[:-1] * (1.0 + relative[:, None] * rng.standard_normal(v[:-1].shape))
            ok = ~failed[t.name][:-1]
            band[t.name][k] = np.nanquantile(sims[ok], [0.025, 0.5, 0.975], axis=0) if ok.any() else None
            at_map[t.name][k] = v[-1]
    return band, grids, at_map


def volume_change_table(forward: LabForward, post, observations, tests, at_pct=(3.0, 5.0, 10.0), sigmas=None,
                        n_draws=200, seed=0, amplitude=None) -> list:
    """Volumetric strain eps_v (%, compression positive, dilation negative) of drained ``tests`` at the axial
    strains ``at_pct`` (%): measured (the record, linearly interpolated), MAP and the 95 % posterior predictive
    band (:func:`predictive`, noise and the model-error term ``amplitude`` on the void-ratio curve).
    eps_v = 100 (e0 - e) / (1 + e0), a decreasing function of e, so the band of eps_v is the band of e mapped (its
    ends swapped). Rows of dicts: test, e0, p0 (kPa), eps_a (%), measured, map, lo, hi (eps_v, %); None where the
    record or the simulation stops short."""
    band, grids, at_map = predictive(forward, post, n_draws=n_draws, seed=seed, sigmas=sigmas, amplitude=amplitude)
    specs = {t.name: t for t in forward.tests}
    rows = []
    for name in tests:
        spec, rec = specs[name], observations[name].curves["e"]
        e0 = spec.e0

        def eps_v(e):
            return 100.0 * (e0 - e) / (1.0 + e0)

        grid = grids[name]
        for x in at_pct:
            inside = grid[0] <= x <= grid[-1]
            measured = float(eps_v(np.interp(x, rec.x, rec.y))) if rec.x[0] <= x <= rec.x[-1] else None
            lo_hi = band[name]["e"]
            rows.append(dict(test=name, e0=e0, p0=spec.p0, eps_a=x, measured=measured,
                             map=float(eps_v(np.interp(x, grid, at_map[name]["e"]))) if inside else None,
                             lo=float(eps_v(np.interp(x, grid, lo_hi[2]))) if inside and lo_hi is not None else None,
                             hi=float(eps_v(np.interp(x, grid, lo_hi[0]))) if inside and lo_hi is not None else None))
    return rows


def plot_curves(path, observations, forward, post, title, reference=None, predict=(), seed=0, sigmas=None):
    """Data vs MAP curves with the 95 % posterior predictive band, one row per test (the paper's Figs. 2-4, 13), on a
    sheet (:mod:`cases.study.outputs.figures.sheet`). ``reference``: optional {test: {curve: (x, y)}} drawn dashed
    (true-value curves); ``predict``: names of tests not used in the calibration (titled "prediction");
    ``sigmas``: as :func:`predictive`."""
    band, grids, at_map = predictive(forward, post, seed=seed, sigmas=sigmas)
    tests = list(forward.tests)
    ncol = max(len(CURVES[t.drainage == "drained"]) for t in tests)
    sheet, frames = panel_sheet(len(tests) * ncol, (4.6, 3.0), ncol, legend=4)
    ax = sheet.ax
    for row, t in enumerate(tests):
        obs = observations[t.name] if t.name in observations.tests else None
        for col, k in enumerate(CURVES[t.drainage == "drained"]):
            x = grids[t.name]
            shown = [(x, at_map[t.name][k])]
            if band[t.name][k] is not None:
                shown += [(x, band[t.name][k][0]), (x, band[t.name][k][2])]
            if reference and t.name in reference:
                shown.append(reference[t.name][k])
            if obs is not None and k in obs.curves:
                shown.append((obs.curves[k].x, obs.curves[k].y))
            cell = sheet.cell(*frames[row * ncol + col], padded(np.concatenate([v for v, _ in shown])),
                              padded(np.concatenate([v for _, v in shown])))
            if band[t.name][k] is not None:
                ax.fill_between(cell.x(x), cell.y(band[t.name][k][0]), cell.y(band[t.name][k][2]), color="C0",
                                alpha=0.25, lw=0, label=sheet.once("95 % posterior predictive"))
            ax.plot(cell.x(x), cell.y(at_map[t.name][k]), "C0-", lw=1.5, label=sheet.once("MAP"))
            if reference and t.name in reference:
                rx, ry = reference[t.name][k]
                ax.plot(cell.x(rx), cell.y(ry), "k--", lw=1, label=sheet.once("true values"))
            if obs is not None and k in obs.curves:
                ax.plot(cell.x(obs.curves[k].x), cell.y(obs.curves[k].y), ".", color="C3", ms=3,
                        label=sheet.once("data"))
            role = "prediction" if t.name in predict else "calibration"
            cell.title(f"{t.name} ({role}): e0 {t.e0:g}, p'0 {t.p0:g} kPa")
            cell.x_axis(abscissa_label("axial_strain"), edge=0.0)
            cell.y_axis(quantity_label(k), edge=0.0)
    sheet.legend_row()
    save(sheet.finish(), path, title, 110)


def plot_stress_paths(path, observations, forward, post, title):
    """stress_paths.png: the q-p' paths of the tests (:func:`cases.study.outputs.figures.curves.stress_paths_figure`),
    the MAP on the simulation grid, the records' p' from their q (and u) on the test's total stress path; nothing
    when the MAP's solve fails."""
    result = forward([{k: v for k, v in post.map.items() if not is_error_parameter(k)}])[0]
    if isinstance(result, Exception):
        return
    dense = {(t, k): v for t, curves in result.items() for k, v in curves.items()}
    at_records = {t.name: {k: np.interp(t.curves["q"].x, *v) for k, v in result[t.name].items()} for t in observations}
    drained = {(t.name, None): conditions_of(t).drainage == "drained" for t in observations}
    save(stress_paths_figure(observations, at_records, drained, dense), path, title)


def critical_void_ratio(params, p):
    """(VI) e_c(p') for a full SIMSAND parameter dict (through the model, not a copy of the formula)."""
    return SIMSAND(**params).critical_void_ratio(p)


def plot_csl(path, lines: dict, end_states=None, title=""):
    """CSL in e-log p' (Fig. 6/14 style): ``lines`` {label: full SIMSAND parameter dict}; ``end_states``
    {label: (p', e)} of the data at the end of each test."""
    plt = pyplot()
    p = np.geomspace(5.0, 5000.0, 200)
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    for k, (label, prm) in enumerate(lines.items()):
        ax.semilogx(p, critical_void_ratio(prm, p), ["C3-", "k--", "C0:", "C2-."][k % 4], label=label)
    for label, (pe, ee) in (end_states or {}).items():
        ax.semilogx(pe, ee, "o", mfc="none", label=label)
    ax.set_xlabel("p' (kPa)")
    ax.set_ylabel("critical void ratio e_c")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_map_spread(path, summaries, names, reference: dict, title):
    """MAP of each run divided by the reference value, per parameter and method (the paper's Fig. 5 style)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(1.0 + 0.8 * len(names), 3.6))
    methods = sorted({s["method"] for s in summaries})
    for k, m in enumerate(methods):
        runs = [s for s in summaries if s["method"] == m]
        for j, n in enumerate(names):
            maps = np.array([s["parameters"][n]["map"] for s in runs])
            shift = 0.25 * (k - (len(methods) - 1) / 2)
            ax.plot(np.full(maps.size, j + shift) + np.linspace(-0.08, 0.08, maps.size), maps / reference[n],
                    "os"[k % 2], color=f"C{k}", mfc="none", label=m if j == 0 else None)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(range(len(names)))
    ax.set_xticklabels(names, rotation=45)
    ax.set_ylabel("MAP / reference value")
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sampler_settings(args, preset, max_failure_fraction):
    """tmcmc settings of a SIMSAND study: the preset's sweep cap, ``--sweeps`` (fixed count) or adaptive, and the
    study's failure allowance."""
    return dict(max_steps=preset["max_steps"], n_steps=args.sweeps or "adaptive", min_steps=min(2, args.sweeps or 2),
                max_failure_fraction=max_failure_fraction)


def write_runs(top, title, summaries, names, references, spread_reference, note=""):
    """With several runs: runs.md (average MAP and spread per method beside the references) and map_spread.png."""
    if len(summaries) < 2:
        return
    top = Path(top)
    text = f"# {title}\n\n" + (f"**{note}**\n\n" if note else "")
    (top / "runs.md").write_text(text + runs_table(summaries, names, references) + "\n")
    shown = [n for n in names if n in spread_reference]
    plot_map_spread(top / "map_spread.png", summaries, shown, spread_reference,
                    f"MAP of {len(summaries)} runs / reference: {title}")
