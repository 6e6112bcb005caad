"""Concealed viscosity or partial drainage at pressuremeter scale, two SBP expansions: the proof
``cases.study.proof_sbp`` (usage, data sets and generating models there), run by the concealed-effect command line.

    python -m cases.concealed_sbp --effect viscosity
    python -m cases.concealed --scale sbp --effect viscosity      # the same
"""
import sys

from . import study  # noqa: F401 - the study library, as the proof's users know it (cases.concealed_sbp.study)
from .study import proof_sbp
from .study.proof_sbp import *  # noqa: F401,F403 - the proof's names: programme, data, loop problem
from .study.proof_cli import main as proofs_main


def main(argv=None):
    return proofs_main(["--scale", "sbp", *(sys.argv[1:] if argv is None else argv)], description=proof_sbp.__doc__)


if __name__ == "__main__":
    sys.exit(main())
