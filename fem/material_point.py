"""The one place where the FE meets the constitutive models: component mapping and sign conversion.

FE mechanics is tension positive (stress and strain), with the axisymmetric vector (rr, zz, tt, rz). The material
models are compression positive with Voigt order (11, 22, 33, 12, 23, 31) (docs/reference.md, "Conventions used
everywhere"). Mapping r -> 1, z -> 2, theta -> 3, rz -> 12 and a sign flip of every component:

    eps_soil = -eps_fe (padded with gamma_23 = gamma_31 = 0),   sigma_fe = -sigma'_soil[:4],
    D_fe = d sigma_fe / d eps_fe = D_soil[:4, :4]  (two sign flips cancel).

Effective stresses only; the pore pressure is added by the solver (total = effective - u, tension positive).
"""
from __future__ import annotations

import numpy as np

from constitutive import IntegrationError, MaterialModel
from constitutive.jit import all_finite

__all__ = ["MaterialPoints", "soil_stress", "IntegrationError"]


def soil_stress(stress_fe):
    """FE tension-positive (n, 4) -> soil compression-positive Voigt (n, 6)."""
    out = np.zeros((stress_fe.shape[0], 6))
    out[:, :4] = -stress_fe
    return out


class MaterialPoints:
    """One material point per element (one-point integration), wrapping a constitutive model.

    ``stress`` holds the soil-convention effective stress (n, 6) of the last converged state, ``state`` the model
    state, ``dstrain`` the soil-convention strain increment (n, 6) of the next trial (columns 4-5, gamma_23 and
    gamma_31, stay zero). :meth:`trial` and :meth:`evaluate` evaluate an increment from the converged state
    without committing it.
    """

    def __init__(self, model: MaterialModel, stress0_soil, void_ratio0):
        if not isinstance(model, MaterialModel):
            raise TypeError(f"material must be a constitutive.MaterialModel, got {type(model).__name__}")
        self.model = model
        self.stress = np.array(stress0_soil, dtype=float)
        self.state = model.initial_state(self.stress, void_ratio0)
        self.dstrain = np.zeros_like(self.stress)

    def trial(self, dstrain_fe, dt, tangent=True):
        """Update over strain increment dstrain_fe (n, 4, FE tension positive) in time dt (s): :meth:`evaluate`
        of eps_soil = -dstrain_fe."""
        self.dstrain[:, :4] = -dstrain_fe
        return self.evaluate(dt, tangent)

    def evaluate(self, dt, tangent=True):
        """Update over the soil-convention increment ``dstrain`` in time dt (s).

        Returns (stress_soil (n, 6), state, D_fe (n, 4, 4)); D_fe may be None with ``tangent=False`` (the model's
        choice, ``MaterialModel.update``). Raises IntegrationError.
        """
        stress, state, tangent = self.model.update(self.stress, self.state, self.dstrain, dt, tangent=tangent)
        if not all_finite(stress):
            bad = int(np.flatnonzero(~np.all(np.isfinite(stress), axis=1))[0])
            raise IntegrationError(bad, "non-finite stress")
        return stress, state, None if tangent is None else tangent[:, :4, :4]

    def commit(self, stress_soil, state):
        self.stress = stress_soil
        self.state = state
