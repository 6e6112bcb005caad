"""The log-evidence of a calibrated model class from its refined posterior mode: Laplace, corrected by importance
sampling.

Why not TMCMC's own estimate alone. ln Z_TMCMC = sum_j ln mean_k w_jk over the tempering stages (docs/reference.md
section 2) is exact only when each stage's particles follow that stage's tempered posterior. With few particles and
few MCMC sweeps per stage (the quick settings: 64 particles, at most 4 sweeps) the population lags behind a narrow,
ridge-shaped posterior, and the estimate falls short by an amount that grows with the number of stages: measured on
a two-test CK0U programme, 18 units of ln Z for a 5-parameter class of 14 stages and about 170 for a 7-parameter
class of 23 stages, enough to decide a Bayes factor by the sampler's lag. The estimate here uses the TMCMC posterior
only as a starting point:

1. every parameter is mapped to the real line, u = logit((theta - lo)/(hi - lo)) (uniform prior) or the same on
   ln theta (log-uniform), and the target is g(u) = ln L(theta(u)) + ln pi(theta(u)) + sum ln |d theta/d u| (so
   that Z = integral exp(g) du, exactly);
2. the mode u* of g is refined from the best of the sample's points and the further starts given by damped Newton steps
   with the gradient and Hessian from central differences (one batch of d^2 + d + 1 solves per step, steps h_i = 0.2 x
   the current posterior standard deviation along u_i), in the saddle-free metric |H| (eigenvalues by absolute value)
   and a trust region of MAX_STEP per coordinate, the step and multiples of it (TRIAL_MULTIPLES, 0.03 to 4) tried in
   one batch; the best is kept only when it raises g, and the climb stops where g is concave and the quadratic
   model's remaining ascent is below CONVERGED_GAIN (1e-3 nats). The climb is repeated from
   each point asked for whatever its value (e.g. a nested class's mode with the added parameters at mid-prior), the
   highest mode kept: a posterior sample of few particles may sit on a lesser mode of a multimodal target (measured:
   an enriched class of a two-test CRS programme, ln g 265.5 climbed from the sample against 294.8 from a start at
   mid-prior of the added parameters);
3. Laplace: ln Z_L = g(u*) + (d/2) ln 2 pi - (1/2) ln det(-H(u*));
4. importance sampling with the proposal q, an equal mixture of Student-t distributions (``df`` degrees of freedom)
   centred at u* with scale matrices (-H)^-1 and WIDE^2 (-H)^-1 (a defensive mixture for curved posteriors):
   ln Z_IS = ln mean_i exp(g(u_i) - ln q(u_i)), u_i ~ q, unbiased in Z whatever the posterior's shape; its
   spread is given by the effective sample size ESS = (sum w)^2 / sum w^2 and the delta-method standard error
   sqrt((mean w^2 / (mean w)^2 - 1) / N);
5. when the effective sample size falls short of ``min_ess`` N (a skewed or bounded posterior that the curvature at
   the mode misplaces: a destructuration class's (chi0, xi), measured ESS 2-25 of 256), up to ``adapt_rounds``
   further batches of N draws follow, each from a Student-t proposal with the weighted mean and covariance of all
   draws so far (adaptive multiple importance sampling, Cornuet, Marin, Mira & Robert 2012), the covariance shrunk
   toward (-H)^-1 by d / (ESS + d) while the weights are few. Every draw of every batch is weighted against the
   mixture of all the batches' proposals in proportion to their draws (the deterministic-mixture, or balance
   heuristic, weights: Veach & Guibas 1995; Owen & Zhou 2000), so the first batch's defensive proposal stays in the
   denominator of every weight; ESS, standard error and ln Z_IS are those of the pooled weights, N their number.
   The rounds stop as soon as the pooled ESS reaches ``min_ess`` N. The reported ln Z is ln Z_IS when it does,
   else ln Z_L, or the lower bound of step 6 where ln Z_L falls below it (method "lower bound"): a Laplace value
   below a bound that holds with probability 0.95 is known to be short (the curvature at the mode misses mass that
   a skewed or bounded posterior holds: a destructuration class, Laplace 258.6, bound 261.7, importance sampling
   263.9 at ESS 15 of 1024), and the bound is the highest value the draws vouch for;
6. a lower bound that holds whatever the proposals' fit: each batch's estimate from its own proposal alone, Z_i =
   mean_j exp(g(u_ij) - ln q_i(u_ij)), is unbiased and positive given the batches before it (q_i is fixed before its
   draws), so by Markov's inequality P(Z_i >= c Z | the earlier batches) <= 1/c. For the first batch alone,
   ln Z >= ln Z_1 + ln delta with probability at least 1 - delta; for all K = 1 + ``adapt_rounds`` batches, the
   conditional bounds multiply, P(every Z_i >= c Z) <= c^-K, so ln Z >= min_i ln Z_i + (ln delta)/K with
   probability at least 1 - delta (the minimum of K estimates, Gogate, Bidyuk & Dechter 2007). ``log_lower`` is the
   larger of the two, each taken at delta = LOWER_BOUND_RISK / 2, so that it exceeds ln Z with probability at most
   LOWER_BOUND_RISK = 0.05: ln Z_1 - 3.69, or min_i ln Z_i - 0.92 for K = 4, where adapted batches that fit a
   skewed posterior the first batch misses make the second the tighter; the second exists only when all K batches
   were drawn (K is then fixed by the settings, not by the draws). Without adaptation (``adapt_rounds`` 0) the two
   are one: ln Z_1 - 3.00.

References: Tierney & Kadane (1986) Laplace's method; Geweke (1989) importance sampling with a Student-t proposal
fitted at the mode; Cornuet et al. (2012, Scand. J. Stat. 39) adaptive multiple importance sampling; Gogate,
Bidyuk & Dechter (2007, AAAI) lower bounds on the evidence by Markov's inequality; Llorente,
Martino, Delgado & Lopez-Santiago (2023, SIAM Review 65) sections 3 and 5.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy import special, stats

__all__ = ["EvidenceEstimate", "mode_evidence"]

#: finite-difference step along u_i, as a fraction of the posterior standard deviation along u_i
STEP_FRACTION = 0.2
#: the wide half of the importance proposal has this many times the local standard deviations
WIDE = 3.0
#: the further importance batches, each fitted to the pooled weighted draws, when the first falls short of its ESS
ADAPT_ROUNDS = 3
#: the probability with which ``log_lower`` may exceed ln Z (module docstring, step 6)
LOWER_BOUND_RISK = 0.05
#: the largest Newton step along any u_i (u is a logit: 1 moves a parameter in mid-range by about a quarter of its
#: prior range)
MAX_STEP = 1.0
#: the multiples of the (trust-region) Newton step tried in one batch, the best kept when it raises g; those above 1
#: carry a climb whose quadratic model keeps falling short of the ascent (an error parameter far below the misfit:
#: Newton moves its logarithm by at most 1/2 a step) farther per stencil
TRIAL_MULTIPLES = (4.0, 2.0, 1.0, 0.5, 0.25, 0.1, 0.03)
#: a climb stops where g is concave and the ascent its quadratic model has left, (1/2) grad' (-H)^-1 grad, is below
#: this (nats): a further stencil would move ln Z by less
CONVERGED_GAIN = 1e-3


@dataclass(frozen=True)
class EvidenceEstimate:
    """log_evidence: the reported ln Z (``method`` "importance sampling", "Laplace" or "lower bound": module
    docstring, step 5); log_laplace, log_is: the two
    estimates (log_is None when no draw had weight); std_error: standard error of ln Z_IS; ess: effective sample
    size of the importance weights; n_draws: proposal draws; n_solves: log-likelihood evaluations spent (mode,
    Hessian, draws; an ``inference.Likelihood`` solves once the sets that share their soil parameters);
    log_posterior_mode: g at the refined mode; mode: the refined mode in the parameters (theta, the prior's order);
    log_lower: a lower bound of ln Z with probability 1 - LOWER_BOUND_RISK (module docstring, step 6; None when no
    draw of the first batch had weight); log_likelihood_mode: ln L at the refined mode (g less the log prior density
    and the log Jacobian of u): Z = int L pi dtheta <= max L, so no estimate of this class's ln Z can exceed the
    highest ln L it reaches (None in records made before it was kept)."""

    log_evidence: float
    method: str
    log_laplace: float
    log_is: float | None
    std_error: float
    ess: float
    n_draws: int
    n_solves: int
    log_posterior_mode: float
    mode: tuple = ()
    log_lower: float | None = None
    log_likelihood_mode: float | None = None

    def to_dict(self) -> dict:
        return asdict(self)


class _Unbounded:
    """theta <-> u (module docstring, step 1) for an ``inference.Prior``'s bounds, and g(u)."""

    def __init__(self, prior, log_likelihood):
        self.prior, self.log_likelihood = prior, log_likelihood
        self.lo = np.array([b.lower for b in prior.bounds], dtype=float)
        self.hi = np.array([b.upper for b in prior.bounds], dtype=float)
        self.log = np.array([b.kind == "log-uniform" for b in prior.bounds])
        # the log only of the log-uniform bounds (> 0)
        self.a = np.where(self.log, np.log(np.where(self.log, self.lo, 1.0)), self.lo)
        self.b = np.where(self.log, np.log(np.where(self.log, self.hi, 1.0)), self.hi)
        self.n_solves = 0

    def to_u(self, theta):
        x = np.where(self.log, np.log(np.where(self.log, np.maximum(theta, self.lo), 1.0)), theta)
        f = np.clip((x - self.a) / (self.b - self.a), 1e-12, 1.0 - 1e-12)
        return np.log(f) - np.log1p(-f)

    def to_theta(self, u):
        x = self.a + (self.b - self.a) * special.expit(u)
        return np.where(self.log, np.exp(x), x)

    def g(self, u):
        """g (m,) at u (m, d); -inf outside the prior's support or where the solve failed."""
        u = np.atleast_2d(u)
        theta = self.to_theta(u)
        log_jac = self.log_jacobian(u)
        log_prior = np.asarray(self.prior.logpdf(theta), dtype=float)
        out = np.full(len(u), -np.inf)
        ok = np.isfinite(log_prior) & np.isfinite(log_jac)
        if ok.any():
            self.n_solves += int(ok.sum())
            out[ok] = np.asarray(self.log_likelihood(theta[ok]), dtype=float) + log_prior[ok] + log_jac[ok]
        return np.where(np.isfinite(out), out, -np.inf)

    def log_jacobian(self, u):
        """sum_i ln |d theta_i/d u_i| (m,) at u (m, d); -inf where u is so far out that theta sits on a bound."""
        f = special.expit(np.atleast_2d(u))
        x = self.a + (self.b - self.a) * f
        with np.errstate(divide="ignore"):
            return (np.log(self.b - self.a) + np.log(f) + np.log1p(-f) + np.where(self.log, x, 0.0)).sum(axis=1)


def _derivatives(g, u, h):
    """(g(u), gradient, Hessian) by central differences with steps h (d,), one batch of d^2 + d + 1 evaluations:
    g at u, at u +- h_i e_i and, for each pair i < j, at u + h_i e_i + h_j e_j and u - h_i e_i - h_j e_j.
    H_ii = (g(+i) - 2 g0 + g(-i)) / h_i^2 and
    H_ij = (g(+i+j) - g(+i) - g(+j) + 2 g0 - g(-i) - g(-j) + g(-i-j)) / (2 h_i h_j),
    both exact for a quadratic and in error by O(h^2) otherwise (the seven-point mixed difference along the diagonal,
    Abramowitz & Stegun 1964, section 25.3; the four-corner formula costs 2 d^2 + 1)."""
    d = len(u)
    eye = np.eye(d)
    points = [u]
    for i in range(d):
        for s in (1.0, -1.0):
            points.append(u + s * h[i] * eye[i])
    pairs = [(i, j) for i in range(d) for j in range(i + 1, d)]
    for i, j in pairs:
        for s in (1.0, -1.0):
            points.append(u + s * (h[i] * eye[i] + h[j] * eye[j]))
    v = g(np.array(points))
    f0, plus, minus = v[0], v[1:2 * d + 1:2], v[2:2 * d + 1:2]
    with np.errstate(invalid="ignore"):  # a failed solve (-inf) makes a difference NaN: the flag refuses the stencil
        grad = (plus - minus) / (2.0 * h)
        H = np.diag((plus - 2.0 * f0 + minus) / h ** 2)
        for k, (i, j) in enumerate(pairs):
            both_plus, both_minus = v[2 * d + 1 + 2 * k], v[2 * d + 2 + 2 * k]
            H[i, j] = H[j, i] = (both_plus - plus[i] - plus[j] + 2.0 * f0 - minus[i] - minus[j] + both_minus) / (
                2.0 * h[i] * h[j])
    return f0, grad, H, bool(np.all(np.isfinite(v)))


class _StudentMixture:
    """The importance proposal: an equal mixture of Student-t distributions centred at ``mode`` with the scale
    matrices ``covs``: at the mode, (-H)^-1 and WIDE^2 (-H)^-1, the wide half covering the tails of a curved or skewed
    posterior that the local curvature underestimates (a defensive mixture, Hesterberg 1995); one matrix for an
    adapted batch (module docstring, step 5)."""

    def __init__(self, mode, covs, df):
        self.parts = [stats.multivariate_t(loc=mode, shape=c, df=df) for c in covs]

    def rvs(self, n, rng):
        d = len(self.parts[0].loc)
        which = len(self.parts) - 1 - np.floor(rng.random(n) * len(self.parts)).astype(int)
        out = np.empty((n, d))
        for k, part in enumerate(self.parts):
            rows = which == k
            if rows.any():
                out[rows] = np.atleast_2d(part.rvs(size=int(rows.sum()), random_state=rng)).reshape(-1, d)
        return out

    def logpdf(self, x):
        return np.logaddexp.reduce([part.logpdf(x) for part in self.parts], axis=0) - np.log(len(self.parts))


def _weights(log_w):
    """(ln mean w, ESS, standard error of ln mean w) of importance log-weights (-inf for no weight); ln mean w is
    None when no draw has weight."""
    finite = np.isfinite(log_w)
    if not finite.any():
        return None, 0.0, np.inf
    w = np.exp(np.where(finite, log_w - log_w[finite].max(), -np.inf))
    ess = float(w.sum() ** 2 / (w ** 2).sum())
    error = float(np.sqrt(max(np.mean(w ** 2) / np.mean(w) ** 2 - 1.0, 0.0) / len(w)))
    return float(special.logsumexp(log_w[finite]) - np.log(len(w))), ess, error


def _importance(t, mode, cov, n_draws, min_ess, rounds, df, rng):
    """Importance sampling of g from the defensive mixture at ``mode``, adapted by up to ``rounds`` further batches
    while the pooled ESS stays under ``min_ess`` of the draws (module docstring, steps 4-5): (ln Z_IS or None, ESS,
    standard error, number of draws, each batch's own estimate ln Z_i (None: no draw had weight), step 6)."""
    proposals = [_StudentMixture(mode, (cov, WIDE ** 2 * cov), df)]
    draws = proposals[0].rvs(n_draws, rng)
    log_g = t.g(draws)
    d = len(mode)
    own = []
    while True:
        # each batch's estimate from its own proposal (the lower bounds), then the balance heuristic: each draw
        # against the mixture of every batch's proposal (equal batch sizes)
        own.append(_weights(log_g[-n_draws:] - proposals[-1].logpdf(draws[-n_draws:]))[0])
        log_q = np.logaddexp.reduce([p.logpdf(draws) for p in proposals], axis=0) - np.log(len(proposals))
        log_w = log_g - log_q
        log_is, ess, error = _weights(log_w)
        if log_is is None or ess >= min_ess * len(draws) or len(proposals) > rounds:
            return log_is, ess, error, len(draws), own
        finite = np.isfinite(log_w)
        w = np.exp(np.where(finite, log_w - log_w[finite].max(), -np.inf))
        w /= w.sum()
        mean = w @ draws
        centred = draws - mean
        shrink = d / (ess + d)
        fitted = (1.0 - shrink) * (centred.T * w) @ centred + shrink * cov
        proposals.append(_StudentMixture(mean, (0.5 * (fitted + fitted.T),), df))
        batch = proposals[-1].rvs(n_draws, rng)
        draws, log_g = np.vstack([draws, batch]), np.concatenate([log_g, t.g(batch)])


def _negative_definite(H):
    """-H made positive definite, its eigenvalues replaced by their absolute values (at least 1e-8 of the largest;
    the saddle-free Newton metric, Dauphin et al. 2014): (matrix, its inverse, whether H was negative definite)."""
    w, V = np.linalg.eigh(-0.5 * (H + H.T))
    concave = bool(w.min() > 0.0)
    w = np.maximum(np.abs(w), 1e-8 * max(np.abs(w).max(), 1e-300))
    return (V * w) @ V.T, (V / w) @ V.T, concave


def _climb(t, u, h, iterations):
    """Damped saddle-free Newton ascent of g from u (module docstring, step 2): (mode, its derivatives), or None when
    no finite difference around a point can be taken inside the support."""
    derivatives = None
    for _ in range(iterations + 1):
        for _shrink in range(4):
            derivatives = _derivatives(t.g, u, h)
            if derivatives[3]:
                break
            h = 0.25 * h
        else:
            return None
        f0, grad, H, _ = derivatives
        _, cov, concave = _negative_definite(H)
        h = STEP_FRACTION * np.sqrt(np.diag(cov))
        step = cov @ grad
        if concave and 0.5 * grad @ step < CONVERGED_GAIN:
            break
        step *= min(1.0, MAX_STEP / max(np.abs(step).max(), 1e-300))   # trust region in u
        trial = u + np.outer(TRIAL_MULTIPLES, step)
        values = t.g(trial)
        best = int(np.argmax(values))
        if not values[best] > f0 + 1e-6:
            break
        u = trial[best]
    return u, derivatives


def mode_evidence(log_likelihood, prior, samples, log_values=None, starts=None, climbs=None, iterations=10,
                  n_draws=256, min_ess=0.1, seed=0, df=4.0, adapt_rounds=ADAPT_ROUNDS) -> EvidenceEstimate | None:
    """ln Z of one model class (module docstring).

    log_likelihood: thetas (m, d) -> (m,) log-likelihoods (-inf for a failed solve); prior: an ``inference.Prior``
    (``bounds``, ``logpdf``); samples: (n, d) posterior sample (its spread sets the first finite-difference steps);
    log_values: (n,) log-likelihoods of ``samples`` (evaluated when None); starts: (k, d) further candidate starting
    points (e.g. a nested class's mode with the added parameters at their null values): the mode is climbed from
    the best of the sample and these; climbs: (m, d) points from each of which the mode is climbed as well, whatever
    their starting value (e.g. the added parameters at mid-prior); the highest mode found is kept, each climb
    costing up to ``iterations`` batches of d^2 + d + 8 solves; iterations: at most this many Newton steps per climb;
    n_draws: importance draws per batch; min_ess: the fraction of the draws the effective sample size must reach for
    ln Z_IS to be reported; seed: of the draws; df: the proposals' degrees of freedom; adapt_rounds: the further
    adapted batches at most (module docstring, step 5; 0: the first batch only). Returns None when no finite difference
    around any climb's end can be taken inside the support."""
    t = _Unbounded(prior, log_likelihood)
    samples = np.atleast_2d(np.asarray(samples, dtype=float))
    us = t.to_u(samples)
    start = t.g(us) if log_values is None else (
        np.asarray(log_values, dtype=float) + np.asarray(prior.logpdf(samples), dtype=float)
        + t.log_jacobian(us))
    h = STEP_FRACTION * np.maximum(us.std(axis=0), 1e-3)
    if starts is not None and len(starts):
        extra = t.to_u(np.atleast_2d(np.asarray(starts, dtype=float)))
        us, start = np.vstack([us, extra]), np.concatenate([start, t.g(extra)])
    ends = [_climb(t, us[int(np.argmax(np.where(np.isfinite(start), start, -np.inf)))], h, iterations)]
    for u in ([] if climbs is None else t.to_u(np.atleast_2d(np.asarray(climbs, dtype=float)))):
        ends.append(_climb(t, u, h, iterations))
    ends = [e for e in ends if e is not None]
    if not ends:
        return None
    u, derivatives = max(ends, key=lambda e: e[1][0])
    f0, _, H, _ = derivatives
    A, cov, _ = _negative_definite(H)
    d = len(u)
    log_laplace = float(f0 + 0.5 * d * np.log(2.0 * np.pi) - 0.5 * np.linalg.slogdet(A)[1])
    log_is, ess, error, drawn, own = _importance(t, u, cov, n_draws, min_ess, adapt_rounds, df,
                                                 np.random.default_rng(seed))
    lower = _lower_bound(own, adapt_rounds)
    if log_is is not None and ess >= min_ess * drawn:
        value, method = log_is, "importance sampling"
    elif lower is not None and lower > log_laplace:
        value, method = lower, "lower bound"
    else:
        value, method = log_laplace, "Laplace"
    theta = t.to_theta(u[None, :])
    log_likelihood_mode = float(f0 - prior.logpdf(theta)[0] - t.log_jacobian(u[None, :])[0])
    return EvidenceEstimate(value, method, log_laplace, log_is, error, ess, drawn, t.n_solves, float(f0),
                            tuple(float(v) for v in theta[0]), lower, log_likelihood_mode)


def _lower_bound(own, adapt_rounds):
    """``log_lower`` of the module docstring (step 6) from each batch's own estimate ``own`` (ln Z_i, None for a
    batch without weight) under ``adapt_rounds``: the larger of ln Z_1 + ln(delta/2) and, when all 1 + adapt_rounds
    batches were drawn, min_i ln Z_i + ln(delta/2)/(1 + adapt_rounds); ln Z_1 + ln delta without adaptation; None
    when the first batch had no weight."""
    if own[0] is None:
        return None
    if adapt_rounds == 0:
        return own[0] + float(np.log(LOWER_BOUND_RISK))
    half = float(np.log(LOWER_BOUND_RISK / 2.0))
    bounds = [own[0] + half]
    if len(own) == 1 + adapt_rounds and all(v is not None for v in own):
        bounds.append(min(own) + half / len(own))
    return max(bounds)

