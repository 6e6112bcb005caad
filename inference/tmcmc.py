"""Transitional Markov chain Monte Carlo: O-TMCMC (Ching & Chen 2007) and DE-TMCMC (Jin, Yin et al. 2019).

REFERENCE.md section 2. Stages q_0 = 0 < q_1 < ... < q_m = 1 with f_j ∝ p(theta) L(theta)^q_j:
1. q_{j+1} by bisection so that the coefficient of variation of w_k = L_k^(q_{j+1} - q_j) equals 1 (log space);
2. weights (9), S_j = mean(w) (10), ln Z = sum_j ln S_j;
3. proposal covariance Sigma_j = beta^2 * weighted covariance (11)-(12), beta^2 = 0.04;
4. resampling with probabilities w_k / sum w (step 5.1);
5. Metropolis moves targeting p(theta) L^q_{j+1}: Gaussian random walk N(theta, Sigma_j) (O-TMCMC, 5.2) or the
   differential-evolution move (13)-(15) with binomial crossover (DE-TMCMC). Proposals outside the prior support are
   rejected without a forward solve.

Chains: ``chains="particles"`` moves every resampled particle for a number of sweeps, fixed or adaptive (stop when
the correlation between the particles' start and current positions falls below ``corr_threshold``: the smaller of
the plain population correlation and a within-mode estimate from copies of one parent, see
``_Run.start_correlation``);
``chains="ching-chen"`` grows one chain per distinct resampled point with length equal to its multiplicity (the
original algorithm; every chain state is a sample).

O-TMCMC proposal covariance (``covariance``): "global" — Eqs. (11)-(12), beta^2 times the weighted covariance of
the whole stage population (the paper's rule); "mixture" — a Gaussian mixture fitted to the weighted stage population
(``fit_gaussian_mixture``: EM, components added while the BIC improves), so that each mode gets its own covariance
(the global covariance of a multimodal population contains the spread between modes, which makes a random walk step
far too long in that direction and too short in the others). Each move of a particle is, with probability
``independence``, an independence proposal from the mixture, else a random walk N(theta, beta^2 Sigma_c) with the
component c drawn from the responsibilities r_c(theta) of the current point (beta^2 = 2.38^2 / d by default, the
optimal random-walk scale for a Gaussian mode). Both are Metropolis-Hastings moves with their proposal density ratio
in the acceptance (``mixture_proposal``): the random walk's covariance depends on the current point, so it is not
symmetric. The alternative, a covariance chosen once per chain from its starting point and kept, is symmetric for
each chain but not exact: the choice depends on where the chain starts, so the marginal of the moved population
is not the target unless the chains never leave their component. The mixtures are fitted once per stage, before
the moves, and fixed during it; the fit is crossed: one mixture to the even-indexed and one to the odd-indexed
particles of the weighted population, and a chain moves with the mixture fitted to the half its parent is not in.
A mixture fitted to the particle being moved rates the particle's own position too high (most of all for small
modes, whose covariance rests on few points), so particles leave such modes too easily: on B2 at N = 1000 the minor
mode weight fell to 0.086 and the log evidence rose by +0.17 with a self-fitted mixture, 0.099 and +0.08 crossed.

DE variants (``de_variant``): "paper" — Eq. (14) as written, with the theta_best pull, all particles moved at once
from one population; "symmetric" — theta_best term off; "redblue" — theta_best term off and the population split in
two halves, each moved with differences drawn from the other half (as emcee does), which keeps detailed balance.

Random numbers: each move draws its arrays from a stream keyed by (seed, stage, sweep, move), row k belonging to
particle (chain) k. Samples, MAP and evidence therefore do not depend on the executor or the number of MPI ranks,
and a run resumed from a checkpoint continues with exactly the numbers it would have drawn.
"""
from __future__ import annotations

import math
import signal
import sys
import time
from pathlib import Path

import numpy as np
from scipy.special import logsumexp

from .checkpoint import load_checkpoint, save_checkpoint
from .executors import Evaluator, MPIExecutor, _BaseExecutor, default_executor
from .likelihood import Likelihood
from .priors import Prior
from .results import Posterior

__all__ = ["SamplerError", "tmcmc", "choose_next_exponent", "stage_weights", "weighted_covariance",
           "de_proposal", "GaussianMixture", "fit_gaussian_mixture", "mixture_proposal", "EXIT_CHECKPOINTED"]

#: exit status after a SIGTERM/SIGUSR1 was turned into a checkpoint (EX_TEMPFAIL: "try again")
EXIT_CHECKPOINTED = 75

#: the adaptive-sweep rule uses siblings of one parent when at least this fraction of the particles are extra copies
SIBLING_FRACTION = 0.1


class SamplerError(RuntimeError):
    """The sampler cannot continue (too many failed forward solves, invalid settings)."""


# ---------------------------------------------------------------------------------------------- formulas
def choose_next_exponent(log_like, q, cov_target=1.0, tol=1e-10):
    """Step 1: the next tempering exponent q' in (q, 1] such that COV(L^(q'-q)) = cov_target (bisection in
    log space, shifted by max ln L). -inf entries (failed particles) have zero weight. Returns 1 if the COV
    stays below the target up to q' = 1."""
    finite = np.isfinite(log_like)
    if not finite.any():
        raise SamplerError("every particle has zero likelihood: cannot choose the next stage")
    shifted = np.where(finite, log_like - np.max(log_like[finite]), -np.inf)

    def cov(dq):
        w = np.exp(dq * shifted)
        m = w.mean()
        return w.std() / m

    hi = 1.0 - q
    if cov(hi) <= cov_target:
        return 1.0
    lo = hi
    while cov(lo) > cov_target:
        lo *= 0.1
        if lo < 1e-300:
            raise SamplerError(f"the fraction of zero-likelihood particles ({1 - finite.mean():.0%}) alone gives "
                               f"a weight COV above {cov_target}: cannot temper")
    hi = min(hi, lo * 10.0)
    while hi - lo > tol * hi:  # COV grows monotonically with the exponent step
        mid = 0.5 * (lo + hi)
        if cov(mid) > cov_target:
            hi = mid
        else:
            lo = mid
    return q + lo


def stage_weights(log_like, dq):
    """Eqs. (9)-(10): returns (normalized weights, ln S_j) with w_k = L_k^dq; -inf gives weight 0."""
    lw = np.where(np.isfinite(log_like), dq * log_like, -np.inf)
    log_sum = logsumexp(lw)
    return np.exp(lw - log_sum), float(log_sum - np.log(len(log_like)))


def weighted_covariance(theta, weights):
    """Eq. (12): sum_k w_k (theta_k - mean)(theta_k - mean)^T with normalized weights."""
    mean = weights @ theta
    dev = theta - mean
    return (weights[:, None] * dev).T @ dev


def de_proposal(current, best, diff_a, diff_b, gamma, lam, zeta, crossover):
    """Eqs. (13)-(15): theta* = theta + (1 + lambda) gamma [(theta_best - theta) + (theta_a - theta_b)] + zeta on the
    components selected by the binomial crossover mask (others keep the current value). ``best`` may be None
    (the symmetric variants drop the theta_best pull)."""
    pull = diff_a - diff_b if best is None else (best - current) + (diff_a - diff_b)
    mutated = current + (1.0 + lam)[:, None] * gamma * pull + zeta
    return np.where(crossover, mutated, current)


def _logsumexp_rows(a):
    """ln sum_c exp(a[:, c]) for rows with at least one finite entry (faster than scipy's for small K)."""
    top = a.max(1)
    return top + np.log(np.exp(a - top[:, None]).sum(1))


class GaussianMixture:
    """A Gaussian mixture sum_c pi_c N(mu_c, Sigma_c) held by its Cholesky factors (arrays only: it pickles into a
    checkpoint). ``component_logpdf(x, scale)`` gives ln N(x; mu_c, scale^2 Sigma_c) for every component; with
    ``centred=True`` the means are taken as zero (the density of a displacement under the random-walk proposal)."""

    def __init__(self, weights, means, covs):
        self.weights = np.asarray(weights, dtype=float)
        self.means = np.asarray(means, dtype=float)
        self.covs = np.asarray(covs, dtype=float)
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
        log_g = _logsumexp_rows(joint)
        return joint - log_g[:, None], log_g


def fit_gaussian_mixture(theta, weights, max_components=5, floor=0.0, ridge=1e-6, max_iter=15, tol=1e-3):
    """A Gaussian mixture fitted to the weighted population (theta_k, w_k) by EM, deterministic (no random numbers).

    K = 1 is the weighted mean and covariance (Eq. 12). K + 1 components start from the K-component fit with the
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
                         _logsumexp_rows(log_r_new + walk) - _logsumexp_rows(log_r + walk))
    return proposal, log_ratio, (log_r_new, log_g_new)


def resample(weights, rng, method="systematic"):
    """Step 4 (5.1): N indices drawn with probabilities ``weights``, sorted. "multinomial" is Ching & Chen's;
    "systematic" (one uniform, N evenly spaced points on the cumulative weights) has lower variance."""
    n = len(weights)
    if method == "multinomial":
        return np.sort(rng.choice(n, size=n, p=weights))
    if method != "systematic":
        raise ValueError(f"resampling = {method!r}: use 'systematic' or 'multinomial'")
    cum = np.cumsum(weights)
    cum[-1] = 1.0
    return np.searchsorted(cum, (rng.random() + np.arange(n)) / n, side="right").clip(0, n - 1)


def _rng(seed, *key):
    return np.random.default_rng(np.random.SeedSequence([int(seed), *[int(k) for k in key]]))


def _draw_pairs(rng, movers, population):
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


# ---------------------------------------------------------------------------------------------- sampler
class _Run:
    """One TMCMC run on rank 0: the state machine that checkpoints and resumes."""

    def __init__(self, evaluator, prior, executor, settings, checkpoint, fingerprint, progress, log):
        self.ev = evaluator
        self.prior = prior
        self.ex = executor
        self.s = settings
        self.checkpoint = checkpoint
        self.fingerprint = fingerprint
        self.progress = progress
        self.log = log
        self.signal_received = None
        self.t_start = time.perf_counter()
        self.last_save = time.perf_counter()
        self.evals_since_save = 0
        self.last_print = time.perf_counter()

    # ---- output
    def say(self, msg):
        if self.progress:
            print(msg, file=sys.stderr, flush=True)
        if self.log is not None:
            with open(self.log, "a") as fh:
                fh.write(msg + "\n")

    # ---- state
    def fresh_state(self):
        return {
            "phase": "prior", "stage": 0, "q": 0.0, "log_evidence": 0.0, "theta": None, "log_like": None,
            "log_prior": None, "records": [], "stage_theta": [], "stage_log_like": [], "failures": [],
            "n_evals": 0, "map": None, "chain": None, "partial": {}, "wall_before": 0.0,
        }

    def save(self, st):
        if self.checkpoint is None:
            return
        snapshot = dict(st, wall_before=self.wall(st))
        save_checkpoint(self.checkpoint, snapshot, self.fingerprint)
        self.last_save = time.perf_counter()
        self.evals_since_save = 0

    def wall(self, st):
        """Wall time of the run so far, including the time before a resume (s)."""
        return st["wall_before"] + (time.perf_counter() - self.t_start)

    # ---- evaluation of one batch with partial checkpoints
    def evaluate(self, st, thetas, where):
        """Evaluate thetas (m, d); reuse results of a resumed partial batch. Returns (values, reasons, ranks)."""
        m = len(thetas)
        values = np.full(m, np.nan)
        reasons = [None] * m
        ranks = np.zeros(m, dtype=int)
        partial = st["partial"]
        done = np.array(sorted(partial), dtype=int)
        for k in done:
            values[k], reasons[k], ranks[k] = partial[k]
        todo = np.setdiff1d(np.arange(m), done)
        if todo.size:
            def callback(idx, v, r, rk):
                for i, vi, ri, rki in zip(idx, v, r, rk):
                    partial[int(todo[i])] = (float(vi), ri, int(rki))
                self.evals_since_save += len(idx)
                now = time.perf_counter()
                if self.checkpoint is not None and (
                        now - self.last_save > self.s["checkpoint_every"]
                        or (self.s["checkpoint_evals"] and self.evals_since_save >= self.s["checkpoint_evals"])):
                    self.save(st)
                if self.progress and now - self.last_print > self.s["progress_every"]:
                    self.last_print = now
                    self.say(f"    {where}: {len(partial)}/{m} evaluations of this batch done, "
                             f"elapsed {self.wall(st):.0f} s")

            v, r, rk = self.ex.evaluate(self.ev, thetas[todo], callback=callback,
                                        stop=lambda: self.signal_received is not None)
            values[todo], ranks[todo] = v, rk
            for i, k in enumerate(todo):
                reasons[k] = r[i]
            if self.signal_received is not None:
                for i, k in enumerate(todo):  # keep what finished, then stop
                    if np.isnan(v[i]):
                        partial.pop(int(k), None)
                self.save(st)
                raise _Interrupted(self.signal_received)
        st["partial"] = {}
        return values, reasons, ranks

    def account(self, st, thetas, values, reasons, ranks, where):
        """Count evaluations, record failures, track the MAP (7) over every evaluated sample."""
        st["n_evals"] += len(values)
        lp = self.prior.logpdf(thetas)
        post = lp + values
        rec = st["records_current"]
        rec["n_evals"] += len(values)
        for k in np.flatnonzero(~np.isfinite(values)):
            rec["n_failed"] += 1
            st["failures"].append({"stage": st["stage"], "where": where, "particle": int(k), "rank": int(ranks[k]),
                                   "reason": reasons[k], "theta": self.prior.as_dict(thetas[k])})
        if np.isfinite(post).any():
            k = int(np.argmax(np.where(np.isfinite(post), post, -np.inf)))
            if st["map"] is None or post[k] > st["map"]["log_posterior"]:
                st["map"] = {"theta": thetas[k].copy(), "log_posterior": float(post[k]),
                             "log_like": float(values[k])}
        n_ev = max(rec["n_evals"], 1)
        if rec["n_evals"] >= self.s["n_samples"] and rec["n_failed"] > self.s["max_failure_fraction"] * n_ev:
            examples = "\n".join(f"  {f['reason']} at {f['theta']}" for f in st["failures"][-3:])
            raise SamplerError(
                f"stage {st['stage']}: {rec['n_failed']} of {rec['n_evals']} forward evaluations failed "
                f"(> {self.s['max_failure_fraction']:.0%}, max_failure_fraction); last failures:\n{examples}")

    # ---- stage 0
    def prior_stage(self, st):
        if "records_current" not in st:  # (a resumed stage 0 keeps its record)
            st["records_current"] = self.new_record(0, 0.0)
            st["records_current"]["wall_at_start"] = self.wall(st)
        thetas = self.prior.sample(_rng(self.s["seed"], 0, 0, 0), self.s["n_samples"])
        values, reasons, ranks = self.evaluate(st, thetas, "stage 0 (prior)")
        self.account(st, thetas, values, reasons, ranks, "prior")
        st["theta"], st["log_like"] = thetas, values
        st["log_prior"] = self.prior.logpdf(thetas)
        self.close_stage(st, acceptance=float("nan"), sweeps=0, log_s=0.0)
        st["phase"] = "select"

    def new_record(self, stage, q):
        return {"stage": stage, "q": q, "log_S": 0.0, "acceptance": float("nan"), "n_evals": 0, "n_failed": 0,
                "sweeps": 0, "wall_s": 0.0, "wall_at_start": None, "beta2": self.s["beta2"]}

    def close_stage(self, st, acceptance, sweeps, log_s):
        rec = st.pop("records_current")
        rec.update(acceptance=acceptance, sweeps=sweeps, log_S=log_s)
        rec["wall_s"] = self.wall(st) - rec.pop("wall_at_start")
        st["records"].append(rec)
        st["stage_theta"].append(st["theta"].copy())
        st["stage_log_like"].append(st["log_like"].copy())
        j = rec["stage"]
        elapsed = self.wall(st)
        rate = rec["n_evals"] / rec["wall_s"] if rec["wall_s"] > 0 else float("inf")
        qs = [r["q"] for r in st["records"] if r["q"] > 0]
        eta = ""
        if len(qs) >= 2 and qs[-1] < 1:
            per_stage = math.log(qs[-1] / qs[0]) / (len(qs) - 1)
            if per_stage > 0:
                remaining = -math.log(qs[-1]) / per_stage
                eta = f", ETA ~{remaining * elapsed / len(st['records']):.0f} s"
        self.say(f"stage {j:3d}  q={rec['q']:.4e}  ln S={log_s:+.4f}  acc={acceptance:.3f}  sweeps={sweeps}  "
                 f"failed={rec['n_failed']}  {rate:.1f} evals/s  elapsed {elapsed:.1f} s{eta}")

    # ---- stage selection and resampling (steps 1-4)
    def select(self, st):
        q = st["q"]
        q_next = choose_next_exponent(st["log_like"], q, self.s["cov_target"])
        w, log_s = stage_weights(st["log_like"], q_next - q)
        st["log_evidence"] += log_s
        st["stage"] += 1
        st["records_current"] = self.new_record(st["stage"], q_next)
        st["records_current"]["wall_at_start"] = self.wall(st)
        theta = st["theta"]
        cov = self.s["beta2"] * weighted_covariance(theta, w)
        cov += np.diag(1e-12 * (self.prior.upper - self.prior.lower) ** 2)
        best = theta[int(np.argmax(np.where(np.isfinite(st["log_like"]), st["log_like"], -np.inf)))].copy()
        mixtures = None
        if self.s["covariance"] == "mixture":  # fitted once per stage, before the moves: fixed during the stage
            # cross-fitted: one mixture to the even-indexed and one to the odd-indexed weighted particles
            half = np.arange(len(theta)) % 2
            mixtures = [fit_gaussian_mixture(theta, w * (half == h) if w[half == h].sum() > 0 else w,
                                             self.s["max_components"],
                                             floor=1e-12 * (self.prior.upper - self.prior.lower) ** 2)
                        for h in (0, 1)]
            st["records_current"]["components"] = [m.n_components for m in mixtures]
        parents = resample(w, _rng(self.s["seed"], st["stage"], 0, 0), self.s["resampling"])
        if self.s["chains"] == "ching-chen":
            uniq, counts = np.unique(parents, return_counts=True)
            start = uniq
            length = counts
        else:
            start = parents
            length = None
        st["chain"] = {
            "q_next": q_next, "log_S": log_s, "cov": cov, "chol": np.linalg.cholesky(cov), "best": best,
            "mixtures": None,
            "start": theta[start].copy(), "pos": theta[start].copy(), "log_like": st["log_like"][start].copy(),
            "log_prior": st["log_prior"][start].copy(), "length": length, "sweep": 0, "move": 0,
            "accepted": 0, "proposed": 0, "samples": [] if length is not None else None,
        }
        if mixtures is not None:  # each chain moves with the mixture fitted to the other half than its parent
            st["chain"].update(mixtures=mixtures, fit_of=1 - start % 2,
                               resp=[m.log_responsibilities(theta[start]) for m in mixtures])
        st.setdefault("scale", 1.0)
        st["phase"] = "mcmc"

    # ---- MCMC (steps 5-6)
    def moves_per_sweep(self):
        return 2 if (self.s["proposal"] == "de" and self.s["de_variant"] == "redblue") else 1

    def propose(self, st, ch, movers, rng):
        """Proposals for the movers, the Hastings term ln q(theta | theta*) - ln q(theta* | theta) (0 for the
        symmetric moves) and, for the mixture move, the proposals' mixture responsibilities (else None)."""
        pos = ch["pos"]
        d = pos.shape[1]
        if self.s["proposal"] == "gaussian":
            z = rng.standard_normal((pos.shape[0], d))[movers]
            if ch["mixtures"] is None:
                return pos[movers] + st["scale"] * (z @ ch["chol"].T), 0.0, None
            pick, kind = rng.random(pos.shape[0])[movers], rng.random(pos.shape[0])[movers]
            proposal, log_hastings, resp_new = np.empty_like(z), np.empty(movers.size), []
            for g, mix in enumerate(ch["mixtures"]):
                sel = ch["fit_of"][movers] == g
                rows = movers[sel]
                proposal[sel], log_hastings[sel], resp = mixture_proposal(
                    mix, pos[rows], z[sel], pick[sel], kind[sel], st["scale"] * math.sqrt(self.s["beta2"]),
                    self.s["independence"], tuple(r[rows] for r in ch["resp"][g]))
                resp_new.append((sel, resp))
            return proposal, log_hastings, resp_new
        C = pos.shape[0]
        if self.s["de_variant"] == "redblue":
            half = ch["move"]
            population = np.flatnonzero(np.arange(C) % 2 != half)
        else:
            population = np.arange(C)
        gamma = st["scale"] * 2.38 / math.sqrt(2.0 * self.s["de_delta"] * d)
        lam = rng.uniform(-self.s["de_c"], self.s["de_c"], C)[movers]
        zeta = rng.normal(0.0, math.sqrt(self.s["de_c_star"]), (C, d))[movers]
        cross = rng.random((C, d))[movers] <= self.s["de_cr"]
        i_rand = rng.integers(0, d, C)[movers]
        cross[np.arange(movers.size), i_rand] = True
        a, b = _draw_pairs(rng, movers, population)
        best = ch["best"] if self.s["de_variant"] == "paper" else None
        return de_proposal(pos[movers], best, pos[a], pos[b], gamma, lam, zeta, cross), 0.0, None

    def mcmc(self, st):
        ch = st["chain"]
        q_next = ch["q_next"]
        C = ch["pos"].shape[0]
        while True:
            sweep, move = ch["sweep"], ch["move"]
            if ch["length"] is not None:
                active = np.flatnonzero(ch["length"] > sweep)
                if active.size == 0:
                    break
            else:
                active = np.arange(C)
            if self.s["proposal"] == "de" and self.s["de_variant"] == "redblue":
                movers = active[active % 2 == move]
            else:
                movers = active
            rng = _rng(self.s["seed"], st["stage"], sweep + 1, move)
            proposal, log_hastings, resp_new = self.propose(st, ch, movers, rng)
            u = rng.random(C)[movers]
            lp_new = self.prior.logpdf(proposal)
            inside = np.isfinite(lp_new)
            ll_new = np.full(movers.size, -np.inf)
            if inside.any():
                vals, reasons, ranks = self.evaluate(st, proposal[inside], f"stage {st['stage']} sweep {sweep + 1}")
                self.account(st, proposal[inside], vals, reasons, ranks, f"sweep {sweep + 1}")
                ll_new[inside] = vals
            old = ch["log_prior"][movers] + q_next * ch["log_like"][movers]
            with np.errstate(invalid="ignore"):
                new = lp_new + q_next * ll_new
                accept = np.isfinite(new) & (np.log(u) < new - old + log_hastings)
            idx = movers[accept]
            ch["pos"][idx] = proposal[accept]
            ch["log_like"][idx] = ll_new[accept]
            ch["log_prior"][idx] = lp_new[accept]
            for g, (sel, resp) in enumerate(resp_new or ()):  # cached mixture responsibilities of the positions
                for cached, new_values in zip(ch["resp"][g], resp):
                    cached[movers[sel & accept]] = new_values[accept[sel]]
            ch["accepted"] += int(accept.sum())
            ch["proposed"] += int(movers.size)
            if self.s["scale_adapt"] and movers.size and ch["mixtures"] is None:
                # proposal scale steered toward the target acceptance (population statistic, between moves)
                st["scale"] *= math.exp(accept.mean() - self.s["target_acceptance"])
            # advance the (sweep, move) counter; a sweep ends after all its moves
            if move + 1 < self.moves_per_sweep():
                ch["move"] = move + 1
            else:
                ch["move"] = 0
                ch["sweep"] = sweep + 1
                if ch["length"] is not None:
                    ch["samples"].append((active, ch["pos"][active].copy(), ch["log_like"][active].copy(),
                                          ch["log_prior"][active].copy()))
                elif self.sweeps_done(ch):
                    break
            if self.checkpoint is not None and time.perf_counter() - self.last_save > self.s["checkpoint_every"]:
                self.save(st)
        self.finish_stage(st)

    def sweeps_done(self, ch):
        n = ch["sweep"]
        if self.s["n_steps"] != "adaptive":
            return n >= int(self.s["n_steps"])
        if n < self.s["min_steps"]:
            return False
        if n >= self.s["max_steps"]:
            return True
        return self.start_correlation(ch) < self.s["corr_threshold"]

    @staticmethod
    def start_correlation(ch):
        """Correlation between the particles' start and current positions, mean over dimensions: the smaller of the
        plain correlation over the population and a within-mode estimate from siblings.

        Siblings (copies of one resampled parent, hence one start x0) move independently given x0. For a mode of
        variance s^2 and a lag correlation rho, the mean squared displacement is D = E(x - x0)^2 = 2 s^2 (1 - rho)
        and the spread among siblings is W = E Var(x | x0) = s^2 (1 - rho^2) (exact for Gaussian modes), so
        rho = 2 W / D - 1 with W and D taken over the siblings. Both are local, so the spread between modes, which
        keeps the plain correlation near 1 on a multimodal posterior, drops out. Each estimate errs high in its own
        case: the plain one through the spread between modes, the sibling one because copies come from high-weight
        starts near a mode's centre, which move less (on unimodal problems it exceeds the plain one); hence the
        minimum. The sibling estimate needs at least ``SIBLING_FRACTION`` of the population to be extra copies."""
        a, b = ch["start"], ch["pos"]
        da, db = a - a.mean(0), b - b.mean(0)
        den = np.sqrt((da * da).sum(0) * (db * db).sum(0))
        plain = float(np.where(den > 0, (da * db).sum(0) / np.where(den > 0, den, 1.0), 0.0).mean())
        _, group, counts = np.unique(a, axis=0, return_inverse=True, return_counts=True)
        group = group.ravel()
        dof = int(np.sum(counts[counts > 1] - 1))
        if dof < SIBLING_FRACTION * len(a):
            return plain
        in_group = counts[group] > 1
        g, x = group[in_group], b[in_group]
        sums = np.zeros((counts.size, x.shape[1]))
        np.add.at(sums, g, x)
        within = ((x - sums[g] / counts[g][:, None]) ** 2).sum(0) / dof
        disp = ((x - a[in_group]) ** 2).mean(0)
        rho = np.where(disp > 0, 2.0 * within / np.where(disp > 0, disp, 1.0) - 1.0, 1.0)
        return min(plain, float(np.clip(rho, -1.0, 1.0).mean()))

    def finish_stage(self, st):
        ch = st["chain"]
        if ch["length"] is not None:  # Ching & Chen: every chain state is a sample, in (sweep, chain) order
            st["theta"] = np.concatenate([s[1] for s in ch["samples"]])
            st["log_like"] = np.concatenate([s[2] for s in ch["samples"]])
            st["log_prior"] = np.concatenate([s[3] for s in ch["samples"]])
        else:
            st["theta"], st["log_like"], st["log_prior"] = ch["pos"], ch["log_like"], ch["log_prior"]
        st["q"] = ch["q_next"]
        acc = ch["accepted"] / max(ch["proposed"], 1)
        self.close_stage(st, acceptance=acc, sweeps=ch["sweep"], log_s=ch["log_S"])
        st["chain"] = None
        st["phase"] = "select" if st["q"] < 1.0 else "done"

    # ---- driver
    def run(self, st):
        self.install_signals()
        try:
            while st["phase"] != "done":
                if st["phase"] == "prior":
                    self.prior_stage(st)
                    self.save(st)
                elif st["phase"] == "select":
                    if st["stage"] >= self.s["max_stages"]:
                        raise SamplerError(f"no convergence to q = 1 within max_stages = {self.s['max_stages']}")
                    self.select(st)
                elif st["phase"] == "mcmc":
                    self.mcmc(st)
                    self.save(st)
        finally:
            self.restore_signals()
        return st

    def install_signals(self):
        self._previous = {}
        if self.checkpoint is None:
            return

        def handler(signum, frame):
            self.signal_received = signum

        for sig in (signal.SIGTERM, signal.SIGUSR1):
            try:
                self._previous[sig] = signal.signal(sig, handler)
            except ValueError:  # not the main thread
                pass

    def restore_signals(self):
        for sig, prev in self._previous.items():
            signal.signal(sig, prev)


class _Interrupted(Exception):
    def __init__(self, signum):
        self.signum = signum


def _fingerprint(loglike, prior, settings):
    if hasattr(loglike, "fingerprint"):
        fp = loglike.fingerprint() if callable(loglike.fingerprint) else loglike.fingerprint
    else:
        fp = getattr(loglike, "__qualname__", type(loglike).__qualname__)
    keys = ("n_samples", "proposal", "de_variant", "chains", "n_steps", "min_steps", "max_steps", "corr_threshold",
            "beta2", "cov_target", "seed", "de_c", "de_c_star", "de_delta", "de_cr", "resampling", "scale_adapt",
            "target_acceptance")
    if settings["covariance"] != "global":  # (checkpoints written before the option existed stay resumable)
        keys += ("covariance", "max_components", "independence")
    out = {"likelihood": str(fp), "prior": str(prior.describe())}
    out.update({k: settings[k] for k in keys})
    return out


def tmcmc(loglike, prior: Prior, n_samples=2000, proposal="de", *, de_variant="redblue", chains="particles",
          n_steps="adaptive", min_steps=2, max_steps=25, corr_threshold=0.3, beta2=None, cov_target=1.0,
          covariance="global", max_components=5, independence=0.8,
          de_c=0.1, de_c_star=1e-12, de_delta=3.0, de_cr=0.9, executor=None, dispatch="dynamic", seed=0,
          checkpoint=None, resume=False, checkpoint_every=60.0, checkpoint_evals=None, progress=True,
          progress_every=10.0, vectorized=False, timeout=None, max_failure_fraction=0.1, max_stages=200,
          resampling="systematic", scale_adapt=False, target_acceptance=0.25, log=None) -> Posterior:
    """Sample the posterior p(theta | D) ∝ p(theta) L(theta) by TMCMC and estimate the log-evidence.

    loglike: an :class:`inference.Likelihood` (Eqs. 3-6, bound to the prior's parameter order here), a callable
        theta (d,) -> ln L, or with ``vectorized=True`` thetas (m, d) -> (m,).
    prior: :class:`inference.Prior` (``UniformPrior``/``LogUniformPrior``); theta is in its order.
    proposal: "gaussian" (O-TMCMC) or "de" (DE-TMCMC); ``de_variant`` "paper", "symmetric" or "redblue".
    covariance: O-TMCMC proposal covariance, "global" (Eqs. 11-12, the default) or "mixture" (one per mode of a
        Gaussian mixture with at most ``max_components`` components fitted to each stage's weighted population; a
        fraction ``independence`` of the moves are independence proposals from the mixture; see the module notes).
        "mixture" keeps the proposal fixed within a stage, so it does not go with ``scale_adapt``.
    beta2: the random-walk scale beta^2; None gives 0.04 with "global" (the paper) and 2.38^2 / d with "mixture".
    chains: "particles" (n_steps sweeps per stage, "adaptive" or an int) or "ching-chen".
    executor: None chooses MPI under mpirun (``dispatch`` "dynamic" or "spmd"), else a local process pool.
    checkpoint / resume: a file written atomically after every stage and every ``checkpoint_every`` seconds (or
        ``checkpoint_evals`` evaluations) inside a stage; SIGTERM/SIGUSR1 write it and exit with status 75.
    timeout: seconds per forward evaluation (a time-out is a failed, zero-likelihood particle).
    max_failure_fraction: stop with SamplerError when more than this fraction of a stage's evaluations failed.
    Returns a :class:`inference.Posterior` on every rank.
    """
    if not isinstance(prior, Prior):
        raise TypeError("prior must be an inference.Prior (UniformPrior / LogUniformPrior)")
    if int(n_samples) != n_samples or n_samples < 2:
        raise ValueError(f"n_samples = {n_samples}: need an integer >= 2")
    if proposal not in ("gaussian", "de"):
        raise ValueError(f"proposal = {proposal!r}: use 'gaussian' (O-TMCMC) or 'de' (DE-TMCMC)")
    if de_variant not in ("paper", "symmetric", "redblue"):
        raise ValueError(f"de_variant = {de_variant!r}: use 'paper', 'symmetric' or 'redblue'")
    if chains not in ("particles", "ching-chen"):
        raise ValueError(f"chains = {chains!r}: use 'particles' or 'ching-chen'")
    if n_steps != "adaptive" and (int(n_steps) != n_steps or n_steps < 1):
        raise ValueError(f"n_steps = {n_steps!r}: use 'adaptive' or a positive integer")
    if proposal == "de" and n_samples < 5:
        raise ValueError("DE-TMCMC needs n_samples >= 5 (three distinct partners per move)")
    if covariance not in ("global", "mixture"):
        raise ValueError(f"covariance = {covariance!r}: use 'global' (Eqs. 11-12) or 'mixture'")
    if covariance == "mixture" and proposal != "gaussian":
        raise ValueError("covariance = 'mixture' is a move of O-TMCMC: use it with proposal = 'gaussian'")
    if covariance == "mixture" and scale_adapt:
        raise ValueError("covariance = 'mixture' keeps its proposal fixed within a stage: scale_adapt must be False")
    if not (0.0 <= independence <= 1.0) or int(max_components) != max_components or max_components < 1:
        raise ValueError("independence must be in [0, 1] and max_components a positive integer")
    if beta2 is None:
        beta2 = 2.38**2 / prior.dim if covariance == "mixture" else 0.04
    if not (beta2 > 0 and cov_target > 0):
        raise ValueError("beta2 and cov_target must be > 0")
    if isinstance(loglike, Likelihood):
        loglike.bind(prior.names)
    settings = dict(n_samples=int(n_samples), proposal=proposal, de_variant=de_variant if proposal == "de" else None,
                    chains=chains, n_steps=n_steps, min_steps=int(min_steps), max_steps=int(max_steps),
                    corr_threshold=float(corr_threshold), beta2=float(beta2), cov_target=float(cov_target),
                    de_c=de_c, de_c_star=de_c_star, de_delta=de_delta, de_cr=de_cr, seed=int(seed),
                    checkpoint_every=float(checkpoint_every), checkpoint_evals=checkpoint_evals,
                    progress_every=float(progress_every), max_failure_fraction=float(max_failure_fraction),
                    max_stages=int(max_stages), resampling=resampling, scale_adapt=bool(scale_adapt),
                    target_acceptance=float(target_acceptance), covariance=covariance,
                    max_components=int(max_components), independence=float(independence))
    evaluator = Evaluator(loglike, vectorized=vectorized, timeout=timeout)
    own_executor = executor is None
    if not (executor is None or isinstance(executor, _BaseExecutor)):
        raise TypeError(f"executor = {executor!r}: pass None (MPI under mpirun, else a process pool) or an instance "
                        "of inference.SerialExecutor, PoolExecutor or MPIExecutor")
    if executor is None:
        executor = default_executor(dispatch)
    if isinstance(executor, MPIExecutor) and not executor.is_root:
        payload = executor.serve(evaluator)
        return _unwrap(payload)
    fingerprint = _fingerprint(loglike, prior, settings)
    run = _Run(evaluator, prior, executor, settings, checkpoint, fingerprint, progress and executor.is_root, log)
    payload = None
    try:
        if resume and checkpoint is not None and Path(checkpoint).exists():
            st = load_checkpoint(checkpoint, fingerprint)
            run.say(f"resuming from {checkpoint}: stage {st['stage']}, phase {st['phase']}, "
                    f"{st['n_evals']} evaluations done")
        else:
            st = run.fresh_state()
        st = run.run(st)
        post = Posterior.from_state(st, prior, settings, executor, run.wall(st))
        payload = ("ok", post)
    except _Interrupted as intr:
        run.say(f"signal {intr.signum} received: checkpoint written to {checkpoint}; resume with resume=True")
        payload = ("exit", EXIT_CHECKPOINTED)
    except BaseException as exc:
        payload = ("error", f"{type(exc).__name__}: {exc}")
        if isinstance(executor, MPIExecutor):
            executor.finish(payload)
        if own_executor:
            executor.close()
        raise
    if isinstance(executor, MPIExecutor):
        executor.finish(payload)
    if own_executor:
        executor.close()
    return _unwrap(payload)


def _unwrap(payload):
    kind, value = payload
    if kind == "ok":
        return value
    if kind == "exit":
        raise SystemExit(value)
    raise SamplerError(f"rank 0 stopped: {value}")
