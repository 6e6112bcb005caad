"""Concealed viscosity at lab scale, seven tests at seven strain rates: the proof
``cases.study.proof_rates`` (usage, data sets and generating models there), run by the concealed-effect command line.

    python -m cases.concealed_viscosity --quick --diagnose
    python -m cases.concealed --programme rates --quick --diagnose      # the same
"""
import sys

from . import study  # noqa: F401 - the study library, as the proof's users know it (cases.concealed_viscosity.study)
from .study import proof_rates
from .study.proof_rates import *  # noqa: F401,F403 - the proof's names: programme, data, loop problem
from .study.proof_cli import main as proofs_main


def main(argv=None):
    return proofs_main(["--programme", "rates", *(sys.argv[1:] if argv is None else argv)],
                       description=proof_rates.__doc__)


if __name__ == "__main__":
    sys.exit(main())
