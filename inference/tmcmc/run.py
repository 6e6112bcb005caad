"""The driver of a TMCMC run on the root rank: it loops the steps of :mod:`.steps` over the phases until DONE and
owns everything around them: evaluations through the executor, checkpoints, signals, progress lines and the ETA.

Phases (:class:`Phase`): PRIOR (:func:`initial`) -> SELECT (:func:`select`, steps 1-4 of docs/reference.md
section 2) -> MCMC (:func:`mutate`, steps 5-6) -> SELECT ... -> DONE when beta = 1. The state is checkpointed after
stage 0 and after every stage's sweeps, every ``checkpoint_every`` seconds (between Metropolis moves and as
evaluations arrive) and every ``checkpoint_evals`` evaluations; evaluations finished inside an interrupted batch are
kept (``RunState.partial``) and reused on resume. SIGTERM/SIGUSR1 write a checkpoint and stop the run
(:class:`Interrupted`).

Progress lines: one per stage with its exponent, ln S_j, acceptance, sweeps, failures, evaluations per second,
``elapsed`` (the run's wall time summed over its sessions, as ``wall_s`` of the results) and an ETA
(:func:`eta_text`); and the executor's event lines (``note``: a pool worker lost and replaced).
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
from .state import Phase, RunState
from .steps import initial, mutate, select

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
        self.previous_handlers = {}

    def run(self, st: RunState) -> RunState:
        """Loop the steps from the state's phase until DONE, checkpointing after every stage."""
        self.install_signals()
        try:
            while st.phase is not Phase.DONE:
                if st.phase is Phase.PRIOR:
                    st = initial(st, self.s, self.prior, self.evaluator_for(st), started=self.wall(st))
                    self.stage_closed(st)
                    self.save(st)
                elif st.phase is Phase.SELECT:
                    st = select(st, self.s, self.move, started=self.wall(st))
                elif st.phase is Phase.MCMC:
                    st = mutate(st, self.s, self.prior, self.move, self.evaluator_for(st), after_move=self.timed_save)
                    self.stage_closed(st)
                    self.save(st)
        finally:
            self.restore_signals()
        return st

    # ---- output
    def say(self, msg):
        if self.progress:
            print(msg, file=sys.stderr, flush=True)
        if self.log is not None:
            with open(self.log, "a") as fh:
                fh.write(msg + "\n")

    def stage_closed(self, st: RunState):
        """Note the wall time of the stage a step has just closed and print its progress line."""
        rec = st.records[-1]
        elapsed = self.wall(st)
        rec.wall_s = elapsed - rec.wall_at_start
        rate = rec.n_evals / rec.wall_s if rec.wall_s > 0 else float("inf")
        self.say(f"stage {rec.stage:3d}  beta={rec.exponent:.4e}  ln S={rec.log_S:+.4f}  acc={rec.acceptance:.3f}  "
                 f"sweeps={rec.sweeps}  failed={rec.n_failed}  {rate:.1f} evals/s  elapsed {elapsed:.1f} s"
                 f"{eta_text(st.records)}")

    # ---- state
    def save(self, st: RunState):
        if self.checkpoint is None:
            return
        save_checkpoint(self.checkpoint, dataclasses.replace(st, wall_before=self.wall(st)), self.fingerprint)
        self.last_save = time.perf_counter()
        self.evals_since_save = 0

    def timed_save(self, st: RunState):
        """A checkpoint when ``checkpoint_every`` seconds have passed since the last one."""
        if self.checkpoint is not None and time.perf_counter() - self.last_save > self.s.checkpoint_every:
            self.save(st)

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
    def evaluator_for(self, st: RunState):
        """The ``evaluate`` callable handed to a step that updates ``st`` in place."""
        return lambda thetas: self.evaluate(st, thetas)

    def evaluate(self, st: RunState, thetas):
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
            where = "stage 0 (prior)" if st.phase is Phase.PRIOR else f"stage {st.stage} sweep {st.chain.sweep + 1}"

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
                                        stop=lambda: self.signal_received is not None, note=self.say)
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

    # ---- signals
    def install_signals(self):
        self.previous_handlers = {}
        if self.checkpoint is None:
            return

        def handler(signum, frame):
            self.signal_received = signum

        for sig in (signal.SIGTERM, signal.SIGUSR1):
            try:
                self.previous_handlers[sig] = signal.signal(sig, handler)
            except ValueError:  # not the main thread
                pass

    def restore_signals(self):
        for sig, prev in self.previous_handlers.items():
            signal.signal(sig, prev)


def remaining_evaluations(records):
    """Estimate of the evaluations still to come after the last finished stage, from its records
    (:class:`StageRecord`, stage 0 first). Returns (evaluations, settled) or None when no estimate can be made yet.

    Stages continue until beta = 1. Once the prior no longer dominates, each stage multiplies the exponent by about the
    same factor, so the remaining stage count is ceil(ln(1 / beta_j) / ln(beta_j / beta_{j-1})) with the latest step,
    and each remaining stage costs the evaluations of the latest stage. Early steps in ln beta are larger than later
    ones and early stages need fewer sweeps, so an average over all stages (or over time including the cheap prior
    stage) underestimates; the latest stage is used instead. ``settled`` is False while the step in ln beta still
    shrinks by more than 10 % or the latest stage cost 10 % more evaluations than the one before: the estimate is then a
    lower bound. No estimate before two stages with beta > 0 have finished.
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
    still getting longer) or ", ETA unknown"; nothing once beta = 1."""
    if records[-1].exponent >= 1.0:
        return ""
    estimate = remaining_evaluations(records)
    last = records[-1]
    if estimate is None or last.wall_s <= 0 or last.n_evals == 0:
        return ", ETA unknown"
    evaluations, settled = estimate
    return f", ETA {'~' if settled else '>'}{evaluations * last.wall_s / last.n_evals:.0f} s"
