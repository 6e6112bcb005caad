"""Stress and strain invariants in Voigt notation, vectorized over points.

Compression positive. Stress Voigt (s11, s22, s33, s12, s23, s31); strain Voigt with engineering shear
(e11, e22, e33, g12, g23, g31), g = 2 e. All functions take arrays of shape (n, 6) and return (n,) or (n, 6).
"""
from __future__ import annotations

import numpy as np

IDENTITY = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
#: weights that turn a Voigt stress double contraction into a:b = sum w_i a_i b_i
STRESS_WEIGHTS = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
#: weights for strain Voigt vectors (engineering shear): e:e = sum w_i e_i e_i
STRAIN_WEIGHTS = np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5])


def mean_stress(stress):
    """p' = tr(sigma')/3 (kPa)."""
    return stress[..., :3].sum(axis=-1) / 3.0


def deviator(stress):
    """s = sigma' - p' I, Voigt (n, 6)."""
    return stress - mean_stress(stress)[..., None] * IDENTITY


def deviatoric_stress(stress):
    """q = sqrt(3/2 s:s) (kPa); equals sigma_a - sigma_r in triaxial compression."""
    s = deviator(stress)
    return np.sqrt(1.5 * np.sum(STRESS_WEIGHTS * s * s, axis=-1))


def j3(stress):
    """Third invariant det(s) of the stress deviator."""
    s = deviator(stress)
    s11, s22, s33, s12, s23, s31 = (s[..., i] for i in range(6))
    return s11 * s22 * s33 + 2.0 * s12 * s23 * s31 - s11 * s23**2 - s22 * s31**2 - s33 * s12**2


def lode_sin3theta(stress, floor=1e-12):
    """sin 3theta = (3 sqrt3 / 2) J3 / J2^(3/2), +1 in triaxial compression (compression positive), -1 in extension.

    Returns 0 where the deviator vanishes (J2 below ``floor`` times p'^2).
    """
    s = deviator(stress)
    J2 = 0.5 * np.sum(STRESS_WEIGHTS * s * s, axis=-1)
    p = np.abs(mean_stress(stress))
    small = J2 <= floor * np.maximum(p * p, 1.0)
    val = 1.5 * np.sqrt(3.0) * j3(stress) / np.where(small, 1.0, J2) ** 1.5
    return np.where(small, 0.0, np.clip(val, -1.0, 1.0))


def volumetric_strain(strain):
    """eps_v = eps_11 + eps_22 + eps_33 (compression positive)."""
    return strain[..., :3].sum(axis=-1)


def deviatoric_strain(strain):
    """eps_d = sqrt(2/3 e:e), e the strain deviator; equals eps_a - eps_v/3 in triaxial compression."""
    e = strain - volumetric_strain(strain)[..., None] / 3.0 * IDENTITY
    return np.sqrt(2.0 / 3.0 * np.sum(STRAIN_WEIGHTS * e * e, axis=-1))


def isotropic_stiffness(bulk, shear):
    """Isotropic elastic stiffness D (n, 6, 6) mapping engineering-shear strain Voigt to stress Voigt.

    ``bulk`` K and ``shear`` G in kPa, scalars or arrays of shape (n,).
    """
    K = np.atleast_1d(np.asarray(bulk, dtype=float))
    G = np.atleast_1d(np.asarray(shear, dtype=float))
    K, G = np.broadcast_arrays(K, G)
    n = K.shape[0]
    D = np.zeros((n, 6, 6))
    lam = K - 2.0 * G / 3.0
    D[:, :3, :3] = lam[:, None, None]
    idx = np.arange(3)
    D[:, idx, idx] += 2.0 * G[:, None]
    idx = np.arange(3, 6)
    D[:, idx, idx] = G[:, None]
    return D
