"""The Burswood ANICREEP pressuremeter expansion at the default Newton tolerance against the same problem converged
to rtol 1e-10 (an independent reference: the fixed point the default solve approximates, docs/reference.md
section 7)."""
import numpy as np

import constitutive as C
import fem

N_INCREMENTS = 100


def _expansion(rtol):
    model = C.ANICREEP(M=1.71, lambda_=0.40, kappa=0.026, nu=0.3, e0=2.0, sigma_p0=58.4, C_alpha_e=0.020,
                       vertical_axis=2)
    problem = fem.pressuremeter(model, n_increments=N_INCREMENTS, save_fields="none", rtol=rtol)
    return fem.Solver(problem).solve()


def test_cavity_curve_equals_the_tightly_converged_curve_within_the_newton_tolerance():
    """Every step is accepted when each free dof's residual is below rtol times its force or flux level, so each
    step's state lies within about rtol (relative to the stress level) of the step's exact fixed point, and over n
    steps the curve drifts at most n rtol: the bound 100 x 1e-6 of the cavity pressure level, for the cavity
    pressure and its excess pore pressure alike (measured: 9e-4 and 1.2e-3 kPa against a bound of 1.7e-2 kPa)."""
    rtol = 1e-6
    default, tight = _expansion(rtol), _expansion(1e-10)
    bound = N_INCREMENTS * rtol * np.abs(tight.cavity_pressure).max()
    assert np.max(np.abs(default.cavity_pressure - tight.cavity_pressure)) < bound
    assert np.max(np.abs(default.cavity_excess_pore_pressure - tight.cavity_excess_pore_pressure)) < bound
    # a plastic, partly drained expansion (the calibrated curve, not a trivial elastic one)
    assert tight.cavity_pressure[-1] > 150.0 and tight.cavity_excess_pore_pressure[-1] > 40.0
