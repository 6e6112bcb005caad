"""Concealed physics at pressuremeter scale: the two-rate self-boring pressuremeter of the Burswood case,
SYNTHETIC data with a hidden effect, a rate-independent base class, and the calibrate -> diagnose loop.

    python -m validation.concealed --scale sbp --effect viscosity                 # set_1, calibrated
    python -m validation.concealed --scale sbp --effect viscosity --diagnose      # locate, explain, enrich, compare
    python -m validation.concealed --scale sbp --effect "partial drainage" --diagnose   # set_2 (both candidates)
    python -m validation.concealed --scale sbp --effect "partial drainage" --diagnose --pressure-only
    python -m validation.concealed --scale sbp --control --diagnose               # set_3: data from the base class
    python -m validation.concealed --scale sbp --confusion --seeds 1              # every set, with/without pore p.
    python -m validation.concealed --scale sbp --generate                         # rewrite the shipped SYNTHETIC data

The data are SYNTHETIC (not measurements): two SBP expansions at the Burswood site (docs/reference.md section 5: 0.167
%/s and 0.0185 %/s to 10 % cavity strain, sigma'_v0 31 kPa, K0 0.9, u0 38.8 kPa, probe radius 41.5 mm; ANICREEP with
lambda 0.40, kappa 0.026, e0 2.0, nu 0.3 fixed, M 1.71 and sigma'_p0 58.4 kPa), simulated by the coupled FE of
``cases.study.forward.sbp`` with the generating model of :data:`EFFECTS` (stated here, never in the data files), times
independent multiplicative noise c ~ N(1, 0.02^2) per point on the total cavity pressure and the total wall pore
pressure (Eq. 1). Data generation and calibration use the SAME coarse FE (:data:`PRESET`: 30 radial cells x 1 layer, 30
increments, outer boundary moved as the elastic field at 200 a0), so there is no discretization bias.

Base class: rate-independent ANICREEP (``viscous=False``, anisotropic as in the Burswood case) in the coupled FE with
the permeability held at the value the engineer assumes (:data:`EFFECTS` ``k_assumed``), M, sigma'_p0 and sigma_eps
free. Enrichments from ``constitutive.physics_catalog``: viscosity (``viscous=True``, C_alpha_e log-uniform) and
partial drainage (the same coupled FE with the permeability free, log-uniform over five decades).
"""
from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import inference
from cases.study.cli import UsageError, arguments
from cases.study.forward.sbp import SBPForward
from cases.study.loop.covariates import drainage_time_factor, programme_covariates
from cases.study.loop.problem import LoopProblem, run_loop
from cases.study.outputs.report import plot_loop
from cases.study.programme import TestSpec
from cases.study.reading.presets import FE_FIELDS, Preset
from cases.study.reading.records import load_sbp_recordings, write_records
from cases.study.reading.schema import Settings
from constitutive import physics_catalog
from inference import diagnosis

CASE = "concealed_sbp"
DATA = Path(__file__).parents[1] / "data" / "concealed_sbp"
#: coarse FE (same for data and calibration) and the sampler size
PRESET = Preset(radial_cells=30, layers=1, increments=30, outer="field", outer_radius_a0=200.0)
SETTINGS = Settings(n_samples=48, max_steps=3, predictive_draws=16)
#: the Burswood site at 5.25 m (docs/reference.md section 5; kPa, m/s, m) and the two expansion rates (1/s)
SITE = {"sigma_v0": 31.0, "K0": 0.9, "u0": 38.8, "permeability": 3.3e-9, "a0": 0.0415}
RATES = {"fast": 0.00167, "slow": 0.000185}
#: ANICREEP values held fixed (docs/reference.md section 5 defaults)
FIXED = {"nu": 0.3, "lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "tau": 86400.0}
NOISE = 0.02
N_POINTS = 40
CURVES = ("cavity_pressure", "pore_pressure")
#: base class: rate independent, anisotropic ANICREEP in the coupled FE with the assumed permeability
BASE_SWITCHES = {"viscous": False, "anisotropy": True, "destructuration": False}
BASE_BOUNDS = {"M": (0.5, 2.0), "sigma_p0": (10.0, 200.0)}
SIGMA_BOUNDS = {"sigma_eps": (0.002, 0.3)}
GENERATING = {"M": 1.71, "sigma_p0": 58.4}
#: hidden effects: generating switches and values, true permeability, the permeability the base class assumes, and
#: the blind name of the shipped data set (file and directory names never name the effect)
EFFECTS = {
    "viscosity": {"switches": {"viscous": True}, "values": {"C_alpha_e": 0.02}, "k_true": 3.3e-9,
                  "k_assumed": 3.3e-9, "dataset": "set_1"},
    "partial drainage": {"switches": {}, "values": {}, "k_true": 1.0e-7, "k_assumed": 1.0e-9, "dataset": "set_2"},
    "none": {"switches": {}, "values": {}, "k_true": 3.3e-9, "k_assumed": 3.3e-9, "dataset": "set_3"},
}


def programme(permeability: float) -> list:
    """The two SBP tests at the site with the permeability ``permeability`` (m/s)."""
    return [TestSpec(name, "sbp", sigma_v0=SITE["sigma_v0"], K0=SITE["K0"], u0=SITE["u0"], permeability=permeability,
                     probe_radius=SITE["a0"], strain_rate=rate, depth=5.25) for name, rate in RATES.items()]


def forward(switches: dict, permeability: float, curves=CURVES) -> SBPForward:
    """One ANICREEP class (``switches``, ``coupled``: the permeability a free parameter) in the coupled FE of
    :data:`PRESET` at the site with ``permeability`` (m/s)."""
    return SBPForward(PRESET, {**SITE, "permeability": permeability}, RATES, FIXED, "ANICREEP", switches,
                      curves=curves)


def generating_forward(effect: str) -> tuple:
    """(SBPForward, parameters) of the generating model of ``effect``."""
    e = EFFECTS[effect]
    return forward({**BASE_SWITCHES, **e["switches"]}, e["k_true"]), {**GENERATING, **e["values"]}


# ------------------------------------------------------------------------------------------------ data
def strains() -> np.ndarray:
    """Recorded cavity strains (%): N_POINTS equally spaced to 10 %."""
    return np.linspace(0.0, 10.0, N_POINTS + 1)[1:]


def synthetic_curves(effect: str, seed: int, noise=NOISE) -> dict:
    """{test: {column: values}} of the SYNTHETIC records with hidden ``effect`` ("none": the control)."""
    fw, params = generating_forward(effect)
    results = fw.results(params)
    rng = np.random.default_rng(np.random.SeedSequence([seed, list(EFFECTS).index(effect), 11]))
    x = strains()
    out = {}
    for name, res in results.items():
        sx = 100.0 * res.cavity_strain
        cols = {"time_s": np.interp(x, sx, res.time), "cavity_strain_pct": x}
        for c, y in (("cavity_pressure_kPa", res.cavity_pressure), ("pore_pressure_kPa", res.cavity_pore_pressure)):
            cols[c] = np.interp(x, sx, y) * rng.normal(1.0, noise, x.size)
        out[name] = cols
    return out


def header(effect: str, seed: int, test: str, noise=NOISE) -> list:
    return ["synthetic: NOT MEASURED DATA. Generated with this project's coupled FE from a generating model stated in "
            "validation/proofs/ (its --generate option); the file does not name it",
            f"synthetic_noise: multiplicative c ~ N(1, {noise}^2) per point on both pressures (Eq. 1), seed {seed}",
            f"test: {test}", f"strain_rate_per_s: {RATES[test]}",
            f"site: sigma_v0_kPa {SITE['sigma_v0']}, K0 {SITE['K0']}, u0_kPa {SITE['u0']}, probe_radius_m "
            f"{SITE['a0']}", "depth_m: 5.25"]


def write_data(effect: str, seed: int = 1, directory=None) -> dict:
    """Write one SYNTHETIC data set (``DATA/<dataset>/sbp_{fast,slow}.csv``); returns {test: path}."""
    directory = Path(directory or DATA / EFFECTS[effect]["dataset"])
    directory.mkdir(parents=True, exist_ok=True)
    return {name: write_records(directory / f"sbp_{name}.csv", header(effect, seed, name), cols)
            for name, cols in synthetic_curves(effect, seed).items()}


def observations_from(curves: dict, pore_pressure: bool, label: str) -> inference.Observations:
    names = CURVES if pore_pressure else CURVES[:1]
    return inference.Observations([
        inference.Test(t, {c: inference.Curve(cols["cavity_strain_pct"], cols[f"{c}_kPa"], "cavity_strain", c, "%",
                                              "kPa") for c in names},
                       {"synthetic": label, "strain_rate_per_s": RATES[t]}) for t, cols in curves.items()])


def load_data(effect: str, pore_pressure=True) -> inference.Observations:
    files = {t: DATA / EFFECTS[effect]["dataset"] / f"sbp_{t}.csv" for t in RATES}
    obs = load_sbp_recordings(files, pore_pressure=pore_pressure)
    return inference.Observations([inference.Test(t.name, t.curves, {**t.conditions, "synthetic": "yes"})
                                   for t in obs])


# ------------------------------------------------------------------------------------------------ the loop problem
class SBPProblem(LoopProblem):
    """The base class of this case as a loop problem (``cases.study.loop.problem.LoopProblem``)."""

    case = CASE
    model = "ANICREEP"
    base_switches = BASE_SWITCHES
    base_bounds = BASE_BOUNDS
    forward_arguments = physics_catalog.COUPLED_FE_ARGUMENTS
    sigma_bounds = SIGMA_BOUNDS
    base_dir = "base"

    def __init__(self, k_assumed: float, pore_pressure: bool, processes=None, all_enrichments=False):
        self.k_assumed = float(k_assumed)
        self.curves = CURVES if pore_pressure else CURVES[:1]
        self.processes = processes
        self.all_enrichments = all_enrichments

    def forward(self, switches):
        return forward(switches, self.k_assumed, self.curves)

    def map_curves(self, params, switches):
        return forward(switches, self.k_assumed, self.curves)(params)

    def catalog_switches(self, switches):
        return {"coupled": False, **switches}

    def also_enrich(self, diag):
        """Every other enrichable candidate that is named or, with ``all_enrichments``, whenever the base misfits."""
        return [c.name for c in diag.candidates if c.name in ENRICHABLE
                and (c.named or (self.all_enrichments and diag.verdict == "structured mismatch"))]

    def executor(self):
        return inference.default_executor("dynamic", self.processes)

    def summary_extra(self, switches):
        return {"k_assumed": self.k_assumed, "curves": list(self.curves),
                "fe": {k: getattr(PRESET, k) for k in FE_FIELDS}}

    def describe(self, label, base_name):
        return (f"**SYNTHETIC data** ({label}). Two SBP expansions (0.167 %/s, 0.0185 %/s); base class {base_name} "
                f"in the coupled FE with k = {self.k_assumed:g} m/s assumed, M, sigma'_p0, sigma_eps free; curves "
                f"{', '.join(self.curves)}; catalog: constitutive.physics_catalog.")

    def curve_covariates(self, like, map_curves) -> dict:
        """Per-point covariates: strain rate (test condition), time since the start of the expansion, cavity strain
        level (``cases.study.loop.covariates.programme_covariates``) and the drainage time factor T = c_h t / a0^2
        (c_h of Randolph & Wroth from the assumed permeability and the in-situ elastic shear modulus of the fixed kappa,
        nu)."""
        p0 = SITE["sigma_v0"] * (1.0 + 2.0 * SITE["K0"]) / 3.0
        bulk = (1.0 + FIXED["e0"]) * p0 / FIXED["kappa"]
        shear = 3.0 * bulk * (1.0 - 2.0 * FIXED["nu"]) / (2.0 * (1.0 + FIXED["nu"]))
        cov = programme_covariates(programme(self.k_assumed), like.observations, {t: {} for t in RATES})
        cov["drainage time factor"] = {k: drainage_time_factor(t, self.k_assumed, shear, FIXED["nu"], SITE["a0"])
                                       for k, t in cov["time"].items()}
        return cov

    def plot(self, path, like, classes, diag, label):
        plot_loop(path, like, classes, diag, label, True)


# ------------------------------------------------------------------------------------------------ the case's loop
#: catalog candidates whose enrichment this case can calibrate (the coupled FE with ANICREEP)
ENRICHABLE = ("viscosity", "partial drainage")


def _with_curves(candidate) -> list:
    """The diagnosis' items of ``candidate`` with the curves each is measured on (from the catalog, same order)."""
    return [replace(i, curves=s["curves"])
            for i, s in zip(candidate.items, physics_catalog.candidate(candidate.name).signature)]


def _recorded(item, curves) -> bool:
    return item.curves is None or bool(set(item.curves) & set(curves))


def design_limits(diag, pore_pressure: bool) -> tuple:
    """(What these records cannot decide, in words or "", the tool's answer in one line), from the diagnosis'
    candidate items, attribution and Bayes factors.

    Enrichable candidates none of whose primary signature items is on a recorded curve (without the wall pore
    pressure: viscosity's primary items are on effective stresses and the pore pressure, partial drainage's on the
    pore pressure) cannot be named; when such candidates share a significant supporting item (the cavity pressure
    rising with strain rate, which both produce on a total pressure), or when the base misfits, the records cannot
    tell them apart (the answer then says so, and adds which one the Bayes factors favour only when they separate the
    classes by ln B >= 3)."""
    curves = CURVES if pore_pressure else CURVES[:1]
    enrichable = [replace(c, items=tuple(_with_curves(c))) for c in diag.candidates if c.name in ENRICHABLE]
    lnb = {c.candidate: c.log_bayes_vs_base for c in diag.classes if c.role == "enriched"}
    attribution = {a.name: a for a in diag.attribution}
    notes = []
    for c in enrichable:
        for i in c.items:
            a = attribution.get(i.covariate)
            if (i.role == "primary" and i.status == "not significant" and a is not None and a.kind == "between"
                    and not a.contrast and _recorded(i, curves)):
                notes.append(f"{c.name}: a between-test trend of {i.covariate} cannot be significant with "
                             f"{len(RATES)} tests under the permutation null; more tests are needed")
    blind = [c for c in enrichable if not any(_recorded(i, curves) for i in c.items if i.role == "primary")]
    shared = [i for c in blind for i in c.items if i.status == "supports"]
    for c in blind:
        missing = {k for i in c.items if i.role == "primary" for k in i.curves or ()} - set(curves)
        notes.append(f"{c.name}: its primary signature needs curves that are not recorded here "
                     f"({', '.join(sorted(missing & set(CURVES)) or sorted(missing))})")
    if len(blind) > 1 and shared:
        a = attribution[shared[0].covariate]
        notes.append(f"the records show a significant effect of {a.name} (p = {a.p_adjusted:.2g}; "
                     f"{shared[0].meaning}; rank correlation {shared[0].rank_correlation:+.2f}) that "
                     f"{' and '.join(c.name for c in blind)} both produce: without the wall pore pressure the "
                     "records cannot tell them apart; record the wall pore pressure")
    ranked = sorted(((v, n) for n, v in lnb.items() if v is not None), reverse=True)
    top = ranked[0] if ranked and ranked[0][0] >= diagnosis.STRONG_LOG_BAYES else None
    separated = top is not None and (len(ranked) == 1 or top[0] - ranked[1][0] >= diagnosis.STRONG_LOG_BAYES)
    named = diag.named
    if diag.verdict == "structured mismatch" and len(named) != 1 and top is not None:
        if not separated:
            notes.append(f"the evidence does not separate {top[1]} and {ranked[1][1]} (ln B {top[0]:.1f} and "
                         f"{ranked[1][0]:.1f}, difference below {diagnosis.STRONG_LOG_BAYES:g})")
        else:
            notes.append(f"the signatures name no candidate; the evidence favours {top[1]} (ln B {top[0]:.1f}" +
                         ("" if len(ranked) == 1 else f"; next {ranked[1][0]:.1f}") + ")")
    undecidable = len(blind) > 1 and (shared or diag.verdict == "structured mismatch")
    if undecidable:
        answer = (f"cannot tell {' from '.join(c.name for c in blind)} apart: record the wall pore pressure" +
                  (f" (the evidence alone favours {top[1]}, ln B {top[0]:.1f}, but the signatures cannot check it)"
                   if separated else ""))
    elif diag.omitted_physics != "none":
        answer = f"{diag.omitted_physics} (named by its signature, ln B {lnb[diag.omitted_physics]:.1f})"
    elif named:
        answer = f"{', '.join(named)} named; enriched class not calibrated or not confirmed"
    else:
        answer = diag.recommendation
    return "; ".join(notes), answer


def run_case(effect: str, seed: int, out: Path, pore_pressure=True, settings=SETTINGS, args=None, generated=None,
             processes=None, all_enrichments=False, data_seed=None) -> dict:
    """The loop on one data set (cases.study.loop.problem.run_loop): calibrate the base class, diagnose, calibrate the
    enriched class of the best named candidate and, with ``all_enrichments`` (or when several are named), every other
    enrichable candidate (:meth:`SBPProblem.also_enrich`); the diagnosis compares every class. Returns a row for the
    confusion table. ``seed``: the sampler's seed; ``data_seed``: the noise seed of ``generated`` (default ``seed``;
    the shipped data have noise seed 1)."""
    t0 = time.perf_counter()
    out = Path(out)
    data_seed = (seed if generated is not None else 1) if data_seed is None else data_seed
    label = (f"data set {EFFECTS[effect]['dataset']}, noise seed {data_seed}, sampler seed {seed}, "
             f"{'with' if pore_pressure else 'without'} pore pressure")
    obs = (observations_from(generated, pore_pressure, "yes") if generated is not None
           else load_data(effect, pore_pressure))
    problem = SBPProblem(EFFECTS[effect]["k_assumed"], pore_pressure, processes, all_enrichments)
    diag = run_loop(problem, obs, args or arguments(__doc__, []), out, seed, settings, label).final
    limits, answer = design_limits(diag, pore_pressure)
    row = {"effect": effect, "dataset": EFFECTS[effect]["dataset"], "seed": seed, "data_seed": data_seed,
           "pore_pressure": pore_pressure,
           "verdict": diag.verdict, "named": diag.named,
           "omitted_physics": diag.omitted_physics, "log_bayes": diag.log_bayes,
           "log_evidence": {c.name: c.log_evidence for c in diag.classes},
           "regions": [f"{r.test} {r.curve} {r.x_start:.3g}-{r.x_end:.3g} % ({r.sign}, "
                       f"{100 * r.mean_relative:+.1f} %)" for r in diag.mismatch_regions],
           "scores": {c.name: round(c.score, 3) for c in diag.candidates},
           "parameters": {c.name: c.parameters for c in diag.classes},
           "design_limits": limits, "recommendation": diag.recommendation, "answer": answer,
           "wall_s": time.perf_counter() - t0}
    (out / "case.json").write_text(json.dumps(row, indent=1, default=float))
    return row


def run(args) -> int:
    """The command line of ``validation.concealed --scale sbp``."""
    args.effect = args.effect or "viscosity"
    if args.effect not in EFFECTS or args.effect == "none":
        raise UsageError(f"--effect {args.effect}: choose among {', '.join(e for e in EFFECTS if e != 'none')}")
    if args.generate:
        for effect in EFFECTS:
            print(json.dumps({k: str(v) for k, v in write_data(effect).items()}))
        return 0
    out = Path(args.out or Path("results") / CASE)
    settings = Settings(args.samples or SETTINGS.n_samples, SETTINGS.max_steps, SETTINGS.predictive_draws)
    if not args.confusion:
        effect = "none" if args.control else args.effect
        gen = None if args.data_seed == 1 else synthetic_curves(effect, args.data_seed)
        row = run_case(effect, args.seed, out, not args.pressure_only, settings, args, gen, args.processes,
                       all_enrichments=args.all_enrichments, data_seed=args.data_seed)
        print(json.dumps(row, default=float))
        return 0
    rows = []
    for s in range(args.seed, args.seed + (args.seeds or 1)):
        for effect in EFFECTS:
            for pp in (True, False):
                gen = None if s == 1 else synthetic_curves(effect, s)
                d = out / f"{EFFECTS[effect]['dataset']}_seed{s}_{'pp' if pp else 'p_only'}"
                rows.append(run_case(effect, s, d, pp, settings, args, gen, args.processes, all_enrichments=True))
                print(json.dumps(rows[-1], default=float), flush=True)
    (out / "confusion.json").write_text(json.dumps(rows, indent=1, default=float))
    return 0
