"""The terms of the paper's likelihood for one test (docs/reference.md section 1), scalar or vectorized over a batch
of parameter sets with the same bits for each set.

Eq. (1): U_obs = c U_num(b), c ~ N(1, sigma_eps^2).
Eq. (5): J_g = 1/N_0 sum_j [1/N_j sum_i ((U_obs_i - U_num_i)/U_obs_i)^2] over the N_0 curves of one test.
Eq. (4): ln p(D|theta) = -N/2 ln(2 pi sigma_eps^2) - N/(2 sigma_eps^2) J_g, N = number of points used.
Eq. (6): ln p(D|theta) = sum_i w_i ln p(D_i|theta) over tests, w_i = 1 by default.
Eq. (6g), error groups: the curves are split into groups G, each with its own error parameter sigma_g, and each
test's term of Eq. (6) becomes
    ln p(D_i|theta) = sum_g [ -N_ig/2 ln(2 pi sigma_g^2) - N_i J_ig / (2 sigma_g^2) ],
    J_ig = 1/N_0 sum_{j in g} 1/N_j sum_k ((U_obs_k - U_num_k)/U_obs_k)^2,
N_ig the points of the test's curves in group g (sum_g N_ig = N_i, sum_g J_ig = J_g). One group is Eq. (4).
Relative errors are dimensionless; sigma_eps and sigma_g are relative (0.02 is 2 %).
"""
from __future__ import annotations

import numpy as np

__all__ = ["curve_mean_squares", "goodness_of_fit", "log_likelihood_test"]


def curve_mean_squares(observed, simulated) -> list:
    """The inner mean of Eq. (5) per curve: 1/N_j sum_i ((U_obs_i - U_num_i)/U_obs_i)^2, a float or (m,) per curve
    (arguments as :func:`goodness_of_fit`). The squares are summed in point order (a cumulative sum): numpy's sum
    and dot order their additions differently for a vector and for the rows of a matrix, and one parameter set must
    get the same bits whatever batch it is in."""
    out = []
    for o, s in zip(observed, simulated):
        rel = (o - s) / o
        out.append(np.cumsum(rel * rel, axis=-1)[..., -1] / rel.shape[-1])
    return out


def goodness_of_fit(observed, simulated):
    """Eq. (5): mean over curves of the mean squared relative error.

    observed: list of recorded value arrays (n_j,); simulated: the list of the matching simulated arrays, each (n_j,)
    (returns a float) or (m, n_j) for a batch of m parameter sets (returns J_g per set, (m,))."""
    total = 0.0
    for mean_square in curve_mean_squares(observed, simulated):
        total = total + mean_square
    total = total / len(observed)
    return float(total) if np.ndim(total) == 0 else total


def log_likelihood_test(j_g, n_points, sigma_eps, n_test=None):
    """Eq. (4) for one test with N points (vectorizes over sigma_eps and j_g); with ``n_test`` the term of one error
    group of Eq. (6g): ``j_g`` is then J_ig, ``n_points`` N_ig and ``n_test`` the test's N_i."""
    n_test = n_points if n_test is None else n_test
    return -0.5 * n_points * np.log(2.0 * np.pi * sigma_eps**2) - n_test * j_g / (2.0 * sigma_eps**2)
