"""Concealed physics: SYNTHETIC data made by a model class with one effect more than the base class, and the
calibrate -> locate -> explain -> enrich -> compare loop that must name the effect without being told.

    python -m cases.concealed --effect anisotropy --quick --diagnose              # twelve triaxial tests (lab scale)
    python -m cases.concealed --effect destructuration --quick --diagnose
    python -m cases.concealed --control --quick --diagnose                        # data from the base class
    python -m cases.concealed --confusion --seeds 2 --quick                       # every effect and the control
    python -m cases.concealed --programme rates --quick --diagnose                # seven tests at seven rates
    python -m cases.concealed --scale sbp --effect "partial drainage"             # two SBP expansions
    python -m cases.concealed --scale sbp --effect viscosity --pressure-only      # without the wall pore pressure
    python -m cases.concealed [...] --generate                                     # rewrite the shipped data

Options, data sets and outputs: cases.study.proof_cli and the proofs cases.study.proof_lab, proof_rates, proof_sbp
(the generating models are stated there, never in the data files). The documented commands
``python -m cases.concealed_viscosity``, ``cases.concealed_lab`` and ``cases.concealed_sbp`` run the same proofs.
"""
import sys

from cases.study.proof_cli import main

if __name__ == "__main__":
    sys.exit(main(description=__doc__))
