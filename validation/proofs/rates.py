"""Concealed physics at lab scale, six strain rates: the first complete missing-physics loop, on SYNTHETIC data.

    python -m validation.concealed --programme rates --quick --diagnose
        # = python -m validation.concealed --programme rates ...
    python -m validation.concealed --programme rates --quick --diagnose  # calibrate, locate, explain, enrich, compare
    python -m validation.concealed --programme rates --quick --diagnose --control
        # negative control (data from the base model)
    python -m validation.concealed --programme rates --quick --seeds 3   # detections and false alarms over noise seeds
    python -m validation.concealed --programme rates --generate          # rewrite the shipped synthetic data

The data are SYNTHETIC (not measurements): seven laboratory tests on a soft clay of Burswood-like properties, run by
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
with M, sigma'_p0 and sigma_eps free. The loop (``--diagnose``, ``cases.study.loop.problem.run_loop``): calibrate the
base class by DE-TMCMC; screen its residuals with per-point covariates (strain rate between tests; time, strain level,
stress ratio and p' along the curves); rank the candidate physics of ``constitutive.physics_catalog`` by signature;
calibrate the enriched class of the best-ranked named candidate that has an implemented enrichment; compare
log-evidences (Bayes factor). ``--control`` replaces the data by recordings generated from the base class itself
(same noise): the tool must then find nothing to enrich. The programme, data and loop problem are those of
``validation.proofs.common``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cases.study.cli import UsageError
from cases.study.loop.problem import run_loop as loop
from cases.study.programme import TestSpec
from cases.study.reading.schema import Settings
from constitutive.registry import class_name
from validation.proofs import common as proofs
from validation.proofs.common import PRESETS

CASE = "concealed_viscosity"
DATA = Path(__file__).parents[1] / "data"
#: shipped data sets: the concealed one and the negative control
DATASETS = {"concealed": DATA / "concealed_lab", "control": DATA / "concealed_control"}
#: ANICREEP parameters held fixed in every class (Burswood-like soft clay, docs/reference.md section 5 defaults)
FIXED = {"lambda_": 0.40, "kappa": 0.026, "e0": 2.0, "nu": 0.25, "tau": 86400.0}
#: the model that made the concealed data (switches and values); never written into the data files
GENERATING = {"switches": {"viscous": True, "anisotropy": True}, "M": 1.45, "sigma_p0": 100.0, "C_alpha_e": 0.02}
BASE_SWITCHES = {"viscous": False, "anisotropy": True}
BASE_BOUNDS = {"M": (0.8, 2.0), "sigma_p0": (40.0, 200.0)}
NOISE = 0.02
PER_HOUR = 1.0 / 360000.0  # 1 %/h in 1/s
KINDS = {"CK0UC": "K0-consolidated undrained triaxial compression", "CRS": "constant-rate-of-strain oedometer"}


def _programme() -> proofs.Programme:
    """T1-T6: CK0UC at six rates to 10 %, O1: CRS at 2 %/h to 25 %; 20 records each, geometric from 0.1 %."""
    tests = [TestSpec(f"T{i + 1}", "triaxial", drainage="undrained", direction="compression", consolidation="K0",
                      sigma_v0=80.0, K0=0.5, strain_rate=r * PER_HOUR)
             for i, r in enumerate((0.1, 0.3, 1.0, 3.0, 10.0, 30.0))]
    tests.append(TestSpec("O1", "oedometer_crs", sigma_v0=80.0, K0=0.5, strain_rate=2.0 * PER_HOUR))
    kind = {t.name: proofs.test_kind(t) for t in tests}
    return proofs.Programme(
        tuple(tests), {t.name: np.geomspace(1e-3, 0.10 if kind[t.name] == "CK0UC" else 0.25, 20) for t in tests},
        {t.name: ("q", "p") if kind[t.name] == "CK0UC" else ("axial_stress",) for t in tests},
        {t.name: {"test_type": f"{kind[t.name]} ({KINDS[kind[t.name]]})", "strain_rate_per_s": t.strain_rate,
                  "sigma_v0_kPa": t.sigma_v0, "k0": t.K0, "e0": FIXED["e0"]} for t in tests})


PROGRAMME = _programme()
TESTS = PROGRAMME.tests
PROBLEM = proofs.ProgrammeProblem(CASE, PROGRAMME, FIXED, BASE_SWITCHES, BASE_BOUNDS, "six CK0UC tests at six rates "
                                  "and one CRS test; catalog: constitutive.physics_catalog.")


def simulate(tests, params: dict, switches: dict):
    """({test: {quantity: (m, 20)}}, {test: failed (m,)}) of the programme for a batch ``params`` {name: (m,)}."""
    return PROGRAMME.forward(FIXED, switches).simulate(params)


def synthetic_curves(control: bool, seed: int):
    """{test: {curve: recorded values}} of the concealed data (or of the control) with noise seed ``seed``."""
    switches = BASE_SWITCHES if control else GENERATING["switches"]
    values = {k: GENERATING[k] for k in (("M", "sigma_p0") if control else ("M", "sigma_p0", "C_alpha_e"))}
    return proofs.synthetic_curves(PROGRAMME, FIXED, switches, values, [seed, 1 if control else 0], NOISE)


def observations_from(curves: dict, label: str):
    return proofs.observations_from(PROGRAMME, curves, label)


def load_data(directory):
    return proofs.load_data(PROGRAMME, directory)


def run_loop(obs, args, out: Path, seed: int, settings: Settings, label: str):
    """Calibrate, locate, explain, enrich, recalibrate, compare; writes everything into ``out``; returns the loop's
    records (``inference.diagnosis.LoopResult``)."""
    return loop(PROBLEM, obs, args, out, seed, settings, label)


def seeds_table(rows) -> str:
    lines = ["| seed | data | verdict | named | omitted physics | ln B | loop (s) |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lnb = ", ".join(f"{v:+.1f}" for v in r["log_bayes"].values()) or "-"
        lines.append(f"| {r['seed']} | {r['label']} | {r['verdict']} | {', '.join(r['named']) or '-'} | "
                     f"{r['omitted_physics']} | {lnb} | {r['loop_s']:.0f} |")
    hits = sum(r["omitted_physics"] == "viscosity" for r in rows if r["label"] == "concealed")
    alarms = sum(r["omitted_physics"] != "none" or r["verdict"] != "consistent with noise"
                 for r in rows if r["label"] == "control")
    n_c, n_0 = (sum(r["label"] == k for r in rows) for k in ("concealed", "control"))
    lines += ["", f"Detections (viscosity named and confirmed): {hits}/{n_c}; misses {n_c - hits}/{n_c}. "
                  f"False alarms on the control (structured verdict or any physics adopted): {alarms}/{n_0}."]
    return "\n".join(lines) + "\n"


def run(args) -> int:
    """The command line of ``validation.concealed --programme rates``."""
    if args.effect not in (None, "viscosity"):
        raise UsageError(f"--effect {args.effect}: the six-rate programme conceals viscosity only")
    if args.generate:
        print(json.dumps({k: {t: str(p) for t, p in proofs.write_data(PROGRAMME, d, synthetic_curves(
            k == "control", 1), NOISE, 1).items()} for k, d in DATASETS.items()}))
        return 0
    preset = PRESETS["quick" if args.quick else "paper"]
    settings = Settings(args.samples or preset.n_samples, preset.max_steps, preset.predictive_draws)
    out = Path(args.out or Path("results") / CASE)
    if args.seeds:
        rows = []
        for seed in range(args.seed, args.seed + args.seeds):
            for label in ("concealed", "control"):
                obs = observations_from(synthetic_curves(label == "control", seed), f"synthetic, {label}")
                result = run_loop(obs, args, out / f"{label}_seed{seed}", seed, settings,
                                  f"{label}, noise seed {seed}")
                d = result.final
                rows.append({"seed": seed, "label": label, "verdict": d.verdict, "omitted_physics": d.omitted_physics,
                             "named": d.named, "log_bayes": d.log_bayes, "loop_s": result.timing["loop_s"]})
                (out / "seeds.md").write_text("# Concealed-physics loop over noise seeds (SYNTHETIC data)\n\n"
                                              + seeds_table(rows))
        print((out / "seeds.md").read_text())
        return 0
    label = "control" if args.control else "concealed"
    obs = load_data(DATASETS[label])
    if args.diagnose:
        result = run_loop(obs, args, out / label, args.seed, settings, f"{label}, shipped data")
        d = result.final
        print(json.dumps({"case": CASE, "data": label, "verdict": d.verdict, "omitted_physics": d.omitted_physics,
                          "log_bayes": d.log_bayes, "timing": result.timing}, default=float))
    else:
        cls, post, _ = PROBLEM.calibrate_class(obs, class_name(BASE_SWITCHES, "ANICREEP"), BASE_SWITCHES, BASE_BOUNDS,
                                               (), args, out / label, args.seed, settings)
        print(json.dumps({"case": CASE, "data": label, "log_evidence": cls.log_evidence, "map": post.map}))
    return 0
