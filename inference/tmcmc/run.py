"""The TMCMC run on the root rank: a state machine over typed state that checkpoints, resumes and reports progress.

Phases: "prior" (stage 0 samples the prior) -> "select" (next exponent, weights, evidence, resampling, the move's
per-stage fit; steps 1-4 of docs/reference.md section 2) -> "mcmc" (Metropolis moves targeting pi(theta) L^p_{j+1};
steps 5-6) -> "select" ... -> "done" when p = 1. The state is checkpointed after every phase, every
``checkpoint_every`` seconds and every ``checkpoint_evals`` evaluations; evaluations finished inside an interrupted
batch are kept. SIGTERM/SIGUSR1 write a checkpoint and stop the run (:class:`Interrupted`).

Chains: "particles" moves every resampled particle for a number of sweeps, fixed or adaptive (stop when
:func:`start_correlation` falls below ``corr_threshold``); "ching-chen" grows one chain per distinct resampled
point with length equal to its multiplicity (the original algorithm; every chain state is a sample).

Progress lines: one per stage with its exponent, ln S_j, acceptance, sweeps, failures, evaluations per second,
``elapsed`` (the run's wall time summed over its sessions, as ``wall_s`` of the results) and an ETA
(:func:`eta_text`).
"""
from __future__ import annotations

import dataclasses
import math
import signal
import sys
import time

import numpy as np

from ..checkpoint import save_checkpoint
from .moves import Move
from .settings import TMCMCSettings
from .stage import (SamplerError, choose_next_exponent, random_stream, resample, stage_weights,
                    start_correlation)
from .state import ChainState, MapPoint, RunState, StageRecord

__all__ = ["Run", "Interrupted", "remaining_evaluations", "eta_text"]


class Interrupted(Exception):
    """SIGTERM or SIGUSR1 arrived; the checkpoint is written."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


class Run:
    """One TMCMC run on the root rank. ``evaluate`` batches go through ``executor``; ``move`` is the Metropolis
    move built from ``settings``; ``checkpoint`` a path or None; ``progress`` prints stage lines on stderr and
    ``log`` appends them to a file."""

    def __init__(self, evaluator, prior, executor, settings: TMCMCSettings, move: Move, checkpoint, fingerprint,
                 progress, log):
        self.ev = evaluator
        self.prior = prior
        self.ex = executor
        self.s = settings
        self.move = move
        self.checkpoint = checkpoint
        self.fingerprint = fingerprint
        self.progress = progress
        self.log = log
        self.signal_received = None
        self.t_start = time.perf_counter()
        self.last_save = time.perf_counter()
        self.evals_since_save = 0
        self.last_print = time.perf_counter()
        self._previous = {}

    # ---- output
    def say(self, msg):
        if self.progress:
            print(msg, file=sys.stderr, flush=True)
        if self.log is not None:
            with open(self.log, "a") as fh:
                fh.write(msg + "\n")

    # ---- state
    def save(self, st: RunState):
        if self.checkpoint is None:
            return
        save_checkpoint(self.checkpoint, dataclasses.replace(st, wall_before=self.wall(st)), self.fingerprint)
        self.last_save = time.perf_counter()
        self.evals_since_save = 0

    def wall(self, st: RunState):
        """Wall time of the run summed over its sessions (s), :meth:`walls`."""
        return self.walls(st)[0]

    def walls(self, st: RunState):
        """(wall time of the run summed over its sessions, of this session) (s), from one clock reading. A session is
        one call of the sampler; the earlier sessions' time, ``st.wall_before``, counts up to their last
        checkpoint (time after it was lost with the work it did)."""
        session = time.perf_counter() - self.t_start
        return st.wall_before + session, session

    # ---- evaluation of one batch with partial checkpoints
    def evaluate(self, st: RunState, thetas, where):
        """Evaluate thetas (m, d); reuse results of a resumed partial batch. Returns (values, reasons, ranks)."""
        m = len(thetas)
        values = np.full(m, np.nan)
        reasons = [None] * m
        ranks = np.zeros(m, dtype=int)
        partial = st.partial
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
                        now - self.last_save > self.s.checkpoint_every
                        or (self.s.checkpoint_evals and self.evals_since_save >= self.s.checkpoint_evals)):
                    self.save(st)
                if self.progress and now - self.last_print > self.s.progress_every:
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
                raise Interrupted(self.signal_received)
        st.partial = {}
        return values, reasons, ranks

    def account(self, st: RunState, thetas, values, reasons, ranks, where):
        """Count evaluations, record failures, track the MAP (7) over every evaluated sample."""
        st.n_evals += len(values)
        lp = self.prior.logpdf(thetas)
        post = lp + values
        rec = st.current
        rec.n_evals += len(values)
        for k in np.flatnonzero(~np.isfinite(values)):
            rec.n_failed += 1
            st.failures.append({"stage": st.stage, "where": where, "particle": int(k), "rank": int(ranks[k]),
                                "reason": reasons[k], "theta": self.prior.as_dict(thetas[k])})
        if np.isfinite(post).any():
            k = int(np.argmax(np.where(np.isfinite(post), post, -np.inf)))
            if st.map is None or post[k] > st.map.log_posterior:
                st.map = MapPoint(thetas[k].copy(), float(post[k]), float(values[k]))
        n_ev = max(rec.n_evals, 1)
        if rec.n_evals >= self.s.n_samples and rec.n_failed > self.s.max_failure_fraction * n_ev:
            examples = "\n".join(f"  {f['reason']} at {f['theta']}" for f in st.failures[-3:])
            raise SamplerError(
                f"stage {st.stage}: {rec.n_failed} of {rec.n_evals} forward evaluations failed "
                f"(> {self.s.max_failure_fraction:.0%}, max_failure_fraction); last failures:\n{examples}")

    # ---- stage 0
    def prior_stage(self, st: RunState):
        """Stage 0: N_s draws of the prior (a constrained prior is drawn by rejection from its box, so ln Z is the
        evidence under the constrained, renormalized prior: :class:`inference.Prior`) and their likelihoods."""
        if st.current is None:  # (a resumed stage 0 keeps its record)
            st.current = self.new_record(st, 0, 0.0)
        thetas = self.prior.sample(random_stream(self.s.seed, 0, 0, 0), self.s.n_samples)
        values, reasons, ranks = self.evaluate(st, thetas, "stage 0 (prior)")
        self.account(st, thetas, values, reasons, ranks, "prior")
        st.theta, st.log_like = thetas, values
        st.log_prior = self.prior.logpdf(thetas)
        self.close_stage(st, acceptance=float("nan"), sweeps=0, log_s=0.0)
        st.phase = "select"

    def new_record(self, st: RunState, stage, exponent):
        return StageRecord(stage, exponent, self.s.beta2, wall_at_start=self.wall(st))

    def close_stage(self, st: RunState, acceptance, sweeps, log_s):
        rec, st.current = st.current, None
        rec.acceptance, rec.sweeps, rec.log_S = acceptance, sweeps, log_s
        rec.wall_s = self.wall(st) - rec.wall_at_start
        st.records.append(rec)
        st.stage_theta.append(st.theta.copy())
        st.stage_log_like.append(st.log_like.copy())
        elapsed = self.wall(st)
        rate = rec.n_evals / rec.wall_s if rec.wall_s > 0 else float("inf")
        self.say(f"stage {rec.stage:3d}  p={rec.exponent:.4e}  ln S={log_s:+.4f}  acc={acceptance:.3f}  "
                 f"sweeps={sweeps}  failed={rec.n_failed}  {rate:.1f} evals/s  elapsed {elapsed:.1f} s"
                 f"{eta_text(st.records)}")

    # ---- stage selection and resampling (steps 1-4)
    def select(self, st: RunState):
        p = st.exponent
        p_next = choose_next_exponent(st.log_like, p, self.s.cov_target)
        w, log_s = stage_weights(st.log_like, p_next - p)
        st.log_evidence += log_s
        st.stage += 1
        st.current = self.new_record(st, st.stage, p_next)
        theta = st.theta
        parents = resample(w, random_stream(self.s.seed, st.stage, 0, 0), self.s.resampling)
        if self.s.chains == "ching-chen":
            start, length = np.unique(parents, return_counts=True)
        else:
            start, length = parents, None
        chain = ChainState(exponent=p_next, log_S=log_s, start=theta[start].copy(), pos=theta[start].copy(),
                           log_like=st.log_like[start].copy(), log_prior=st.log_prior[start].copy(),
                           scale=st.scale, length=length, samples=[] if length is not None else None)
        st.current.components = self.move.prepare(chain, theta, w, st.log_like, start)
        st.chain = chain
        st.phase = "mcmc"

    # ---- MCMC (steps 5-6)
    def mcmc(self, st: RunState):
        ch = st.chain
        p_next = ch.exponent
        C = ch.pos.shape[0]
        while True:
            sweep, move = ch.sweep, ch.move
            if ch.length is not None:
                active = np.flatnonzero(ch.length > sweep)
                if active.size == 0:
                    break
            else:
                active = np.arange(C)
            movers = self.move.movers(active, move)
            rng = random_stream(self.s.seed, st.stage, sweep + 1, move)
            proposal = self.move.propose(ch, movers, rng)
            u = rng.random(C)[movers]
            lp_new = self.prior.logpdf(proposal.theta)
            inside = np.isfinite(lp_new)
            ll_new = np.full(movers.size, -np.inf)
            if inside.any():
                vals, reasons, ranks = self.evaluate(st, proposal.theta[inside], f"stage {st.stage} sweep {sweep + 1}")
                self.account(st, proposal.theta[inside], vals, reasons, ranks, f"sweep {sweep + 1}")
                ll_new[inside] = vals
            old = ch.log_prior[movers] + p_next * ch.log_like[movers]
            with np.errstate(invalid="ignore"):
                new = lp_new + p_next * ll_new
                accept = np.isfinite(new) & (np.log(u) < new - old + proposal.log_hastings)
            idx = movers[accept]
            ch.pos[idx] = proposal.theta[accept]
            ch.log_like[idx] = ll_new[accept]
            ch.log_prior[idx] = lp_new[accept]
            self.move.accepted(ch, movers, accept, proposal)
            ch.accepted += int(accept.sum())
            ch.proposed += int(movers.size)
            if self.s.scale_adapt and movers.size:
                # proposal scale steered toward the target acceptance (population statistic, between moves)
                ch.scale *= math.exp(accept.mean() - self.s.target_acceptance)
            # advance the (sweep, move) counter; a sweep ends after all its moves
            if move + 1 < self.move.moves_per_sweep:
                ch.move = move + 1
            else:
                ch.move = 0
                ch.sweep = sweep + 1
                if ch.length is not None:
                    ch.samples.append((active, ch.pos[active].copy(), ch.log_like[active].copy(),
                                       ch.log_prior[active].copy()))
                elif self.sweeps_done(ch):
                    break
            if self.checkpoint is not None and time.perf_counter() - self.last_save > self.s.checkpoint_every:
                self.save(st)
        self.finish_stage(st)

    def sweeps_done(self, ch: ChainState):
        n = ch.sweep
        if self.s.n_steps != "adaptive":
            return n >= int(self.s.n_steps)
        if n < self.s.min_steps:
            return False
        if n >= self.s.max_steps:
            return True
        return start_correlation(ch.start, ch.pos) < self.s.corr_threshold

    def finish_stage(self, st: RunState):
        ch = st.chain
        if ch.length is not None:  # Ching & Chen: every chain state is a sample, in (sweep, chain) order
            st.theta = np.concatenate([s[1] for s in ch.samples])
            st.log_like = np.concatenate([s[2] for s in ch.samples])
            st.log_prior = np.concatenate([s[3] for s in ch.samples])
        else:
            st.theta, st.log_like, st.log_prior = ch.pos, ch.log_like, ch.log_prior
        st.exponent = ch.exponent
        st.scale = ch.scale
        acc = ch.accepted / max(ch.proposed, 1)
        self.close_stage(st, acceptance=acc, sweeps=ch.sweep, log_s=ch.log_S)
        st.chain = None
        st.phase = "select" if st.exponent < 1.0 else "done"

    # ---- driver
    def run(self, st: RunState) -> RunState:
        self.install_signals()
        try:
            while st.phase != "done":
                if st.phase == "prior":
                    self.prior_stage(st)
                    self.save(st)
                elif st.phase == "select":
                    if st.stage >= self.s.max_stages:
                        raise SamplerError(f"no convergence to p = 1 within max_stages = {self.s.max_stages}")
                    self.select(st)
                elif st.phase == "mcmc":
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


def remaining_evaluations(records):
    """Estimate of the evaluations still to come after the last finished stage, from its records
    (:class:`StageRecord`, stage 0 first). Returns (evaluations, settled) or None when no estimate can be made yet.

    Stages continue until p = 1. Once the prior no longer dominates, each stage multiplies the exponent by about the
    same factor, so the remaining stage count is ceil(ln(1 / p_j) / ln(p_j / p_{j-1})) with the latest step, and
    each remaining stage costs the evaluations of the latest stage. Early steps in ln p are larger than later ones
    and early stages need fewer sweeps, so an average over all stages (or over time including the cheap prior
    stage) underestimates; the latest stage is used instead. ``settled`` is False while the step in ln p still
    shrinks by more than 10 % or the latest stage cost 10 % more evaluations than the one before: the estimate is
    then a lower bound. No estimate before two stages with p > 0 have finished.
    """
    p = [r.exponent for r in records]
    j = len(records) - 1
    if j < 2 or p[-1] >= 1.0 or p[-2] <= 0.0:
        return None
    step = math.log(p[-1] / p[-2])
    if step <= 0.0:
        return None
    stages = math.ceil(-math.log(p[-1]) / step)
    settled = (j >= 3 and p[-3] > 0.0 and step >= 0.9 * math.log(p[-2] / p[-3])
               and records[-1].n_evals <= 1.1 * records[-2].n_evals)
    return stages * records[-1].n_evals, settled


def eta_text(records):
    """The ETA of a progress line: the remaining evaluations (:func:`remaining_evaluations`) at the latest stage's
    rate (evaluations per second of wall time), as ", ETA ~N s", ", ETA >N s" (a lower bound, while stages are
    still getting longer) or ", ETA unknown"; nothing once p = 1."""
    if records[-1].exponent >= 1.0:
        return ""
    estimate = remaining_evaluations(records)
    last = records[-1]
    if estimate is None or last.wall_s <= 0 or last.n_evals == 0:
        return ", ETA unknown"
    evaluations, settled = estimate
    return f", ETA {'~' if settled else '>'}{evaluations * last.wall_s / last.n_evals:.0f} s"
