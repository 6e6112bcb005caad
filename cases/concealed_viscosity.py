"""Concealed physics at lab scale: the first complete missing-physics loop of issue 6, on SYNTHETIC data.

    python -m cases.concealed_viscosity --quick --diagnose          # calibrate, locate, explain, enrich, compare
    python -m cases.concealed_viscosity --quick --diagnose --control   # negative control (data from the base model)
    python -m cases.concealed_viscosity --quick --seeds 3           # detections and false alarms over noise seeds
    python -m cases.concealed_viscosity --generate                  # rewrite the shipped synthetic data

The data are SYNTHETIC (not measurements): six laboratory tests on a soft clay of Burswood-like properties, run by
``constitutive.labtests`` on one material point with a *generating* model stated in :data:`GENERATING` (this module,
never in the data files), times independent multiplicative noise c ~ N(1, 0.02^2) per point (Eq. 1):
- six K0-consolidated undrained triaxial compression tests (CK0UC, T1-T6) from sigma'_v = 80 kPa, K0 = 0.5, to
  10 % axial strain at 0.1, 0.3, 1, 3, 10 and 30 %/h: records q and p' (kPa) against axial strain (%);
- one constant-rate-of-strain oedometer test (CRS, O1) from sigma'_v = 80 kPa to 25 % axial strain at 2 %/h:
  records sigma'_v;
each at its own axial strain rate (the test condition ``strain_rate_per_s`` in the file header). Six rates of one
test type are what lets the between-test attribution reach significance: its null permutes the rates among the
tests (exactly, up to 7 tests) and fits each curve kind on its own, so a perfect monotone rate trend over the six
triaxial tests has p = 2/6! = 0.0028 (with three tests per curve kind it would still have p = 1/9).

The base model class is the rate-independent ANICREEP (``viscous=False``, anisotropic; lambda, kappa, e0, nu fixed)
with M, sigma'_p0 and sigma_eps free. The loop (``--diagnose``): calibrate the base class by DE-TMCMC; screen its
residuals (``inference.screen``: locate) with per-point covariates (strain rate between tests; time, strain level,
stress ratio and p' along the curves); rank the candidate physics of ``constitutive.physics_catalog`` by signature
(``inference.diagnosis.rank_candidates``: explain); calibrate the enriched class of the best-ranked named candidate
that has an implemented enrichment; compare log-evidences (Bayes factor) and report before/after
(``inference.diagnosis.diagnose_directory``, also ``python -m inference.diagnose DIR``). ``--control`` replaces the data
by recordings generated from the base class itself (same noise): the tool must then find nothing to enrich.

Rate-independent forward models are solved once per distinct test geometry (their curves do not depend on the strain
rate; the model's ``rate_dependent`` attribute says so) and viscous ones once per test.
"""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import inference
from constitutive import ANICREEP, labtests
from inference.likelihood import ForwardModelError

from . import calibrate, study
from .calibrate import LoopProblem, Settings
from .study import write_records

CASE = "concealed_viscosity"
DATA = Path(__file__).parent / "data"
#: shipped data sets: the concealed one and the negative control
DATASETS = {"concealed": DATA / "concealed_lab", "control": DATA / "concealed_control"}

#: ANICREEP parameters held fixed in every class (Burswood-like soft clay, REFERENCE section 5 defaults)
FIXED = {"lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "nu": 0.25, "tau": 86400.0}
#: the model that made the concealed data (switches and values); never written into the data files
GENERATING = {"switches": {"viscous": True, "anisotropy": True}, "M": 1.45, "sigma_p0": 100.0, "C_alpha_e": 0.02}
#: the base class (rate independent, anisotropic) and its free parameters
BASE_SWITCHES = {"viscous": False, "anisotropy": True}
BASE_BOUNDS = {"M": (0.8, 2.0), "sigma_p0": (40.0, 200.0)}
SIGMA_BOUNDS = {"sigma_eps": (0.002, 0.3)}
NOISE = 0.02
PER_HOUR = 1.0 / 360000.0  # 1 %/h in 1/s


@dataclass(frozen=True)
class LabTest:
    """One laboratory test: kind "CK0UC" (undrained triaxial compression) or "CRS"; rate in 1/s; strain grid (-)."""

    name: str
    kind: str
    strain_rate: float
    sigma_v0: float = 80.0
    k0: float = 0.5

    @property
    def strains(self):
        """Recorded axial strains (-): geometric from 0.1 % so the stiff start is resolved, 20 points."""
        top = 0.10 if self.kind == "CK0UC" else 0.25
        return np.geomspace(1e-3, top, 20)

    @property
    def curves(self):
        return ("q", "p") if self.kind == "CK0UC" else ("axial_stress",)


TESTS = tuple(LabTest(f"T{i + 1}", "CK0UC", r * PER_HOUR) for i, r in enumerate((0.1, 0.3, 1.0, 3.0, 10.0, 30.0))) \
    + (LabTest("O1", "CRS", 2.0 * PER_HOUR),)
CURVE_UNITS = {"q": "q_kPa", "p": "p_kPa", "axial_stress": "sigma_v_kPa"}


# ------------------------------------------------------------------------------------------------ forward model
def simulate(tests, params: dict, switches: dict):
    """Curves of every test for a batch: params {name: (m,) array}; returns ({test: {curve: (m, 20)}}, {test:
    failed (m,)}). Rate-independent classes run once per (kind, start) and reuse the curves for every rate."""
    values = {**FIXED, **params}
    m = int(np.size(values["M"]))
    model = ANICREEP(**{k: np.broadcast_to(np.asarray(v, dtype=float), (m,)).copy() for k, v in values.items()},
                     **switches)
    curves, failed, done = {}, {}, {}
    for t in tests:
        key = (t.kind, t.sigma_v0, t.k0, t.strain_rate if model.rate_dependent else None)
        if key not in done:
            if t.kind == "CK0UC":
                p0 = t.sigma_v0 * (1.0 + 2.0 * t.k0) / 3.0
                c = labtests.undrained_triaxial(model, values["e0"], p0, t.strains, k0=t.k0, strain_rate=t.strain_rate,
                                                on_failure="nan", route="generic")
            else:
                c = labtests.oedometer_crs(model, values["e0"], t.sigma_v0, t.strains, t.strain_rate, k0=t.k0,
                                           on_failure="nan")
            done[key] = c
        c = done[key]
        curves[t.name] = {name: c[name] for name in t.curves}
        curves[t.name]["stress_ratio"] = c["q"] / c["p"]
        curves[t.name]["mean_stress"] = c["p"]
        failed[t.name] = c["failed"] | ~np.all(np.isfinite(c["q"]), axis=1)
    return curves, failed


class LabForward:
    """Batched forward model (``inference.Likelihood(batch=True)``) of a model class given by its switches;
    ``simulate_tests(tests, params, switches) -> (curves, failed)`` defaults to this module's :func:`simulate` (another
    lab case passes its own; each test names its recorded ``curves``)."""

    def __init__(self, tests, switches, simulate_tests=None):
        self.tests = tuple(tests)
        self.switches = dict(switches)
        self.simulate_tests = simulate if simulate_tests is None else simulate_tests

    def __call__(self, batch):
        names = list(batch[0])
        params = {n: np.array([p[n] for p in batch], dtype=float) for n in names}
        curves, failed = self.simulate_tests(self.tests, params, self.switches)
        out = []
        for i in range(len(batch)):
            bad = [t.name for t in self.tests if failed[t.name][i]]
            out.append(ForwardModelError(f"ANICREEP {self.switches}: lab-test integration failed in {bad}") if bad
                       else {t.name: {c: curves[t.name][c][i] for c in t.curves} for t in self.tests})
        return out


# ------------------------------------------------------------------------------------------------ data
def synthetic_curves(control: bool, seed: int, tests=TESTS):
    """{test: {curve: recorded values}} of the concealed data (or of the control) with noise seed ``seed``."""
    switches = BASE_SWITCHES if control else GENERATING["switches"]
    params = {k: np.array([GENERATING[k]]) for k in ("M", "sigma_p0")}
    if not control:
        params["C_alpha_e"] = np.array([GENERATING["C_alpha_e"]])
    curves, failed = simulate(tests, params, switches)
    if any(f[0] for f in failed.values()):
        raise RuntimeError(f"generating model failed: {failed}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, 1 if control else 0]))
    return {t.name: {c: curves[t.name][c][0] * rng.normal(1.0, NOISE, t.strains.size) for c in t.curves}
            for t in tests}


def observations_from(curves: dict, label: str, tests=TESTS) -> inference.Observations:
    out = []
    for t in tests:
        cs = {c: inference.Curve(100.0 * t.strains, curves[t.name][c], "axial_strain", CURVE_UNITS[c][:-4], "%", "kPa")
              for c in t.curves}
        out.append(inference.Test(t.name, cs, {"synthetic": label, "test_type": t.kind,
                                               "strain_rate_per_s": t.strain_rate}))
    return inference.Observations(out)


def write_data(directory, control: bool, seed: int = 1) -> dict:
    """Write the SYNTHETIC records, one CSV per test, headers naming only the test conditions (not the generating
    model: the diagnosis must find it). Returns {test: path}."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    curves = synthetic_curves(control, seed)
    kind = {"CK0UC": "K0-consolidated undrained triaxial compression", "CRS": "constant-rate-of-strain oedometer"}
    paths = {}
    for t in TESTS:
        header = ["synthetic: NOT MEASURED DATA. Generated with constitutive.labtests from a generating model stated "
                  "in this project's issue-6 proof case (cases/); the file does not name it", f"synthetic_noise: multiplicative c ~ N(1, {NOISE}^2) per point (Eq. 1), seed {seed}",
                  f"test: {t.name}", f"test_type: {t.kind} ({kind[t.kind]})", f"strain_rate_per_s: {t.strain_rate:.6g}",
                  f"sigma_v0_kPa: {t.sigma_v0:g}", f"k0: {t.k0:g}", f"e0: {FIXED['e0']:g}"]
        paths[t.name] = write_records(directory / f"{t.name}.csv", header, {
            "axial_strain_pct": 100.0 * t.strains, **{CURVE_UNITS[c]: curves[t.name][c] for c in t.curves}})
    return paths


def load_data(directory) -> inference.Observations:
    """The shipped records of ``directory`` (one CSV per test of :data:`TESTS`); strains must equal the test grid."""
    parts = []
    for kind, curves in (("CK0UC", {"q": "q", "p": "p"}), ("CRS", {"axial_stress": "sigma_v"})):
        files = {t.name: Path(directory) / f"{t.name}.csv" for t in TESTS if t.kind == kind}
        parts += list(inference.Observations.from_csv(files, x="axial_strain", curves=curves,
                                                      units={"axial_strain": "%", "q": "kPa", "p": "kPa",
                                                             "sigma_v": "kPa"}))
    for t in TESTS:
        x = next(iter(parts[[p.name for p in parts].index(t.name)].curves.values())).x
        if not np.allclose(x, 100.0 * t.strains, rtol=1e-6):
            raise inference.DataError(f"{directory}/{t.name}.csv: axial strains differ from the test grid")
    return inference.Observations(parts)


# ------------------------------------------------------------------------------------------------ covariates
def covariates(like, map_curves: dict, tests=TESTS) -> dict:
    """Per-point covariates (names from physics_catalog.COVARIATES) for every recorded curve: strain rate (test
    condition), time since the start of shearing, strain level |eps_a|, and the MAP simulation's stress ratio and
    p'."""
    cov = {"strain rate": {}, "time": {}, "strain level": {}, "stress ratio": {}, "mean effective stress": {}}
    for t in tests:
        for c in t.curves:
            k = (t.name, c)
            cov["strain rate"][k] = t.strain_rate
            cov["time"][k] = np.abs(t.strains) / t.strain_rate
            cov["strain level"][k] = np.abs(t.strains)
            cov["stress ratio"][k] = map_curves[t.name]["stress_ratio"]
            cov["mean effective stress"][k] = map_curves[t.name]["mean_stress"]
    return cov


# ------------------------------------------------------------------------------------------------ the loop
PRESETS = {"paper": Settings(400, 8, 100), "quick": Settings(200, 5, 60)}


class _Problem(LoopProblem):
    """This case's pieces of the shared loop (cases.calibrate.calibrate_class / run_loop): the programme ``tests``
    run by ``simulate`` (another lab case sets its own)."""

    case = CASE
    model = "ANICREEP"
    base_switches = BASE_SWITCHES
    base_bounds = BASE_BOUNDS
    sigma_bounds = SIGMA_BOUNDS
    tests = TESTS
    simulate = staticmethod(simulate)

    def forward(self, switches):
        return LabForward(self.tests, switches, self.simulate)

    def map_curves(self, params, switches):
        raw, _ = self.simulate(self.tests, {k: np.array([v]) for k, v in params.items()}, switches)
        return {t: {c: v[0] for c, v in cs.items()} for t, cs in raw.items()}

    def covariates(self, like, map_curves):
        return covariates(like, map_curves)

    def summary_extra(self, switches):
        return {"fixed": FIXED, "synthetic": True}

    def description(self, label, base_name):
        return (f"**SYNTHETIC data** ({label}). Base class {base_name} with M, sigma'_p0, sigma_eps free; "
                "catalog: constitutive.physics_catalog.")

    def plot(self, path, like, classes, diag, label):
        plot_loop(path, like, classes, diag, label)


PROBLEM = _Problem()


def calibrate_class(obs, name, switches, bounds, log_uniform, args, out, seed, settings):
    """Calibrate one model class; returns (the class dict of inference.diagnosis.write_input, Posterior, Likelihood,
    MAP raw curves)."""
    return calibrate.calibrate_class(obs, name, switches, bounds, log_uniform, args, out, seed, settings, PROBLEM)


def class_name(switches):
    return calibrate.class_name(switches, "ANICREEP")


def run_loop(obs, args, out: Path, seed: int, settings: Settings, label: str) -> dict:
    """Calibrate, locate, explain, enrich, recalibrate, compare; writes everything into ``out``."""
    return calibrate.run_loop(obs, args, out, seed, settings, label, PROBLEM)


# ------------------------------------------------------------------------------------------------ figure
def plot_loop(path, like, classes, diag, label):
    """Data, base and enriched MAP fits (top row) and the base class's relative residuals with the mismatch regions
    shaded (bottom row), one column per curve kind."""
    plt = study.pyplot()
    names = ["q", "p", "axial_stress"]
    ylabels = {"q": "q (kPa)", "p": "p' (kPa)", "axial_stress": "sigma'_v (kPa)"}
    fig, axes = plt.subplots(2, 3, figsize=(15, 8), sharex="col")
    base = classes[0]
    enriched = classes[1] if len(classes) > 1 else None
    for j, cname in enumerate(names):
        top, bottom = axes[0, j], axes[1, j]
        for i, t in enumerate(like.observations):
            if cname not in t.curves:
                continue
            c, color = t.curves[cname], f"C{i}"
            rate = float(t.conditions["strain_rate_per_s"]) / PER_HOUR
            top.plot(c.x, c.y, "o", ms=3, mfc="none", color=color, label=f"{t.name} ({rate:g} %/h): data")
            top.plot(c.x, base["map_simulated"][t.name, cname], "--", color="k", lw=1)
            if enriched is not None:
                top.plot(c.x, enriched["map_simulated"][t.name, cname], "-", color=color, lw=1.3)
            r = c.y / base["map_simulated"][t.name, cname] - 1.0
            bottom.plot(c.x, 100 * r, "o-", ms=3, lw=0.6, color=color)
            for reg in diag["mismatch_regions"]:
                if reg["test"] == t.name and reg["curve"] == cname:
                    bottom.axvspan(reg["x_start"], reg["x_end"], color=color, alpha=0.15)
        top.set_ylabel(ylabels[cname])
        top.set_xscale("log")
        top.legend(fontsize=7, loc="upper left" if cname == "axial_stress" else "lower right", ncol=2)
        bottom.axhline(0, color="k", lw=0.6)
        bottom.set_xlabel("axial strain (%)")
        bottom.set_ylabel("base residual U_obs/U_sim - 1 (%)")
    fig.suptitle(f"SYNTHETIC data ({label}): {diag['verdict']}; omitted physics: {diag['omitted_physics']}\n"
                 "dashed black: base MAP (rate independent: one curve for all rates)"
                 + ("; solid: enriched MAP" if enriched else "") + "; shaded: mismatch regions of the base class",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------------------------ command line
def _options(ap):
    ap.add_argument("--diagnose", action="store_true", help="run the whole missing-physics loop")
    ap.add_argument("--control", action="store_true", help="negative control: data generated by the base class")
    ap.add_argument("--seeds", type=int, help="repeat the loop on K noise seeds, concealed and control, and tabulate "
                                              "detections and false alarms")
    ap.add_argument("--generate", action="store_true", help="rewrite the shipped synthetic data and exit")


def seeds_table(rows) -> str:
    lines = ["| seed | data | verdict | named | omitted physics | ln B | loop (s) |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lnb = ", ".join(f"{v:+.1f}" for v in r["log_bayes"].values()) or "-"
        lines.append(f"| {r['seed']} | {r['label']} | {r['verdict']} | {', '.join(r['named']) or '-'} | "
                     f"{r['omitted_physics']} | {lnb} | {r['loop_s']:.0f} |")
    hits = sum(r["omitted_physics"] == "viscosity" for r in rows if r["label"] == "concealed")
    alarms = sum(r["omitted_physics"] != "none" or r["verdict"] != "consistent with noise"
                 for r in rows if r["label"] == "control")
    n_c = sum(r["label"] == "concealed" for r in rows)
    n_0 = sum(r["label"] == "control" for r in rows)
    lines += ["", f"Detections (viscosity named and confirmed): {hits}/{n_c}; misses {n_c - hits}/{n_c}. "
                  f"False alarms on the control (structured verdict or any physics adopted): {alarms}/{n_0}."]
    return "\n".join(lines) + "\n"


def main(argv=None):
    args = study.arguments(__doc__, argv, quick_help="N_s 200, at most 5 sweeps per stage, 60 predictive draws",
                           add=_options)
    if args.generate:
        paths = {k: {t: str(p) for t, p in write_data(d, k == "control").items()} for k, d in DATASETS.items()}
        print(json.dumps(paths))
        return 0
    settings = PRESETS["quick" if args.quick else "paper"]
    if args.samples:
        settings = Settings(args.samples, settings.max_steps, settings.predictive_draws)
    out = Path(args.out or Path("results") / CASE)
    if args.seeds:
        rows = []
        for k in range(args.seeds):
            seed = args.seed + k
            for label in ("concealed", "control"):
                obs = observations_from(synthetic_curves(label == "control", seed), f"synthetic, {label}")
                d = run_loop(obs, args, out / f"{label}_seed{seed}", seed, settings, f"{label}, noise seed {seed}")
                rows.append({"seed": seed, "label": label, "verdict": d["verdict"], "omitted_physics":
                             d["omitted_physics"], "named": [c["name"] for c in d["candidates"] if c["named"]],
                             "log_bayes": d["log_bayes"], "loop_s": d["timing"]["loop_s"]})
                (out / "seeds.md").write_text("# Concealed-physics loop over noise seeds (SYNTHETIC data)\n\n"
                                              + seeds_table(rows))
        print((out / "seeds.md").read_text())
        return 0
    label = "control" if args.control else "concealed"
    obs = load_data(DATASETS[label])
    if args.diagnose:
        d = run_loop(obs, args, out / label, args.seed, settings, f"{label}, shipped data")
        print(json.dumps({"case": CASE, "data": label, "verdict": d["verdict"], "omitted_physics": d["omitted_physics"],
                          "log_bayes": d["log_bayes"], "timing": d["timing"]}, default=float))
    else:
        cls, post, _, _ = calibrate_class(obs, class_name(BASE_SWITCHES), BASE_SWITCHES, BASE_BOUNDS, (), args,
                                          out / label, args.seed, settings)
        print(json.dumps({"case": CASE, "data": label, "log_evidence": cls["log_evidence"], "map": post.map}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
