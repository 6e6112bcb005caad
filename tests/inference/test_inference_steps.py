"""The TMCMC steps (inference.tmcmc.steps) on their own, without the driver: the stage formulas of docs/reference.md
section 2 checked on hand-made populations, the Metropolis sweeps with a plain evaluate callable, and the phase enum
through a checkpoint."""
import copy
import json
import math
import zipfile

import numpy as np
import pytest

from inference import SerialExecutor, UniformPrior, tmcmc
from inference.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from inference.tmcmc import SamplerError, TMCMCSettings, make_move
from inference.tmcmc.state import STATE_TYPES, Phase, RunState, StageRecord
from inference.tmcmc.steps import initial, mutate, select

PRIOR = UniformPrior({"x": (-1.0, 9.0), "y": (-5.0, 5.0)})


def _loglike(thetas):
    return -0.5 * ((thetas[:, 0] - 1.0) ** 2 / 0.3 + (thetas[:, 1] + 0.5) ** 2 / 0.2)


def _evaluate(thetas):
    assert np.all(PRIOR.in_support(thetas))  # proposals outside the prior are rejected without a solve
    return _loglike(thetas), [None] * len(thetas), np.zeros(len(thetas), dtype=int)


def _two_level_state(a=10.0, p=0.2, log_z=-1.25):
    """Eight particles: two with ln L = 0 and six with ln L = -a, at distinct positions."""
    theta = np.column_stack([np.arange(8.0), np.linspace(-1.0, 1.0, 8)])
    log_like = np.array([0.0, -a, -a, 0.0, -a, -a, -a, -a])
    return RunState(phase=Phase.SELECT, stage=2, exponent=p, log_evidence=log_z, theta=theta, log_like=log_like,
                    log_prior=PRIOR.logpdf(theta), records=[StageRecord(0, 0.0, 0.04), StageRecord(1, p, 0.04)])


@pytest.mark.parametrize("chains", ["particles", "ching-chen"])
def test_select_gives_the_stage_formulas_on_a_two_level_population(chains):
    """Two likelihood levels, a fraction f = 1/4 at L = 1 and 3/4 at L = e^-a: the weights of Eq. (9) are 1 and
    r = e^(-a dp), and COV(w) = 1 (step 1) reads f + (1 - f) r^2 = 2 (f + (1 - f) r)^2, i.e. 3 r^2 + 6 r - 1 = 0,
    r = 2 / sqrt(3) - 1; S_j = (2 + 6 r) / 8 (Eq. (10))."""
    a, p, log_z = 10.0, 0.2, -1.25
    settings = TMCMCSettings(n_samples=8, proposal="gaussian", chains=chains, seed=3).resolved(2)
    move = make_move(settings, PRIOR)
    st = _two_level_state(a, p, log_z)
    theta = st.theta.copy()
    out = select(st, settings, move, started=12.5)
    r = 2.0 / math.sqrt(3.0) - 1.0
    dp = -math.log(r) / a
    assert out is st and st.phase is Phase.MCMC and st.stage == 3
    ch = st.chain
    assert ch.exponent == pytest.approx(p + dp, rel=1e-9) and st.current.exponent == ch.exponent
    assert ch.log_S == pytest.approx(math.log((2.0 + 6.0 * r) / 8.0), rel=1e-8)
    assert st.log_evidence == pytest.approx(log_z + math.log((2.0 + 6.0 * r) / 8.0), rel=1e-8)
    assert st.current.stage == 3 and st.current.wall_at_start == 12.5
    # resampling (step 4): systematic, so particle k is drawn floor or ceil of N wbar_k times
    w = np.where(st.log_like == 0.0, 1.0, r) / (2.0 + 6.0 * r)
    index = {tuple(t): k for k, t in enumerate(theta)}
    drawn = [index[tuple(t)] for t in ch.start]
    counts = np.bincount(drawn, minlength=8) if chains == "particles" else np.zeros(8, int)
    if chains == "ching-chen":
        counts[drawn] = ch.length
        assert len(set(drawn)) == len(drawn) and ch.samples == []
    assert counts.sum() == 8
    assert np.all((counts == np.floor(8 * w)) | (counts == np.ceil(8 * w)))
    np.testing.assert_array_equal(ch.pos, ch.start)
    np.testing.assert_array_equal(ch.log_like, st.log_like[drawn])
    # the move's fit (step 3): Sigma_j = beta^2 C_j, Eqs. (11)-(12), plus the 1e-12 jitter of the prior ranges
    sigma = settings.beta2 * np.cov(theta, rowvar=False, aweights=w, bias=True) + np.diag([1e-10, 1e-10])
    np.testing.assert_allclose(ch.chol @ ch.chol.T, sigma, rtol=1e-8)  # (p_{j+1} to the bisection tolerance)


def test_select_goes_to_one_when_the_cov_stays_below_the_target():
    settings = TMCMCSettings(n_samples=8, proposal="gaussian", seed=3).resolved(2)
    st = _two_level_state(a=0.5, p=0.6)
    select(st, settings, make_move(settings, PRIOR))
    r = math.exp(-0.5 * 0.4)  # dp = 1 - p
    assert st.chain.exponent == 1.0
    assert st.chain.log_S == pytest.approx(math.log((2.0 + 6.0 * r) / 8.0), rel=1e-12)


def test_select_stops_after_max_stages():
    settings = TMCMCSettings(n_samples=8, proposal="gaussian", max_stages=2).resolved(2)
    with pytest.raises(SamplerError, match="max_stages = 2"):
        select(_two_level_state(), settings, make_move(settings, PRIOR))


def _steps_until_done(settings, after_move=None):
    move = make_move(settings, PRIOR)
    st = initial(RunState(), settings, PRIOR, _evaluate)
    while st.phase is not Phase.DONE:
        st = select(st, settings, move)
        st = mutate(st, settings, PRIOR, move, _evaluate, after_move=after_move)
    return st


@pytest.mark.parametrize("options", [dict(proposal="de"), dict(proposal="gaussian", chains="ching-chen")])
def test_the_steps_alone_give_the_sampler_result(options):
    """initial, then select and mutate until DONE with a plain evaluate callable: the numbers of tmcmc()."""
    settings = TMCMCSettings(n_samples=30, seed=5, max_steps=3, vectorized=True, **options).resolved(2)
    st = _steps_until_done(settings)
    post = tmcmc(_loglike, PRIOR, settings, executor=SerialExecutor(), progress=False)
    assert st.exponent == 1.0 and st.log_evidence == post.log_evidence
    assert [r.exponent for r in st.records] == [s["beta"] for s in post.stages]
    for mine, theirs in zip(st.stage_theta, post.stage_samples):
        np.testing.assert_array_equal(mine, theirs)
    np.testing.assert_array_equal(st.map.theta, post.map_theta)
    assert st.n_evals == post.n_forward_solves


def test_mutate_stopped_between_moves_continues_exactly():
    """A copy of the state taken in ``after_move`` and handed to mutate again ends as the uninterrupted stage."""
    settings = TMCMCSettings(n_samples=30, seed=9, proposal="de", de_variant="redblue", n_steps=3).resolved(2)
    move = make_move(settings, PRIOR)
    start = select(initial(RunState(), settings, PRIOR, _evaluate), settings, move)
    straight = mutate(copy.deepcopy(start), settings, PRIOR, move, _evaluate)

    class Stop(Exception):
        pass

    taken = []

    def stop_at_third(st):
        if len(taken) < 3:
            taken.append(copy.deepcopy(st))
        if len(taken) == 3:
            raise Stop

    with pytest.raises(Stop):
        mutate(copy.deepcopy(start), settings, PRIOR, move, _evaluate, after_move=stop_at_third)
    assert (taken[-1].chain.sweep, taken[-1].chain.move) == (1, 1)  # red-blue: two moves per sweep
    resumed = mutate(taken[-1], settings, PRIOR, move, _evaluate)
    assert resumed.phase is straight.phase is Phase.SELECT
    np.testing.assert_array_equal(resumed.theta, straight.theta)
    np.testing.assert_array_equal(resumed.log_like, straight.log_like)
    assert resumed.records[-1] == straight.records[-1] and resumed.n_evals == straight.n_evals


def test_the_phase_enum_round_trips_through_a_checkpoint(tmp_path):
    path = tmp_path / "c.ckpt"
    for phase in Phase:
        save_checkpoint(path, RunState(phase=phase, stage=2), {"seed": 0})
        with zipfile.ZipFile(path) as zf:
            stored = json.loads(zf.read("meta.json"))["state"]["fields"]["phase"]
        assert stored == {"enum": "Phase", "value": phase.value}  # readable: the value string
        assert load_checkpoint(path, {"seed": 0}, STATE_TYPES).phase is phase
    # a checkpoint that holds the bare value string gives the enum member
    st = RunState(stage=2)
    st.phase = "mcmc"
    save_checkpoint(path, st, {"seed": 0})
    assert load_checkpoint(path, {"seed": 0}, STATE_TYPES).phase is Phase.MCMC
    save_checkpoint(path, RunState(phase=Phase.DONE), {"seed": 0})
    # only the enums the reader is given are rebuilt
    with pytest.raises(CheckpointError, match="'Phase' is not part of the sampler state"):
        load_checkpoint(path, {"seed": 0}, {k: v for k, v in STATE_TYPES.items() if k != "Phase"})
