"""Constitutive benchmarks: ``python -m constitutive.bench [WORD ...] [--list]`` prints one JSON line per benchmark.

With words, only the benchmarks whose name contains one of them run; ``--list`` prints the names and runs nothing.
To add a benchmark: write a function returning a dict (its JSON line) and append it to ``BENCHMARKS``.
Timings: ``seconds`` wall-clock on whatever machine runs this (noisy on shared machines), and where given
``cpu_seconds``, the process CPU time (less sensitive to other jobs).
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from .. import labtests
from ..anicreep import ANICREEP
from ..mcc import ModifiedCamClay
from ..sand.simsand import SIMSAND


def _mcc_batch(n, seed=0):
    rng = np.random.default_rng(seed)
    model = ModifiedCamClay(M=rng.uniform(0.8, 1.6, n), lambda_=rng.uniform(0.1, 0.4, n),
                            kappa=rng.uniform(0.01, 0.05, n), nu=0.3, ocr=rng.uniform(1.0, 4.0, n))
    return model, rng.uniform(0.6, 1.5, n)


def _mcc_triaxial_batch(drained, n=2000, n_points=100, substeps=2):
    """MCC drained or undrained triaxial to 25 % axial strain, n parameter sets in one vectorized call."""
    model, e0 = _mcc_batch(n, seed=0 if drained else 1)
    axial = np.linspace(0.0, 0.25, n_points + 1)[1:]
    test = labtests.drained_triaxial if drained else labtests.undrained_triaxial
    t0 = time.perf_counter()
    test(model, e0, 100.0, axial, substeps=substeps)
    wall = time.perf_counter() - t0
    return {"benchmark": f"mcc_{'drained' if drained else 'undrained'}_triaxial_batch", "n_particles": n,
            "n_steps": n_points * substeps, "seconds": round(wall, 3), "ms_per_particle_test": round(1e3 * wall / n, 4)}


def mcc_drained_triaxial_batch():
    return _mcc_triaxial_batch(drained=True)


def mcc_undrained_triaxial_batch():
    return _mcc_triaxial_batch(drained=False)


def _timed_updates(name, model, stress, state, dstrain, dt, n_increments):
    """n_increments successive updates of all points; wall and process CPU time (the CPU time is less sensitive
    to other jobs on a shared machine), per point-increment and per call."""
    n = stress.shape[0]
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(n_increments):
        stress, state, _ = model.update(stress, state, dstrain, dt)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"benchmark": name, "n_points": n, "n_increments": n_increments, "seconds": round(wall, 4),
            "cpu_seconds": round(cpu, 4), "us_per_point_increment": round(1e6 * wall / (n * n_increments), 3),
            "cpu_us_per_point_increment": round(1e6 * cpu / (n * n_increments), 3),
            "ms_per_call": round(1e3 * wall / n_increments, 4), "cpu_ms_per_call": round(1e3 * cpu / n_increments, 4)}


def mcc_update_points(n=240, n_increments=200):
    """MCC material-point update over n Gauss points (plastic loading each increment)."""
    model = ModifiedCamClay(M=1.2, lambda_=0.2, kappa=0.04, nu=0.3)
    stress = np.tile([100.0, 80.0, 90.0, 10.0, -5.0, 3.0], (n, 1))
    state = model.initial_state(stress, 1.0)
    dstrain = np.tile([1e-4, -2e-5, 0.0, 1e-5, 0.0, 0.0], (n, 1))
    model.update(stress, state, dstrain, 1.0)  # compile (or load the numba cache) outside the timing
    return _timed_updates("mcc_update_points", model, stress, state, dstrain, 1.0, n_increments)


def anicreep_update_points(n=240, n_increments=50, dt=0.6):
    """ANICREEP update over n Gauss points, Burswood parameters (M 1.71, sigma'_p0 58.4 kPa, C_alpha_e 0.02), undrained
    cavity-expansion increments (eps_r = -eps_theta = 0.1 %, FE axes r->1, z->2 vertical, theta->3), dt 0.6 s."""
    model = ANICREEP(M=1.71, lambda_=0.40, kappa=0.026, nu=0.3, e0=2.0, sigma_p0=58.4, C_alpha_e=0.02,
                     vertical_axis=2)
    stress = np.tile([27.9, 31.0, 27.9, 0.0, 0.0, 0.0], (n, 1))
    state = model.initial_state(stress)
    dstrain = np.tile([1e-3, 0.0, -1e-3, 0.0, 0.0, 0.0], (n, 1))
    model.update(stress, state, dstrain, dt)  # compile (or load the numba cache) outside the timing
    return _timed_updates("anicreep_update_points", model, stress, state, dstrain, dt, n_increments)


def lab_small_batches(n=32, repeats=2):
    """The laboratory drivers on a batch of n particles, as a study's forward model calls them (where the per-step
    Python glue counts as much as the kernels): ANICREEP (viscous, anisotropic, current specific volume) undrained
    triaxial to 15 % in 300 steps at 1e-6 1/s, and the same clay with delayed swelling in an oedometer programme
    (load to 200 kPa, unload to 50 kPa, reload to 100 kPa, 2 h stages); ``repeats`` times each, after one run that
    compiles or loads the numba cache."""
    from .swelling import DelayedSwelling
    rng = np.random.default_rng(3)
    clay = ANICREEP(M=rng.uniform(1.0, 1.4, n), lambda_=rng.uniform(0.15, 0.35, n), kappa=0.03, nu=0.25, e0=1.2,
                    sigma_p0=rng.uniform(60.0, 120.0, n), C_alpha_e=rng.uniform(0.004, 0.012, n),
                    specific_volume="current")
    swelling = DelayedSwelling(clay, rng.uniform(0.005, 0.02, n), rng.uniform(1e3, 1e4, n))
    axial = np.linspace(0.0, 0.15, 301)[1:]
    runs = {"anicreep_undrained_triaxial": lambda: labtests.undrained_triaxial(clay, 1.2, 100.0, axial,
                                                                               strain_rate=1e-6, on_failure="nan"),
            "swelling_oedometer_stages": lambda: labtests.oedometer_loading(
                swelling, 1.2, 40.0, [200.0, 50.0, 100.0], 7200.0, n_times=6, on_failure="nan")}
    out = {"benchmark": "lab_small_batches", "n_particles": n, "repeats": repeats}
    for name, run in runs.items():
        run()
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(repeats):
            run()
        out[f"{name}_seconds"] = round((time.perf_counter() - t0) / repeats, 4)
        out[f"{name}_cpu_seconds"] = round((time.process_time() - c0) / repeats, 4)
    return out


def _simsand_batch(n, seed=0, **options):
    """SIMSAND parameter sets drawn from the synthetic-study prior box (docs/reference.md section 5), nu, K_0, n
    fixed."""
    rng = np.random.default_rng(seed)
    bounds = dict(e_ref=(0.5, 1.5), lambda_c=(0.001, 0.1), xi=(0.01, 1.0), phi_mu=(20.0, 50.0), k_p=(1e-4, 1e-2),
                  A_d=(0.5, 2.0), n_p=(0.1, 10.0), n_d=(0.1, 10.0))
    return SIMSAND(nu=0.2, K_0=100.0, n=0.6, **{k: rng.uniform(lo, hi, n) for k, (lo, hi) in bounds.items()}, **options)


def _simsand_triaxial(name, path, run, n, n_points, e0, p0, model):
    """Time ``run(model, axial)`` (a drained test to 25 %); wall and process CPU seconds (CPU is less sensitive to
    other jobs on a shared machine)."""
    axial = np.linspace(0.0, 0.25, n_points + 1)[1:]
    t0, c0 = time.perf_counter(), time.process_time()
    curves = run(model, axial)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"benchmark": name, "path": path, "n_particles": n, "n_steps": n_points, "e0": e0, "p0": p0,
            "stol": model.stol, "n_failed": int(curves["failed"].sum()), "seconds": round(wall, 3),
            "cpu_seconds": round(cpu, 3), "ms_per_particle_test": round(1e3 * wall / n, 4),
            "cpu_ms_per_particle_test": round(1e3 * cpu / n, 4)}


def simsand_drained_triaxial_batch(n=2000, n_points=100, e0=0.7, p0=200.0, integrator="compiled"):
    """SIMSAND drained triaxial to 25 % axial strain over n prior parameter sets, one call of the triaxial fast path
    (SIMSAND.triaxial_test, compiled kernel; compiled or loaded from the numba cache outside the timing); failed
    (uncontrollable) points are flagged, not retried. ``integrator="numpy"``: the numpy reference of the same path."""
    model = _simsand_batch(n, triaxial_integrator=integrator)
    model.triaxial_test(e0, p0, [1e-3], on_failure="nan")  # compile (or load the numba cache)
    suffix = "" if integrator == "compiled" else f"_{integrator}"
    return _simsand_triaxial(f"simsand_drained_triaxial_batch{suffix}", f"SIMSAND.triaxial_test ({integrator})",
                             lambda m, a: m.triaxial_test(e0, p0, a, on_failure="nan"), n, n_points, e0, p0, model)


def simsand_drained_triaxial_numpy_reference():
    return simsand_drained_triaxial_batch(integrator="numpy")


def simsand_drained_triaxial_generic(n=20, n_points=100, e0=0.7, p0=200.0):
    """The same test through the generic mixed-control driver (labtests.drained_triaxial, 6-component update)."""
    return _simsand_triaxial("simsand_drained_triaxial_generic", "labtests.drained_triaxial(route='generic')",
                             lambda m, a: labtests.drained_triaxial(m, e0, p0, a, on_failure="nan", route="generic"),
                             n, n_points, e0, p0, _simsand_batch(n))


#: benchmarks run in order by ``python -m constitutive.bench``; each returns one JSON-able dict
BENCHMARKS = [mcc_update_points, anicreep_update_points, mcc_drained_triaxial_batch, mcc_undrained_triaxial_batch,
              lab_small_batches, simsand_drained_triaxial_batch, simsand_drained_triaxial_numpy_reference,
              simsand_drained_triaxial_generic]


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m constitutive.bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("words", nargs="*", metavar="WORD", help="run only the benchmarks whose name contains a word")
    ap.add_argument("--list", action="store_true", help="print the benchmark names and exit")
    args = ap.parse_args(argv)
    chosen = [b for b in BENCHMARKS if not args.words or any(w in b.__name__ for w in args.words)]
    for bench in chosen:
        print(bench.__name__ if args.list else json.dumps(bench()), flush=True)
