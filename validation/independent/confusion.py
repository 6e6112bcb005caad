"""The missing-physics diagnosis on the independent generator's programmes: its confusion table.

    python -m validation.independent.confusion [--seeds 1 2 3] [--programmes ciu ck0u ...] [--out DIR]
                                          [--controls effects|model-form|all|multi] [--skip-done]
                                          [--stop-at HH:MM]
                                          [--table-only]

Each case of validation/data/independent/ (programme x hidden effect x noise seed; the truth in its KEY.json) goes
through ``python -m cases.calibrate <case>/study.toml --quick --diagnose --out DIR/<case>`` as a subprocess under
``nice``, one at a time, exactly as an engineer would run it (Modified Cam Clay base, the study file written from the
file headers). The named effects (DIR/<case>/loop.json ``named``, in ranked order) and the confirmed one (its
``omitted_physics``) are compared with the hidden effect:

- named: the hidden effect is among the named candidates (first: it is the best-ranked one);
- confirmed: the confirmed effect is the hidden one ("none" on a negative control);
- false alarm: an effect confirmed that is not the hidden one (any confirmed effect on a control).

``--controls`` selects the cases: ``effects`` (default) the hidden-effect cases and their negative controls,
``model-form`` the model-form-only controls of :mod:`validation.independent.controls` (plain clay written with other
conventions: every confirmed effect on them is a false alarm; KEY.json ``model_form`` names the variant; the
programmes crs_load and crs_ur carry only these), ``all`` both, ``multi`` the multi-effect set of
:mod:`validation.independent.multi` (two effects at once, and the rate-step programme's one-effect case and control;
KEY.json ``effects`` lists them). The table has one row per programme, hidden effect(s) and model-form variant, and
the summary counts the false alarms on the model-form controls on their own.

Effects confirmed: the loop's ``confirmed_chain`` (loop.json, the effects confirmed one after another by the stepwise
diagnosis) where present, else its ``omitted_physics`` unless "none". A case is confirmed (fully detected) when every
effect it holds is in that list (a control: when it is empty), a false alarm when the list holds an effect the case
does not; named: every effect it holds is among the named candidates.

Anisotropy in the crs, il and relaxation programmes (one-dimensional compression and relaxation from a K0 state)
gives the same records as the control by construction: those cells are left out; the SBP pairs (two expansion
rates, each with a hold) carry viscosity or nothing. After every case DIR/confusion.md
(per programme and hidden effect: named / confirmed / false alarm over the seeds run, run times; then one line per
case with the reason of a miss: screening verdict, attribution p-values, candidates' ln B) and DIR/confusion.json
are rewritten, so a stopped sweep leaves its table. Run times are the subprocess wall times on the machine it ran
on (the loop's own ``timing.loop_s`` is kept too).
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from .recording import SEEDS

__all__ = ["DATA", "EFFECTS", "PROGRAMMES", "CONTROL_SETS", "LEFT_OUT", "load_key", "case_order", "outcome",
           "summarize", "main"]

DATA = Path(__file__).resolve().parent.parent / "data" / "independent"
DEFAULT_OUT = Path("results") / "independent"
PROGRAMMES = ("ciu", "ck0u", "crs", "il", "relaxation", "sbp", "crs_load", "crs_ur", "ratestep")
CONTROL_SETS = ("effects", "model-form", "all", "multi")
EFFECTS = ("none", "viscosity", "anisotropy", "destructuration")
#: (programme, effect) cells whose records equal the control's by construction, and the SBP cells the generator
#: does not write (its pressuremeter pairs carry viscosity or nothing)
LEFT_OUT = {("crs", "anisotropy"), ("il", "anisotropy"), ("relaxation", "anisotropy"), ("sbp", "anisotropy"),
            ("sbp", "destructuration")}
#: run order within a seed: controls and viscosity first, then anisotropy, then destructuration
ORDER = ("none", "viscosity", "anisotropy", "destructuration")
RUN_FILE = "confusion_run.json"


def load_key(data=DATA) -> dict:
    """{case id: {"programme", "effect", "seed", "parameters"}} of the generator's KEY.json (the multi-effect cases
    with "effects" too, the model-form controls with "model_form")."""
    return json.loads((Path(data) / "KEY.json").read_text())


def truth_effects(truth: dict) -> list:
    """The effects a case holds: KEY.json ``effects``, else its one ``effect`` ([] for "none")."""
    return list(truth.get("effects", [] if truth["effect"] == "none" else [truth["effect"]]))


def truth_label(truth: dict) -> str:
    """The hidden effect(s) of a case in one cell: "a + b" for a multi-effect case, else its ``effect``."""
    return (" + ".join(truth_effects(truth)) or "none") if "effects" in truth else truth["effect"]


def confirmed_effects(loop: dict) -> list:
    """The effects the loop confirmed: its ``confirmed_chain``, else [``omitted_physics``] unless "none"."""
    if "confirmed_chain" in loop:
        return list(loop["confirmed_chain"])
    return [] if loop["omitted_physics"] == "none" else [loop["omitted_physics"]]


def case_order(key: dict, seeds=SEEDS, programmes=PROGRAMMES, controls="effects") -> list:
    """Case ids to run: seed by seed, in each seed the effects in :data:`ORDER` and the programmes in the order
    given (the :data:`LEFT_OUT` cells skipped), then the model-form controls (variant by variant); ``controls``
    (:data:`CONTROL_SETS`) selects the effect cases, the model-form controls or both, or the multi-effect set (seed
    by seed, programme by programme, the most effects first)."""
    if controls == "multi":
        multi = sorted(((v["seed"], programmes.index(v["programme"]), -len(v["effects"]), case)
                        for case, v in key.items() if "effects" in v and v["seed"] in seeds
                        and v["programme"] in programmes))
        return [m[-1] for m in multi]
    by_cell = {(v["programme"], v["effect"], v.get("model_form"), v["seed"]): case for case, v in key.items()
               if "effects" not in v}
    variants = sorted({v["model_form"] for v in key.values() if "model_form" in v})
    out = []
    for s in seeds:
        if controls in ("effects", "all"):
            out += [by_cell[p, e, None, s] for e in ORDER for p in programmes
                    if (p, e) not in LEFT_OUT and (p, e, None, s) in by_cell]
        if controls in ("model-form", "all"):
            out += [by_cell[p, "none", m, s] for m in variants for p in programmes if (p, "none", m, s) in by_cell]
    return out


def run_case(case: str, data: Path, out: Path, timeout: float | None = None) -> dict:
    """Run the diagnosis loop of one case (subprocess, ``nice``, its own process group: a run past ``timeout``
    seconds is killed with its pool workers); its stdout/stderr go to DIR/<case>.log; returns {"returncode",
    "timed_out", "wall_s", "started", "command"} (also written as DIR/<case>/confusion_run.json)."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = ["nice", sys.executable, "-m", "cases.calibrate", str(data / case / "study.toml"), "--quick",
           "--diagnose", "--debug", "--out", str(out / case)]
    started = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    t0 = time.perf_counter()
    with open(out / f"{case}.log", "w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            rc, timed_out = proc.wait(timeout=timeout), False
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            rc, timed_out = proc.wait(), True
    run = {"returncode": rc, "timed_out": timed_out, "wall_s": time.perf_counter() - t0, "started": started,
           "command": " ".join(cmd), "commit": _commit()}
    (out / case).mkdir(parents=True, exist_ok=True)
    (out / case / RUN_FILE).write_text(json.dumps(run, indent=1) + "\n")
    return run


def _commit() -> str | None:
    """The git commit of the code that ran the case (None outside a git checkout)."""
    try:
        return subprocess.run(["git", "-C", str(Path(__file__).parent), "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None


def _error_tail(out: Path, case: str, lines=25) -> str:
    log = out / f"{case}.log"
    return "\n".join(log.read_text().splitlines()[-lines:]) if log.exists() else ""


def outcome(case: str, truth: dict, out: Path) -> dict:
    """One case's row: the truth, what the loop named and confirmed, run times and the diagnosis' reasons."""
    d = out / case
    run = json.loads((d / RUN_FILE).read_text()) if (d / RUN_FILE).exists() else {}
    row = {"case": case, "programme": truth["programme"], "effect": truth_label(truth),
           "effects": truth_effects(truth), "model_form": truth.get("model_form"), "seed": truth["seed"],
           "wall_s": run.get("wall_s"), "returncode": run.get("returncode"), "started": run.get("started")}
    if not (d / "loop.json").exists() or not (d / "diagnosis.json").exists():
        return {**row, "status": "timed out" if run.get("timed_out") else "failed", "error": _error_tail(out, case)}
    loop = json.loads((d / "loop.json").read_text())
    diag = json.loads((d / "diagnosis.json").read_text())
    named, confirmed, held = list(loop["named"]), confirmed_effects(loop), truth_effects(truth)
    lnb = {cl["candidate"]: cl["log_bayes_vs_base"] for cl in diag["classes"] if cl["role"] == "enriched"}
    row.update({
        "status": "ran", "loop_s": loop["timing"]["loop_s"], "calibration_s": loop["timing"]["calibration_s"],
        "verdict": diag["verdict"], "named": named, "confirmed": ", ".join(confirmed) or "none",
        "confirmed_chain": confirmed,
        "named_ok": bool(held) and all(e in named for e in held),
        "named_first": bool(named) and bool(held) and named[0] == held[0],
        "confirmed_ok": all(e in confirmed for e in held) if held else not confirmed,
        "confirmed_each": sum(e in confirmed for e in held),
        "false_alarm": any(c not in held for c in confirmed),
        "named_on_control": not held and bool(named),
        "ln_B": lnb, "threshold_ln_B": diag.get("threshold_log_bayes"),
        "attribution": [{k: a.get(k) for k in ("name", "p_value", "p_adjusted", "r2")} for a in diag["attribution"]],
        "candidates": [{"name": c["name"], "score": c["score"], "named": c["named"], "plausible": c["plausible"],
                        "decision": c.get("decision"), "confirmed": c.get("confirmed"),
                        "pattern_explained": c.get("pattern_explained"), "pattern_left": c.get("pattern_left")}
                       for c in diag["candidates"]],
        "warnings": diag.get("warnings", {}), "recommendation": diag.get("recommendation"),
        "not_calibrated": loop.get("not_calibrated", {})})
    return row


def summarize(rows: list) -> list:
    """Per (programme, hidden effect(s), model-form variant or None): counts over the cases run, and their run
    times; the effect cases first (one effect, then several), then the model-form controls."""
    cells = {}
    for r in rows:
        cells.setdefault((r["programme"], r["effect"], r.get("model_form")), []).append(r)

    def order(cell):
        (prog, effect, form), rs = cell
        return (form is not None, form or "", PROGRAMMES.index(prog), len(rs[0]["effects"]),
                EFFECTS.index(effect) if effect in EFFECTS else len(EFFECTS), effect)
    out = []
    for (prog, effect, form), rs in sorted(cells.items(), key=order):
        ran = [r for r in rs if r["status"] == "ran"]
        times = [r["wall_s"] for r in rs if r.get("wall_s") is not None]
        out.append({"programme": prog, "effect": effect, "model_form": form, "cases": len(rs), "ran": len(ran),
                    "failed": len(rs) - len(ran),
                    "timed_out": sum(r["status"] == "timed out" for r in rs),
                    "named": sum(r["named_ok"] for r in ran) if effect != "none" else None,
                    "named_on_control": sum(r["named_on_control"] for r in ran) if effect == "none" else None,
                    "confirmed": sum(r["confirmed_ok"] for r in ran),
                    "effects_confirmed": f"{sum(r['confirmed_each'] for r in ran)}/{len(rs[0]['effects']) * len(ran)}",
                    "false_alarm": sum(r["false_alarm"] for r in ran),
                    "wall_s": times})
    return out


def _fmt_p(p):
    return "-" if p is None else f"{p:.2g}"


def _reason(r: dict) -> str:
    """The diagnosis' own reasons for one case, in one table cell."""
    if r["status"] == "timed out":
        return f"timed out: killed after {r['wall_s']:.0f} s"
    if r["status"] != "ran":
        last = [ln for ln in r.get("error", "").splitlines() if ln.strip()]
        return f"failed (exit {r.get('returncode')}): {last[-1] if last else 'no output'}"
    att = ", ".join(f"{a['name']} p={_fmt_p(a['p_value'])}/{_fmt_p(a['p_adjusted'])}" for a in r["attribution"])
    cands = ", ".join(f"{c['name']} {'named' if c['named'] else 'plausible' if c['plausible'] else 'no'}"
                      f" s={c['score']:.2f}" for c in r["candidates"])
    lnb = ", ".join(f"{k} {v:+.1f}" for k, v in r["ln_B"].items() if v is not None) or "none calibrated"
    warn = "; ".join(w for ws in r["warnings"].values() for w in ws)
    return (f"{r['verdict']}; attribution (p raw/Holm): {att or '-'}; candidates: {cands}; ln B: {lnb}"
            + (f"; warnings: {warn}" if warn else ""))


def write_tables(rows: list, out: Path, settings: dict) -> None:
    """DIR/confusion.json and DIR/confusion.md from the rows."""
    cells = summarize(rows)
    (out / "confusion.json").write_text(json.dumps({"settings": settings, "cells": cells, "cases": rows},
                                                   indent=1, default=float) + "\n")
    lines = ["# Confusion table of the diagnosis on the independent generator's programmes", "",
             f"Written by `python -m validation.independent.confusion` ({settings['written']}); each case: "
             "`python -m cases.calibrate study.toml --quick --diagnose` with the Modified Cam Clay base of its "
             "study file. Counts over the seeds run; run time: subprocess wall time, s. Anisotropy in crs, il "
             "and relaxation is left out (records equal to the control by construction).", "",
             "Model-form controls (true effect `none (variant)`): the plain clay written with another convention "
             "(validation/independent/controls.py); any effect confirmed on them is a false alarm.", "",
             "Multi-effect cases (true effects `a + b`, validation/independent/multi.py): confirmed when every effect "
             "they hold is confirmed (loop.json `confirmed_chain`, else `omitted_physics`); the effects confirmed "
             "over the cases are counted too.", "",
             "| programme | true effect | cases | named | confirmed | false alarm | failed | run time s (mean, max) |",
             "|---|---|---|---|---|---|---|---|"]
    for c in cells:
        n = c["ran"]
        named = (f"{c['named']}/{n}" if c["effect"] != "none" else f"({c['named_on_control']}/{n} named)")
        t = c["wall_s"]
        times = f"{sum(t) / len(t):.0f}, {max(t):.0f}" if t else "-"
        timed = f" ({c['timed_out']} timed out)" if c["timed_out"] else ""
        truth = c["effect"] + (f" ({c['model_form']})" if c["model_form"] else "")
        lines.append(f"| {c['programme']} | {truth} | {c['cases']} | {named} | {c['confirmed']}/{n} | "
                     f"{c['false_alarm']}/{n} | {c['failed']}{timed} | {times} |")
    ran = [r for r in rows if r["status"] == "ran"]
    effects = [r for r in ran if r["effect"] != "none"]
    controls = [r for r in ran if r["effect"] == "none" and not r.get("model_form")]
    forms = [r for r in ran if r.get("model_form")]
    multi = [r for r in ran if len(r["effects"]) > 1]
    lines += ["", f"Effects named {sum(r['named_ok'] for r in effects)}/{len(effects)}, confirmed "
              f"{sum(r['confirmed_ok'] for r in effects)}/{len(effects)}; controls clean "
              f"{sum(r['confirmed_ok'] for r in controls)}/{len(controls)}; model-form controls clean "
              f"{sum(r['confirmed_ok'] for r in forms)}/{len(forms)} (false alarms "
              f"{sum(r['false_alarm'] for r in forms)}/{len(forms)}); false alarms "
              f"{sum(r['false_alarm'] for r in ran)}/{len(ran)}; failed {len(rows) - len(ran)}."
              + (f" Multi-effect cases fully detected {sum(r['confirmed_ok'] for r in multi)}/{len(multi)} (effects "
                 f"confirmed {sum(r['confirmed_each'] for r in multi)}/{sum(len(r['effects']) for r in multi)})."
                 if multi else ""), "",
              "| case | seed | true effect | named (ranked) | confirmed | run time s | reason (screening; attribution; "
              "candidates; ln B vs base) |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        named = ", ".join(r.get("named") or []) or "-"
        wall = "-" if r.get("wall_s") is None else f"{r['wall_s']:.0f}"
        truth = r["effect"] + (f" ({r['model_form']})" if r.get("model_form") else "")
        lines.append(f"| {r['case']} | {r['seed']} | {truth} | {named} | {r.get('confirmed', '-')} | "
                     f"{wall} | {_reason(r)} |")
    (out / "confusion.md").write_text("\n".join(lines) + "\n")


def _past(stop_at: str | None) -> bool:
    if not stop_at:
        return False
    now = dt.datetime.now(dt.timezone.utc)
    hh, mm = (int(x) for x in stop_at.split(":"))
    return (now.hour, now.minute) >= (hh, mm)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m validation.independent.confusion", description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS), help="noise seeds (default 1 2 3)")
    ap.add_argument("--programmes", nargs="+", default=list(PROGRAMMES), choices=PROGRAMMES)
    ap.add_argument("--controls", choices=CONTROL_SETS, default="effects",
                    help="effects: the hidden-effect cases and their negative controls (default); model-form: the "
                         "plain clay written with other conventions (validation/independent/controls.py; every "
                         "confirmed effect a false alarm); all: both")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    ap.add_argument("--data", type=Path, default=DATA, help=f"the generator's data folder (default {DATA})")
    ap.add_argument("--skip-done", action="store_true", help="keep a case whose DIR/<case>/loop.json exists")
    ap.add_argument("--stop-at", metavar="HH:MM", help="launch no new case after this UTC time")
    ap.add_argument("--timeout", type=float, metavar="S", help="kill a case's run after S seconds (a miss)")
    ap.add_argument("--table-only", action="store_true", help="rewrite the tables from the cases already run")
    args = ap.parse_args(argv)
    key = load_key(args.data)
    cases = case_order(key, args.seeds, args.programmes, args.controls)
    args.out.mkdir(parents=True, exist_ok=True)
    settings = {"seeds": args.seeds, "programmes": args.programmes, "controls": args.controls, "data": str(args.data),
                "command": "python -m cases.calibrate <case>/study.toml --quick --diagnose"}
    rows = []
    for case in cases:
        done = (args.out / case / "loop.json").exists() or (args.out / case / RUN_FILE).exists()
        if not args.table_only and not (args.skip_done and done):
            if _past(args.stop_at):
                print(f"{case}: not run (past --stop-at {args.stop_at} UTC)", flush=True)
                continue
            run = run_case(case, args.data, args.out, args.timeout)
            print(f"{case}: exit {run['returncode']}{' (timed out)' if run['timed_out'] else ''}, "
                  f"{run['wall_s']:.0f} s", flush=True)
        if not (args.out / case).exists():
            continue
        rows.append(outcome(case, key[case], args.out))
        settings["written"] = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        write_tables(rows, args.out, settings)
    if rows:
        print(f"tables: {args.out / 'confusion.md'}, {args.out / 'confusion.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
