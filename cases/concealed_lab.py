"""Concealed physics at lab scale, parametrised by the hidden effect (issue 6): one laboratory programme, one base
model class, one negative control, and three hidden effects the missing-physics loop must name without being told.

    python -m cases.concealed_lab --effect anisotropy --quick --diagnose      # calibrate, locate, explain, enrich
    python -m cases.concealed_lab --effect destructuration --quick --diagnose
    python -m cases.concealed_lab --effect viscosity --quick --diagnose
    python -m cases.concealed_lab --control --quick --diagnose                # data from the base class itself
    python -m cases.concealed_lab --confusion --seeds 2 --quick               # every effect and the control x seeds
    python -m cases.concealed_lab --generate                                   # rewrite the shipped SYNTHETIC data

The data are SYNTHETIC (not measurements): twelve undrained triaxial tests on a soft clay of Burswood-like properties
(lambda 0.40, kappa 0.026, e0 2.0, nu 0.25 fixed in every class), run by ``constitutive.labtests`` on one material
point with a *generating* model stated in :data:`EFFECTS` (this module, never in the data files), times independent
multiplicative noise c ~ N(1, 0.02^2) per point (Eq. 1). The programme crosses
- consolidation: K0 (sigma'_h0 = 0.5 sigma'_v0) or isotropic (p'_0 = the K0 test's mean stress),
- stress path direction: compression or extension (axial strain to +15 % or -15 %, 20 geometric points from 0.1 %),
- consolidation stress sigma'_v0 = 40, 60, 80 kPa (below the natural preconsolidation stress 100 kPa),
- axial strain rate 0.3, 1 or 3 %/h, assigned as a Latin square so that the rate is balanced against direction,
  consolidation and stress;
each test records the mean and the radial effective stress (p' and sigma'_r = sigma_r - u; both stay well above zero
in compression and in extension, so relative residuals are well defined: q changes sign in K0 extension and
sigma'_a falls to about (1 - 2M/3) p' at critical state in extension). Every test condition is in the file header.

The base model class is the rate-independent, isotropic, unstructured ANICREEP (``viscous=False,
anisotropy=False, destructuration=False``: Modified Cam Clay with (1 + e0)) with M, sigma'_p0 and sigma_eps free.
Hidden effects (the generating model differs from the base class by exactly one switch):
- ``anisotropy``: the S-CLAY1 rotated surfaces with rotational hardening (alpha_K0, omega, omega_d from M);
- ``destructuration``: S-CLAY1S bonding (chi0 = 6, xi = 9, xi_d = 0.2; sigma'_p0 is the apparent, structured
  preconsolidation stress);
- ``viscosity``: the overstress rate law with C_alpha_e = 0.02 (tau = 1 day);
- control: the base class itself.
The loop (``cases.calibrate.run_loop``, shared with ``cases.concealed_viscosity``): calibrate the base class by
DE-TMCMC; screen its residuals with per-point covariates (:func:`covariates`: strain rate, time, strain level, stress
path direction, consolidation, overconsolidation, and the MAP's stress ratio and p'); rank the candidate physics of
``constitutive.physics_catalog`` by signature; calibrate the enriched class of the best-ranked named candidate with
an implemented enrichment; compare log-evidences. The same programme, base class and covariates serve every hidden
effect, so the tool is told nothing but the data.
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import inference
from constitutive import ANICREEP, labtests

from . import concealed_viscosity as cv
from . import study
from .calibrate import Settings, calibrate_class, class_name, run_loop
from .study import write_records
from .concealed_viscosity import FIXED, NOISE, PER_HOUR

CASE = "concealed_lab"
DATA = Path(__file__).parent / "data" / "concealed_programme"

#: the base class (rate independent, isotropic, unstructured) and its free parameters
BASE_SWITCHES = {"viscous": False, "anisotropy": False, "destructuration": False}
BASE_BOUNDS = {"M": (0.8, 2.0), "sigma_p0": (40.0, 200.0)}
#: values shared by every generating model
GENERATING = {"M": 1.2, "sigma_p0": 100.0}
#: hidden effects: the generating model's switches and extra parameters, and the blind name of its shipped data set
#: (directory names and files never name the effect). "none" is the negative control.
EFFECTS = {
    "anisotropy": {"switches": {"anisotropy": True}, "values": {}, "dataset": "set_A"},
    "destructuration": {"switches": {"destructuration": True}, "values": {"chi0": 6.0, "xi": 9.0, "xi_d": 0.2},
                        "dataset": "set_B"},
    "viscosity": {"switches": {"viscous": True}, "values": {"C_alpha_e": 0.02}, "dataset": "set_C"},
    "none": {"switches": {}, "values": {}, "dataset": "set_D"},
}
K0 = 0.5
CURVES = ("p", "radial_stress")
CURVE_UNITS = {"p": "p_kPa", "radial_stress": "sigma_r_kPa"}


@dataclass(frozen=True)
class Triaxial:
    """One undrained triaxial test: consolidation "K0" | "isotropic", direction "compression" | "extension",
    sigma'_v0 (kPa) of the K0 state (the isotropic test starts at the same mean stress), axial strain rate (1/s)."""

    name: str
    consolidation: str
    direction: str
    sigma_v0: float
    strain_rate: float

    @property
    def strains(self):
        """Recorded axial strains (-), signed (extension negative): geometric from 0.1 % to 15 %, 20 points."""
        return (1.0 if self.direction == "compression" else -1.0) * np.geomspace(1e-3, 0.15, 20)

    @property
    def k0(self):
        return K0 if self.consolidation == "K0" else 1.0

    @property
    def p0(self):
        return self.sigma_v0 * (1.0 + 2.0 * K0) / 3.0

    @property
    def curves(self):
        return CURVES

    @property
    def kind(self):
        return f"C{'K0' if self.consolidation == 'K0' else 'I'}U{'C' if self.direction == 'compression' else 'E'}"


def _programme():
    tests, groups = [], [(c, d) for c in ("K0", "isotropic") for d in ("compression", "extension")]
    rates, stresses = (0.3, 1.0, 3.0), (40.0, 60.0, 80.0)
    for g, (cons, direction) in enumerate(groups):
        for i, sv in enumerate(stresses):
            tests.append(Triaxial(f"T{len(tests) + 1:02d}", cons, direction, sv, rates[(i + g) % 3] * PER_HOUR))
    return tuple(tests)


TESTS = _programme()


# ------------------------------------------------------------------------------------------------ forward model
def simulate(tests, params: dict, switches: dict):
    """Curves of every test for a batch: params {name: (m,) array}; returns ({test: {curve: (m, 20)}}, {test:
    failed (m,)}); curves p', sigma'_r and, for the covariates, the stress ratio q/p' and p'. The tests run as one
    batch of m x (number of tests) material points (per strain rate for a rate-dependent class: the drivers take one
    rate per call)."""
    values = {**FIXED, **params}
    m = int(np.size(values["M"]))
    probe = ANICREEP(**{k: np.broadcast_to(np.asarray(v, dtype=float), (m,))[:1] for k, v in values.items()},
                     **switches)
    groups = {}
    for t in tests:
        groups.setdefault(t.strain_rate if probe.rate_dependent else None, []).append(t)
    curves, failed = {}, {}
    for group in groups.values():
        k = len(group)  # points ordered test-major: test j's particles are rows j*m ... (j+1)*m - 1
        model = ANICREEP(**{n: np.tile(np.broadcast_to(np.asarray(v, dtype=float), (m,)), k)
                            for n, v in values.items()}, **switches)
        c = labtests.undrained_triaxial(model, values["e0"], np.repeat([t.p0 for t in group], m),
                                        np.repeat([t.strains for t in group], m, axis=0),
                                        k0=np.repeat([t.k0 for t in group], m), strain_rate=group[0].strain_rate,
                                        on_failure="nan", route="generic")
        for j, t in enumerate(group):
            rows = slice(j * m, (j + 1) * m)
            curves[t.name] = {name: c[name][rows] for name in CURVES}
            curves[t.name]["stress_ratio"] = c["q"][rows] / c["p"][rows]
            curves[t.name]["mean_stress"] = c["p"][rows]
            failed[t.name] = c["failed"][rows] | ~np.all(np.isfinite(c["q"][rows]), axis=1)
    return curves, failed


# ------------------------------------------------------------------------------------------------ data
def generating_switches(effect: str) -> dict:
    return {**BASE_SWITCHES, **EFFECTS[effect]["switches"]}


def synthetic_curves(effect: str, seed: int, tests=TESTS):
    """{test: {curve: recorded values}} of the data with hidden ``effect`` ("none": the control), noise seed ``seed``."""
    params = {k: np.array([v]) for k, v in {**GENERATING, **EFFECTS[effect]["values"]}.items()}
    curves, failed = simulate(tests, params, generating_switches(effect))
    if any(f[0] for f in failed.values()):
        raise RuntimeError(f"generating model failed: {failed}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, list(EFFECTS).index(effect), 7]))
    return {t.name: {c: curves[t.name][c][0] * rng.normal(1.0, NOISE, t.strains.size) for c in CURVES}
            for t in tests}


def _conditions(t: Triaxial) -> dict:
    return {"test_type": t.kind, "consolidation": t.consolidation, "stress_path_direction": t.direction,
            "sigma_v0_kPa": t.sigma_v0, "k0": t.k0, "p0_kPa": t.p0, "strain_rate_per_s": t.strain_rate}


def observations_from(curves: dict, label: str, tests=TESTS) -> inference.Observations:
    return inference.Observations([
        inference.Test(t.name, {c: inference.Curve(100.0 * t.strains, curves[t.name][c], "axial_strain",
                                                   CURVE_UNITS[c][:-4], "%", "kPa") for c in CURVES},
                       {"synthetic": label, **_conditions(t)}) for t in tests])


def write_data(directory, effect: str, seed: int = 1) -> dict:
    """Write the SYNTHETIC records of one data set, one CSV per test; headers name only the test conditions (not the
    generating model: the diagnosis must find it). Returns {test: path}."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    curves = synthetic_curves(effect, seed)
    paths = {}
    for t in TESTS:
        header = ["synthetic: NOT MEASURED DATA. Generated with constitutive.labtests from a generating model stated "
                  "in this project's issue-6 proof case (cases/); the file does not name it",
                  f"synthetic_noise: multiplicative c ~ N(1, {NOISE}^2) per point (Eq. 1), seed {seed}",
                  f"test: {t.name}", f"e0: {FIXED['e0']:g}",
                  *(f"{k}: {v:.6g}" if isinstance(v, float) else f"{k}: {v}" for k, v in _conditions(t).items())]
        paths[t.name] = write_records(directory / f"{t.name}.csv", header, {
            "axial_strain_pct": 100.0 * t.strains, **{CURVE_UNITS[c]: curves[t.name][c] for c in CURVES}})
    return paths


def load_data(directory) -> inference.Observations:
    """The shipped records of ``directory`` (one CSV per test of :data:`TESTS`); strains must equal the test grid."""
    files = {t.name: Path(directory) / f"{t.name}.csv" for t in TESTS}
    obs = inference.Observations.from_csv(files, x="axial_strain", curves={c: u[:-4] for c, u in CURVE_UNITS.items()},
                                          units={"axial_strain": "%", "p": "kPa", "sigma_r": "kPa"})
    for t in TESTS:
        x = next(iter(obs[t.name].curves.values())).x
        if not np.allclose(x, 100.0 * t.strains, rtol=1e-6):
            raise inference.DataError(f"{directory}/{t.name}.csv: axial strains differ from the test grid")
    return obs


# ------------------------------------------------------------------------------------------------ covariates
def covariates(like, map_curves: dict, tests=TESTS) -> dict:
    """Per-point covariates (names from physics_catalog.COVARIATES) for every recorded curve: those of
    ``cases.concealed_viscosity.covariates`` (strain rate, time since the start of shearing, strain level |eps_a|,
    the MAP simulation's stress ratio q/p' and p'), the test conditions stress path direction, consolidation and
    overconsolidation sigma'_p0(MAP)/sigma'_v0 (from ``map_curves[test]["overconsolidation"]``), and the post-peak
    strain of each record (:func:`post_peak_strain`)."""
    cov = cv.covariates(like, map_curves, tests)
    extra = {"stress path direction": lambda t: t.direction, "consolidation": lambda t: t.consolidation,
             "overconsolidation": lambda t: float(map_curves[t.name]["overconsolidation"]),
             "post-peak strain": lambda t: post_peak_strain(np.abs(t.strains), np.abs(
                 3.0 * (like.observations[t.name].curves["p"].y - like.observations[t.name].curves["radial_stress"].y)))}
    for name, value in extra.items():
        cov[name] = {t.name: value(t) for t in tests}
    return cov


def post_peak_strain(strain, deviator):
    """|strain| beyond the strain of the largest recorded |q|, NaN up to that point (and everywhere when the record
    peaks at its last point): the covariate is defined on the softening branch only."""
    k = int(np.argmax(deviator))
    return np.where(np.arange(strain.size) > k, strain - strain[k], np.nan)


# ------------------------------------------------------------------------------------------------ the loop
class LabProblem(cv._Problem):
    """The loop problem of cases.concealed_viscosity (model, sigma_eps prior, summary, forward model) with this case's
    programme and simulation, base class, covariates, description and figure."""

    case = CASE
    base_switches = BASE_SWITCHES
    base_bounds = BASE_BOUNDS
    tests = TESTS
    simulate = staticmethod(simulate)

    def map_curves(self, params, switches):
        """The MAP curves with each test's overconsolidation sigma'_p0 / sigma'_v0 (a covariate)."""
        raw = super().map_curves(params, switches)
        return {t.name: {**raw[t.name], "overconsolidation": params["sigma_p0"] / t.sigma_v0} for t in TESTS}

    def covariates(self, like, map_curves):
        return covariates(like, map_curves)

    def description(self, label, base_name):
        return (f"**SYNTHETIC data** ({label}). Base class {base_name} with M, sigma'_p0, sigma_eps free; twelve "
                "undrained triaxial tests (K0/isotropic consolidation x compression/extension x 3 stresses, 3 rates); "
                "catalog: constitutive.physics_catalog.")

    def plot(self, path, like, classes, diag, label):
        plot_loop(path, like, classes, diag, label)


PROBLEM = LabProblem()


# ------------------------------------------------------------------------------------------------ figure
GROUPS = ("CK0UC", "CK0UE", "CIUC", "CIUE")


def plot_loop(path, like, classes, diag, label):
    """Per test type (columns): recorded q = 3(p' - sigma'_r) against axial strain with the base (dashed) and enriched
    (solid) MAP (top), and the base class's relative residuals of p' (circles) and sigma'_r (crosses) with the
    mismatch regions shaded (bottom)."""
    plt = study.pyplot()
    fig, axes = plt.subplots(2, len(GROUPS), figsize=(4.6 * len(GROUPS), 8), sharex="col")
    base, enriched = classes[0], (classes[1] if len(classes) > 1 else None)
    for j, group in enumerate(GROUPS):
        top, bottom = axes[0, j], axes[1, j]
        for i, t in enumerate(x for x in TESTS if x.kind == group):
            color = f"C{i}"
            curves = like.observations[t.name].curves
            x = curves["p"].x

            def q(values):
                return 3.0 * (values[t.name, "p"] - values[t.name, "radial_stress"])

            recorded = {(t.name, c): curves[c].y for c in CURVES}
            top.plot(x, q(recorded), "o", ms=3, mfc="none", color=color,
                     label=f"{t.name}: sigma'_v0 {t.sigma_v0:g} kPa, {t.strain_rate / PER_HOUR:g} %/h")
            top.plot(x, q(base["map_simulated"]), "--", color=color, lw=1)
            if enriched is not None:
                top.plot(x, q(enriched["map_simulated"]), "-", color=color, lw=1.3)
            for c, marker in zip(CURVES, ("o-", "x-")):
                bottom.plot(x, 100 * (curves[c].y / base["map_simulated"][t.name, c] - 1.0), marker, ms=3, lw=0.5,
                            color=color)
            for reg in diag["mismatch_regions"]:
                if reg["test"] == t.name:
                    bottom.axvspan(reg["x_start"], reg["x_end"], color=color, alpha=0.12)
        top.set_title(group, fontsize=10)
        top.set_ylabel("q = sigma'_a - sigma'_r (kPa)")
        top.legend(fontsize=7)
        bottom.axhline(0, color="k", lw=0.6)
        bottom.set_xlabel("axial strain (%)")
        bottom.set_ylabel("base residual U_obs/U_sim - 1 (%): o p', x sigma'_r")
    fig.suptitle(f"SYNTHETIC data ({label}): {diag['verdict']}; omitted physics: {diag['omitted_physics']}\n"
                 "dashed: base MAP" + ("; solid: enriched MAP" if enriched else "")
                 + "; shaded: mismatch regions of the base class", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ------------------------------------------------------------------------------------------------ confusion table
def row_of(effect: str, seed: int, d: dict) -> dict:
    return {"hidden": effect, "seed": seed, "verdict": d["verdict"], "named": [c["name"] for c in d["candidates"]
                                                                                if c["named"]],
            "omitted_physics": d["omitted_physics"], "log_bayes": d["log_bayes"], "loop_s": d["timing"]["loop_s"],
            "calibration_s": d["timing"]["calibration_s"]}


def confusion_markdown(rows) -> str:
    """The runs and the confusion matrix (true hidden effect x omitted physics named by the loop)."""
    lines = ["| hidden effect | seed | verdict | named candidates | omitted physics (named) | ln B | loop (s) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lnb = ", ".join(f"{k}: {v:+.1f}" for k, v in r["log_bayes"].items()) or "-"
        lines.append(f"| {r['hidden']} | {r['seed']} | {r['verdict']} | {', '.join(r['named']) or '-'} | "
                     f"**{r['omitted_physics']}** | {lnb} | {r['loop_s']:.0f} |")
    truths = [e for e in EFFECTS if any(r["hidden"] == e for r in rows)]
    named = list(EFFECTS) + sorted({r["omitted_physics"] for r in rows} - set(EFFECTS))
    lines += ["", "Confusion matrix (rows: hidden effect, 'none' = control; columns: omitted physics the loop names):",
              "", "| hidden \\ named | " + " | ".join(named) + " |", "|---" * (len(named) + 1) + "|"]
    for e in truths:
        counts = [sum(r["hidden"] == e and r["omitted_physics"] == n for r in rows) for n in named]
        lines.append(f"| {e} | " + " | ".join(str(c) for c in counts) + " |")
    right = sum(r["hidden"] == r["omitted_physics"] for r in rows)
    lines += ["", f"Correct: {right}/{len(rows)}."]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------------ command line
def _options(ap):
    ap.add_argument("--effect", choices=[e for e in EFFECTS if e != "none"], default="anisotropy",
                    help="the hidden effect of the data (default anisotropy)")
    ap.add_argument("--control", action="store_true", help="negative control: data generated by the base class")
    ap.add_argument("--diagnose", action="store_true", help="run the whole missing-physics loop")
    ap.add_argument("--seeds", type=int, help="repeat the loop on K noise seeds (from --seed), data made in memory")
    ap.add_argument("--confusion", action="store_true", help="every hidden effect and the control x --seeds K "
                                                             "(default 2): runs and confusion matrix")
    ap.add_argument("--generate", action="store_true", help="rewrite the shipped synthetic data and exit")


def main(argv=None):
    args = study.arguments(__doc__, argv, quick_help="N_s 200, at most 5 sweeps per stage, 60 predictive draws",
                           add=_options)
    if args.generate:
        print(json.dumps({e: str(write_data(DATA / spec["dataset"], e)["T01"].parent) for e, spec in EFFECTS.items()}))
        return 0
    preset = cv.PRESETS["quick" if args.quick else "paper"]  # the same sampler settings as the viscosity case
    settings = Settings(args.samples or preset.n_samples, preset.max_steps, preset.predictive_draws)
    out = Path(args.out or Path("results") / CASE)
    effect = "none" if args.control else args.effect
    if args.confusion or args.seeds:
        effects = list(EFFECTS) if args.confusion else [effect]
        rows = []
        for k in range(args.seeds or 2):
            seed = args.seed + k
            for e in effects:
                obs = observations_from(synthetic_curves(e, seed), f"synthetic, {EFFECTS[e]['dataset']}")
                d = run_loop(obs, args, out / f"{EFFECTS[e]['dataset']}_seed{seed}", seed, settings,
                             f"{EFFECTS[e]['dataset']}, noise seed {seed}", PROBLEM)
                rows.append(row_of(e, seed, d))
                (out / "confusion.json").write_text(json.dumps(rows, indent=1, default=float))
                (out / "confusion.md").write_text("# Concealed physics at lab scale (SYNTHETIC data)\n\n"
                                                  + confusion_markdown(rows))
        print((out / "confusion.md").read_text())
        return 0
    dataset = EFFECTS[effect]["dataset"]
    obs = load_data(DATA / dataset)
    t0 = time.perf_counter()
    if args.diagnose:
        d = run_loop(obs, args, out / dataset, args.seed, settings, f"{dataset}, shipped data", PROBLEM)
        print(json.dumps({"case": CASE, "data": dataset, "verdict": d["verdict"], "omitted_physics":
                          d["omitted_physics"], "log_bayes": d["log_bayes"], "timing": d["timing"]}, default=float))
    else:
        cls, post, _, _ = calibrate_class(obs, class_name(BASE_SWITCHES), BASE_SWITCHES, BASE_BOUNDS, (), args,
                                          out / dataset, args.seed, settings, PROBLEM)
        print(json.dumps({"case": CASE, "data": dataset, "log_evidence": cls["log_evidence"], "map": post.map,
                          "wall_s": time.perf_counter() - t0}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
