"""Toyoura sand: SIMSAND identified from Verdugo & Ishihara's (1996) drained triaxial tests (the paper's section 3.2,
docs/reference.md section 5). The curves are measurements (digitised, CC-BY-4.0; cases/data/toyoura/SOURCE.md). The
study is the file cases/studies/toyoura.toml, run by the one runner (``cases.study.routes.dispatch``, route "sand").

    python -m cases.toyoura [--quick] [--method de|o|both] [--samples N] [--seed S] [--runs R] [--out DIR] [--resume]
                            [--undrained FILE[:E0:P0_KPA] ...] [--free NAMES] [--sweeps K]
                            [--error-groups [FILE] | --single-sigma]

The paper calibrated on drained test 2 (e0 0.916, p'0 100 kPa) and undrained tests 7 (e0 0.735, 100 kPa) and 12
(e0 0.833, 1 MPa), and predicted the rest. The undrained curves are not available, so by default this study
SUBSTITUTES drained test 6 (e0 0.810, p'0 500 kPa) for tests 7 and 12: the densest state at the highest available
pressure, the closest to test 12, and with test 2 it spans both pressures (for n and the CSL's lambda, xi) and a
loose-contractive and a dense-dilative state (for n_p, n_d, A_d). Tests 1, 3, 4, 5 are predicted. Every output says so.

Undrained recordings (``--undrained FILE``, CSV with columns eps_a_pct, q_kPa, u_kPa and header lines ``# e0:`` and
``# p0_kPa:``, or ``FILE:E0:P0_KPA``) are calibrated as the paper did, q(eps_a) and the excess pore pressure
u(eps_a) from isotropic p'0; the calibration set is then test 2 plus the undrained tests, tests 1, 3-6 predicted.

Free parameters and bounds as the paper (nu = 0.2 fixed; the study file's [model.free]); ``--free`` identifies a
subset, the others held at the paper's optimisation reference values ([reference.paper_reference]). Error model: one
error parameter per quantity (Eq. 6g: sigma_eps_stress for q and u, sigma_eps_volume for the void ratio e) by
default; ``--single-sigma`` one sigma_eps for every curve (Eq. 4, the paper's); ``--error-groups`` the groups of the
``[sigma_eps]`` table of FILE (default cases/examples/toyoura_groups.toml). About 5 % of the prior box fails (drained
path lost control): zero-likelihood particles, at most half of a stage allowed.

Outputs in DIR (default results/toyoura): posterior.npz, posterior.nc (ArviZ), summary.json (with J_g of every test at
MAP, calibration and prediction), report.md (MAP/mean/std beside the paper's Table 3 and the volumetric strain of the
predicted tests at 3, 5 and 10 % axial strain: measured, MAP, 95 % posterior predictive; the Predictions section: each
predicted test's 95 % band with the model-error term of docs/reference.md section 10, its coverage, width and
scores), curves.png (Fig. 13 style), stress_paths.png, predictions.png, marginals.png, pairs.png, stages.png, csl.png,
leave_one_out/<test>/ (the calibrations without each calibration test that size the model error); ``--runs R``:
runs.md and map_spread.png (MAP / paper's DE-TMCMC mean).
"""
from __future__ import annotations

import sys
from pathlib import Path

from cases.study.cli import command
from cases.study.routes import dispatch as routes

__all__ = ["STUDY", "main"]

#: the study file
STUDY = Path(__file__).parent / "studies" / "toyoura.toml"


@command
def main(argv=None):
    return routes.main(argv, __doc__, STUDY, quick_help="N_s 300, at most 6 sweeps per stage")


if __name__ == "__main__":
    sys.exit(main())
