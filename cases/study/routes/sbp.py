"""The pressuremeter route of the one runner (``[runner] route = "sbp"``): a study file of self-boring pressuremeter
expansions at one site, one particle's forward model being every expansion's coupled FE solve
(:class:`cases.study.forward.sbp.SBPForward`, whole on one process or MPI rank). The paper's Burswood study
(cases/studies/burswood_sbp.toml) is such a study.

Recordings: the study's test files, or ``--recordings TEST=CSV ...`` with ``--rates TEST=RATE`` (cavity strain rate,
1/s) for test names the study does not have; columns ``cavity_strain_pct, cavity_pressure_kPa`` and optionally
``pore_pressure_kPa`` (total pore pressure at the wall) and ``time_s`` (``cases.study.reading.records``). The wall
pore pressure is used whenever every record has it (``--pressure-only`` drops it). Pressures are total radial
stresses on the cavity wall, compression positive, kPa; cavity strain is u_a/a0 in %.

FE and sampler settings: the study's ``[fe]``/``[sampler]`` (``--quick``: ``[fe.quick]``/``[sampler.quick]``), FE
sizes overridden by ``--radial-cells``, ``--layers``, ``--increments``; MCMC sweeps per stage ``[runner] sweeps``
(``--quick``: adaptive), ``--sweeps K`` (0: adaptive). ``--fixed NAME=VALUE`` overrides the study's fixed values,
``--generate`` rewrites the SYNTHETIC recordings from ``[synthetic]`` at the ``[runner] truth`` values with the
full FE setting, ``--throughput N`` times N forward evaluations.
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import inference
from cases.study.checks import StudyError
from cases.study.cli import UsageError, pairs
from cases.study.forward.sbp import SBPForward
from cases.study.outputs.report import runs_table
from cases.study.outputs.sbp import SBPCase, write_sbp_outputs
from cases.study.reading.presets import PRESETS
from cases.study.reading.records import generating_values, has_pore_pressure, load_sbp_recordings
from cases.study.runner import announce_compilation, evaluate_once, is_root, kernel_files, run_all, throughput
from cases.study.synthetic.generate import generate_sbp
from constitutive import ParameterError
from inference import DataError

__all__ = ["site_of", "sbp_forward", "check_fixed", "generate_recordings", "run"]

#: units of the parameters in reports
UNITS = {"sigma_p0": "kPa", "tau": "s"}


def site_of(study) -> dict:
    """The in situ state shared by the study's tests (kPa, m/s, m); a StudyError when they differ."""
    sites = [t.site for t in study.tests]
    if any(s != sites[0] for s in sites):
        raise StudyError(f"{study.path}: the pressuremeter route needs one site: the tests give {sites}")
    return sites[0]


def sbp_forward(study, preset, fixed=None, rates=None, curves=("cavity_pressure",)) -> SBPForward:
    """The SBP forward model of the study: its model with its fixed values (updated by ``fixed``) in the FE at its
    site, one expansion per test of ``rates`` ({test: cavity strain rate, 1/s}; default the study's)."""
    rates = rates or {t.name: t.strain_rate for t in study.tests}
    return SBPForward(preset, site_of(study), rates, {**study.fixed, **(fixed or {})}, curves=curves)


def check_fixed(study, fixed: dict):
    """``--fixed`` values: known names, and the model accepts them with the free parameters anywhere in their
    bounds (checked at the lower and the upper corner): a UsageError naming the option and the values otherwise."""
    unknown = set(fixed) - set(study.fixed)
    if unknown:
        raise UsageError(f"--fixed: unknown parameter(s) {sorted(unknown)}; fixed ones are {sorted(study.fixed)}")
    forward = sbp_forward(study, PRESETS["quick"], fixed)
    for corner in ({k: b[i] for k, b in study.free.items()} for i in (0, 1)):
        try:
            forward.material(corner)
        except (ParameterError, ValueError) as exc:
            raise UsageError(f"--fixed {' '.join(f'{k}={v:g}' for k, v in fixed.items())}: {study.model} refuses "
                             f"these values: {' '.join(str(exc).split())}") from None


def _truth(study) -> dict:
    """The generating values of the study's synthetic records (``[runner] truth``), or its free parameters at
    mid-range without them."""
    key = study.runner["truth"]
    if key is None:
        return {k: 0.5 * (lo + hi) for k, (lo, hi) in study.free.items()}
    return dict(study.references[key].values)


def generate_recordings(study, directory=None, params=None, noise=None, seed=None, preset=None, n_points=None,
                        fixed=None) -> dict:
    """Write SYNTHETIC SBP recordings (one CSV per test) from the FE at ``params`` (default: ``[runner] truth``)
    with multiplicative noise c ~ N(1, noise^2) on pressure and pore pressure (Eq. 1); defaults from
    ``[synthetic]`` and the full FE setting, written beside the study's records. Returns {test: path}."""
    synthetic, truth = study.synthetic, _truth(study)
    params = dict(truth if params is None else params)
    depth = {t.depth for t in study.tests if t.depth is not None}
    return generate_sbp(directory or Path(study.tests[0].file).resolve().parent,
                        sbp_forward(study, preset or study.preset(False), fixed), params,
                        synthetic["noise"] if noise is None else noise, synthetic["seed"] if seed is None else seed,
                        n_points or synthetic["points"],
                        f"python -m cases.calibrate {study.path.name} --generate ([synthetic])",
                        f" ({study.references[study.runner['truth']].source})"
                        if params == truth and study.runner["truth"] else "",
                        [f"depth_m: {d:g}" for d in depth])


def _preset(study, run, args):
    base = "quick" if run.quick else "paper"
    settings = study.settings(run.quick)
    preset = replace(study.preset(run.quick), n_samples=settings.n_samples, max_steps=settings.max_steps,
                     sweeps=None if run.quick else study.runner["sweeps"])
    preset = replace(preset, **{k: v for k, v in (("radial_cells", args.radial_cells), ("layers", args.layers),
                                                  ("increments", args.increments)) if v is not None})
    if args.sweeps is not None:
        preset = replace(preset, sweeps=args.sweeps or None)
    return preset, base if preset == PRESETS[base] else f"{base}, modified"


def run(study, run_settings, args) -> int:
    """Calibrate the pressuremeter study ``study`` with the command line's run settings and pressuremeter options
    (module docstring)."""
    run = run_settings
    preset, label = _preset(study, run, args)
    fixed = pairs(args.fixed, "--fixed",
                  units={k: (f"fixed {k}", UNITS.get(k, "-")) for k in study.fixed})
    check_fixed(study, fixed)
    rates = (pairs(args.rates, "--rates", units={"": ("cavity strain rate", "1/s")})
             or {t.name: t.strain_rate for t in study.tests})
    for test, rate in rates.items():
        if not rate > 0:
            raise UsageError(f"--rates: {test}={rate:g}: a cavity expansion needs a strain rate > 0 (1/s)")
    if args.generate:
        print(json.dumps({k: str(v) for k, v in generate_recordings(study, fixed=fixed or None).items()}))
        return 0
    files = (pairs(args.recordings, "--recordings", cast=Path)
             or {t.name: Path(t.file).resolve() for t in study.tests})
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
    generating = _truth(study)
    truth = generating_values(observations, generating)
    forward = sbp_forward(study, preset, fixed, rates, ("cavity_pressure", "pore_pressure") if use_pore_pressure
                          else ("cavity_pressure",))
    like = inference.Likelihood(observations, forward)
    bounds = {**study.free, "sigma_eps": study.sigma_bounds}
    prior = inference.UniformPrior(bounds)
    if not run.resume:  # a checkpoint is checked first: no message before its refusal
        announce_compilation(kernel_files(study.spec.cls, fe=True), lambda: evaluate_once(like, prior))
    forward.compile_material(generating)
    if args.throughput:
        throughput(like, prior, run, args.throughput, study.name)
        return 0
    sweeps = preset.sweeps
    settings = dict(max_steps=max(preset.max_steps, sweeps or 0), n_steps=sweeps or "adaptive",
                    min_steps=min(2, sweeps or 2), max_stages=args.max_stages or 200, timeout=args.timeout)
    references = {r.source: r.values for k, r in study.references.items() if k != study.runner["truth"]}
    note = study.runner["note"]
    outputs = SBPCase(study.name, study.description, study.description, study.model, references, bounds, UNITS,
                      f"; {note}" if note else "", {"references": references})

    def finish(one, seed, out, post):
        return write_sbp_outputs(out, outputs, one, seed, post, like, forward, preset, label, synthetic, truth)

    default_out = Path("results") / study.name
    summaries = run_all(run, default_out, like, prior, run.samples or preset.n_samples, settings, finish)
    if is_root() and len(summaries) > 1:
        table = runs_table(summaries, prior.names, {"generating": truth, **references} if truth else references)
        (Path(run.out or default_out) / "runs.md").write_text(f"# {study.description}: independent runs\n\n" + table
                                                              + "\n")
    return 0
