"""Elastic-perfectly plastic von Mises model for undrained (total-strength) clay, with radial return.

Matching to Tresca (docs/reference.md section 6, Gibson & Anderson): the yield stress in terms of the deviatoric stress
q = sqrt(3/2 s:s) is ``q_y = sqrt(3) s_u``. In plane strain with incompressible plastic flow (the cavity expansion,
eps_z = 0) the out-of-plane stress is the mean of the in-plane ones, sigma_z = (sigma_r + sigma_theta)/2, so
q = sqrt(3)/2 |sigma_r - sigma_theta| and yield q = q_y is exactly the Tresca condition |sigma_r - sigma_theta| = 2 s_u.
(The other common matching, q_y = 2 s_u, agrees with Tresca in triaxial compression instead; it is not used.)

Compression positive, kPa, Voigt order (11, 22, 33, 12, 23, 31) with engineering shear strain.
"""
from __future__ import annotations

import numpy as np

from .base import MaterialModel, ParameterError, ParameterRange, as_points
from .invariants import IDENTITY, STRESS_WEIGHTS, deviator, isotropic_stiffness

#: unit deviatoric stiffness P: s = G P eps maps an engineering-shear strain Voigt vector to 2 G e (stress Voigt)
DEVIATORIC_UNIT = isotropic_stiffness(0.0, 1.0)[0]


class VonMises(MaterialModel):
    """Von Mises, elastic-perfectly plastic, associated flow; backward-Euler radial return (exact for this model).

    Parameters (scalars or arrays of shape (n,)):
        s_u : undrained shear strength (kPa) > 0, Tresca-equivalent in plane strain (q_y = sqrt(3) s_u);
        nu  : Poisson's ratio, -1 < nu < 0.5;
        E or G : Young's or shear modulus (kPa) > 0, give exactly one.

    State: ``void_ratio`` (output only, updated with the volumetric strain), ``plastic_strain`` (n, 6),
    ``plastic_shear_strain`` (accumulated eps_q^p = sum of the plastic multipliers, (n,)).
    ``update`` returns the consistent (algorithmic) tangent C = K 1(x)1 + 2 G theta (I_dev - n(x)n), theta = q_y/q_trial
    (Simo & Hughes 1998, perfect plasticity).
    """

    name = "von Mises"
    rate_dependent = False
    tangent_kind = "consistent"
    parameter_names = ("s_u", "G", "nu")
    parameter_ranges = {
        "s_u": ParameterRange(0.0, None, (5.0, 200.0), "kPa"),
        "nu": ParameterRange(-1.0, 0.5, (0.1, 0.49)),
        "E": ParameterRange(0.0, None, (1.0e3, 1.0e5), "kPa"),
        "G": ParameterRange(0.0, None, (1.0e3, 5.0e4), "kPa"),
    }
    required_parameters = ("s_u", "nu")
    exactly_one = (("E", "G"),)

    def __init__(self, s_u, nu, E=None, G=None):
        if (E is None) == (G is None):
            raise ParameterError(f"{self.name}: give exactly one of E or G (got E={E}, G={G})")
        self.s_u = self._checked("s_u", s_u)
        self.nu = self._checked("nu", nu)
        if G is None:
            E = self._checked("E", E)
            self.G = E / (2.0 * (1.0 + self.nu))
        else:
            self.G = self._checked("G", G)

    @property
    def bulk_modulus(self):
        return 2.0 * self.G * (1.0 + self.nu) / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def yield_stress(self):
        """q_y = sqrt(3) s_u (kPa)."""
        return np.sqrt(3.0) * self.s_u

    def initial_state(self, stress0, void_ratio0=None) -> dict:
        stress0 = as_points(stress0, "stress0")
        n = stress0.shape[0]
        e0 = np.zeros(n) if void_ratio0 is None else np.broadcast_to(np.asarray(void_ratio0, float), (n,)).copy()
        return {"void_ratio": e0, "plastic_strain": np.zeros((n, 6)), "plastic_shear_strain": np.zeros(n)}

    def update(self, stress, state, dstrain, dt, tangent=True):
        stress = as_points(stress, "stress")
        dstrain = as_points(dstrain, "dstrain")
        n = stress.shape[0]
        G = np.broadcast_to(self.G, (n,))
        K = np.broadcast_to(self.bulk_modulus, (n,))
        q_y = np.broadcast_to(self.yield_stress, (n,))
        D = isotropic_stiffness(K, G)
        trial = stress + np.einsum("nij,nj->ni", D, dstrain)
        s_trial = deviator(trial)
        norm_s = np.sqrt(np.sum(STRESS_WEIGHTS * s_trial * s_trial, axis=1))  # |s| = sqrt(2/3) q
        q_trial = np.sqrt(1.5) * norm_s
        plastic = q_trial > q_y
        theta = np.where(plastic, q_y / np.where(plastic, q_trial, 1.0), 1.0)
        new_stress = trial - (1.0 - theta)[:, None] * s_trial
        # plastic multiplier (= plastic deviatoric strain increment eps_q^p) and flow n = 3/2 s/q (tensor)
        dlam = np.where(plastic, (q_trial - q_y) / (3.0 * G), 0.0)
        unit = s_trial / np.where(plastic, norm_s, 1.0)[:, None]  # s/|s|, stress Voigt
        flow = np.sqrt(1.5) * unit * STRESS_WEIGHTS  # engineering-strain Voigt of 3/2 s/q
        tangent = (K[:, None, None] * np.outer(IDENTITY, IDENTITY)
                   + (2.0 * G * theta)[:, None, None]
                   * (0.5 * DEVIATORIC_UNIT - plastic[:, None, None] * np.einsum("ni,nj->nij", unit, unit)))
        e = state["void_ratio"]
        new_state = {
            "void_ratio": e - (1.0 + e) * dstrain[:, :3].sum(axis=1),
            "plastic_strain": state["plastic_strain"] + dlam[:, None] * flow,
            "plastic_shear_strain": state["plastic_shear_strain"] + dlam,
        }
        return new_stress, new_state, tangent
