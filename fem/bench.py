"""Benchmarks of the FE solver, printed as JSON lines: ``python -m fem.bench [--repeat N]``.

One pressuremeter expansion, default 240-element mesh (60 x 4), 100 equal increments to 10 % cavity strain at
0.167 %/s, Burswood initial state: linear elastic, Modified Cam Clay and ANICREEP.
Wall time per solve (best of N after one warm-up, which also builds nothing new: the Solver is built once, as in the
calibration loop), the one-off build time, Newton work counters (residual evaluations, material calls, second
material calls for a tangent (a rate-dependent material is asked for it only before a factorization), banded LU
factorizations, step cuts) and the peak resident memory of the process. ``--newton both`` adds full Newton with the
tangent predictor (problem.predictor 'tangent') and modified Newton (refresh_ratio 0.1) beside the default (full
Newton, extrapolated predictor).
"""
from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np

import constitutive as C

from . import Solver, pressuremeter


def materials():
    yield "linear_elastic", C.LinearElastic(E=5000.0, nu=0.3)
    yield "modified_cam_clay", C.ModifiedCamClay(M=1.2, lambda_=0.40, kappa=0.026, nu=0.3, ocr=58.4 / 31.0)
    yield "anicreep", C.ANICREEP(M=1.71, lambda_=0.40, kappa=0.026, nu=0.3, e0=2.0, sigma_p0=58.4, C_alpha_e=0.020,
                                 vertical_axis=2)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m fem.bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5, help="timed solves per case after the warm-up (default 5)")
    ap.add_argument("--newton", choices=("full", "both"), default="full",
                    help="full: the default Newton only; both: also the tangent predictor and modified Newton")
    args = ap.parse_args(argv)
    variants = {"full": {}}
    if args.newton == "both":
        variants.update({"full, tangent predictor": {"predictor": "tangent"}, "modified": {"refresh_ratio": 0.1}})
    for (name, model), (newton, options) in ((m, v) for m in materials() for v in variants.items()):
        t0 = time.perf_counter()
        solver = Solver(pressuremeter(model, n_increments=100, save_fields="none", **options))
        build = time.perf_counter() - t0
        solver.solve()
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            result = solver.solve()
            times.append(time.perf_counter() - t0)
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        print(json.dumps({"case": f"pressuremeter_{name}", "newton": newton, "n_cells": solver.problem.mesh.n_cells,
                          "n_dofs": solver.n_dofs, "half_bandwidth": solver.kl, "increments": 100,
                          "solve_s_best": round(min(times), 4), "solve_s_median": round(float(np.median(times)), 4),
                          "build_s": round(build, 4), "peak_rss_MB": round(rss, 1),
                          "cavity_pressure_kPa": round(float(result.cavity_pressure[-1]), 3),
                          "cavity_excess_pore_pressure_kPa": round(float(result.cavity_excess_pore_pressure[-1]), 3),
                          "residual_evaluations": solver.stats["residuals"],
                          "material_calls": solver.stats["material_calls"],
                          "tangent_calls": solver.stats["tangent_calls"],
                          "factorizations": solver.stats["factorizations"],
                          "step_cuts": solver.stats["cuts"]}), flush=True)


if __name__ == "__main__":
    main()
