"""Toyoura sand: SIMSAND identified from Verdugo & Ishihara's (1996) drained triaxial tests (the paper's section 3.2,
docs/reference.md section 5). The curves are measurements (digitised, CC-BY-4.0; cases/data/toyoura/SOURCE.md).

    python -m cases.toyoura [--quick] [--method de|o|both] [--samples N] [--seed S] [--runs R] [--out DIR] [--resume]
                            [--undrained FILE[:E0:P0_KPA] ...] [--free NAMES] [--sweeps K] [--error-groups [FILE]]

The paper calibrated on drained test 2 (e0 0.916, p'0 100 kPa) and undrained tests 7 (e0 0.735, 100 kPa) and 12
(e0 0.833, 1 MPa), and predicted the rest. The undrained curves are not available, so by default this study
SUBSTITUTES drained test 6 (e0 0.810, p'0 500 kPa) for tests 7 and 12: it is the densest state at the highest
available pressure, the closest to test 12 (e0 0.833 at 1 MPa), and with test 2 it spans both pressures (for n and
the CSL's lambda, xi) and a loose-contractive and a dense-dilative state (for n_p, n_d, A_d). Tests 1, 3, 4, 5 are
predicted. Every output says so.

Undrained recordings supplied by a user (``--undrained FILE``, CSV with columns eps_a_pct, q_kPa, u_kPa and header
lines ``# e0:`` and ``# p0_kPa:``, or ``FILE:E0:P0_KPA`` on the command line) are calibrated as the paper did: curves
q(eps_a) and excess pore pressure u(eps_a) of an undrained test from isotropic p'0 (constant total radial stress,
isochoric). The calibration set is then test 2 plus the undrained tests (the paper's set) and drained tests 1 and
3-6 are predicted.

Free parameters and bounds as the paper (nu = 0.2 fixed): K_0 [50, 300], n [0.1, 0.9], e_ref [0.5, 1.5],
lambda [0.001, 0.1], xi [0.1, 1.0], phi_mu [20, 50], k_p [0.001, 0.1], A_d [0.1, 2], n_p [0, 10], n_d [0, 10],
sigma_eps (0, 1). n_p = 0 or n_d = 0 is valid in (VII) (phi_p = phi_pt = phi_mu) and SIMSAND accepts it, so the
lower bounds are kept at 0 (no clipping). ``--free`` identifies a subset, the others held at the paper's
optimisation reference values.

Error model: one sigma_eps for every curve (the paper's Eq. 4), or with ``--error-groups`` one error parameter per
group of curves (Eq. 6g, docs/reference.md section 1) read from the ``[sigma_eps]`` table of FILE by the study
library's reader (cases.study.reading.error_model; default cases/examples/toyoura_groups.toml: sigma_eps_stress for q (and u
of undrained recordings), sigma_eps_volume for the void ratio e). A dense sand's void ratio changes by about 0.01 on
e of about 0.7: its relative errors are far below those of q, and with one sigma the volume change is effectively
unconstrained.

Forward model (cases.study.sand): all calibration tests of a batch in one batched SIMSAND call, simulated at
0.1 % steps to 1 % and 0.25 % steps beyond, interpolated linearly to the recorded strains (0.1 % spacing).
About 5 % of the prior box fails (drained path lost control): zero-likelihood particles, MAX_FAILURE_FRACTION 0.5
(cases.study.sand).

Outputs in DIR (cases.study contract): summary.json (with J_g of every test at MAP, calibration and prediction),
report.md (MAP/mean/std beside the paper's Table 3), curves.png (Fig. 13 style: data, MAP and 95 % posterior
predictive of all tests, calibration and prediction), marginals.png, stages.png, csl.png; ``--runs R``: runs.md and
map_spread.png (MAP / paper's DE-TMCMC mean). report.md and stdout also give the volumetric strain of the predicted
drained tests at 3, 5 and 10 % axial strain (measured, MAP, 95 % posterior predictive; :func:`volume_lines`).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import inference
from cases.study.cli import arguments
from cases.study.outputs.report import parameter_table
from cases.study.runner import is_root, method_name, run_all, write_summary
from cases.study.reading.checks import Checker, read_toml
from cases.study.cli import UsageError, command, unit_hint
from cases.study.reading.error_model import ErrorModel, read_error_model
from cases.study.sand import CURVES, MAX_FAILURE_FRACTION, add_options, free_subset, parameters, run_line, \
    sampler_settings, sand_forward, volume_change_table, write_figures, write_runs
from inference.observations import read_csv_table
from inference.priors import Bound

CASE = "toyoura"
DATA = Path(__file__).parent / "data" / "toyoura"
DEFAULT_OUT = Path("results") / CASE
#: the error groups of ``--error-groups`` without a FILE
ERROR_GROUPS = Path(__file__).parent / "examples" / "toyoura_groups.toml"
#: axial strains (%) at which the predicted tests' volumetric strain is reported
VOLUME_AT_PCT = (3.0, 5.0, 10.0)

#: paper test number -> data file (SOURCE.md)
FILES = {"test1": "wang34_Tokyo_TMD6.csv", "test2": "wang34_Tokyo_TMD5.csv", "test3": "wang34_Tokyo_TMD4.csv",
         "test4": "wang34_Tokyo_TMD3.csv", "test5": "wang34_Tokyo_TMD2.csv", "test6": "wang34_Tokyo_TMD1.csv"}
CALIBRATION = ("test2", "test6")          # test6 substitutes for the unavailable undrained tests 7 and 12
FIXED = {"nu": 0.2}
BOUNDS = dict(K_0=(50.0, 300.0), n=(0.1, 0.9), e_ref=(0.5, 1.5), lambda_c=(0.001, 0.1), xi=(0.1, 1.0),
              phi_mu=(20.0, 50.0), k_p=(0.001, 0.1), A_d=(0.1, 2.0), n_p=(0.0, 10.0), n_d=(0.0, 10.0))
SIGMA_BOUNDS = (0.0, 1.0)
#: the paper's Table 3
PAPER_REFERENCE = dict(K_0=130.0, n=0.5, e_ref=0.920, lambda_c=0.0131, xi=0.78, phi_mu=32.40, k_p=0.0030, A_d=0.50,
                       n_p=1.60, n_d=4.10)
PAPER_DE_MEAN = dict(K_0=144.6, n=0.463, e_ref=0.904, lambda_c=0.0097, xi=0.933, phi_mu=32.18, k_p=0.0043, A_d=0.42,
                     n_p=3.157, n_d=4.24, sigma_eps=0.057)
PAPER_DE_STD = dict(K_0=6.96, n=0.018, e_ref=0.002, lambda_c=6.6e-4, xi=0.019, phi_mu=0.26, k_p=4.4e-4, A_d=0.023,
                    n_p=0.52, n_d=0.43, sigma_eps=0.0055)
PAPER_O_MEAN = dict(K_0=172.6, n=0.449, e_ref=0.928, lambda_c=0.0212, xi=0.81, phi_mu=30.74, k_p=0.0010, A_d=0.68,
                    n_p=5.35, n_d=5.00, sigma_eps=0.28)
GRID_PCT = np.concatenate([np.arange(1, 11) * 0.1, 1.0 + np.arange(1, 125) * 0.25])   # to 32 %
PRESETS = {"full": dict(n_samples=2000, max_steps=25), "quick": dict(n_samples=300, max_steps=6)}
SUBSTITUTION_NOTE = ("The paper calibrated on drained test 2 and UNDRAINED tests 7 and 12, whose curves are not "
                     "available; this run calibrates on drained tests 2 and 6 instead (test 6 substitutes for 7 and "
                     "12) and predicts drained tests 1, 3, 4, 5.")


def load_drained(name: str) -> inference.Test:
    """One shipped drained test (paper numbering) as q(eps_a) and e(eps_a), derived as SOURCE.md states."""
    path = DATA / FILES[name]
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
    conditions = {"e0": cond["e0"], "p0_kPa": cond["sigma3_kPa"], "drained": "true", "file": FILES[name]}
    return inference.Test(name, curves, conditions, str(path))


def parse_undrained(spec: str):
    """``FILE`` or ``FILE:E0:P0_KPA`` -> (path, conditions given on the command line)."""
    parts = spec.split(":")
    if len(parts) not in (1, 3):
        raise UsageError(f"--undrained {spec!r}: use FILE or FILE:E0:P0_KPA")
    extra = {} if len(parts) == 1 else {"e0": parts[1], "p0_kPa": parts[2]}
    for (key, value), (what, unit) in zip(extra.items(), (("initial void ratio E0", "-"), ("p'0 P0_KPA", "kPa"))):
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


def build(undrained=(), free=None, error_model: ErrorModel | None = None):
    """(calibration observations, all observations, calibration forward, all-tests forward, likelihood, prior).
    ``error_model``: error groups (Eq. 6g) and their bounds; None: one sigma_eps in SIGMA_BOUNDS (the paper's)."""
    free = free_subset(free, BOUNDS)
    drained = {n: load_drained(n) for n in FILES}
    user = load_undrained(undrained)
    calibration = [drained["test2"]] + user if user else [drained[n] for n in CALIBRATION]
    cal_obs = inference.Observations(calibration)
    all_obs = inference.Observations(calibration + [t for n, t in drained.items() if n not in cal_obs.tests])
    fixed = {**FIXED, **{k: v for k, v in PAPER_REFERENCE.items() if k not in free}}
    grid = _grid(all_obs)
    forward = sand_forward(cal_obs, fixed, grid)
    forward_all = sand_forward(all_obs, fixed, grid)
    like = likelihood(cal_obs, forward, error_model)
    if error_model is None:
        prior = inference.UniformPrior({**{k: BOUNDS[k] for k in free}, "sigma_eps": SIGMA_BOUNDS})
    else:
        prior = inference.Prior([Bound(k, *BOUNDS[k]) for k in free] + [
            Bound(k, *map(float, b), error_model.kind) for k, b in error_model.parameter_bounds().items()])
    return cal_obs, all_obs, forward, forward_all, like, prior


def likelihood(observations, forward, error_model: ErrorModel | None = None) -> inference.Likelihood:
    """Eqs. (4)-(6) of ``observations`` (batched forward model): one sigma_eps, or the groups of ``error_model``."""
    groups = None if error_model is None else error_model.curve_groups(observations)
    return inference.Likelihood(observations, forward, batch=True, sigma="sigma_eps", groups=groups)


def curve_sigmas(like: inference.Likelihood) -> dict:
    """{curve: its error parameter} with error groups (for the posterior predictive), {} with one sigma_eps."""
    if len(like.groups) == 1:
        return {}
    name = dict(zip(like.groups, like.sigma_names))
    return {curve: name[g] for (_, curve), g in like.group_of.items()}


def volume_lines(rows) -> list:
    """Markdown table of :func:`cases.study.sand.volume_change_table` rows: eps_v (%) measured, MAP, 95 % band."""
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


def _grid(obs):
    """GRID_PCT, extended at 0.25 % steps when a (user) record goes further."""
    top = max(c.x.max() for t in obs for c in t.curves.values())
    extra = GRID_PCT[-1] + 0.25 * np.arange(1, int(np.ceil(max(0.0, top - GRID_PCT[-1]) / 0.25)) + 1)
    return np.concatenate([GRID_PCT, extra])


def _options(ap):
    ap.add_argument("--undrained", nargs="+", default=[], metavar="FILE[:E0:P0_KPA]",
                    help="undrained recordings (eps_a_pct, q_kPa, u_kPa) to calibrate on as the paper did")
    ap.add_argument("--error-groups", nargs="?", const=ERROR_GROUPS, type=Path, metavar="FILE",
                    help="one error parameter per group of curves (Eq. 6g) from FILE's [sigma_eps] table "
                         f"(default {ERROR_GROUPS.relative_to(Path(__file__).parents[1])})")
    add_options(ap, BOUNDS, "at the paper's reference values")


REFERENCES = {"paper reference (optimisation)": PAPER_REFERENCE, "paper DE-TMCMC mean MAP": PAPER_DE_MEAN,
              "paper DE-TMCMC std": PAPER_DE_STD, "paper O-TMCMC": PAPER_O_MEAN}


def jg_all(like_all, post) -> dict:
    """J_g (Eq. 5) of every test, calibration and prediction, at the MAP (one forward solve)."""
    like_all.bind(post.names)
    try:
        return {t: float(v) for t, v in like_all.summary_goodness(post.map_theta).items()}
    except Exception as exc:  # noqa: BLE001 - a diagnostic, reported rather than fatal
        return {"error": f"{type(exc).__name__}: {exc}"}


def report_run(out, args, post, cal_obs, all_obs, forward_all, summary, like, volume_rows):
    method = method_name(args.method)
    note = "" if args.undrained else SUBSTITUTION_NOTE
    predicted = [t.name for t in all_obs if t.name not in cal_obs.tests]
    sigmas = curve_sigmas(like)
    write_figures(out, all_obs, forward_all, post, f"Toyoura sand (Verdugo & Ishihara 1996, measured): {method}, "
                  f"calibrated on {', '.join(cal_obs.tests)}; predicted {', '.join(predicted)}",
                  {"paper ref.": PAPER_REFERENCE, "paper DE mean": PAPER_DE_MEAN},
                  {"paper reference": {**FIXED, **PAPER_REFERENCE}, "paper DE-TMCMC mean": parameters(
                      forward_all, PAPER_DE_MEAN)}, "Toyoura sand: CSL (VI) of the MAP vs the paper's values",
                  "end (data)", predict=predicted, sigmas=sigmas)
    jg = summary["J_g_all_tests"]
    errors = ("one sigma_eps for every curve (Eq. 4)" if not sigmas else "error groups (Eq. 6g): " + "; ".join(
        f"{n}: {', '.join(sorted({c for c, m in sigmas.items() if m == n}))}" for n in like.sigma_names))
    text = [f"# {CASE}: {method}, seed {summary['seed']} (measured data: Verdugo & Ishihara 1996, CC-BY-4.0)", ""]
    if note:
        text += [f"**{note}**", ""]
    text += [run_line(summary), "", f"Error model: {errors}.", "",
             "J_g (Eq. 5) at MAP: " + ", ".join(
                 f"{k} {v:.3g} ({'calibration' if k in cal_obs.tests else 'prediction'})"
                 for k, v in jg.items() if isinstance(v, float)), "",
             parameter_table(post, REFERENCES), "",
             "Volumetric strain of the predicted drained tests (%, compression positive, dilation negative; "
             "eps_v = 100 (e0 - e)/(1 + e0); measured: the record interpolated; 95 % posterior predictive of Eq. 1 "
             "on e):", "", *volume_lines(volume_rows), "",
             "Figures: curves.png (Fig. 13 style), marginals.png, stages.png, csl.png."]
    (Path(out) / "report.md").write_text("\n".join(text) + "\n")


@command
def main(argv=None):
    args = arguments(__doc__, argv, quick_help="N_s 300, at most 6 sweeps per stage", add=_options)
    error_model = read_error_groups(args.error_groups) if args.error_groups else None
    cal_obs, all_obs, forward, forward_all, like, prior = build(args.undrained, args.free, error_model)
    like_all = likelihood(all_obs, forward_all, error_model)
    predicted = [t for t in all_obs.tests if t not in cal_obs.tests and "e" in all_obs[t].curves]
    preset = PRESETS["quick" if args.quick else "full"]
    n_samples = args.samples or preset["n_samples"]
    settings = sampler_settings(args, preset, MAX_FAILURE_FRACTION)

    def finish(run_args, seed, out, post):
        volume_rows = volume_change_table(forward_all, post, all_obs, predicted, VOLUME_AT_PCT,
                                          sigmas=curve_sigmas(like))
        if is_root():
            print("\n".join([f"volumetric strain of the predicted tests, seed {seed}:", *volume_lines(volume_rows)]))
        summary = write_summary(out, CASE, run_args, seed, post, like, extra={
            "synthetic": False, "calibration_tests": list(cal_obs.tests),
            "predicted_tests": [t for t in all_obs.tests if t not in cal_obs.tests],
            "substitution": "" if args.undrained else SUBSTITUTION_NOTE, "undrained_files": list(args.undrained),
            "fixed": forward.fixed, "J_g_all_tests": jg_all(like_all, post),
            "max_failure_fraction": MAX_FAILURE_FRACTION, "error_groups": str(args.error_groups or ""),
            "volume_change": volume_rows})
        report_run(out, run_args, post, cal_obs, all_obs, forward_all, summary, like, volume_rows)
        return summary

    summaries = run_all(args, DEFAULT_OUT, like, prior, n_samples, settings, finish)
    if is_root():
        write_runs(args.out or DEFAULT_OUT, f"{CASE} (measured data, Verdugo & Ishihara 1996)", summaries,
                   list(prior.names), REFERENCES, PAPER_DE_MEAN, note="" if args.undrained else SUBSTITUTION_NOTE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
