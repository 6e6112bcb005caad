"""The steps of a TMCMC run (docs/reference.md section 2), each a function of the run state and its inputs.

- :func:`initial`: stage 0, N_s draws of the prior and their likelihoods;
- :func:`select`: steps 1-4, the next exponent, weights Eq. (9), S_j Eq. (10) and ln Z, resampling and the move's
  per-stage fit (Eqs. (11)-(12) or the mixture);
- :func:`mutate`: steps 5-6, the Metropolis sweeps targeting pi(theta) L^beta_{j+1}, and the stage's close (step 7
  when beta = 1).

A step updates the :class:`RunState` it is given in place and returns it, moving ``phase`` on (PRIOR -> SELECT ->
MCMC -> SELECT ... -> DONE). The steps read no clock, handle no signal, print nothing and write no file: forward
solves go through ``evaluate``, a callable thetas (m, d) -> (ln L (m,), failure reasons, ranks), and the caller may
pass ``after_move``, called with the state between two Metropolis moves, where the state is complete (a checkpoint
taken there resumes exactly). Random numbers come from the streams of :func:`random_stream` keyed by
(seed, stage, sweep, move), so the steps give the same numbers however often they are interrupted and resumed.

Chains: "particles" moves every resampled particle for a number of sweeps, fixed or adaptive (stop when
:func:`start_correlation` falls below ``corr_threshold``); "ching-chen" grows one chain per distinct resampled
point with length equal to its multiplicity (the original algorithm; every chain state is a sample).
"""
from __future__ import annotations

import math

import numpy as np

from .moves import Move
from .settings import TMCMCSettings
from .stage import SamplerError, choose_next_exponent, random_stream, resample, stage_weights, start_correlation
from .state import ChainState, MapPoint, Phase, RunState, StageRecord

__all__ = ["initial", "select", "mutate", "account", "sweeps_done"]


def initial(st: RunState, settings: TMCMCSettings, prior, evaluate, started=0.0) -> RunState:
    """Stage 0: N_s draws of the prior from the stream (seed, 0, 0, 0) and their likelihoods; the population becomes
    the stage-0 samples and the phase SELECT. A constrained prior is drawn by rejection from its box, so ln Z is the
    evidence under the constrained, renormalized prior (:class:`inference.Prior`). ``started``: the run's wall time
    (s) noted in the stage record when the stage begins here (a resumed stage 0 keeps its record)."""
    if st.current is None:
        st.current = StageRecord(0, 0.0, settings.beta2, wall_at_start=started)
    thetas = prior.sample(random_stream(settings.seed, 0, 0, 0), settings.n_samples)
    values, reasons, ranks = evaluate(thetas)
    account(st, settings, prior, thetas, values, reasons, ranks, "prior")
    st.theta, st.log_like = thetas, values
    st.log_prior = prior.logpdf(thetas)
    close_stage(st, acceptance=float("nan"), sweeps=0, log_s=0.0)
    st.phase = Phase.SELECT
    return st


def select(st: RunState, settings: TMCMCSettings, move: Move, started=0.0) -> RunState:
    """Steps 1-4: the next exponent beta_{j+1} (COV of the weights = ``cov_target``), the weights Eq. (9) and
    ln S_j Eq. (10) added to ln Z, N_s parents resampled with the normalized weights from the stream
    (seed, j + 1, 0, 0), the chains started at them ("particles": one per parent; "ching-chen": one per distinct
    parent, as long as its multiplicity) and the move's per-stage fit to the weighted population (Eqs. (11)-(12),
    theta_best of Eq. (14) or the mixtures). Opens the record of stage j + 1 (``started``: the run's wall time, s)
    and sets the phase MCMC. Raises :class:`SamplerError` when ``max_stages`` stages are done without beta = 1."""
    if st.stage >= settings.max_stages:
        raise SamplerError(f"no convergence to beta = 1 within max_stages = {settings.max_stages}")
    p = st.exponent
    p_next = choose_next_exponent(st.log_like, p, settings.cov_target)
    w, log_s = stage_weights(st.log_like, p_next - p)
    st.log_evidence += log_s
    st.stage += 1
    st.current = StageRecord(st.stage, p_next, settings.beta2, wall_at_start=started)
    theta = st.theta
    parents = resample(w, random_stream(settings.seed, st.stage, 0, 0), settings.resampling)
    if settings.chains == "ching-chen":
        start, length = np.unique(parents, return_counts=True)
    else:
        start, length = parents, None
    chain = ChainState(exponent=p_next, log_S=log_s, start=theta[start].copy(), pos=theta[start].copy(),
                       log_like=st.log_like[start].copy(), log_prior=st.log_prior[start].copy(),
                       scale=st.scale, length=length, samples=[] if length is not None else None)
    st.current.components = move.prepare(chain, theta, w, st.log_like, start)
    st.chain = chain
    st.phase = Phase.MCMC
    return st


def mutate(st: RunState, settings: TMCMCSettings, prior, move: Move, evaluate, after_move=None) -> RunState:
    """Steps 5-6: Metropolis moves of the chains from where they stand (sweep, move) until the stage's sweeps are
    done. Move i of sweep n draws from the stream (seed, j, n, i); a proposal is accepted with probability
    min(1, pi(theta*) L(theta*)^beta_{j+1} q(theta | theta*) / (pi(theta) L(theta)^beta_{j+1} q(theta* | theta))), and
    one outside the prior's support is rejected without a forward solve. With ``scale_adapt`` the proposal scale is
    multiplied by exp(acceptance - target_acceptance) after every move. ``after_move(st)`` is called between moves
    (not after the last). Then the stage closes: its samples become the population ("ching-chen": every chain state
    after each sweep, in (sweep, chain) order), its record is appended, and the phase is SELECT, or DONE at beta = 1."""
    ch = st.chain
    p_next = ch.exponent
    C = ch.pos.shape[0]
    while True:
        sweep, i_move = ch.sweep, ch.move
        if ch.length is not None:
            active = np.flatnonzero(ch.length > sweep)
            if active.size == 0:
                break
        else:
            active = np.arange(C)
        movers = move.movers(active, i_move)
        rng = random_stream(settings.seed, st.stage, sweep + 1, i_move)
        proposal = move.propose(ch, movers, rng)
        u = rng.random(C)[movers]
        lp_new = prior.logpdf(proposal.theta)
        inside = np.isfinite(lp_new)
        ll_new = np.full(movers.size, -np.inf)
        if inside.any():
            values, reasons, ranks = evaluate(proposal.theta[inside])
            account(st, settings, prior, proposal.theta[inside], values, reasons, ranks, f"sweep {sweep + 1}")
            ll_new[inside] = values
        old = ch.log_prior[movers] + p_next * ch.log_like[movers]
        with np.errstate(invalid="ignore"):
            new = lp_new + p_next * ll_new
            accept = np.isfinite(new) & (np.log(u) < new - old + proposal.log_hastings)
        idx = movers[accept]
        ch.pos[idx] = proposal.theta[accept]
        ch.log_like[idx] = ll_new[accept]
        ch.log_prior[idx] = lp_new[accept]
        move.accepted(ch, movers, accept, proposal)
        ch.accepted += int(accept.sum())
        ch.proposed += int(movers.size)
        if settings.scale_adapt and movers.size:
            # proposal scale steered toward the target acceptance (population statistic, between moves)
            ch.scale *= math.exp(accept.mean() - settings.target_acceptance)
        # advance the (sweep, move) counter; a sweep ends after all its moves
        if i_move + 1 < move.moves_per_sweep:
            ch.move = i_move + 1
        else:
            ch.move = 0
            ch.sweep = sweep + 1
            if ch.length is not None:
                ch.samples.append((active, ch.pos[active].copy(), ch.log_like[active].copy(),
                                   ch.log_prior[active].copy()))
            elif sweeps_done(ch, settings):
                break
        if after_move is not None:
            after_move(st)
    if ch.length is not None:
        st.theta = np.concatenate([s[1] for s in ch.samples])
        st.log_like = np.concatenate([s[2] for s in ch.samples])
        st.log_prior = np.concatenate([s[3] for s in ch.samples])
    else:
        st.theta, st.log_like, st.log_prior = ch.pos, ch.log_like, ch.log_prior
    st.exponent = ch.exponent
    st.scale = ch.scale
    close_stage(st, acceptance=ch.accepted / max(ch.proposed, 1), sweeps=ch.sweep, log_s=ch.log_S)
    st.chain = None
    st.phase = Phase.SELECT if st.exponent < 1.0 else Phase.DONE
    return st


def sweeps_done(ch: ChainState, settings: TMCMCSettings) -> bool:
    """Whether the "particles" chains have swept enough: ``n_steps`` sweeps, or when adaptive at least ``min_steps``
    and then until :func:`start_correlation` falls below ``corr_threshold`` or ``max_steps`` are done."""
    n = ch.sweep
    if settings.n_steps != "adaptive":
        return n >= int(settings.n_steps)
    if n < settings.min_steps:
        return False
    if n >= settings.max_steps:
        return True
    return start_correlation(ch.start, ch.pos) < settings.corr_threshold


def account(st: RunState, settings: TMCMCSettings, prior, thetas, values, reasons, ranks, where) -> None:
    """Count a batch's evaluations, record its failures (``where``: "prior" or "sweep n") and track the MAP, Eq. (7)
    of docs/reference.md section 1, over every evaluated sample. Raises :class:`SamplerError` once the stage has
    made N_s evaluations of which more than ``max_failure_fraction`` failed."""
    st.n_evals += len(values)
    post = prior.logpdf(thetas) + values
    rec = st.current
    rec.n_evals += len(values)
    for k in np.flatnonzero(~np.isfinite(values)):
        rec.n_failed += 1
        st.failures.append({"stage": st.stage, "where": where, "particle": int(k), "rank": int(ranks[k]),
                            "reason": reasons[k], "theta": prior.as_dict(thetas[k])})
    if np.isfinite(post).any():
        k = int(np.argmax(np.where(np.isfinite(post), post, -np.inf)))
        if st.map is None or post[k] > st.map.log_posterior:
            st.map = MapPoint(thetas[k].copy(), float(post[k]), float(values[k]))
    n_ev = max(rec.n_evals, 1)
    if rec.n_evals >= settings.n_samples and rec.n_failed > settings.max_failure_fraction * n_ev:
        examples = "\n".join(f"  {f['reason']} at {f['theta']}" for f in st.failures[-3:])
        raise SamplerError(
            f"stage {st.stage}: {rec.n_failed} of {rec.n_evals} forward evaluations failed "
            f"(> {settings.max_failure_fraction:.0%}, max_failure_fraction); last failures:\n{examples}")


def close_stage(st: RunState, acceptance, sweeps, log_s) -> None:
    """Complete the open stage record (acceptance, sweeps, ln S_j) and append it and the population as the stage's
    samples."""
    rec, st.current = st.current, None
    rec.acceptance, rec.sweeps, rec.log_S = acceptance, sweeps, log_s
    st.records.append(rec)
    st.stage_theta.append(st.theta.copy())
    st.stage_log_like.append(st.log_like.copy())
