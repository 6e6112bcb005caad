"""Burswood clay, self-boring pressuremeter: ANICREEP parameters from two expansion rates (docs/reference.md section 5).

    python -m cases.burswood_sbp --quick            # the README's main job (DE-TMCMC, local process pool)
    mpirun -n 8 python -m cases.burswood_sbp        # the paper's setting, N_s = 2000, whole FE solves per rank
    python -m cases.burswood_sbp --recordings fast=my_fast.csv slow=my_slow.csv   # your own SBP records

Two SBP expansions at 5.25 m depth (Lee & Fahey), 0.167 %/s and 0.0185 %/s to 10 % cavity strain, in situ
sigma'_v0 = 31 kPa, K0 = 0.9, u0 = 38.8 kPa, k = 3.3e-9 m/s; ANICREEP with nu = 0.3, lambda = 0.40, kappa = 0.026,
e0 = 2.0 fixed (docs/reference.md section 5: the printed Table 5 is garbled; these are the documented defaults,
``--fixed`` overrides) and M, sigma'_p0 (kPa), C_alpha_e and the error sigma_eps identified (Table 4 bounds). One
particle's forward model is both coupled FE solves (``cases.study.forward.sbp``); each runs whole on one process or
MPI rank.

Recordings. The measured Burswood curves are not public. The shipped recordings (cases/data/burswood_sbp/) are
SYNTHETIC: our FE at the paper's DE-TMCMC MAP (M 1.71, sigma'_p0 58.4 kPa, C_alpha_e 0.020) with the paper preset's
mesh and increments, times independent multiplicative noise c ~ N(1, 0.02^2) per point (Eq. 1), made by
:func:`generate_recordings` (``--generate``). Real recordings load from CSV files with columns
``cavity_strain_pct, cavity_pressure_kPa`` and optionally ``pore_pressure_kPa`` (total pore pressure at the wall) and
``time_s``, read and checked as a study's ``sbp`` tests (``cases.study.reading.records``). The wall pore pressure is used
whenever every record has it (``--pressure-only`` drops it): the cavity pressure alone leaves a ridge in (M, sigma'_p0)
(a weaker critical-state ratio and a larger preconsolidation pressure give nearly the same pressure curves), which
the pore pressure, set by the effective stress path, breaks.

Sign convention: pressures are total radial stresses on the cavity wall, compression positive, kPa; cavity strain is
u_a/a0 in % (small strain, as the FE).
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import inference
from constitutive import ANICREEP, ParameterError
from inference import DataError

from cases.study.cli import (UsageError, arguments, command, non_negative_int, pairs, positive_int, quantity,
                             run_settings)
from cases.study.synthetic.generate import generate_sbp
from cases.study.outputs.report import runs_table
from cases.study.reading.presets import FE_FIELDS, PRESETS, Preset
from cases.study.reading.records import generating_values, has_pore_pressure, load_sbp_recordings
from cases.study.runner import announce_compilation, is_root, kernel_files, run_all, throughput
from cases.study.forward.sbp import SBPForward
from cases.study.outputs.sbp import SBPCase, write_sbp_outputs

__all__ = ["SITE", "FIXED", "RATES", "BOUNDS", "GENERATING", "PAPER", "Preset", "PRESETS", "FE_FIELDS",
           "burswood_forward", "check_fixed", "generate_recordings", "main"]

CASE = "burswood_sbp"
DATA = Path(__file__).parent / "data" / "burswood_sbp"

#: in situ state at 5.25 m (docs/reference.md section 5); kPa, m/s
SITE = {"sigma_v0": 31.0, "K0": 0.9, "u0": 38.8, "permeability": 3.3e-9, "a0": 0.0415}
#: ANICREEP parameters held fixed (docs/reference.md section 5 defaults)
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


def burswood_forward(preset, fixed=None, site=None, rates=None, curves=("cavity_pressure",)) -> SBPForward:
    """The SBP forward model of this site: ANICREEP with :data:`FIXED` (updated by ``fixed``) in the FE at
    :data:`SITE` (updated by ``site``), one expansion per test of ``rates`` (default :data:`RATES`)."""
    return SBPForward(preset, {**SITE, **(site or {})}, rates or RATES, {**FIXED, **(fixed or {})}, curves=curves)


def check_fixed(fixed: dict):
    """``--fixed`` values: known names, and ANICREEP accepts them with the identified parameters anywhere in
    :data:`BOUNDS` (checked at the corners of M and sigma'_p0 with C_alpha_e at its bounds): a UsageError naming the
    option and the values otherwise, before any solve."""
    unknown = set(fixed) - set(FIXED)
    if unknown:
        raise UsageError(f"--fixed: unknown parameter(s) {sorted(unknown)}; fixed ones are {sorted(FIXED)}")
    forward = burswood_forward(PRESETS["quick"], fixed)
    for corner in ({k: BOUNDS[k][i] for k in GENERATING} for i in (0, 1)):
        try:
            forward.material(corner)
        except (ParameterError, ValueError) as exc:
            raise UsageError(f"--fixed {' '.join(f'{k}={v:g}' for k, v in fixed.items())}: ANICREEP refuses these "
                             f"values: {' '.join(str(exc).split())}") from None


OUTPUTS = SBPCase(CASE, "Burswood clay SBP", "Burswood SBP", "ANICREEP", PAPER, BOUNDS, UNITS,
                  "; the measured Burswood curves are not public", {"paper_table5": PAPER})


def generate_recordings(directory=DATA, params=None, noise=RECORD_NOISE, seed=2019, preset=PRESETS["paper"],
                        n_points=50, fixed=None, site=None) -> dict:
    """Write SYNTHETIC SBP recordings (one CSV per test) from our FE at ``params`` (default: the paper's MAP),
    with multiplicative noise c ~ N(1, noise^2) on pressure and pore pressure (Eq. 1). Returns {test: path}."""
    params = dict(GENERATING if params is None else params)
    return generate_sbp(directory, burswood_forward(preset, fixed, site), params, noise, seed, n_points,
                        "cases.burswood_sbp.generate_recordings",
                        " (the paper's DE-TMCMC MAP)" if params == GENERATING else "", ["depth_m: 5.25"])


def _options(ap):
    ap.add_argument("--recordings", nargs="+", metavar="TEST=CSV",
                    help="SBP records, e.g. fast=f.csv slow=s.csv (test names must be those of --rates)")
    ap.add_argument("--rates", nargs="+", metavar="TEST=RATE", help="cavity strain rate per test in 1/s "
                    "(default fast=0.00167 slow=0.000185)")
    ap.add_argument("--pressure-only", action="store_true",
                    help="calibrate on the cavity pressure alone even when the records have the wall pore pressure")
    ap.add_argument("--fixed", nargs="+", metavar="NAME=VALUE", help="override fixed ANICREEP values "
                    "(nu, lambda_, kappa, e0, tau)")
    ap.add_argument("--radial-cells", type=positive_int, help="FE cells along the radius, >= 1")
    ap.add_argument("--layers", type=positive_int, help="FE cell layers, >= 1")
    ap.add_argument("--increments", type=positive_int, help="FE load increments to 10 %% cavity strain, >= 1")
    ap.add_argument("--sweeps", type=non_negative_int,
                    help="MCMC sweeps per stage: 1 is the paper's one Metropolis step per resampled particle (the "
                    "paper setting's default), 0 adaptive up to 25 (--quick: adaptive up to 4 by default)")
    ap.add_argument("--max-stages", type=positive_int, default=200, help="stop after this many stages (tests)")
    ap.add_argument("--timeout", type=quantity("time per forward evaluation", "s"),
                    help="seconds per forward evaluation (then a failed particle)")
    ap.add_argument("--generate", action="store_true", help="regenerate the shipped synthetic recordings and exit")
    ap.add_argument("--throughput", type=positive_int, metavar="N",
                    help="benchmark: time N forward evaluations (prior draws) on this executor and exit")


@command
def main(argv=None):
    args = arguments(__doc__, argv, add=_options, quick_help="the README's main job: the paper's 60 radial cells in "
                                                              "one layer, 100 increments, N_s 64")
    run = run_settings(args)
    base = "quick" if run.quick else "paper"
    preset = replace(PRESETS[base], **{k: v for k, v in (("radial_cells", args.radial_cells), ("layers", args.layers),
                                                         ("increments", args.increments)) if v is not None})
    if args.sweeps is not None:
        preset = replace(preset, sweeps=args.sweeps or None)
    label = base if preset == PRESETS[base] else f"{base}, modified"
    fixed = pairs(args.fixed, "--fixed", units={k: (f"fixed {k}", "s" if k == "tau" else "-") for k in FIXED})
    check_fixed(fixed)
    rates = pairs(args.rates, "--rates", units={"": ("cavity strain rate", "1/s")}) or RATES
    for test, rate in rates.items():
        if not rate > 0:
            raise UsageError(f"--rates: {test}={rate:g}: a cavity expansion needs a strain rate > 0 (1/s)")
    if args.generate:
        print(json.dumps({k: str(v) for k, v in generate_recordings(fixed=fixed or None).items()}))
        return 0
    files = pairs(args.recordings, "--recordings", cast=Path) or {t: DATA / f"sbp_{t}.csv" for t in RATES}
    missing = set(files) - set(rates)
    if missing:
        raise UsageError(f"--recordings names test(s) {sorted(missing)} without a cavity strain rate; give --rates")
    rates = {t: rates[t] for t in files}
    with_pore_pressure = {t: has_pore_pressure(p) for t, p in files.items()}
    use_pore_pressure = not args.pressure_only and all(with_pore_pressure.values())
    if not args.pressure_only and any(with_pore_pressure.values()) and not use_pore_pressure:
        having = next(t for t, v in with_pore_pressure.items() if v)
        lacking = next(t for t, v in with_pore_pressure.items() if not v)
        raise DataError(f"{files[lacking]}: no pore_pressure_kPa column while {files[having]} has one: give it in "
                        "every record, or calibrate on the cavity pressure alone with --pressure-only")
    observations = load_sbp_recordings(files, pore_pressure=use_pore_pressure)
    synthetic = any("synthetic" in t.conditions for t in observations)
    truth = generating_values(observations, GENERATING)
    forward = burswood_forward(preset, fixed, rates=rates, curves=("cavity_pressure", "pore_pressure")
                               if use_pore_pressure else ("cavity_pressure",))
    if not run.resume:  # a checkpoint is checked first: no message before its refusal
        announce_compilation(kernel_files(ANICREEP, fe=True))
    forward.compile_material(GENERATING)
    like = inference.Likelihood(observations, forward)
    prior = inference.UniformPrior(BOUNDS)
    if args.throughput:
        throughput(like, prior, run, args.throughput, CASE)
        return 0
    sweeps = preset.sweeps
    settings = dict(max_steps=max(preset.max_steps, sweeps or 0), n_steps=sweeps or "adaptive",
                    min_steps=min(2, sweeps or 2), max_stages=args.max_stages, timeout=args.timeout)

    def finish(one, seed, out, post):
        return write_sbp_outputs(out, OUTPUTS, one, seed, post, like, forward, preset, label, synthetic, truth)

    summaries = run_all(run, Path("results") / CASE, like, prior, run.samples or preset.n_samples, settings, finish)
    if is_root() and len(summaries) > 1:
        table = runs_table(summaries, prior.names, {"generating": truth, **PAPER} if truth else PAPER)
        (Path(run.out or Path("results") / CASE) / "runs.md").write_text(
            "# Burswood SBP: independent runs\n\n" + table + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
