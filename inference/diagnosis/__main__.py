"""Missing-physics diagnosis of a finished run directory, from the command line.

    python -m inference.diagnosis DIR [--threshold LN_B] [--margin LN_B]
    python -m inference.diagnose DIR ...        (the same command)

Reads DIR/diagnosis_input.json and .npz (written by a case run with ``--diagnose``:
``inference.diagnosis.write_input``), diagnoses under the settings and decision rule recorded there (so the
conclusion is the loop's own), writes DIR/diagnosis.json and DIR/diagnosis.md
(``inference.diagnosis.diagnose_directory``) and prints one JSON line: the verdict, the omitted physics, the log
Bayes factors and the ln B threshold applied. ``--threshold`` and ``--margin`` (natural-log Bayes factors) replace
the recorded rule's.
"""
from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

from .files import diagnose_directory, read_input, recorded_rule

__all__ = ["main"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m inference.diagnosis",
                                 description="Missing-physics diagnosis of a finished case run directory "
                                             "(reads DIR/diagnosis_input.json and .npz, writes DIR/diagnosis.json and "
                                             "DIR/diagnosis.md)")
    ap.add_argument("directory", type=Path)
    ap.add_argument("--threshold", type=float, default=None,
                    help="ln Bayes factor needed to confirm an enrichment (default: the rule recorded in DIR)")
    ap.add_argument("--margin", type=float, default=None,
                    help="ln Bayes factor by which the confirmed class must lead the others (default: the rule "
                         "recorded in DIR)")
    args = ap.parse_args(argv)
    rule = None
    if args.threshold is not None or args.margin is not None:
        rule = recorded_rule(args.directory, read_input(args.directory)[0])
        rule = replace(rule, threshold=rule.threshold if args.threshold is None else args.threshold,
                       margin=rule.margin if args.margin is None else args.margin)
    d = diagnose_directory(args.directory, rule)
    print(json.dumps({"directory": str(args.directory), "verdict": d.verdict, "omitted_physics": d.omitted_physics,
                      "log_bayes": d.log_bayes, "threshold_log_bayes": d.rule.threshold,
                      "wall_s": round(d.wall_s, 3)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
