"""Concealed physics at lab scale, parametrised by the hidden effect: one laboratory programme, one base
model class, one negative control, and three hidden effects the missing-physics loop must name without being told.

    python -m validation.concealed --effect anisotropy --quick --diagnose
        # = python -m validation.concealed --scale lab ...
    python -m validation.concealed --scale lab --effect anisotropy --quick --diagnose
        # calibrate, locate, explain, enrich
    python -m validation.concealed --scale lab --effect destructuration --quick --diagnose
    python -m validation.concealed --scale lab --effect viscosity --quick --diagnose
    python -m validation.concealed --scale lab --control --quick --diagnose     # data from the base class itself
    python -m validation.concealed --scale lab --confusion --seeds 2 --quick    # every effect and the control x seeds
    python -m validation.concealed --scale lab --generate                       # rewrite the shipped SYNTHETIC data

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
The loop (``cases.study.loop.problem.run_loop`` on the problem of ``validation.proofs.common``): calibrate the base
class by DE-TMCMC; screen its residuals with per-point covariates (:func:`covariates`: strain rate, time, strain level,
stress path direction, consolidation, overconsolidation, and the MAP's stress ratio and p'); rank the candidate physics
of ``constitutive.physics_catalog`` by signature; calibrate the enriched class of the best-ranked named candidate with
an implemented enrichment; compare log-evidences. The same programme, base class and covariates serve every hidden
effect, so the tool is told nothing but the data.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from cases.study.cli import UsageError
from cases.study.loop.covariates import post_peak_strain
from cases.study.loop.problem import run_loop as loop
from cases.study.programme import TestSpec
from cases.study.reading.schema import Settings
from constitutive.registry import class_name
from validation.proofs import common as proofs
from validation.proofs.common import PRESETS

CASE = "concealed_lab"
DATA = Path(__file__).parents[1] / "data" / "concealed_programme"

#: ANICREEP parameters held fixed in every class (Burswood-like soft clay, docs/reference.md section 5 defaults)
FIXED = {"lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "nu": 0.25, "tau": 86400.0}
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
NOISE = 0.02
K0 = 0.5
PER_HOUR = 1.0 / 360000.0  # 1 %/h in 1/s


def _programme() -> proofs.Programme:
    """Twelve undrained triaxial tests: consolidation x direction x sigma'_v0 40, 60, 80 kPa, rates 0.3, 1, 3 %/h in a
    Latin square; 20 records each, geometric from 0.1 % to 15 % (extension negative). An isotropic test starts at the
    mean stress of the K0 state of its sigma'_v0 (kept in the record for the overconsolidation covariate)."""
    tests, strains, conditions = [], {}, {}
    groups = [(c, d) for c in ("K0", "isotropic") for d in ("compression", "extension")]
    for g, (cons, direction) in enumerate(groups):
        for i, sv in enumerate((40.0, 60.0, 80.0)):
            p0, k0 = sv * (1.0 + 2.0 * K0) / 3.0, (K0 if cons == "K0" else 1.0)
            start = dict(K0=K0) if cons == "K0" else dict(p0=p0)
            t = TestSpec(f"T{len(tests) + 1:02d}", "triaxial", drainage="undrained", direction=direction,
                         consolidation=cons, sigma_v0=sv, strain_rate=(0.3, 1.0, 3.0)[(i + g) % 3] * PER_HOUR, **start)
            tests.append(t)
            strains[t.name] = (1.0 if direction == "compression" else -1.0) * np.geomspace(1e-3, 0.15, 20)
            conditions[t.name] = {"e0": FIXED["e0"], "test_type": proofs.test_kind(t), "consolidation": cons,
                                  "stress_path_direction": direction, "sigma_v0_kPa": sv, "k0": k0, "p0_kPa": p0,
                                  "strain_rate_per_s": t.strain_rate}
    return proofs.Programme(tuple(tests), strains, {t.name: ("p", "radial_stress") for t in tests}, conditions)


PROGRAMME = _programme()
TESTS = PROGRAMME.tests


def extra_covariates(like, map_curves: dict) -> dict:
    """The overconsolidation sigma'_p0(MAP)/sigma'_v0 and the post-peak strain of each record."""
    return {"overconsolidation": {t.name: float(map_curves[t.name]["overconsolidation"]) for t in TESTS},
            "post-peak strain": {t.name: post_peak_strain(np.abs(PROGRAMME.strains[t.name]), np.abs(3.0 * (
                like.observations[t.name].curves["p"].y - like.observations[t.name].curves["radial_stress"].y)))
                for t in TESTS}}


PROBLEM = proofs.ProgrammeProblem(
    CASE, PROGRAMME, FIXED, BASE_SWITCHES, BASE_BOUNDS, "twelve undrained triaxial tests (K0/isotropic consolidation x "
    "compression/extension x 3 stresses, 3 rates); catalog: constitutive.physics_catalog.", extra_covariates)


def covariates(like, map_curves: dict) -> dict:
    """Per-point covariates: those of every proof (``cases.study.loop.covariates.programme_covariates``: strain rate,
    time, strain level, the MAP's stress ratio and p', stress path direction, consolidation), then
    :func:`extra_covariates`."""
    return PROBLEM.curve_covariates(like, map_curves)


def simulate(tests, params: dict, switches: dict):
    """({test: {quantity: (m, 20)}}, {test: failed (m,)}) of the programme for a batch ``params`` {name: (m,)}."""
    return PROGRAMME.forward(FIXED, switches).simulate(params)


def generating_switches(effect: str) -> dict:
    return {**BASE_SWITCHES, **EFFECTS[effect]["switches"]}


def synthetic_curves(effect: str, seed: int):
    """{test: {curve: recorded values}} of the data with hidden ``effect`` ("none": the control), noise seed
    ``seed``."""
    return proofs.synthetic_curves(PROGRAMME, FIXED, generating_switches(effect),
                                   {**GENERATING, **EFFECTS[effect]["values"]}, [seed, list(EFFECTS).index(effect), 7],
                                   NOISE)


def load_data(directory):
    return proofs.load_data(PROGRAMME, directory)


def run_loop(obs, args, out: Path, seed: int, settings: Settings, label: str, problem=PROBLEM):
    """Calibrate, locate, explain, enrich, recalibrate, compare; writes everything into ``out``."""
    return loop(problem, obs, args, out, seed, settings, label)


# ------------------------------------------------------------------------------------------------ confusion table
def row_of(effect: str, seed: int, result) -> dict:
    d = result.final
    return {"hidden": effect, "seed": seed, "verdict": d.verdict, "named": d.named,
            "omitted_physics": d.omitted_physics, "log_bayes": d.log_bayes, "loop_s": result.timing["loop_s"],
            "calibration_s": result.timing["calibration_s"]}


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


def run(args) -> int:
    """The command line of ``validation.concealed --scale lab``."""
    args.effect = args.effect or "anisotropy"
    if args.effect not in EFFECTS or args.effect == "none":
        raise UsageError(f"--effect {args.effect}: choose among {', '.join(e for e in EFFECTS if e != 'none')}")
    if args.generate:
        print(json.dumps({e: str(proofs.write_data(PROGRAMME, DATA / spec["dataset"], synthetic_curves(e, 1), NOISE, 1)[
            "T01"].parent) for e, spec in EFFECTS.items()}))
        return 0
    preset = PRESETS["quick" if args.quick else "paper"]
    settings = Settings(args.samples or preset.n_samples, preset.max_steps, preset.predictive_draws)
    out = Path(args.out or Path("results") / CASE)
    effect = "none" if args.control else args.effect
    if args.confusion or args.seeds:
        effects = list(EFFECTS) if args.confusion else [effect]
        rows = []
        for k in range(args.seeds or 2):
            seed = args.seed + k
            for e in effects:
                obs = proofs.observations_from(PROGRAMME, synthetic_curves(e, seed),
                                               f"synthetic, {EFFECTS[e]['dataset']}")
                d = run_loop(obs, args, out / f"{EFFECTS[e]['dataset']}_seed{seed}", seed, settings,
                             f"{EFFECTS[e]['dataset']}, noise seed {seed}")
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
        result = run_loop(obs, args, out / dataset, args.seed, settings, f"{dataset}, shipped data")
        d = result.final
        print(json.dumps({"case": CASE, "data": dataset, "verdict": d.verdict, "omitted_physics": d.omitted_physics,
                          "log_bayes": d.log_bayes, "timing": result.timing}, default=float))
    else:
        cls, post, _ = PROBLEM.calibrate_class(obs, class_name(BASE_SWITCHES, "ANICREEP"), BASE_SWITCHES,
                                               BASE_BOUNDS, (), args, out / dataset, args.seed, settings)
        print(json.dumps({"case": CASE, "data": dataset, "log_evidence": cls.log_evidence, "map": post.map,
                          "wall_s": time.perf_counter() - t0}))
    return 0
