"""A user's own recordings: calibrate a chosen base model on them and, with ``--diagnose``, run the missing-physics loop.

    python -m cases.calibrate study.toml [--diagnose] [--out DIR] [--quick] [--method de|o|both] [--samples N]
                                         [--seed S] [--runs R] [--resume] [--processes P]
    python -m cases.calibrate study.toml --generate [--noise X]   # (re)write the study's SYNTHETIC CSVs

The study file (TOML) names the data files (paths relative to the TOML), the type and conditions of every test, the
base model with its fixed parameters and the priors of the free ones, the bounds of the error parameter sigma_eps and
the sampler settings (schema: README "Your own recordings"; reader: ``cases.study.reading.schema``). Everything is checked
before any solve starts (errors name the TOML file, the table and field, and the bad value; CSV errors name the file,
the column and the line; one line on stderr, exit status 2, a traceback only with ``--debug``), and nothing is
written in ``--out`` when something is wrong. A second run on the same ``--out`` is refused while the first runs.
Example studies with SYNTHETIC data are in cases/examples/.

Test types (``cases.study.programme``): ``triaxial``, ``oedometer_crs``, ``oedometer_creep`` (laboratory drivers of
``constitutive.labtests``) and ``sbp`` (the coupled pressuremeter FE). Base models: ``ModifiedCamClay``, ``ANICREEP``
(switches ``viscous``, ``anisotropy``, ``destructuration``) and ``SIMSAND`` (laboratory tests only; switches
``lode_dependence``, ``state_dependent_dilatancy``, the latter needing n_p and n_d). ``--diagnose`` runs the
missing-physics loop (``cases.study.loop.problem.run_loop`` over ``inference.diagnosis.run_loop``): calibrate the base
class, locate the mismatch, explain it with per-point covariates and ``constitutive.physics_catalog``, recalibrate the
enriched class of the best-ranked named candidate whose enrichment exists for the base model, compare
log-evidences.

Outputs in DIR (default results/calibrate/<study name>): summary.json, report.md, curves.png (recorded vs MAP with
the 95 % posterior predictive band), marginals.png, stages.png, posterior.npz, progress.log; with ``--diagnose``
also diagnosis_input.json/.npz, diagnosis.json/.md, diagnosis.png, loop.json and the enriched class in
DIR/enriched_<candidate>/.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from constitutive.registry import class_name
from inference.executors import mpi_world

from cases.study.cli import UsageError, arguments, command, quantity, run_settings
from cases.study.synthetic.generate import generate
from cases.study.loop.problem import CASE, StudyProblem, run_loop
from cases.study.reading.records import load_observations
from cases.study.runner import announce_compilation, kernel_files, out_lock, run_all, run_directories
from cases.study.reading.schema import load_study

__all__ = ["main"]

DEFAULT_OUT = Path("results") / CASE


def _options(ap):
    ap.add_argument("study", type=Path, help="the study file (TOML)")
    ap.add_argument("--diagnose", action="store_true", help="run the whole missing-physics loop")
    ap.add_argument("--generate", action="store_true", help="(re)write the study's SYNTHETIC CSVs from its "
                    "[synthetic] table and exit")
    ap.add_argument("--noise", type=quantity("noise level (standard deviation of c in Eq. 1)", "-", positive=False),
                    help="with --generate: the noise level (default: the [synthetic] table's)")


@command
def main(argv=None):
    args = arguments(__doc__, argv, quick_help="the study's [sampler.quick] and [fe.quick] settings", add=_options)
    run = run_settings(args)
    if args.generate:
        paths = generate(args.study, noise=args.noise)
        print(json.dumps({k: str(v) for k, v in paths.items()}))
        return 0
    study = load_study(args.study)
    observations, times = load_observations(study.tests)
    problem = StudyProblem(study, observations, times, run.quick, run.processes, run.dispatch)
    settings = study.settings(run.quick, run.samples)
    if args.diagnose and mpi_world() is not None:
        raise UsageError("--diagnose runs without mpirun (use --processes for a local pool)")
    default_out = DEFAULT_OUT / study.name
    kernels = kernel_files(study.spec.cls, fe=any("sbp" in (t.type, t.apparatus) for t in study.tests))
    if args.diagnose:
        with out_lock(run.out or default_out):
            if not run.resume:
                announce_compilation(kernels)
            for one, seed, out in run_directories(run, default_out):
                result = run_loop(problem, observations, one, out, seed, settings, f"study {study.name}, seed {seed}")
                d = result.final
                print(json.dumps({"case": CASE, "study": study.name, "out": str(out), "verdict": d.verdict,
                                  "omitted_physics": d.omitted_physics, "log_bayes": d.log_bayes,
                                  "timing": result.timing}, default=float), flush=True)
        return 0
    name = class_name(study.switches, study.model)
    like = problem.make_likelihood(observations, study.switches)
    prior = problem.prior(study.free, study.log_uniform)

    def finish(one, seed, out, post):
        return problem.finish_class(post, like, name, study.switches, one, out, seed, settings.predictive_draws,
                                    post.wall_s)[1]

    run_all(run, default_out, like, prior, settings.n_samples, {"max_steps": settings.max_steps}, finish, kernels)
    return 0


if __name__ == "__main__":
    sys.exit(main())
