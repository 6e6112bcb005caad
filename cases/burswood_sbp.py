"""Burswood clay, self-boring pressuremeter: ANICREEP parameters from two expansion rates (docs/reference.md section 5).
The study is the file cases/studies/burswood_sbp.toml, run by the one runner (``cases.study.routes.dispatch``, route
"sbp").

    python -m cases.burswood_sbp --quick            # the README's main job (DE-TMCMC, local process pool)
    mpirun -n 8 python -m cases.burswood_sbp        # the paper's setting, N_s = 2000, whole FE solves per rank
    python -m cases.burswood_sbp --recordings fast=my_fast.csv slow=my_slow.csv   # your own SBP records

Two SBP expansions at 5.25 m depth (Lee & Fahey), 0.167 %/s and 0.0185 %/s to 10 % cavity strain, in situ
sigma'_v0 = 31 kPa, K0 = 0.9, u0 = 38.8 kPa, k = 3.3e-9 m/s; ANICREEP with nu = 0.3, lambda = 0.40, kappa = 0.026,
e0 = 2.0 fixed (docs/reference.md section 5: the printed Table 5 is garbled; these are the documented defaults,
``--fixed`` overrides) and M, sigma'_p0 (kPa), C_alpha_e and the error sigma_eps identified (Table 4 bounds). One
particle's forward model is both coupled FE solves; each runs whole on one process or MPI rank.

Recordings. The measured Burswood curves are not public. The shipped recordings (cases/data/burswood_sbp/) are
SYNTHETIC: our FE at the paper's DE-TMCMC MAP (M 1.71, sigma'_p0 58.4 kPa, C_alpha_e 0.020) with the paper preset's
mesh and increments, times independent multiplicative noise c ~ N(1, 0.02^2) per point (Eq. 1) (``--generate``
rewrites them). Real recordings load from CSV files with columns ``cavity_strain_pct, cavity_pressure_kPa`` and
optionally ``pore_pressure_kPa`` (total pore pressure at the wall) and ``time_s``. The wall pore pressure is used
whenever every record has it (``--pressure-only`` drops it): the cavity pressure alone leaves a ridge in
(M, sigma'_p0), which the pore pressure, set by the effective stress path, breaks. Further options: ``--rates``,
``--radial-cells``, ``--layers``, ``--increments``, ``--sweeps``, ``--max-stages``, ``--timeout``, ``--throughput N``.

Sign convention: pressures are total radial stresses on the cavity wall, compression positive, kPa; cavity strain is
u_a/a0 in % (small strain, as the FE).
"""
from __future__ import annotations

import sys
from pathlib import Path

from cases.study.cli import command
from cases.study.routes import dispatch as routes

__all__ = ["STUDY", "main"]

#: the study file
STUDY = Path(__file__).parent / "studies" / "burswood_sbp.toml"


@command
def main(argv=None):
    return routes.main(argv, __doc__, STUDY, quick_help="the README's main job: the paper's 60 radial cells in one "
                                                        "layer, 100 increments, N_s 64")


if __name__ == "__main__":
    sys.exit(main())
