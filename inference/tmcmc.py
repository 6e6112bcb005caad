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
from .executors import Evaluator, MPIExecutor, default_executor
from .likelihood import Likelihood
from .priors import Prior
from .results import Posterior

__all__ = ["SamplerError", "tmcmc", "choose_next_exponent", "stage_weights", "weighted_covariance",
           "de_proposal", "EXIT_CHECKPOINTED"]

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
            "start": theta[start].copy(), "pos": theta[start].copy(), "log_like": st["log_like"][start].copy(),
            "log_prior": st["log_prior"][start].copy(), "length": length, "sweep": 0, "move": 0,
            "accepted": 0, "proposed": 0, "samples": [] if length is not None else None,
        }
        st.setdefault("scale", 1.0)
        st["phase"] = "mcmc"

    # ---- MCMC (steps 5-6)
    def moves_per_sweep(self):
        return 2 if (self.s["proposal"] == "de" and self.s["de_variant"] == "redblue") else 1

    def propose(self, st, ch, movers, rng):
        pos = ch["pos"]
        d = pos.shape[1]
        if self.s["proposal"] == "gaussian":
            z = rng.standard_normal((pos.shape[0], d))[movers]
            return pos[movers] + st["scale"] * (z @ ch["chol"].T)
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
        return de_proposal(pos[movers], best, pos[a], pos[b], gamma, lam, zeta, cross)

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
            proposal = self.propose(st, ch, movers, rng)
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
                accept = np.isfinite(new) & (np.log(u) < new - old)
            idx = movers[accept]
            ch["pos"][idx] = proposal[accept]
            ch["log_like"][idx] = ll_new[accept]
            ch["log_prior"][idx] = lp_new[accept]
            ch["accepted"] += int(accept.sum())
            ch["proposed"] += int(movers.size)
            if self.s["scale_adapt"] and movers.size:
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
    out = {"likelihood": str(fp), "prior": str(prior.describe())}
    out.update({k: settings[k] for k in keys})
    return out


def tmcmc(loglike, prior: Prior, n_samples=2000, proposal="de", *, de_variant="redblue", chains="particles",
          n_steps="adaptive", min_steps=2, max_steps=25, corr_threshold=0.3, beta2=0.04, cov_target=1.0,
          de_c=0.1, de_c_star=1e-12, de_delta=3.0, de_cr=0.9, executor=None, dispatch="dynamic", seed=0,
          checkpoint=None, resume=False, checkpoint_every=60.0, checkpoint_evals=None, progress=True,
          progress_every=10.0, vectorized=False, timeout=None, max_failure_fraction=0.1, max_stages=200,
          resampling="systematic", scale_adapt=False, target_acceptance=0.25, log=None) -> Posterior:
    """Sample the posterior p(theta | D) ∝ p(theta) L(theta) by TMCMC and estimate the log-evidence.

    loglike: an :class:`inference.Likelihood` (Eqs. 3-6, bound to the prior's parameter order here), a callable
        theta (d,) -> ln L, or with ``vectorized=True`` thetas (m, d) -> (m,).
    prior: :class:`inference.Prior` (``UniformPrior``/``LogUniformPrior``); theta is in its order.
    proposal: "gaussian" (O-TMCMC) or "de" (DE-TMCMC); ``de_variant`` "paper", "symmetric" or "redblue".
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
                    target_acceptance=float(target_acceptance))
    evaluator = Evaluator(loglike, vectorized=vectorized, timeout=timeout)
    own_executor = executor is None
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
