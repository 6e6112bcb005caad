"""The diagnosis loop's wall time per phase, on study files (default: the shipped 4-test undrained triaxial programme
of a Modified Cam Clay base and the sand programme of a SIMSAND base); prints a table and one JSON line.

    python -m cases.study.loop.bench [STUDY.toml ...] [--repeat 3] [--processes 2] [--out DIR]

Each run is ``python -m cases.calibrate STUDY --quick --diagnose`` in its own process (compiled kernels cached, so the
first run of a fresh clone also pays the compilation: run once before timing). Phases, from DIR/loop.json: per model
class the sampler, the refined evidence, and the record and outputs (summary, report.md), each in its own process's
time (on a pool the classes of one step run side by side, so their phases overlap and add up to more than the
loop); the conventions compared; the screenings and diagnoses; the whole loop; the figures, drawn at its end with the
classes' posterior.nc; and the process's wall time. Medians over ``--repeat`` runs.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

__all__ = ["DEFAULT_STUDIES", "phases", "main"]

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DEFAULT_STUDIES = (EXAMPLES / "ciu_ocr.toml", EXAMPLES / "sand_lab.toml")


def phases(loop: dict) -> dict:
    """{phase: s} of one loop.json: "<class>: sampler|evidence|record and outputs" per calibrated class, "conventions
    not adopted", "screening and diagnosis", "loop", the "figures drawn at the end" (the classes' and the loop's
    figures and the classes' posterior.nc, side by side on the pool) and the "loop and its figures"."""
    out = {}
    for name, ph in (loop.get("phases_s") or {}).items():
        for k, v in (ph or {}).items():
            out[f"{name}: {k.replace('_', ' ')}"] = v
    adopted = set(loop.get("phases_s") or {})
    out["conventions not adopted"] = sum(c.get("wall_s", 0.0) for c in loop.get("conventions", [])
                                         if c["class"] not in adopted)
    timings = [loop["timing"], *loop.get("steps_timing", [])]
    out["screening and diagnosis"] = sum(t["screen_and_rank_s"] + t["diagnose_final_s"] for t in timings)
    out["loop"] = loop["timing"]["loop_s"]
    out["figures drawn at the end"] = loop["timing"].get("figures_s", 0.0)
    out["loop and its figures"] = out["loop"] + out["figures drawn at the end"]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m cases.study.loop.bench", description=__doc__.split("\n")[0])
    ap.add_argument("studies", nargs="*", type=Path, default=list(DEFAULT_STUDIES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None, help="keep the run directories here (default: a temporary one)")
    args = ap.parse_args(argv)
    report = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = args.out or Path(tmp)
        for study in args.studies:
            runs = []
            for k in range(args.repeat):
                out = root / f"{study.stem}_{k}"
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-m", "cases.calibrate", str(study), "--quick", "--diagnose",
                                "--processes", str(args.processes), "--out", str(out)], check=True,
                               stdout=subprocess.DEVNULL)
                run = phases(json.loads((out / "loop.json").read_text()))
                run["process wall"] = time.perf_counter() - t0
                runs.append(run)
            keys = list(dict.fromkeys(k for r in runs for k in r))
            report[study.name] = {k: float(np.median([r.get(k, 0.0) for r in runs])) for k in keys}
            print(f"\n{study} (median of {len(runs)} runs, s)")
            for k, v in report[study.name].items():
                print(f"  {v:8.1f}  {k}")
    print(json.dumps({"benchmark": "diagnosis loop", "repeat": args.repeat, "processes": args.processes,
                      "median_s": report}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
