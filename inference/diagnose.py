"""Missing-physics diagnosis of a finished run directory, from the command line.

    python -m inference.diagnose DIR [--threshold 3]

Reads DIR/diagnosis_input.json and .npz (written by a case run with ``--diagnose``:
``inference.diagnosis.write_input``), writes DIR/diagnosis.json and DIR/diagnosis.md
(``inference.diagnosis.diagnose_directory``) and prints one JSON line: the verdict, the omitted physics and the log
Bayes factors.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from .diagnosis import STRONG_LOG_BAYES, diagnose_directory

__all__ = ["main"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Missing-physics diagnosis of a finished case run directory "
                                             "(reads DIR/diagnosis_input.json and .npz, writes DIR/diagnosis.json and "
                                             "DIR/diagnosis.md)")
    ap.add_argument("directory", type=Path)
    ap.add_argument("--threshold", type=float, default=STRONG_LOG_BAYES,
                    help="ln Bayes factor needed to confirm an enrichment (default 3: B >= 20)")
    args = ap.parse_args(argv)
    d = diagnose_directory(args.directory, args.threshold)
    print(json.dumps({"directory": str(args.directory), "verdict": d["verdict"], "omitted_physics":
                      d["omitted_physics"], "log_bayes": d["log_bayes"], "wall_s": round(d["wall_s"], 3)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
