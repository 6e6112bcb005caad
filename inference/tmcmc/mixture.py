"""Gaussian mixtures for the O-TMCMC "mixture" move: the mixture density and its EM fit to a weighted population.

A multimodal stage population has a global covariance (Eq. (12)) that contains the spread between modes; a mixture
gives each mode its own mean and covariance (docs/reference.md section 2, step 3).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .stage import weighted_covariance

__all__ = ["GaussianMixture", "fit_gaussian_mixture", "logsumexp_rows"]


def logsumexp_rows(a):
    """ln sum_c exp(a[:, c]) for rows with at least one finite entry (faster than scipy's for small K)."""
    top = a.max(1)
    return top + np.log(np.exp(a - top[:, None]).sum(1))


@dataclass(eq=False)
class GaussianMixture:
    """A Gaussian mixture sum_c pi_c N(mu_c, Sigma_c) held by its Cholesky factors: ``weights`` (K,), ``means``
    (K, d), ``covs`` (K, d, d). ``component_logpdf(x, scale)`` gives ln N(x; mu_c, scale^2 Sigma_c) for every
    component; with ``centred=True`` the means are taken as zero (the density of a displacement under the
    random-walk proposal)."""

    weights: np.ndarray
    means: np.ndarray
    covs: np.ndarray
    chol: np.ndarray = field(init=False, repr=False)
    inv_chol: np.ndarray = field(init=False, repr=False)
    log_det: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self.weights = np.asarray(self.weights, dtype=float)
        self.means = np.asarray(self.means, dtype=float)
        self.covs = np.asarray(self.covs, dtype=float)
        self.chol = np.linalg.cholesky(self.covs)
        self.inv_chol = np.linalg.inv(self.chol)
        self.log_det = 2.0 * np.log(np.diagonal(self.chol, axis1=1, axis2=2)).sum(1)

    @property
    def n_components(self):
        return len(self.weights)

    def component_logpdf(self, x, scale=1.0, centred=False):
        x = np.atleast_2d(x)
        d = x.shape[1]
        dev = x[None] if centred else x[None] - self.means[:, None]
        z = dev @ self.inv_chol.transpose(0, 2, 1)  # (K, m, d)
        sq = np.einsum("kmi,kmi->mk", z, z) / scale**2
        return -0.5 * (sq + self.log_det + d * math.log(2 * math.pi * scale**2))

    def log_responsibilities(self, x):
        """(ln r_c(x), ln g(x)): log posterior component probabilities (m, K) and the log mixture density (m,)."""
        joint = self.component_logpdf(x) + np.log(self.weights)
        log_g = logsumexp_rows(joint)
        return joint - log_g[:, None], log_g


def fit_gaussian_mixture(theta, weights, max_components=5, floor=0.0, ridge=1e-6, max_iter=15, tol=1e-3):
    """A Gaussian mixture fitted to the weighted population (theta_k, w_k) by EM, deterministic (no random numbers).

    K = 1 is the weighted mean and covariance (Eq. (12)). K + 1 components start from the K-component fit with the
    component of largest pi_c lambda_max split in two along its principal axis v (means mu +- sqrt(lambda) v,
    variance along v divided by 4), followed by at most ``max_iter`` EM iterations on the weighted points (stopped when
    the weighted mean log-density gains less than ``tol``). K grows while the Bayesian information criterion improves:
    BIC = -2 n_eff sum_k w_k ln g(theta_k) + n_par ln n_eff, n_eff = 1 / sum w_k^2 (normalized weights),
    n_par = K - 1 + K (d + d (d + 1) / 2); a K with a component of fewer than d + 1 effective points or a singular
    covariance is not taken. Every covariance gets ``ridge`` times the population variance plus ``floor`` (a
    variance per coordinate) on its diagonal. Points of zero weight are ignored."""
    keep = weights > 0
    x, w = theta[keep], weights[keep] / weights[keep].sum()
    d = x.shape[1]
    n_eff = 1.0 / np.sum(w**2)
    cov = weighted_covariance(x, w)
    reg = np.diag(ridge * np.diag(cov) + floor)
    n_par = lambda k: k - 1 + k * (d + d * (d + 1) / 2)  # noqa: E731

    def m_step(resp):
        pi = w @ resp
        if np.min(pi) * n_eff < d + 1:
            return None
        means = (resp * w[:, None]).T @ x / pi[:, None]
        covs = np.empty((len(pi), d, d))
        for c in range(len(pi)):
            dev = x - means[c]
            covs[c] = ((resp[:, c] * w)[:, None] * dev).T @ dev / pi[c] + reg
        try:
            return GaussianMixture(pi, means, covs)
        except np.linalg.LinAlgError:
            return None

    def em(mix):
        ll_old = -np.inf
        for _ in range(max_iter):
            log_r, log_g = mix.log_responsibilities(x)
            ll = float(w @ log_g)
            if ll - ll_old < tol:
                break
            mix, ll_old = m_step(np.exp(log_r)), ll
            if mix is None:
                return None, -np.inf
        return mix, ll  # (after max_iter: the log-density of the previous iterate, a lower bound since EM ascends)

    best = GaussianMixture([1.0], [w @ x], [cov + reg])
    best_bic = -2.0 * n_eff * float(w @ best.log_responsibilities(x)[1]) + n_par(1) * math.log(n_eff)
    for k in range(2, max_components + 1):
        lam, vec = np.linalg.eigh(best.covs)
        c = int(np.argmax(best.weights * lam[:, -1]))
        step = math.sqrt(lam[c, -1]) * vec[c, :, -1]
        cov_half = best.covs[c] - 0.75 * lam[c, -1] * np.outer(vec[c, :, -1], vec[c, :, -1])
        others = np.arange(best.n_components) != c
        try:
            start = GaussianMixture(
                np.concatenate([best.weights[others], [best.weights[c] / 2] * 2]),
                np.concatenate([best.means[others], [best.means[c] + step, best.means[c] - step]]),
                np.concatenate([best.covs[others], [cov_half, cov_half]]))
        except np.linalg.LinAlgError:
            break
        mix, ll = em(start)
        if mix is None:
            break
        bic = -2.0 * n_eff * ll + n_par(k) * math.log(n_eff)
        if bic >= best_bic:
            break
        best, best_bic = mix, bic
    return best
