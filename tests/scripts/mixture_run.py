"""small_run.py with the O-TMCMC mixture move (proposal "gaussian", covariance "mixture"); same arguments, --proposal
is overridden. Used by the rank-count test of the mixture move.

python tests/scripts/mixture_run.py OUT.npz [--dispatch dynamic|spmd] [--executor auto|serial|pool] ...
"""
import functools
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import small_run  # noqa: E402

small_run.tmcmc = functools.partial(small_run.tmcmc, covariance="mixture")

if __name__ == "__main__":
    sys.argv += ["--proposal", "gaussian"]
    small_run.main()
