"""The one runner of study files: ``python -m cases.calibrate study.toml`` and the paper's entry points
(``cases.burswood_sbp``, ``cases.toyoura``, ``cases.simsand_synthetic``, each its study file in cases/studies/).

The study file's ``[runner] route`` (:mod:`cases.study.reading.runner_table`) chooses how it is calibrated:
"study" (default; any model and test type, ``--diagnose`` the missing-physics loop, ``--generate`` the
``[synthetic]`` records), "sand" (:mod:`cases.study.routes.sand`) or "sbp" (:mod:`cases.study.routes.sbp`). Every route
takes the common options (:func:`cases.study.cli.arguments`); an option of another route is refused with one line
naming it and the study's route.
"""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import inference
from cases.study.cli import UsageError, arguments, non_negative_int, positive_int, quantity, run_settings
from cases.study.loop.problem import CASE, run_loop
from cases.study.loop.study_problem import StudyProblem
from cases.study.programme import condition_features
from cases.study.reading.records import load_observations
from cases.study.reading.schema import load_study
from cases.study.routes import sand as sand_route
from cases.study.routes import sbp as sbp_route
from cases.study.routes.held_out import predict_held_out
from cases.study.runner import announce_compilation, evaluate_once, kernel_files, out_lock, run_all, run_directories
from cases.study.synthetic.generate import generate
from constitutive.registry import class_name
from inference.executors import mpi_world

__all__ = ["OPTIONS", "main"]

#: each route's own options (argparse dests); the common ones are every route's
OPTIONS = {"study": ("diagnose", "generate", "noise"),
           "sand": ("free", "sweeps", "undrained", "error_groups", "single_sigma", "noise", "generate", "regenerate"),
           "sbp": ("recordings", "rates", "pressure_only", "fixed", "radial_cells", "layers", "increments", "sweeps",
                   "max_stages", "timeout", "generate", "throughput")}


def _comma_list(text):
    return [x.strip() for x in text.split(",") if x.strip()]


def _options(ap, study_path, route=None):
    """The study positional (without ``study_path``) and the options of ``route`` (None: of every route)."""
    if study_path is None:
        ap.add_argument("study", type=Path, help="the study file (TOML)")

    def group(name):
        return ap.add_argument_group(f"route \"{name}\"") if route in (None, name) else None

    shared = ap.add_argument_group("study file")
    shared.add_argument("--generate", action="store_true", help="(re)write the study's SYNTHETIC records from its "
                        "[synthetic] table and exit")
    if route in (None, "study", "sand"):
        shared.add_argument("--noise", type=quantity("noise level (standard deviation of c in Eq. 1)", "-",
                                                      positive=False), help="the noise level of the synthetic records "
                            "(route \"study\": with --generate; route \"sand\": which records, one of [runner] "
                            "noise_levels)")
    if route in (None, "sand", "sbp"):
        shared.add_argument("--sweeps", type=non_negative_int, help="MCMC sweeps per stage (0: adaptive, capped "
                            "by the preset)")
    if g := group("study"):
        g.add_argument("--diagnose", action="store_true", help="run the whole missing-physics loop")
    if g := group("sand"):
        g.add_argument("--free", type=_comma_list, help="comma-separated subset of the free parameters to identify "
                       "(the others held at [runner] hold_at)")
        g.add_argument("--undrained", nargs="+", metavar="FILE[:E0:P0_KPA]",
                       help="undrained recordings (eps_a_pct, q_kPa, u_kPa) replacing [runner] substitutes")
        g.add_argument("--error-groups", nargs="?", const=True, type=Path, metavar="FILE",
                       help="one error parameter per group of curves (Eq. 6g) from FILE's [sigma_eps] table "
                       "(default [runner] error_groups); without it or --single-sigma: one per quantity (stress, "
                       "volume)")
        g.add_argument("--single-sigma", action="store_true", help="one sigma_eps for every curve (Eq. 4): the "
                       "paper's error model, to reproduce its numbers")
        g.add_argument("--regenerate", action="store_true", help="rewrite the synthetic records first, then "
                       "calibrate")
    if g := group("sbp"):
        g.add_argument("--recordings", nargs="+", metavar="TEST=CSV", help="SBP records, e.g. fast=f.csv "
                       "slow=s.csv (test names must have a rate: the study's or --rates)")
        g.add_argument("--rates", nargs="+", metavar="TEST=RATE", help="cavity strain rate per test in 1/s "
                       "(default: the study's tests)")
        g.add_argument("--pressure-only", action="store_true", help="calibrate on the cavity pressure alone even "
                       "when the records have the wall pore pressure")
        g.add_argument("--fixed", nargs="+", metavar="NAME=VALUE", help="override the study's fixed values")
        g.add_argument("--radial-cells", type=positive_int, help="FE cells along the radius, >= 1")
        g.add_argument("--layers", type=positive_int, help="FE cell layers, >= 1")
        g.add_argument("--increments", type=positive_int, help="FE load increments to 10 %% cavity strain, >= 1")
        g.add_argument("--max-stages", type=positive_int, help="stop after this many stages (default 200)")
        g.add_argument("--timeout", type=quantity("time per forward evaluation", "s"),
                       help="seconds per forward evaluation (then a failed particle)")
        g.add_argument("--throughput", type=positive_int, metavar="N",
                       help="benchmark: time N forward evaluations (prior draws) on this executor and exit")


def _refuse_foreign(args, route, study):
    own = set(OPTIONS[route])
    for dest in sorted(set().union(*OPTIONS.values()) - own):
        if getattr(args, dest, None) not in (None, False):
            raise UsageError(f"--{dest.replace('_', '-')}: not an option of a study with [runner] route = "
                             f"{route!r} ({study.path})")


def _complete(args):
    """Every route's option in ``args``, None or False where this command line does not take it."""
    for dest in set().union(*OPTIONS.values()):
        if not hasattr(args, dest):
            setattr(args, dest, None)
    return args


def main(argv, description, study_path=None, quick_help="the study's [sampler.quick] and [fe.quick] settings"):
    """Parse ``argv`` (the study file given as ``study_path`` or as the first positional argument), load the study
    and run it on its route. Returns the exit status."""
    route = load_study(study_path, check_files=False).runner["route"] if study_path else None
    args = arguments(description, argv, quick_help=quick_help, add=lambda ap: _options(ap, study_path, route))
    args = _complete(args)
    run = run_settings(args)
    path = study_path or args.study
    if args.generate and not args.diagnose:
        study = load_study(path, check_files=False)
        if study.runner["route"] == "study":
            print(json.dumps({k: str(v) for k, v in generate(path, noise=args.noise).items()}))
            return 0
    study = load_study(path, check_files=not (args.generate or args.regenerate))
    route = study.runner["route"]
    _refuse_foreign(args, route, study)
    if route == "sand":
        return sand_route.run(study, run, args)
    if route == "sbp":
        return sbp_route.run(study, run, args)
    return _general(study, run, args.diagnose)


def _general(study, run, diagnose) -> int:
    """The general route: calibrate the study's base class, or with ``diagnose`` run the missing-physics loop, on
    the tests to calibrate; the tests with ``role = "predict"`` are predicted from the calibration and scored
    (:func:`cases.study.routes.held_out.predict_held_out`; the loop leaves them out)."""
    recorded, times = load_observations(study.tests)
    calibrated = [t.name for t in study.tests if t.role != "predict"]
    predicted = [t.name for t in study.tests if t.role == "predict"]

    def problem_of(names, processes=run.processes):
        """The study restricted to the tests ``names`` (in the study's order) as a StudyProblem."""
        tests = tuple(t for t in study.tests if t.name in names)
        observations = inference.Observations([recorded[t.name] for t in tests])
        return StudyProblem(replace(study, tests=tests), observations, times, run.quick, processes, run.dispatch)

    def likelihood_of(names):
        sub = problem_of(names, 1)
        return sub.make_likelihood(sub.observations, study.switches)

    problem = problem_of(calibrated)
    observations = problem.observations
    # every test's likelihood, built before any calibration: a predicted curve that no error group takes stops at load
    like_all = likelihood_of(calibrated + predicted) if predicted else None
    settings = study.settings(run.quick, run.samples)
    if diagnose and mpi_world() is not None:
        raise UsageError("--diagnose runs without mpirun (use --processes for a local pool)")
    default_out = Path("results") / CASE / study.name
    kernels = kernel_files(study.spec.cls, fe=any("sbp" in (t.type, t.apparatus) for t in study.tests))
    name = class_name(study.switches, study.model)
    like = problem.make_likelihood(observations, study.switches)
    prior = problem.prior(study.free, study.log_uniform)
    if diagnose:
        with out_lock(run.out or default_out):
            if not run.resume:
                announce_compilation(kernels, lambda: evaluate_once(like, prior))
            for one, seed, out in run_directories(run, default_out):
                result = run_loop(problem, observations, one, out, seed, settings, f"study {study.name}, seed {seed}")
                d = result.final
                print(json.dumps({"case": CASE, "study": study.name, "out": str(out), "verdict": d.verdict,
                                  "omitted_physics": d.omitted_physics, "log_bayes": d.log_bayes,
                                  "timing": result.timing}, default=float), flush=True)
                print(f"report: {out / 'report.md'} (diagnosis: {out / 'diagnosis.md'})", flush=True)
        return 0

    sampler = {"max_steps": settings.max_steps, "max_failure_fraction": problem.failure_fraction}

    def finish(one, seed, out, post):
        lines, extra = [], {}
        if predicted:
            conditions = {t.name: condition_features(t) for t in study.tests}
            lines, entry, _ = predict_held_out(like_all, calibrated, predicted, likelihood_of, prior, post, one, out,
                                               seed, settings.n_samples, sampler, study.name, conditions)
            extra = {"calibration_tests": calibrated, "predicted_tests": predicted, "predictions": entry}
        summary = problem.finish_class(post, like, name, study.switches, one, out, seed, settings.predictive_draws,
                                       post.wall_s, extra=extra)[1]
        if lines:
            report = Path(out) / "report.md"
            report.write_text(report.read_text().rstrip("\n") + "\n\n" + "\n".join(lines) +
                              "\nFigure of the predictions: predictions.png.\n")
        return summary

    run_all(run, default_out, like, prior, settings.n_samples, sampler, finish, kernels)
    return 0
