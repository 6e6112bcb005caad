"""Tolerances shared by the tests that compare regenerated SYNTHETIC records with the shipped files.

FE-generated values are converged to the Newton tolerance (fem.Problem.rtol = 1e-6 on the residual): another path to
the same tolerance (predictor, factorization reuse) moves them by up to ~2e-5 relative (measured: cavity pressure
5e-6, wall pore pressure 2.3e-5), so they are compared at 1e-4 (the records' noise is 2e-2). Values of the laboratory
drivers are printed with 9 significant digits: a flipped last digit is at most rel 1e-8 (2e-8 allowed).
"""
FE_RTOL = 1e-4
PRINTED_RTOL = 2e-8
