"""Concealed anisotropy, destructuration or viscosity at lab scale, twelve undrained triaxial tests: the proof
``cases.study.proof_lab`` (usage, data sets and generating models there), run by the concealed-effect command line.

    python -m cases.concealed_lab --effect anisotropy --quick --diagnose
    python -m cases.concealed --scale lab --effect anisotropy --quick --diagnose      # the same
"""
import sys

from . import study  # noqa: F401 - the study library, as the proof's users know it (cases.concealed_lab.study)
from .study import proof_lab
from .study.proof_lab import *  # noqa: F401,F403 - the proof's names: programme, data, loop problem
from .study.proof_cli import main as proofs_main


def main(argv=None):
    return proofs_main(["--scale", "lab", *(sys.argv[1:] if argv is None else argv)], description=proof_lab.__doc__)


if __name__ == "__main__":
    sys.exit(main())
