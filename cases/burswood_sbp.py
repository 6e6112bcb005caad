"""Burswood clay, self-boring pressuremeter: ANICREEP parameters from two expansion rates (REFERENCE.md section 5).

    python -m cases.burswood_sbp --quick            # the README's main job (DE-TMCMC, local process pool)
    mpirun -n 8 python -m cases.burswood_sbp        # the paper's setting, N_s = 2000, whole FE solves per rank
    python -m cases.burswood_sbp --recordings fast=my_fast.csv slow=my_slow.csv   # your own SBP records

Two SBP expansions at 5.25 m depth (Lee & Fahey), 0.167 %/s and 0.0185 %/s to 10 % cavity strain, in situ
sigma'_v0 = 31 kPa, K0 = 0.9, u0 = 38.8 kPa, k = 3.3e-9 m/s; ANICREEP with nu = 0.3, lambda = 0.40, kappa = 0.026,
e0 = 2.0 fixed (REFERENCE: the printed Table 5 is garbled; these are the documented defaults, ``--fixed`` overrides)
and M, sigma'_p0 (kPa), C_alpha_e and the error sigma_eps identified (Table 4 bounds). One particle's forward model
is both coupled FE solves (fem.pressuremeter, CAX4RP-like elements, cavity wall displacement control, partial
drainage); each solve runs whole on one process or MPI rank.

Recordings. The measured Burswood curves are not public. The shipped recordings (cases/data/burswood_sbp/) are
SYNTHETIC: our FE at the paper's DE-TMCMC MAP (M 1.71, sigma'_p0 58.4 kPa, C_alpha_e 0.020) with the paper preset's
mesh and increments, times independent multiplicative noise c ~ N(1, 0.02^2) per point (Eq. 1), made by
:func:`generate_recordings` (``--generate``). Real recordings load from CSV files with columns
``cavity_strain_pct, cavity_pressure_kPa`` and optionally ``pore_pressure_kPa`` (total pore pressure at the wall) and
``time_s``; units are checked and converted, cavity strain must increase. The wall pore pressure is used whenever
every record has it (``--pressure-only`` drops it): the cavity pressure alone leaves a ridge in (M, sigma'_p0)
(a weaker critical-state ratio and a larger preconsolidation pressure give nearly the same pressure curves), which
the pore pressure, set by the effective stress path, breaks.

Sign convention: pressures are total radial stresses on the cavity wall, compression positive, kPa; cavity strain is
u_a/a0 in % (small strain, as the FE).
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

import constitutive
import fem
import inference
from inference import diagnosis
from inference.observations import DataError, read_csv_table

from . import study

CASE = "burswood_sbp"
DATA = Path(__file__).parent / "data" / "burswood_sbp"

#: in situ state at 5.25 m (REFERENCE section 5); kPa, m/s
SITE = {"sigma_v0": 31.0, "K0": 0.9, "u0": 38.8, "permeability": 3.3e-9, "a0": 0.0415}
#: ANICREEP parameters held fixed (REFERENCE section 5 defaults)
FIXED = {"nu": 0.3, "lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "tau": 86400.0}
#: the two tests: cavity strain rate (1/s)
RATES = {"fast": 0.00167, "slow": 0.000185}
#: Table 4 bounds, plus the error parameter of Eq. (1)
BOUNDS = {"M": (0.5, 2.0), "sigma_p0": (10.0, 200.0), "C_alpha_e": (0.001, 0.05), "sigma_eps": (0.001, 0.3)}
UNITS = {"sigma_p0": "kPa"}
#: the values the synthetic recordings were generated from (the paper's DE-TMCMC MAP)
GENERATING = {"M": 1.71, "sigma_p0": 58.4, "C_alpha_e": 0.020}
#: the paper's Table 5 (MAP)
PAPER = {"paper DE-TMCMC MAP": {"M": 1.71, "sigma_p0": 58.4, "C_alpha_e": 0.020},
         "paper O-TMCMC MAP": {"M": 0.98, "sigma_p0": 102.6, "C_alpha_e": 0.055}}
RECORD_NOISE = 0.02


@dataclass(frozen=True)
class Preset:
    """FE discretization and sampler size. The cavity problem is one-dimensional in r (plane strain, top and bottom
    fixed vertically), so ``layers`` = 1 gives the same answer as the paper's 4 layers at a quarter of the cost.
    ``sweeps``: MCMC sweeps per stage, 1 = the paper's one Metropolis step per resampled particle (REFERENCE
    section 2, step 4), None = adaptive (inference.tmcmc), between 2 and ``max_steps``."""

    radial_cells: int = 60
    layers: int = 4
    increments: int = 100
    outer: str = "fixed"
    outer_radius_a0: float = 3200.0
    n_samples: int = 2000
    sweeps: int | None = 1
    max_steps: int = 25


FE_FIELDS = ("radial_cells", "layers", "increments", "outer", "outer_radius_a0")
PRESETS = {
    "paper": Preset(),
    "quick": Preset(layers=1, n_samples=64, sweeps=None, max_steps=4),
}


# ------------------------------------------------------------------------------------------------ forward model
def pressuremeter_problem(rate: float, preset: Preset, site=None, void_ratio0=FIXED["e0"], save_fields="none"):
    """The fem.Problem of one SBP expansion at cavity strain rate ``rate`` (1/s); material set per particle."""
    site = {**SITE, **(site or {})}
    mesh = fem.Mesh.cavity_strip(a0=site["a0"], outer_radius=preset.outer_radius_a0 * site["a0"],
                                 n_radial=preset.radial_cells, n_vertical=preset.layers)
    placeholder = constitutive.LinearElastic(E=5000.0, nu=FIXED["nu"])
    return fem.pressuremeter(placeholder, mesh=mesh, a0=site["a0"], sigma_v0=site["sigma_v0"], K0=site["K0"],
                             u0=site["u0"], permeability=site["permeability"], void_ratio0=void_ratio0,
                             strain_rate=rate, max_strain=0.10, n_increments=preset.increments, outer=preset.outer,
                             save_fields=save_fields)


class SBPForward:
    """params {M, sigma_p0, C_alpha_e} -> {test: {curve: (cavity strain %, values kPa)}} from both FE solves.

    Picklable: the FE solvers are built lazily in each process (or MPI rank) on first use and reused after.
    ``curves``: "cavity_pressure" (total, kPa) and optionally "pore_pressure" (total pore pressure at the wall).
    """

    def __init__(self, preset: Preset, fixed=None, site=None, rates=None, curves=("cavity_pressure",)):
        self.preset = preset
        self.fixed = {**FIXED, **(fixed or {})}
        self.site = {**SITE, **(site or {})}
        self.rates = dict(rates or RATES)
        self.curves = tuple(curves)
        self._solvers = None

    def __getstate__(self):
        return {**self.__dict__, "_solvers": None}

    def material(self, params):
        """ANICREEP for one particle; the FE's vertical axis is z (Voigt 2)."""
        f = self.fixed
        return constitutive.ANICREEP(M=params["M"], lambda_=f["lambda_"], kappa=f["kappa"], nu=f["nu"], e0=f["e0"],
                                     sigma_p0=params["sigma_p0"], C_alpha_e=params["C_alpha_e"], tau=f["tau"],
                                     vertical_axis=2)

    def compile_material(self):
        """Run one material update so the compiled ANICREEP kernel exists in this process before the process pool
        forks (workers inherit it instead of each compiling it again)."""
        model = self.material(GENERATING)
        stress = fem.Geostatic(self.site["sigma_v0"], self.site["K0"], self.site["u0"]).effective_stress(1)
        model.update(stress, model.initial_state(stress), np.zeros((1, 6)), 1.0)

    def solvers(self, save_fields="none"):
        """{test: fem.Solver}; the ones without saved fields are built once per process and reused."""
        if save_fields == "none" and self._solvers is not None:
            return self._solvers
        built = {name: fem.Solver(pressuremeter_problem(rate, self.preset, self.site, self.fixed["e0"], save_fields))
                 for name, rate in self.rates.items()}
        if save_fields == "none":
            self._solvers = built
        return built

    def results(self, params, save_fields="none") -> dict:
        """{test: fem.Result} for one particle (raises fem.ConvergenceError / IntegrationError on failure)."""
        material = self.material(params)
        return {name: s.solve(material=material) for name, s in self.solvers(save_fields).items()}

    def curves_of(self, results) -> dict:
        out = {}
        for name, res in results.items():
            strain = 100.0 * res.cavity_strain
            sim = {"cavity_pressure": (strain, res.cavity_pressure), "pore_pressure": (strain, res.cavity_pore_pressure)}
            out[name] = {c: sim[c] for c in self.curves}
        return out

    def __call__(self, params) -> dict:
        return self.curves_of(self.results(params))


# ------------------------------------------------------------------------------------------------ recordings
def generate_recordings(directory=DATA, params=None, noise=RECORD_NOISE, seed=2019, preset=PRESETS["paper"],
                        n_points=50, fixed=None, site=None) -> dict:
    """Write SYNTHETIC SBP recordings (one CSV per test) from our FE at ``params`` (default: the paper's MAP),
    with multiplicative noise c ~ N(1, noise^2) on pressure and pore pressure (Eq. 1). Returns {test: path}."""
    params = dict(GENERATING if params is None else params)
    forward = SBPForward(preset, fixed, site)
    results = forward.results(params)
    rng = np.random.default_rng(seed)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, res in results.items():
        strain = np.linspace(0.0, 10.0, n_points + 1)[1:]
        columns = {"time_s": np.interp(strain, 100 * res.cavity_strain, res.time),
                   "cavity_strain_pct": strain,
                   "cavity_pressure_kPa": np.interp(strain, 100 * res.cavity_strain, res.cavity_pressure),
                   "pore_pressure_kPa": np.interp(strain, 100 * res.cavity_strain, res.cavity_pore_pressure)}
        for c in ("cavity_pressure_kPa", "pore_pressure_kPa"):
            columns[c] = columns[c] * rng.normal(1.0, noise, strain.size)
        header = [
            "synthetic: NOT MEASURED DATA. Generated by cases.burswood_sbp.generate_recordings with this project's FE",
            f"synthetic_parameters: {json.dumps(params)}" + (" (the paper's DE-TMCMC MAP)" if params == GENERATING else ""),
            f"synthetic_fixed: {json.dumps(forward.fixed)}; site: {json.dumps(forward.site)}",
            f"synthetic_fe: {json.dumps({k: v for k, v in asdict(preset).items() if k in FE_FIELDS})}",
            f"synthetic_noise: multiplicative c ~ N(1, {noise}^2) per point on pressures (Eq. 1), seed {seed}",
            f"test: {name}", f"strain_rate_per_s: {forward.rates[name]}", "depth_m: 5.25"]
        paths[name] = study.write_records(directory / f"sbp_{name}.csv", header, columns)
    return paths


def has_pore_pressure(path) -> bool:
    return "pore_pressure" in read_csv_table(path)[1]


def load_recordings(files: dict, pore_pressure=False) -> inference.Observations:
    """SBP records {test: CSV path} -> Observations of cavity pressure (and pore pressure) vs cavity strain (%).

    Checks: the columns exist with convertible units (kPa, %), cavity strain strictly increasing and within
    (0, 100] %, pressures positive; errors name the file, the column and the value."""
    curves = {"cavity_pressure": "cavity_pressure"}
    if pore_pressure:
        curves["pore_pressure"] = "pore_pressure"
    for name, path in files.items():
        _, table = read_csv_table(path)
        if "cavity_strain" not in table:
            raise DataError(f"{path}: missing column 'cavity_strain' (cavity strain in %, e.g. cavity_strain_pct); "
                            f"found {list(table)}")
        unit, x = table["cavity_strain"]
        if unit not in ("pct", "%"):
            raise DataError(f"{path}: column 'cavity_strain' must be in % (cavity_strain_pct), got unit {unit!r}")
        steps = np.diff(x)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0)) + 1
            raise DataError(f"{path}: cavity_strain must increase; value {x[i]:g} % at data row {i + 1} follows "
                            f"{x[i - 1]:g} % (give the loading branch only)")
        if x[0] < 0 or x[-1] > 100:
            raise DataError(f"{path}: cavity_strain spans [{x[0]:g}, {x[-1]:g}] %, expected within [0, 100] %")
        for c in curves.values():
            if c in table and np.any(table[c][1] <= 0):
                v = table[c][1][table[c][1] <= 0][0]
                raise DataError(f"{path}: column {c!r} has a non-positive total pressure {v:g}")
    return inference.Observations.from_csv(files, x="cavity_strain", curves=curves,
                                           units={"cavity_strain": "%", "cavity_pressure": "kPa",
                                                  "pore_pressure": "kPa"})


# ------------------------------------------------------------------------------------------------ outputs
def predictive_bands(post, like, n_draws, seed):
    """95 % posterior predictive band of the records (inference.diagnosis: the exact mixture of U_sim (1 + eps) over
    ``n_draws`` posterior samples, each with its sigma_eps). Returns ({(test, curve): PredictiveBand}, draws)."""
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(post.samples), size=min(n_draws, len(post.samples)), replace=False)
    sims, sigmas = diagnosis.simulate_samples(like, post.samples[idx])
    return diagnosis.predictive_bands(like, sims, sigmas), len(idx)


def plot_curves(path, like, map_curves, bands, title):
    plt = study.pyplot()
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
        ax.set_xlabel("cavity strain (%)")
        ax.set_ylabel({"cavity_pressure": "total cavity pressure (kPa)",
                       "pore_pressure": "pore pressure at the wall (kPa)"}[cname])
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def preset_label(args, preset):
    base = "quick" if args.quick else "paper"
    return base if preset == PRESETS[base] else f"{base}, modified"


def report(out, args, post, summary, like, synthetic, truth, bands_drawn, preset):
    names = [n for n in post.names if n != "sigma_eps"]
    ref = {"generating (synthetic)": truth, **PAPER} if truth else dict(PAPER)
    lines = [f"# Burswood clay SBP: {study.method_name(args.method)} calibration of ANICREEP", ""]
    if synthetic:
        lines += ["**The recordings are SYNTHETIC** (see the `# synthetic` lines of their headers; the measured "
                  "Burswood curves are not public). They are not measurements.", ""]
    lines += [f"- tests: {', '.join(f'{t.name} ({t.source})' for t in like.observations)}",
              f"- FE and sampler settings: {preset_label(args, preset)} {json.dumps(asdict(preset))}",
              f"- N_s = {summary['n_samples']}, stages {summary['n_stages']}, forward evaluations "
              f"{summary['n_forward_solves']} (each = {len(like.observations)} FE solves), failed "
              f"{summary['n_failed_solves']}, wall {summary['wall_s']:.1f} s on {summary['ranks']} process(es) "
              f"({summary['executor']})",
              f"- ln Z = {post.log_evidence:.3f}; J_g at MAP: "
              + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                          for k, v in summary["J_g_at_map"].items()), "",
              study.parameter_table(post, ref, UNITS), ""]
    if truth:
        lines.append("Generating values inside the 95 % posterior interval: " + ", ".join(
            f"{n} {'yes' if lo <= truth[n] <= hi else 'NO'}"
            for n in names for lo, hi in [post.credible_interval(n)]))
        lines.append("MAP errors: " + ", ".join(
            f"{n} {100 * (post.map[n] / truth[n] - 1):+.1f} %" for n in names))
        lines.append("")
    lines += ["Figures: curves.png (recorded vs MAP, 95 % posterior predictive band from "
              f"{bands_drawn} posterior draws), marginals.png, stages.png, fields_*.png and map_fields/*.vtu (MAP "
              "solution at 10 % cavity strain). Stage log: progress.log; failed solves: failed_solves.jsonl.", "",
              "| stage | q | ln S | acceptance | sweeps | evaluations | failed | wall (s) |", "|---|---|---|---|---|---|---|---|"]
    for r in summary["stages"]:
        lines.append(f"| {r.get('stage', '')} | {r['q']:.4g} | {r.get('log_S', 0):.3f} | {r.get('acceptance', 0):.2f} | "
                     f"{r.get('sweeps', '')} | {r.get('n_evals', '')} | {r.get('n_failed', '')} | "
                     f"{r.get('wall_s', 0):.1f} |")
    (Path(out) / "report.md").write_text("\n".join(lines) + "\n")


def write_outputs(out, args, post, like, forward, preset, synthetic, truth, seed):
    """Every output of one run; ``truth`` the generating values of synthetic records (or None)."""
    out = Path(out)
    summary = study.write_summary(out, CASE, args, seed, post, like, extra={
        "synthetic_recordings": synthetic, "preset": preset_label(args, preset), "settings_fe": asdict(preset),
        "fixed": forward.fixed, "site": forward.site, "generating": truth, "paper_table5": PAPER})
    params, _ = like.split(post.map_theta)
    results = forward.results(params, save_fields="phases")
    map_curves = forward.curves_of(results)
    bands, drawn = predictive_bands(post, like, 24 if args.quick else 40, seed)
    tag = "SYNTHETIC recordings" if synthetic else "recordings"
    plot_curves(out / "curves.png", like, map_curves, bands,
                f"Burswood SBP, {study.method_name(args.method)}: {tag} vs MAP and posterior predictive")
    study.plot_marginals(post, out / "marginals.png",
                         marks={"generating": truth, **PAPER} if truth else PAPER,
                         bounds=BOUNDS, title=f"Burswood SBP posterior ({tag})")
    study.plot_stages(post, out / "stages.png")
    for name, res in results.items():
        res.write_vtu(out / "map_fields", prefix=f"{name}")
        try:
            res.plot(str(out / f"fields_{name}.png"))
        except Exception as exc:  # noqa: BLE001 - a missing OpenGL stack must not lose the calibration
            print(f"[burswood_sbp] field picture not written: {exc}", file=sys.stderr)
    report(out, args, post, summary, like, synthetic, truth, drawn, preset)
    return summary


def throughput(like, prior, args, n):
    """Forward evaluations per second for n prior draws (seed 0) with the run's executor (1 process with
    ``--processes 1``, the pool, or the MPI ranks); one JSON line on rank 0."""
    like.bind(prior.names)
    evaluator = inference.Evaluator(like)
    thetas = prior.sample(np.random.default_rng(0), n)
    executor = inference.default_executor(args.dispatch, args.processes)
    if executor.is_root:
        t0 = time.perf_counter()
        values, _, _ = executor.evaluate(evaluator, thetas)
        wall = time.perf_counter() - t0
        if isinstance(executor, inference.MPIExecutor):
            executor.finish(("ok", None))
        print(json.dumps({"case": CASE, "benchmark": "throughput", "executor": executor.name,
                          "processes": executor.ranks,
                          "n": n, "wall_s": round(wall, 2), "evaluations_per_s": round(n / wall, 3),
                          "fe_solves_per_s": round(len(like.observations) * n / wall, 3),
                          "failed": int(np.sum(~np.isfinite(values)))}), flush=True)
    else:
        executor.serve(evaluator)
    executor.close()


# ------------------------------------------------------------------------------------------------ command line
def _options(ap):
    ap.add_argument("--recordings", nargs="+", metavar="TEST=CSV",
                    help="SBP records, e.g. fast=f.csv slow=s.csv (test names must be those of --rates)")
    ap.add_argument("--rates", nargs="+", metavar="TEST=RATE", help="cavity strain rate per test in 1/s "
                    "(default fast=0.00167 slow=0.000185)")
    ap.add_argument("--pressure-only", action="store_true",
                    help="calibrate on the cavity pressure alone even when the records have the wall pore pressure")
    ap.add_argument("--fixed", nargs="+", metavar="NAME=VALUE", help="override fixed ANICREEP values "
                    "(nu, lambda_, kappa, e0, tau)")
    ap.add_argument("--radial-cells", type=int)
    ap.add_argument("--layers", type=int)
    ap.add_argument("--increments", type=int)
    ap.add_argument("--sweeps", type=int, help="MCMC sweeps per stage: 1 is the paper's one Metropolis step per "
                    "resampled particle (the paper setting's default), 0 adaptive up to 25 (--quick: adaptive up to 4 "
                    "by default)")
    ap.add_argument("--max-stages", type=int, default=200, help="stop after this many stages (tests)")
    ap.add_argument("--timeout", type=float, help="seconds per forward evaluation (then a failed particle)")
    ap.add_argument("--generate", action="store_true", help="regenerate the shipped synthetic recordings and exit")
    ap.add_argument("--throughput", type=int, metavar="N",
                    help="benchmark: time N forward evaluations (prior draws) on this executor and exit")


def _pairs(items, what, cast=float):
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"{what}: {item!r} must look like NAME=VALUE")
        try:
            out[key] = cast(value)
        except ValueError:
            raise SystemExit(f"{what}: {item!r}: {value!r} is not a valid value") from None
    return out


def main(argv=None):
    args = study.arguments(__doc__, argv, add=_options,
                           quick_help="the README's main job: the paper's 60 radial cells in one layer, 100 increments, "
                                      "N_s 64")
    preset = PRESETS["quick" if args.quick else "paper"]
    preset = replace(preset, **{k: v for k, v in (("radial_cells", args.radial_cells), ("layers", args.layers),
                                                  ("increments", args.increments)) if v is not None})
    if args.sweeps is not None:
        if args.sweeps < 0:
            raise SystemExit(f"--sweeps {args.sweeps}: give 0 (adaptive) or a positive number of sweeps")
        preset = replace(preset, sweeps=args.sweeps or None)
    fixed = _pairs(args.fixed, "--fixed")
    unknown = set(fixed) - set(FIXED)
    if unknown:
        raise SystemExit(f"--fixed: unknown parameter(s) {sorted(unknown)}; fixed ones are {sorted(FIXED)}")
    rates = _pairs(args.rates, "--rates") or RATES
    if args.generate:
        paths = generate_recordings(fixed=fixed or None)
        print(json.dumps({k: str(v) for k, v in paths.items()}))
        return 0
    files = _pairs(args.recordings, "--recordings", cast=Path) or {t: DATA / f"sbp_{t}.csv" for t in RATES}
    missing = set(files) - set(rates)
    if missing:
        raise SystemExit(f"--recordings names test(s) {sorted(missing)} without a cavity strain rate; give --rates")
    rates = {t: rates[t] for t in files}
    use_pore_pressure = not args.pressure_only and all(has_pore_pressure(p) for p in files.values())
    observations = load_recordings(files, pore_pressure=use_pore_pressure)
    synthetic = any("synthetic" in t.conditions for t in observations)
    truth = study.generating_values(observations, GENERATING)
    forward = SBPForward(preset, fixed, rates=rates,
                         curves=("cavity_pressure", "pore_pressure") if use_pore_pressure else ("cavity_pressure",))
    forward.compile_material()
    like = inference.Likelihood(observations, forward)
    prior = inference.UniformPrior(BOUNDS)
    if args.throughput:
        throughput(like, prior, args, args.throughput)
        return 0
    sweeps = preset.sweeps
    settings = dict(max_steps=max(preset.max_steps, sweeps or 0), n_steps=sweeps or "adaptive",
                    min_steps=min(2, sweeps or 2), max_stages=args.max_stages, timeout=args.timeout)

    def finish(run_args, seed, out, post):
        return write_outputs(out, run_args, post, like, forward, preset, synthetic, truth, seed)

    summaries = study.run_all(args, Path("results") / CASE, like, prior, args.samples or preset.n_samples, settings,
                              finish)
    if study.is_root() and len(summaries) > 1:
        base = Path(args.out or Path("results") / CASE)
        table = study.runs_table(summaries, prior.names, {"generating": truth, **PAPER} if truth else PAPER)
        (base / "runs.md").write_text("# Burswood SBP: independent runs\n\n" + table + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
