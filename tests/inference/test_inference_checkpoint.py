"""Sampler checkpoints: npz + JSON with a SHA-256 checksum; nothing in a checkpoint is ever unpickled or executed.

Bit-identity of a killed and resumed run with the uninterrupted one is tested in test_inference_sampler.py."""
import dataclasses
import json
import os
import pickle
import zipfile

import numpy as np
import pytest

from inference import CheckpointError, SerialExecutor, UniformPrior, tmcmc
from inference.checkpoint import load_checkpoint, save_checkpoint
from inference.tmcmc import GaussianMixture
from inference.tmcmc.state import STATE_TYPES, ChainState, MapPoint, Phase, RunState, StageRecord

PRIOR = UniformPrior({"x": (0.0, 1.0), "y": (-1.0, 1.0)})


def _loglike(theta):
    return -((theta[0] - 0.3) ** 2 + theta[1] ** 2) / 0.02


def _run(path, **kw):
    kw = {"n_samples": 40, "seed": 0, "max_steps": 2, **kw}
    return tmcmc(_loglike, PRIOR, executor=SerialExecutor(), checkpoint=path, progress=False, **kw)


def _state():
    """A state with every kind of value a run holds: arrays of several dtypes, -inf and NaN, tuples, dicts with
    integer keys, None, nested dataclasses and a Gaussian mixture."""
    rng = np.random.default_rng(0)
    mix = GaussianMixture([0.4, 0.6], rng.normal(size=(2, 2)), [np.eye(2), [[2.0, 0.3], [0.3, 1.0]]])
    chain = ChainState(exponent=0.25, log_S=-1.5, start=rng.normal(size=(5, 2)), pos=rng.normal(size=(5, 2)),
                       log_like=np.array([-1.0, -np.inf, -2.0, -3.0, -0.5]), log_prior=np.zeros(5), scale=0.9,
                       length=np.array([1, 2, 1, 0, 1]), samples=[(np.arange(3), rng.normal(size=(3, 2)), None, 1.0)],
                       mixtures=[mix], fit_of=np.array([0, 1, 0, 1, 0]),
                       resp=[mix.log_responsibilities(np.zeros((5, 2)))])
    return RunState(phase=Phase.MCMC, stage=3, exponent=0.1 + 0.2, log_evidence=-12.345678901234567,
                    theta=rng.normal(size=(5, 2)), records=[StageRecord(0, 0.0, 0.04, acceptance=float("nan"))],
                    failures=[{"stage": 1, "reason": None, "theta": {"x": 0.1}}], map=MapPoint(np.ones(2), -1.0, -2.0),
                    chain=chain, partial={3: (-np.inf, "RuntimeError: diverged", 1), 0: (-1.25, None, 0)})


def test_state_round_trip_is_exact(tmp_path):
    st = _state()
    path = tmp_path / "c.ckpt"
    save_checkpoint(path, st, {"seed": 1})
    got = load_checkpoint(path, {"seed": 1}, STATE_TYPES)
    assert got.phase is Phase.MCMC and got.stage == 3 and got.exponent == st.exponent
    assert got.log_evidence == st.log_evidence and np.isnan(got.records[0].acceptance)
    np.testing.assert_array_equal(got.theta, st.theta)
    np.testing.assert_array_equal(got.chain.log_like, st.chain.log_like)
    assert got.chain.length.dtype == st.chain.length.dtype
    got.chain.pos[0, 0] = 5.0  # arrays come back writable (the chains move in place)
    assert got.partial == st.partial and isinstance(got.partial[3], tuple)
    assert got.failures == st.failures and got.map.log_like == -2.0
    a, b = got.chain.samples[0], st.chain.samples[0]
    assert isinstance(a, tuple) and a[2] is None and a[3] == 1.0
    np.testing.assert_array_equal(a[1], b[1])
    m, m0 = got.chain.mixtures[0], st.chain.mixtures[0]
    for name in ("weights", "means", "covs", "chol", "inv_chol", "log_det"):
        np.testing.assert_array_equal(getattr(m, name), getattr(m0, name))
    for x, y in zip(got.chain.resp[0], st.chain.resp[0]):
        np.testing.assert_array_equal(x, y)
    # the file is an npz archive: numpy alone reads its arrays, without pickle
    with np.load(path, allow_pickle=False) as npz:
        assert any(np.array_equal(npz[k], st.theta) for k in npz.files if k.startswith("a"))


def test_a_finished_run_checkpoint_holds_the_posterior(tmp_path):
    path = tmp_path / "run.ckpt"
    post = _run(path)
    st = load_checkpoint(path, json.loads(json.dumps(_fingerprint_of(path))), STATE_TYPES)
    assert st.phase is Phase.DONE and st.log_evidence == post.log_evidence
    np.testing.assert_array_equal(np.stack(st.stage_theta), np.stack(post.stage_samples))
    again = _run(path, resume=True)  # resuming a finished run returns the same posterior
    assert again.log_evidence == post.log_evidence
    np.testing.assert_array_equal(again.samples, post.samples)


def _fingerprint_of(path):
    with zipfile.ZipFile(path) as zf:
        return json.loads(zf.read("meta.json"))["fingerprint"]


def test_corrupted_bytes_are_refused_naming_the_file(tmp_path):
    path = tmp_path / "run.ckpt"
    _run(path)
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("a0.npy")
    off = info.header_offset  # local file header: 30 bytes, the name, the extra field, then the data
    start = off + 30 + int.from_bytes(data[off + 26:off + 28], "little") + int.from_bytes(data[off + 28:off + 30],
                                                                                          "little")
    data[start + info.file_size - 3] ^= 0xFF  # a byte of a0.npy's array data
    path.write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match="corrupted") as err:
        _run(path, resume=True)
    assert str(path) in str(err.value) and "\n" not in str(err.value)
    path.write_bytes(b"\x00" * 100)
    with pytest.raises(CheckpointError, match="not a checkpoint") as err:
        _run(path, resume=True)
    assert str(path) in str(err.value)


def test_an_altered_member_fails_the_checksum(tmp_path):
    """meta.json rewritten (valid zip, valid CRC, other content): the SHA-256 of the members no longer matches."""
    path = tmp_path / "run.ckpt"
    _run(path)
    with zipfile.ZipFile(path) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    members["meta.json"] = members["meta.json"].replace(b'"phase"', b'"phase" ', 1)
    with zipfile.ZipFile(path, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    with pytest.raises(CheckpointError, match="checksum mismatch") as err:
        _run(path, resume=True)
    assert str(path) in str(err.value)


class _Payload:
    """Unpickling this object creates a folder: the proof that a pickle was executed."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.mkdir, (str(self.marker),)


def test_a_pickle_is_refused_without_unpickling(tmp_path):
    control = tmp_path / "control"
    pickle.loads(pickle.dumps(_Payload(control)))
    assert control.is_dir()  # the payload is live: unpickling it has an effect
    marker = tmp_path / "unpickled"
    path = tmp_path / "run.ckpt"
    path.write_bytes(pickle.dumps({"format": 1, "fingerprint": {}, "state": _Payload(marker)}))
    with pytest.raises(CheckpointError, match="not a checkpoint of this sampler") as err:
        _run(path, resume=True)
    assert str(path) in str(err.value)
    assert not marker.exists()


def test_only_sampler_state_types_are_built(tmp_path):
    @dataclasses.dataclass
    class Other:
        value: int

    path = tmp_path / "c.ckpt"
    save_checkpoint(path, RunState(failures=[Other(1)]), {})
    with pytest.raises(CheckpointError, match="'Other' is not part of the sampler state"):
        load_checkpoint(path, {}, STATE_TYPES)


def test_fingerprint_mismatch_names_the_field_on_one_line(tmp_path):
    path = tmp_path / "run.ckpt"
    _run(path)
    with pytest.raises(CheckpointError) as err:
        _run(path, resume=True, seed=1)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg
    assert "seed: checkpoint 0, this run 1" in msg
    assert "n_samples" not in msg  # only what differs


def test_a_rechecksummed_state_outside_the_prior_is_refused(tmp_path):
    """A checkpoint altered and written again with a valid checksum (a sample moved outside the prior, as a corrupted
    sigma_eps of -30.4 would be) is refused on resume, naming the file and the particle."""
    path = tmp_path / "run.ckpt"
    _run(path)
    fingerprint = _fingerprint_of(path)
    st = load_checkpoint(path, fingerprint, STATE_TYPES)
    st.theta[2, 0] = -30.4
    save_checkpoint(path, st, fingerprint)
    with pytest.raises(CheckpointError, match="outside the prior") as err:
        _run(path, resume=True)
    assert str(path) in str(err.value) and "particle 2" in str(err.value) and "\n" not in str(err.value)
