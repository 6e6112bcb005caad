"""Tests mirror the packages (tests/constitutive, tests/fem, tests/inference, tests/cases); the data and tolerances
they share (corpus_inputs.py, tolerances.py) and the MPI scripts (scripts/) stay at this level."""
import os
import sys

import pytest

# tests import the packages from the repository root whether or not it is installed, and the shared test modules
# from this folder
TESTS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TESTS)
for path in (ROOT, TESTS):
    if path not in sys.path:
        sys.path.insert(0, path)


@pytest.fixture
def children_left():
    """The child processes this test started that still run, as a function: an earlier test's figure drawer (a
    daemon that ends once its dropped queue is collected) may still run when this test begins and is not counted."""
    import multiprocessing

    before = {p.pid for p in multiprocessing.active_children()}
    return lambda: [p for p in multiprocessing.active_children() if p.pid not in before]
