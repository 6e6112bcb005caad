"""Tests mirror the packages (tests/constitutive, tests/fem, tests/inference, tests/cases); the data and tolerances
they share (corpus_inputs.py, tolerances.py) and the MPI scripts (scripts/) stay at this level."""
import os
import sys

# tests import the packages from the repository root whether or not it is installed, and the shared test modules
# from this folder
TESTS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TESTS)
for path in (ROOT, TESTS):
    if path not in sys.path:
        sys.path.insert(0, path)
