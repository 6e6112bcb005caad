"""Linear isotropic elasticity (the simplest material-point model; FE verification oracles)."""
from __future__ import annotations

import numpy as np

from .base import MaterialModel, ParameterRange, as_points
from .invariants import isotropic_stiffness


class LinearElastic(MaterialModel):
    """Linear isotropic elasticity, sigma' = D eps. E (kPa) > 0, -1 < nu < 0.5; scalars or arrays over points.

    State: ``void_ratio`` (carried for output only, updated with the volumetric strain, compression positive).
    The tangent is exact.
    """

    name = "linear elastic"
    rate_dependent = False
    tangent_kind = "consistent"
    parameter_names = ("E", "nu")
    parameter_ranges = {"E": ParameterRange(0.0, None, (1.0e3, 1.0e5), "kPa"),
                        "nu": ParameterRange(-1.0, 0.5, (0.1, 0.4))}
    required_parameters = ("E", "nu")

    def __init__(self, E, nu):
        self.E = self._checked("E", E)
        self.nu = self._checked("nu", nu)

    @property
    def bulk_modulus(self):
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def shear_modulus(self):
        return self.E / (2.0 * (1.0 + self.nu))

    def initial_state(self, stress0, void_ratio0=None) -> dict:
        stress0 = as_points(stress0, "stress0")
        n = stress0.shape[0]
        e0 = np.zeros(n) if void_ratio0 is None else np.broadcast_to(np.asarray(void_ratio0, float), (n,)).copy()
        return {"void_ratio": e0}

    def update(self, stress, state, dstrain, dt, tangent=True):
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        D = np.broadcast_to(isotropic_stiffness(self.bulk_modulus, self.shear_modulus), (n, 6, 6))
        new_stress = stress + np.einsum("nij,nj->ni", D, dstrain)
        e = state["void_ratio"]
        new_state = {"void_ratio": e - (1.0 + e) * dstrain[:, :3].sum(axis=1)}
        return new_stress, new_state, D.copy()
