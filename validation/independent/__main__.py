"""``python -m validation.independent --write [--folder DIR]``: regenerate the independent generator's programmes
(every programme x hidden effect x noise seed, the pressuremeter's included, then the model-form controls of
:mod:`validation.independent.controls` and the multi-effect cases of :mod:`validation.independent.multi`) and their
KEY.json under validation/data/independent/; ``--write-multi``: the multi-effect cases only (their folders and
KEY.json entries; every other file untouched)."""
from __future__ import annotations

import argparse
from pathlib import Path

from .controls import write_controls
from .multi import write_multi
from .recording import write_all
from .sbp import write_sbp

DATA = Path(__file__).resolve().parent.parent / "data" / "independent"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m validation.independent", description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="write the CSVs, study files and KEY.json")
    ap.add_argument("--write-multi", action="store_true", help="write only the multi-effect cases and their KEY.json "
                    "entries")
    ap.add_argument("--folder", type=Path, default=DATA, help=f"output folder (default {DATA})")
    args = ap.parse_args(argv)
    if args.write_multi and not args.write:
        print(f"{len(write_multi(args.folder))} multi-effect cases written to {args.folder}")
        return 0
    if not args.write:
        ap.print_help()
        return 0
    key = write_all(args.folder)
    key.update(write_sbp(args.folder))
    key.update(write_controls(args.folder))
    key.update(write_multi(args.folder))
    print(f"{len(key)} cases written to {args.folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
