"""A user's own recordings: calibrate a chosen base model on them and, with ``--diagnose``,
run the missing-physics loop.

    python -m cases.calibrate study.toml [--diagnose] [--out DIR] [--quick] [--method de|o|both] [--samples N]
                                         [--seed S] [--runs R] [--resume] [--processes P]
    python -m cases.calibrate study.toml --generate [--noise X]   # (re)write the study's SYNTHETIC CSVs

The study file (TOML) names the data files (paths relative to the TOML), the type and conditions of every test, the
base model with its fixed parameters and the priors of the free ones, the bounds of the error parameter sigma_eps and
the sampler settings (schema: README "Your own recordings"; reader: ``cases.study.reading.schema``). Everything is
checked before any solve starts (errors name the TOML file, the table and field, and the bad value; CSV errors name the
file, the column and the line; one line on stderr, exit status 2, a traceback only with ``--debug``), and nothing is
written in ``--out`` when something is wrong. A second run on the same ``--out`` is refused while the first runs.
Example studies with SYNTHETIC data are in cases/examples/; the paper's studies are in cases/studies/
(burswood_sbp.toml, toyoura.toml, simsand_synthetic.toml).

The study file's ``[runner] route`` chooses how it is calibrated (``cases.study.routes.dispatch``): "study" (the
default, below), "sand" (SIMSAND triaxial tests on a strain grid with predicted tests: ``--free``, ``--sweeps``,
``--undrained``, ``--error-groups``, ``--noise``, ``--regenerate``; ``cases.study.routes.sand``) or "sbp" (pressuremeter
expansions at one site: ``--recordings``, ``--rates``, ``--pressure-only``, ``--fixed``, ``--radial-cells``,
``--layers``, ``--increments``, ``--sweeps``, ``--max-stages``, ``--timeout``, ``--throughput``;
``cases.study.routes.sbp``). ``[reference]`` values (published or generating) are shown beside the posterior in the sand
and sbp routes' report.md and figures.

Test types (``cases.study.programme``): ``triaxial``, ``oedometer_crs``, ``oedometer_creep`` (laboratory drivers of
``constitutive.labtests``) and ``sbp`` (the coupled pressuremeter FE). Base models: ``ModifiedCamClay``, ``ANICREEP``
(switches ``viscous``, ``anisotropy``, ``destructuration``) and ``SIMSAND`` (laboratory tests only; switches
``lode_dependence``, ``state_dependent_dilatancy``, the latter needing n_p and n_d). ``--diagnose`` runs the
missing-physics loop (``cases.study.loop.problem.run_loop`` over ``inference.diagnosis.run_loop``): calibrate the base
class, locate the mismatch, explain it with per-point covariates and ``constitutive.physics_catalog``, recalibrate the
enriched class of the best-ranked named candidate whose enrichment exists for the base model, compare
log-evidences.

Outputs in DIR (default results/calibrate/<study name>): summary.json, report.md, curves.png (recorded vs MAP with the
95 % posterior predictive band), marginals.png, stages.png, posterior.npz, posterior.nc (ArviZ), progress.log; with
``--diagnose`` also diagnosis_input.json/.npz, diagnosis.json/.md, diagnosis.png, loop.json and the enriched class in
DIR/enriched_<candidate>/.
"""
from __future__ import annotations

import sys

from cases.study.cli import command
from cases.study.routes import dispatch as routes

__all__ = ["main"]


@command
def main(argv=None):
    return routes.main(argv, __doc__)


if __name__ == "__main__":
    sys.exit(main())
