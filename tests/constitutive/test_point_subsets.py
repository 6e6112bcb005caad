"""Updates of a subset of the points (MaterialModel.point_subsets, ``update(..., points=)``) against the update of
every point: the rows are the same bits (the points are integrated independently), for per-point and scalar
parameters; and the laboratory driver, which updates only the points still iterating, gives the same curves as
with one update of every point per Newton iteration.
"""

import numpy as np
import pytest

from constitutive import ANICREEP, ModifiedCamClay, labtests
from constitutive.swelling import DelayedSwelling

N = 12


def clays(rng):
    """Models with per-point and with scalar parameters (ANICREEP both specific volumes, MCC, swelling on ANICREEP)."""
    per_point = dict(M=rng.uniform(1.0, 1.4, N), lambda_=rng.uniform(0.15, 0.3, N), kappa=0.03, nu=0.25,
                     e0=rng.uniform(0.9, 1.5, N), sigma_p0=rng.uniform(60.0, 120.0, N),
                     C_alpha_e=rng.uniform(0.004, 0.01, N))
    scalar = dict(M=1.2, lambda_=0.2, kappa=0.03, nu=0.25, e0=1.2, sigma_p0=80.0, C_alpha_e=0.008)
    return [ANICREEP(**per_point), ANICREEP(**per_point, specific_volume="current"),
            ANICREEP(**scalar, specific_volume="current"), ANICREEP(**scalar, viscous=False),
            ModifiedCamClay(M=rng.uniform(1.0, 1.4, N), lambda_=0.2, kappa=0.03, nu=0.3, ocr=rng.uniform(1.0, 2.0, N)),
            DelayedSwelling(ANICREEP(**per_point, specific_volume="current"), rng.uniform(0.005, 0.02, N),
                            rng.uniform(1e3, 1e4, N))]


@pytest.mark.parametrize("which", range(6))
def test_the_rows_of_a_subset_are_those_of_the_whole_update(which):
    rng = np.random.default_rng(which)
    model = clays(rng)[which]
    stress = np.column_stack([rng.uniform(60.0, 100.0, N), rng.uniform(40.0, 70.0, (N, 2)), np.zeros((N, 3))])
    state = model.initial_state(stress, None if model.void_ratio_parameter else 1.1)
    if "p_max" in state:                                   # unloaded: the swelling law acts
        state["p_max"] = 1.3 * state["p_max"]
    dstrain = rng.normal(scale=2e-3, size=(N, 6))
    dt = rng.uniform(0.0, 100.0, N)
    whole = model.update(stress, state, dstrain, dt)
    for rows in (np.array([3]), np.array([0, 5, 11]), np.arange(1, N, 2), np.arange(N)[::-1]):
        part = model.update(stress[rows], {k: v[rows] for k, v in state.items()}, dstrain[rows], dt[rows], points=rows)
        assert np.array_equal(part[0], whole[0][rows]) and np.array_equal(part[2], whole[2][rows])
        assert part[1].keys() == whole[1].keys()
        assert all(np.array_equal(part[1][k], whole[1][k][rows]) for k in whole[1])


@pytest.mark.parametrize("which", [1, 5])
def test_the_driver_gives_the_same_curves_with_and_without_subsets(which):
    """Undrained triaxial and oedometer stages (loading, unloading) of a batch with per-point parameters: the points
    converge after different numbers of Newton (and swelling) iterations, so the driver and the swelling iteration
    update subsets; with subsets off, the same bits."""
    rng = np.random.default_rng(9)
    model = clays(rng)[which]
    base = getattr(model, "base", model)
    axial = np.linspace(0.0, 0.1, 41)[1:]
    runs = (lambda m: labtests.undrained_triaxial(m, base.e0, 60.0, axial, strain_rate=1e-6),
            lambda m: labtests.oedometer_loading(m, base.e0, 40.0, [150.0, 60.0], 3600.0, n_times=5))
    for run in runs:
        with_subsets = run(model)
        base.point_subsets = False
        without = run(model)
        del base.point_subsets
        assert with_subsets.keys() == without.keys()
        assert all(np.array_equal(with_subsets[k], without[k], equal_nan=True) for k in without
                   if isinstance(without[k], np.ndarray))
