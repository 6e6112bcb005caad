"""The sand route of the one runner (``[runner] route = "sand"``): a study file of SIMSAND triaxial tests from
isotropic states calibrated on a strain grid (:mod:`cases.study.routes.sand_study`), with predicted tests, the CSL
figure, the volumetric strain of the predicted drained tests and, for a synthetic study, its record generator. The
paper's sections 3.1 (cases/studies/simsand_synthetic.toml) and 3.2 (cases/studies/toyoura.toml) are such studies.

Records (``[runner] records``): "plain" CSVs (columns eps_a_pct, q_kPa, e; header lines e0, p0_kPa, drained) or
"stress_ratio" CSVs (columns eps_a (%), sr = sigma'_a/sigma'_r, eps_v (%, compression positive); header lines e0 and
sigma3_kPa), from which q = (sr - 1) sigma'_3 (kPa) and e = e0 - (1 + e0) eps_v / 100. The header's e0 and p'0
must equal the study file's ``e0`` and ``p0`` of the test. Undrained recordings given with ``--undrained FILE`` or
``FILE:E0:P0_KPA`` (columns eps_a_pct, q_kPa, u_kPa) replace the ``[runner] substitutes`` tests in the calibration.

Every output names the calibration and the predicted tests; the parameter table and the figures show the study's
``[reference]`` columns; the generating values of a synthetic study (``[runner] truth``) are also drawn as curves.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import inference
from cases.study.checks import Checker, read_toml
from cases.study.cli import UsageError, unit_hint
from cases.study.forward.lab import LabForward
from cases.study.outputs.calibration_warnings import calibration_warnings, warnings_section
from cases.study.outputs.glossary import glossary_lines
from cases.study.outputs.report import parameter_table
from cases.study.programme import TestSpec, condition_features
from cases.study.reading.error_model import ErrorModel, read_error_model
from cases.study.reading.records import write_records
from cases.study.routes.held_out import predict_held_out
from cases.study.routes.sand_study import (
    CURVES,
    conditions_of,
    free_subset,
    parameters,
    run_line,
    sampler_settings,
    sand_forward,
    volume_change_table,
    write_figures,
    write_runs,
)
from cases.study.runner import is_root, method_name, run_all, write_summary
from inference.observations import read_csv_table
from inference.priors import Bound

__all__ = ["SandStudy", "build", "QUANTITY_GROUPS", "default_error_model", "load_stress_ratio",
           "load_undrained", "read_error_groups", "curve_sigmas", "record_files", "generate_records", "volume_lines",
           "run"]


@dataclass
class SandStudy:
    """A sand study ready to sample: calibration and all observations, their forward models (SIMSAND on the strain
    grid), likelihoods and the prior; ``undrained`` the user recordings given."""

    study: object
    cal_obs: inference.Observations
    all_obs: inference.Observations
    forward: LabForward
    forward_all: LabForward
    like: inference.Likelihood
    like_all: inference.Likelihood
    prior: inference.Prior
    undrained: tuple = ()
    grid: object = None

    @property
    def predicted(self) -> list:
        return [t for t in self.all_obs.tests if t not in self.cal_obs.tests]

    @property
    def note(self) -> str:
        """The study's note, said while no undrained recording replaces its substitutes."""
        return "" if self.undrained else self.study.runner["note"]


def load_stress_ratio(name: str, path) -> inference.Test:
    """A drained test recorded as stress ratio and volumetric strain (module docstring) as q(eps_a), e(eps_a)."""
    path = Path(path)
    meta, table = read_csv_table(path)
    for col, unit in (("eps_a", "pct"), ("sr", "-"), ("eps_v", "pct")):
        if col not in table:
            raise inference.DataError(f"{path}: missing column {col!r} (found {list(table)})")
        if table[col][0] != unit:
            raise inference.DataError(f"{path}: column {col!r} is in unit {table[col][0]!r}, expected {unit!r}")
    cond = {}
    for key in ("e0", "sigma3_kPa"):
        try:
            cond[key] = float(meta[key])
        except (KeyError, ValueError):
            raise inference.DataError(f"{path}: header field {key!r} missing or not a number "
                                      f"({meta.get(key)!r})") from None
    eps_a, sr, eps_v = table["eps_a"][1], table["sr"][1], table["eps_v"][1]
    curves = {"q": inference.Curve(eps_a, (sr - 1.0) * cond["sigma3_kPa"], "eps_a", "q", "pct", "kPa"),
              "e": inference.Curve(eps_a, cond["e0"] - (1.0 + cond["e0"]) * eps_v / 100.0, "eps_a", "e", "pct", "-")}
    conditions = {"e0": cond["e0"], "p0_kPa": cond["sigma3_kPa"], "drained": "true", "file": path.name}
    return inference.Test(name, curves, conditions, str(path))


def parse_undrained(spec: str):
    """``FILE`` or ``FILE:E0:P0_KPA`` -> (path, conditions given on the command line)."""
    parts = spec.split(":")
    if len(parts) not in (1, 3):
        raise UsageError(f"--undrained {spec!r}: use FILE or FILE:E0:P0_KPA")
    extra = {} if len(parts) == 1 else {"e0": parts[1], "p0_kPa": parts[2]}
    for value, (what, unit) in zip(extra.values(), (("initial void ratio E0", "-"), ("p'0 P0_KPA", "kPa"))):
        try:
            float(value)
        except ValueError:
            raise UsageError(f"--undrained {spec}: {unit_hint(value, what, unit)}") from None
    return Path(parts[0]), extra


def load_undrained(specs) -> list:
    """A user's undrained recordings: columns eps_a_pct, q_kPa, u_kPa; e0 and p0_kPa from the header or the option."""
    tests = []
    for k, spec in enumerate(specs):
        path, extra = parse_undrained(spec)
        name = f"undrained{k + 1}_{path.stem}"
        obs = inference.Observations.from_csv({name: path}, x="eps_a", curves=CURVES[False],
                                              units={"eps_a": "pct", "q": "kPa", "u": "kPa"},
                                              conditions={name: {**extra, "drained": "false"}})
        tests.append(obs[name])
    return tests


def read_error_groups(path) -> ErrorModel:
    """The ``[sigma_eps]`` table of a TOML file (cases.study.reading.error_model; the file may also hold ``name`` and
    ``description``); StudyError naming the file, table.field and value."""
    doc = read_toml(path)
    ck = Checker(path)
    ck.table(doc, "(top level)", ("name", "description", "sigma_eps"), ("sigma_eps",))
    return read_error_model(ck, doc["sigma_eps"])


def record_files(study, noise=None) -> dict:
    """{test: record path} of the study; ``noise``: a synthetic study's noise level, whose records lie in the folder
    noise<level> beside the study file's (``[runner] noise_levels``)."""
    files = {t.name: Path(t.file).resolve() for t in study.tests}
    levels = study.runner["noise_levels"]
    if noise is None or levels is None:
        if noise is not None:
            raise UsageError(f"--noise {noise:g}: the study {study.name} has no [runner] noise_levels")
        return files
    if noise not in levels:
        raise UsageError(f"--noise {noise:g}: expected one of {', '.join(f'{v:g}' for v in levels)}")
    return {n: p.parent.with_name(f"noise{noise:g}") / p.name for n, p in files.items()}


def _load(study, files) -> dict:
    """{test: inference.Test} of the study's records, their e0 and p'0 checked against the study file."""
    if study.runner["records"] == "stress_ratio":
        tests = {n: load_stress_ratio(n, p) for n, p in files.items()}
    else:
        missing = [str(p) for p in files.values() if not p.is_file()]
        if missing:
            raise inference.DataError(f"record files missing: {missing}; write them with --generate")
        obs = inference.Observations.from_csv(files, x="eps_a", curves=CURVES[True],
                                              units={"eps_a": "pct", "q": "kPa"})
        tests = {n: obs[n] for n in files}
    for spec in study.tests:
        recorded = conditions_of(tests[spec.name])
        if (recorded.e0, recorded.p0) != (spec.e0, spec.p0):
            raise inference.DataError(f"{files[spec.name]}: e0 {recorded.e0:g}, p0 {recorded.p0:g} kPa in the record, "
                                      f"but {study.path} gives e0 {spec.e0:g}, p0 {spec.p0:g} kPa for {spec.name}")
    return tests


def _grid(segments, observations):
    """The simulation's axial strains (%) of ``[runner] grid_pct``, extended at the last step when a record goes
    further; None (the recorded strains) without segments."""
    if not segments:
        return None
    parts, start = [], 0.0
    for step, to in segments:
        parts.append(start + np.arange(1, int(round((to - start) / step)) + 1) * step)
        start = to
    grid = np.concatenate(parts)
    step = segments[-1][0]
    top = max(c.x.max() for t in observations for c in t.curves.values())
    extra = grid[-1] + step * np.arange(1, int(np.ceil(max(0.0, top - grid[-1]) / step)) + 1)
    return np.concatenate([grid, extra])


#: the default error groups of a sand study (Eq. 6g): one error parameter for the stresses (q, and the excess pore
#: pressure u of undrained recordings), one for the void ratio e, whose relative scatter is far smaller
QUANTITY_GROUPS = {"stress": ("q", "u"), "volume": ("e",)}


def default_error_model(study) -> ErrorModel:
    """The error model of a sand study without ``--single-sigma`` or ``--error-groups``: the study file's
    ``[sigma_eps]`` groups, or :data:`QUANTITY_GROUPS` with its ``[sigma_eps]`` bounds and prior."""
    if study.error_model is not None and study.error_model.groups:
        return study.error_model
    return ErrorModel(tuple(study.sigma_bounds), study.sigma_kind, dict(QUANTITY_GROUPS), where=str(study.path))


def likelihood(observations, forward, error_model: ErrorModel | None = None) -> inference.Likelihood:
    """Eqs. (4)-(6) of ``observations`` (batched forward model): one sigma_eps, or the groups of ``error_model``."""
    groups = None if error_model is None else error_model.curve_groups(observations)
    return inference.Likelihood(observations, forward, batch=True, sigma="sigma_eps", groups=groups)


def build(study, free=None, undrained=(), error_model: ErrorModel | None = None, noise=None) -> SandStudy:
    """The sand study of ``study`` (a loaded study file): ``free`` a subset of its free parameters (the others held
    at ``[runner] hold_at``), ``undrained`` recordings replacing the substitutes, ``error_model`` error groups
    (Eq. 6g; None: one sigma_eps with the study's bounds), ``noise`` the noise level of a synthetic study's records."""
    if free and not study.runner["hold_at"]:
        raise UsageError(f"--free: the study {study.name} has no [runner] hold_at for the parameters left out")
    free = free_subset(free, study.free)
    tests = _load(study, record_files(study, noise))
    user = load_undrained(undrained)
    runner = study.runner
    calibrated = [t.name for t in study.tests if t.role == "calibrate"]
    if user:
        calibrated = [n for n in calibrated if n not in runner["substitutes"]]
    calibration = [tests[n] for n in calibrated] + user
    cal_obs = inference.Observations(calibration)
    all_obs = (inference.Observations(calibration + [t for n, t in tests.items() if n not in cal_obs.tests])
               if len(calibration) < len(tests) + len(user) else cal_obs)
    hold = study.references[runner["hold_at"]].values if runner["hold_at"] else {}
    fixed = {**study.fixed, **{k: v for k, v in hold.items() if k in study.spec.parameters and k not in free}}
    grid = _grid(runner["grid_pct"], all_obs)
    forward = sand_forward(cal_obs, fixed, grid)
    forward_all = sand_forward(all_obs, fixed, grid) if all_obs is not cal_obs else forward
    like = likelihood(cal_obs, forward, error_model)
    like_all = likelihood(all_obs, forward_all, error_model) if all_obs is not cal_obs else like
    if error_model is None:
        prior = inference.UniformPrior({**{k: study.free[k] for k in free}, "sigma_eps": study.sigma_bounds})
    else:
        prior = inference.Prior([Bound(k, *study.free[k]) for k in free] + [
            Bound(k, *map(float, b), error_model.kind) for k, b in error_model.parameter_bounds().items()])
    return SandStudy(study, cal_obs, all_obs, forward, forward_all, like, like_all, prior, tuple(undrained), grid)


def generate_records(study, noise: float, seed=None, out=None) -> dict:
    """Write a synthetic study's records (one CSV per test) for ``noise`` (std of c in Eq. (1); 0 = noise-free) from
    SIMSAND at the ``[runner] truth`` values on the ``[synthetic]`` strain grid (``points`` strains evenly spaced to
    ``max_strain_pct``), each point multiplied by its own c ~ N(1, noise^2). Returns {test: path}."""
    synthetic, truth = study.synthetic, study.references[study.runner["truth"]].values
    seed = synthetic["seed"] if seed is None else seed
    strain_pct = tuple(np.round(np.arange(1, synthetic["points"] + 1) * (synthetic["max_strain_pct"]
                                                                          / synthetic["points"]), 10))
    files = record_files(study, noise)
    specs = [TestSpec(t.name, "triaxial", drainage=t.drainage, direction="compression", consolidation="isotropic",
                      p0=t.p0, e0=t.e0) for t in study.tests]
    (result,) = LabForward("SIMSAND", specs, {t.name: np.array(strain_pct) / 100.0 for t in specs},
                           {t.name: tuple(CURVES[True]) for t in specs}, {}, grid=strain_pct)([truth])
    if isinstance(result, Exception):
        raise RuntimeError(f"the generating values failed to integrate: {result}")
    rng = np.random.default_rng([seed, int(round(noise * 1000))])
    paths = {}
    for t in specs:
        x, _ = result[t.name]["q"]
        rows = x > 0  # the initial point is not a measurement
        values = {k: result[t.name][k][1][rows] for k in CURVES[True]}
        if noise > 0:
            values = {k: v * rng.normal(1.0, noise, v.size) for k, v in values.items()}
        head = ["synthetic: true (generated by SIMSAND at the true values; NOT a measurement)",
                f"generator: {study.path.name} [synthetic] (python -m cases.calibrate STUDY --generate)",
                "true_values: " + json.dumps(truth),
                f"noise: multiplicative U_obs = c U_num, c ~ N(1, {noise:g}^2) independently per point (Eq. 1)"
                if noise > 0 else "noise: none (noise-free)", f"seed: {seed}" if noise > 0 else "seed: none",
                f"test: {t.name}, drained triaxial compression from isotropic p'0", f"e0: {t.e0!r}",
                f"p0_kPa: {t.p0!r}", "drained: true"]
        columns = {"eps_a_pct": x[rows], "q_kPa": values["q"], "e": values["e"]}
        path = files[t.name] if out is None else Path(out) / files[t.name].name
        path.parent.mkdir(parents=True, exist_ok=True)
        paths[t.name] = write_records(path, head, columns, exact=columns)
    return paths


def curve_sigmas(like: inference.Likelihood) -> dict:
    """{curve: its error parameter} with error groups (for the posterior predictive), {} with one sigma_eps."""
    if len(like.groups) == 1:
        return {}
    name = dict(zip(like.groups, like.sigma_names))
    return {curve: name[g] for (_, curve), g in like.group_of.items()}


def volume_lines(rows) -> list:
    """Markdown table of :func:`cases.study.routes.sand_study.volume_change_table` rows: eps_v (%) measured, MAP,
    95 % band."""
    def cell(v):
        return "-" if v is None else f"{v:.2f}"

    lines = ["| test | e0 | p'0 (kPa) | eps_a (%) | eps_v measured (%) | eps_v MAP (%) | 95 % predictive (%) |"
             " measured in band |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        inside = ("-" if None in (r["measured"], r["lo"], r["hi"]) else
                  "yes" if r["lo"] <= r["measured"] <= r["hi"] else "no")
        lines.append(f"| {r['test']} | {r['e0']:g} | {r['p0']:g} | {r['eps_a']:g} | {cell(r['measured'])} | "
                     f"{cell(r['map'])} | [{cell(r['lo'])}, {cell(r['hi'])}] | {inside} |")
    return lines


def _jg_all(like_all, post) -> dict:
    """J_g (Eq. 5) of every test, calibration and prediction, at the MAP (one forward solve)."""
    like_all.bind(post.names)
    try:
        return {t: float(v) for t, v in like_all.summary_goodness(post.map_theta).items()}
    except Exception as exc:  # noqa: BLE001 - a diagnostic, reported rather than fatal
        return {"error": f"{type(exc).__name__}: {exc}"}


def _references(s: SandStudy, truth, figures_only=False) -> dict:
    """{source: values} of the study's [reference] columns (the generating ones with ``truth``, its sigma_eps)."""
    key = s.study.runner.get("truth")
    return {r.source: truth if r.key == key and truth else r.values for r in s.study.references.values()
            if r.figures or not figures_only}


def _label(s: SandStudy, noise) -> str:
    if noise is None:
        return s.study.description
    return f"{s.study.description} ({'noise-free' if not noise else f'noise c ~ N(1, {noise:g}^2)'})"


def _warnings(s: SandStudy, post) -> list:
    """The calibration's warnings (``calibration_warnings``: prior bounds, sigma_eps at its ceiling, failed solves,
    poor fits, one sigma_eps for quantities of unequal scatter) from the MAP's curves (one forward solve)."""
    try:
        simulated = {key: values[0] for key, values in s.like.simulated_many(post.map_theta).items()}
    except Exception as exc:  # noqa: BLE001 - a diagnostic, reported rather than fatal
        return [f"the MAP's curves could not be computed for the warnings: {type(exc).__name__}: {exc}"]
    return calibration_warnings(post, s.like, simulated)


def _report(out, run, seed, post, s: SandStudy, summary, volume_rows, truth, noise, reference_curves, predictions):
    """report.md and the figures of one run; ``reference_curves`` the forward model at the generating values,
    ``predictions`` the lines of the Predictions section (predictions.png already drawn when there are any)."""
    method, study = method_name(run.method), s.study
    sigmas = curve_sigmas(s.like)
    predicted = s.predicted
    roles = (f"calibrated on {', '.join(s.cal_obs.tests)}; predicted {', '.join(predicted)}" if predicted
             else f"calibrated on {', '.join(s.cal_obs.tests)}")
    label = _label(s, noise)
    write_figures(out, s.all_obs, s.forward_all, post, f"{study.name}: {label}: {method}, {roles}",
                  _references(s, truth, True),
                  {r: parameters(s.forward_all, v) for r, v in _references(s, truth, True).items()},
                  f"{study.name}: CSL (VI) of the MAP vs the reference values", "end (data)",
                  reference=reference_curves, predict=predicted, sigmas=sigmas,
                  marginals_title=f"{method}, {label}: posterior marginals")
    errors = ("one sigma_eps for every curve (Eq. 4)" if not sigmas else "error groups (Eq. 6g): " + "; ".join(
        f"{n}: {', '.join(sorted({c for c, m in sigmas.items() if m == n}))}" for n in s.like.sigma_names))
    jg = summary.get("J_g_all_tests") or summary.get("J_g_at_map", {})
    text = [f"# {study.name}: {method}, seed {summary['seed']} — {label}", ""]
    if summary["synthetic"]:
        text += ["All curves in this study are SYNTHETIC: generated by SIMSAND at the generating values (the "
                 "`# synthetic:` header lines of the records). They are not measurements.", ""]
    if s.note:
        text += [f"**{s.note}**", ""]
    text += [run_line(summary), "", f"Error model: {errors}.", "",
             "J_g (Eq. 5) at MAP: " + ", ".join(
                 f"{k} {v:.3g} ({'calibration' if k in s.cal_obs.tests else 'prediction'})"
                 for k, v in jg.items() if isinstance(v, float)), "",
             parameter_table(post, _references(s, truth)), ""]
    if volume_rows:
        text += ["Volumetric strain of the predicted drained tests (%, compression positive, dilation negative; "
                 "eps_v = 100 (e0 - e)/(1 + e0); measured: the record interpolated; 95 % posterior predictive of "
                 "(P1) on e, noise and model error):", "", *volume_lines(volume_rows), ""]
    text += [*predictions, *warnings_section(_warnings(s, post)),
             "Figures: curves.png, stress_paths.png, marginals.png, pairs.png, stages.png, csl.png"
             + (", predictions.png." if predictions else "."), "", *glossary_lines()]
    (Path(out) / "report.md").write_text("\n".join(text) + "\n")


def run(study, run_settings, args) -> int:
    """Calibrate the sand study ``study`` with the command line's run settings and sand options (``free``,
    ``sweeps``, ``undrained``, ``error_groups``, ``single_sigma``, ``noise``, ``generate``, ``regenerate``): error
    groups by quantity unless ``single_sigma`` (the paper's one sigma_eps) or ``error_groups`` (a FILE's groups);
    the predicted tests scored with the model-error amplitudes of :func:`cases.study.routes.held_out.leave_one_out`."""
    runner = study.runner
    noise = args.noise
    if noise is None and runner["noise_levels"] is not None:
        noise = study.synthetic.get("noise", 0.0)
    if args.generate or args.regenerate:
        paths = generate_records(study, noise) if is_root() else {}
        if args.generate:
            print(json.dumps({k: str(v) for k, v in paths.items()}))
            return 0
    groups = args.error_groups
    if groups and args.single_sigma:
        raise UsageError("--single-sigma and --error-groups: choose one error model")
    if groups is True:  # --error-groups without FILE
        if runner["error_groups"] is None:
            raise UsageError(f"--error-groups: give FILE (the study {study.name} has no [runner] error_groups)")
        groups = (study.path.parent / runner["error_groups"]).resolve()
    error_model = (read_error_groups(groups) if groups else None if args.single_sigma else
                   default_error_model(study))
    s = build(study, args.free, args.undrained or (), error_model, noise)
    settings = study.settings(run_settings.quick, run_settings.samples)
    sampler = sampler_settings(args, {"max_steps": settings.max_steps}, runner["max_failure_fraction"])
    key = runner.get("truth")
    truth = None
    if key:
        truth = dict(study.references[key].values)
        if noise:
            truth["sigma_eps"] = noise  # noise-free: sigma_eps has no true value
    synthetic = bool(study.synthetic)
    # the curves at the generating values, computed before sampling: the compiled kernel is then loaded once here,
    # before the process pool forks, instead of once in every worker
    soil = {k: v for k, v in (truth or {}).items() if k in study.spec.parameters}
    reference_curves = sand_forward(s.all_obs, {})([soil])[0] if soil else None
    drained_predicted = [t for t in s.predicted if "e" in s.all_obs[t].curves]

    def finish(one, seed, out, post):
        predictions, volume_rows, amplitude, predicted = [], [], {}, {}
        if s.predicted:
            def likelihood_of(tests):
                kept = inference.Observations([s.cal_obs[t] for t in tests])
                return likelihood(kept, sand_forward(kept, s.forward.fixed, s.grid), error_model)

            conditions = {t: condition_features(conditions_of(s.all_obs[t])) for t in s.all_obs.tests}
            predictions, predicted, amplitude = predict_held_out(
                s.like_all, list(s.cal_obs.tests), s.predicted, likelihood_of, s.prior, post, one, out, seed,
                settings.n_samples, sampler, study.name, conditions)
        if runner["volume_at_pct"] and drained_predicted:
            volume_rows = volume_change_table(s.forward_all, post, s.all_obs, drained_predicted,
                                              tuple(runner["volume_at_pct"]), sigmas=curve_sigmas(s.like),
                                              amplitude=amplitude)
            if is_root():
                print("\n".join([f"volumetric strain of the predicted tests, seed {seed}:",
                                 *volume_lines(volume_rows)]))
        extra = {"synthetic": synthetic, "study": str(study.path), "calibration_tests": list(s.cal_obs.tests),
                 "predicted_tests": s.predicted, "substitution": s.note, "undrained_files": list(s.undrained),
                 "fixed": s.forward.fixed, "max_failure_fraction": runner["max_failure_fraction"],
                 "sigma_eps_bounds": list(study.sigma_bounds),
                 "error_model": "single sigma_eps" if error_model is None else
                 {g: list(m) for g, m in error_model.groups.items()}, "error_groups": str(groups or "")}
        if synthetic:
            extra.update(noise=noise, true_values=truth)
        if s.predicted:
            extra["J_g_all_tests"] = _jg_all(s.like_all, post)
            extra["volume_change"] = volume_rows
            extra["predictions"] = predicted
        summary = write_summary(out, study.name, one, seed, post, s.like, extra=extra)
        _report(out, one, seed, post, s, summary, volume_rows, truth, noise if synthetic else None,
                reference_curves, predictions)
        return summary

    default_out = Path("results") / study.name
    summaries = run_all(run_settings, default_out, s.like, s.prior, settings.n_samples, sampler, finish)
    if is_root():
        spread = (truth if runner["spread"] == key and truth else
                  study.references[runner["spread"]].values if runner["spread"] else {})
        write_runs(run_settings.out or default_out, f"{study.name}: {_label(s, noise if synthetic else None)}",
                   summaries, list(s.prior.names), _references(s, truth), spread, note=s.note)
    return 0
