"""Metropolis-Hastings moves of TMCMC (docs/reference.md section 2, steps 5-6), one class per move.

A move is built once from the settings (:func:`make_move`). Each stage, ``prepare`` fits what the move needs to the
weighted population (no random numbers); each move of the chains, ``propose`` draws its arrays from the stream
handed to it, row k belonging to chain k, so the numbers do not depend on the executor or the number of ranks:
- :class:`GaussianMove` (O-TMCMC, step 5; the paper's 5.2): N(theta, Sigma_j), Sigma_j = beta^2 x the weighted
  covariance of the whole stage population, Eqs. (11)-(12);
- :class:`MixtureMove` (O-TMCMC with a mixture covariance): a Gaussian mixture fitted to the weighted population
  (:func:`fit_gaussian_mixture`) gives each mode its own covariance; with probability ``independence`` an
  independence proposal from the mixture, else a random walk N(theta, beta^2 Sigma_c) with the component c drawn
  from the responsibilities r_c(theta) of the current point (beta^2 = 2.38^2 / d by default). Both are
  Metropolis-Hastings moves with their proposal density ratio in the acceptance (:func:`mixture_proposal`): the
  random walk's covariance depends on the current point, so it is not symmetric. The mixtures are fitted once per
  stage and fixed during it, crossed: one to the even-indexed and one to the odd-indexed particles of the weighted
  population, and a chain moves with the mixture fitted to the half its parent is not in. A mixture fitted to the
  particle being moved rates the particle's own position too high (most of all for small modes), so particles leave
  such modes too easily: on B2 at N = 1000 the minor mode weight fell to 0.086 and ln Z rose by +0.17 with a
  self-fitted mixture, 0.099 and +0.08 crossed;
- :class:`DEMove` (DE-TMCMC as written, Eqs. (13)-(15), with the theta_best pull of Eq. (14)),
  :class:`SymmetricDEMove` (pull off) and :class:`RedBlueDEMove` (pull off, the population split in two halves,
  each moved with differences drawn from the other half, as emcee does, which keeps detailed balance).
Proposals outside the prior support are rejected by the run without a forward solve.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .mixture import fit_gaussian_mixture, logsumexp_rows
from .stage import SamplerError, weighted_covariance
from .state import ChainState

__all__ = ["Proposal", "Move", "GaussianMove", "MixtureMove", "DEMove", "SymmetricDEMove", "RedBlueDEMove",
           "make_move", "de_proposal", "mixture_proposal", "draw_pairs"]


@dataclass
class Proposal:
    """Proposed positions of the moving chains (m, d), the Hastings term ln q(theta | theta*) - ln q(theta* | theta)
    (0 for symmetric moves) and, for the mixture move, the proposals' log-responsibilities per mixture."""

    theta: np.ndarray
    log_hastings: np.ndarray | float = 0.0
    responsibilities: list | None = None


class Move:
    """One kind of Metropolis-Hastings proposal. A sweep is ``moves_per_sweep`` moves; move i moves the chains
    ``movers(active, i)``."""

    moves_per_sweep = 1

    def prepare(self, chain: ChainState, theta, weights, log_like, start) -> list | None:
        """Per-stage set-up from the weighted population (theta (N, d), normalized weights, ln L) and the chain
        starts (indices into theta); returns what the stage record notes about it (or None)."""
        return None

    def movers(self, active, move):
        return active

    def propose(self, chain: ChainState, movers, rng) -> Proposal:
        raise NotImplementedError

    def accepted(self, chain: ChainState, movers, accept, proposal: Proposal) -> None:
        """Bookkeeping after the Metropolis decision (``accept`` per mover); the run has moved the chains."""


class GaussianMove(Move):
    """O-TMCMC random walk theta* = theta + scale L z, L L^T = Sigma_j = beta^2 sum_k w_k (theta_k - mean)(...)^T
    (Eqs. (11)-(12)) plus ``jitter`` (a variance per coordinate) on the diagonal."""

    def __init__(self, beta2, jitter):
        self.beta2, self.jitter = beta2, jitter

    def prepare(self, chain, theta, weights, log_like, start):
        cov = self.beta2 * weighted_covariance(theta, weights)
        cov += np.diag(self.jitter)
        chain.chol = np.linalg.cholesky(cov)
        return None

    def propose(self, chain, movers, rng):
        pos = chain.pos
        z = rng.standard_normal(pos.shape)[movers]
        return Proposal(pos[movers] + chain.scale * (z @ chain.chol.T))


class MixtureMove(Move):
    """O-TMCMC with a Gaussian-mixture covariance (module notes): two cross-fitted mixtures of at most
    ``max_components`` components, a fraction ``independence`` of independence proposals, random-walk scale
    sqrt(beta2); ``floor`` (a variance per coordinate) is added to every component covariance."""

    def __init__(self, beta2, independence, max_components, floor):
        self.beta2, self.independence, self.max_components, self.floor = beta2, independence, max_components, floor

    def prepare(self, chain, theta, weights, log_like, start):
        half = np.arange(len(theta)) % 2
        chain.mixtures = [fit_gaussian_mixture(theta, weights * (half == h) if weights[half == h].sum() > 0
                                               else weights, self.max_components, floor=self.floor)
                          for h in (0, 1)]
        chain.fit_of = 1 - start % 2
        chain.resp = [m.log_responsibilities(theta[start]) for m in chain.mixtures]
        return [m.n_components for m in chain.mixtures]

    def propose(self, chain, movers, rng):
        pos = chain.pos
        z = rng.standard_normal(pos.shape)[movers]
        pick, kind = rng.random(pos.shape[0])[movers], rng.random(pos.shape[0])[movers]
        proposal, log_hastings, responsibilities = np.empty_like(z), np.empty(movers.size), []
        for g, mix in enumerate(chain.mixtures):
            sel = chain.fit_of[movers] == g
            rows = movers[sel]
            proposal[sel], log_hastings[sel], resp = mixture_proposal(
                mix, pos[rows], z[sel], pick[sel], kind[sel], chain.scale * math.sqrt(self.beta2),
                self.independence, tuple(r[rows] for r in chain.resp[g]))
            responsibilities.append((sel, resp))
        return Proposal(proposal, log_hastings, responsibilities)

    def accepted(self, chain, movers, accept, proposal):
        # the cached responsibilities follow the chains' positions
        for g, (sel, resp) in enumerate(proposal.responsibilities):
            for cached, new_values in zip(chain.resp[g], resp):
                cached[movers[sel & accept]] = new_values[accept[sel]]


class DEMove(Move):
    """DE-TMCMC as written, Eqs. (13)-(15): every chain moves at once with differences from the whole population and
    the pull toward theta_best, the stage's particle of largest likelihood (which makes the move non-symmetric).
    c, c_star, delta, cr: the c, c*, delta and CR of the equations."""

    def __init__(self, c, c_star, delta, cr):
        self.c, self.c_star, self.delta, self.cr = c, c_star, delta, cr

    def prepare(self, chain, theta, weights, log_like, start):
        chain.best = theta[int(np.argmax(np.where(np.isfinite(log_like), log_like, -np.inf)))].copy()
        return None

    def population(self, n_chains, move):
        """Chains the difference vectors are drawn from."""
        return np.arange(n_chains)

    def propose(self, chain, movers, rng):
        pos = chain.pos
        C, d = pos.shape
        population = self.population(C, chain.move)
        gamma = chain.scale * 2.38 / math.sqrt(2.0 * self.delta * d)
        lam = rng.uniform(-self.c, self.c, C)[movers]
        zeta = rng.normal(0.0, math.sqrt(self.c_star), (C, d))[movers]
        cross = rng.random((C, d))[movers] <= self.cr
        i_rand = rng.integers(0, d, C)[movers]
        cross[np.arange(movers.size), i_rand] = True
        a, b = draw_pairs(rng, movers, population)
        return Proposal(de_proposal(pos[movers], chain.best, pos[a], pos[b], gamma, lam, zeta, cross))


class SymmetricDEMove(DEMove):
    """Eqs. (13)-(15) without the theta_best pull: a symmetric move."""

    def prepare(self, chain, theta, weights, log_like, start):
        return None


class RedBlueDEMove(SymmetricDEMove):
    """The symmetric DE move in two halves (even and odd chains), each moved with differences drawn from the other
    half, which stays fixed during the move (detailed balance, as emcee's red-blue moves)."""

    moves_per_sweep = 2

    def movers(self, active, move):
        return active[active % 2 == move]

    def population(self, n_chains, move):
        return np.flatnonzero(np.arange(n_chains) % 2 != move)


def make_move(settings, prior) -> Move:
    """The move of ``settings`` (:class:`TMCMCSettings` with beta2 resolved) for a problem with this prior; the
    jitter and floor on covariance diagonals are 1e-12 times the squared prior ranges."""
    jitter = 1e-12 * (prior.upper - prior.lower) ** 2
    if settings.proposal == "gaussian":
        if settings.covariance == "mixture":
            return MixtureMove(settings.beta2, settings.independence, settings.max_components, jitter)
        return GaussianMove(settings.beta2, jitter)
    de = {"paper": DEMove, "symmetric": SymmetricDEMove, "redblue": RedBlueDEMove}[settings.de_variant]
    return de(settings.de_c, settings.de_c_star, settings.de_delta, settings.de_cr)


def de_proposal(current, best, diff_a, diff_b, gamma, lam, zeta, crossover):
    """Eqs. (13)-(15): theta* = theta + (1 + lambda) gamma [(theta_best - theta) + (theta_a - theta_b)] + zeta on the
    components selected by the binomial crossover mask (others keep the current value). ``best`` may be None
    (the symmetric variants drop the theta_best pull)."""
    pull = diff_a - diff_b if best is None else (best - current) + (diff_a - diff_b)
    mutated = current + (1.0 + lam)[:, None] * gamma * pull + zeta
    return np.where(crossover, mutated, current)


def mixture_proposal(mix, current, z, pick, kind, scale, independence, current_resp=None):
    """The "mixture" move of O-TMCMC (``covariance="mixture"``): per particle, with probability ``independence``
    (``kind < independence``) an independence proposal theta* ~ g = sum_c pi_c N(mu_c, Sigma_c), else a random walk
    theta* = theta + scale L_c z whose component c is drawn with the responsibilities r_c(theta) of the current point.
    ``z`` (m, d) standard normal, ``pick`` and ``kind`` (m,) uniform; ``current_resp``: ``mix.log_responsibilities``
    of the current points if known. Returns (theta*, ln q(theta | theta*) - ln q(theta* | theta), the
    log_responsibilities of theta*); the second is the Hastings correction of the acceptance ratio:
    independence: ln g(theta) - ln g(theta*);
    random walk: q(theta* | theta) = sum_c r_c(theta) N(theta* - theta; 0, scale^2 Sigma_c), and since the normal
    density is even in the displacement delta, ln q(theta | theta*) - ln q(theta* | theta) =
    logsumexp_c[ln r_c(theta*) + ln N(delta; 0, scale^2 Sigma_c)] - logsumexp_c[ln r_c(theta) + ...]."""
    log_r, log_g = mix.log_responsibilities(current) if current_resp is None else current_resp
    indep = kind < independence
    # component of each particle: from the mixture weights (independence) or the responsibilities (random walk)
    probs = np.where(indep[:, None], mix.weights[None, :], np.exp(log_r))
    cum = np.cumsum(probs, axis=1)
    comp = np.minimum((pick[:, None] * cum[:, -1:] >= cum).sum(1), mix.n_components - 1)
    step = np.einsum("mij,mj->mi", mix.chol[comp], z)
    proposal = np.where(indep[:, None], mix.means[comp] + step, current + scale * step)
    log_r_new, log_g_new = mix.log_responsibilities(proposal)
    walk = mix.component_logpdf(proposal - current, scale, centred=True)
    log_ratio = np.where(indep, log_g - log_g_new,
                         logsumexp_rows(log_r_new + walk) - logsumexp_rows(log_r + walk))
    return proposal, log_ratio, (log_r_new, log_g_new)


def draw_pairs(rng, movers, population):
    """For each mover c draw a != b from ``population`` (both different from c)."""
    pop = np.asarray(population)
    P = pop.size
    a = pop[rng.integers(0, P, movers.size)]
    b = pop[rng.integers(0, P, movers.size)]
    for _ in range(1000):
        bad = (a == movers) | (b == movers) | (a == b)
        if not bad.any():
            return a, b
        a = np.where((a == movers) | (a == b), pop[rng.integers(0, P, movers.size)], a)
        b = np.where((b == movers) | (b == a), pop[rng.integers(0, P, movers.size)], b)
    raise SamplerError("cannot draw distinct DE partners: population too small")
