"""Sampler checkpoints that cannot execute code: an npz archive of arrays plus JSON metadata, checksummed.

A checkpoint holds the whole sampler state (population, stage records, the chains inside a stage, finished
evaluations of the batch under way) and a fingerprint of the problem. Random numbers come from streams keyed by
(seed, stage, sweep, move), so nothing else is needed to continue exactly where the run stopped.

The file is a zip archive (readable with ``numpy.load``) of:
- ``a<k>.npy``: every array of the state, written and read with ``allow_pickle=False``;
- ``meta.json``: the format number, the fingerprint and the state's structure: numbers, strings, lists,
  dataclasses and enum members (by their value) of the kinds the reader is given (by class name), arrays by member
  name;
- ``sha256``: the SHA-256 of every other member (name and bytes, in name order), checked before anything is parsed.
It is written atomically: a temporary file, fsync, rename, fsync of the folder.
"""
from __future__ import annotations

import dataclasses
import enum
import hashlib
import io
import json
import os
import zipfile
from pathlib import Path

import numpy as np

__all__ = ["CheckpointError", "save_checkpoint", "load_checkpoint"]

FORMAT = 2
_META, _SUM = "meta.json", "sha256"


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be used for this run (other problem, other settings, unreadable, corrupted)."""


def save_checkpoint(path, state, fingerprint: dict) -> None:
    """Write ``state`` (a dataclass of numbers, strings, arrays, lists, tuples, dicts, dataclasses and enum members)
    and the problem's ``fingerprint`` (a JSON-able dict) to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {}
    tree = _encode(state, arrays)
    members = {_META: json.dumps({"format": FORMAT, "fingerprint": fingerprint, "state": tree}).encode()}
    for name, array in arrays.items():
        buf = io.BytesIO()
        np.lib.format.write_array(buf, np.asarray(array), allow_pickle=False)
        members[name + ".npy"] = buf.getvalue()
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        with zipfile.ZipFile(fh, "w", zipfile.ZIP_STORED) as zf:
            for name, data in members.items():
                zf.writestr(name, data)
            zf.writestr(_SUM, _digest(members))
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    try:
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:  # pragma: no cover - some file systems do not allow fsync on folders
        pass


def load_checkpoint(path, fingerprint: dict, types: dict):
    """The saved state, after checking the checksum and that the checkpoint was written for this ``fingerprint``;
    ``types`` maps the class names the state may contain to the classes (nothing else is built)."""
    path = Path(path)
    try:
        archive = zipfile.ZipFile(path)
    except zipfile.BadZipFile as exc:
        raise CheckpointError(f"{path}: not a checkpoint of this sampler (not an npz archive: {exc})") from None
    except OSError as exc:
        raise CheckpointError(f"{path}: unreadable checkpoint ({exc})") from None
    with archive:
        try:
            members = {name: archive.read(name) for name in archive.namelist()}
        except Exception as exc:
            raise CheckpointError(f"{path}: corrupted checkpoint ({type(exc).__name__}: {exc})") from None
    if _META not in members or _SUM not in members:
        raise CheckpointError(f"{path}: not a checkpoint of this sampler (no {_META} or {_SUM} member)")
    stored = members.pop(_SUM).decode("ascii", "replace")
    if stored != _digest(members):
        raise CheckpointError(f"{path}: checksum mismatch, the file is corrupted or was altered "
                              f"(sha256 stored {stored[:12]}..., computed {_digest(members)[:12]}...)")
    try:
        meta = json.loads(members[_META])
    except ValueError as exc:
        raise CheckpointError(f"{path}: {_META} is not valid JSON ({exc})") from None
    if meta.get("format") != FORMAT:
        raise CheckpointError(f"{path}: checkpoint format {meta.get('format')!r}, this sampler reads format "
                              f"{FORMAT}")
    saved, current = meta["fingerprint"], json.loads(json.dumps(fingerprint))
    diff = sorted(k for k in set(saved) | set(current) if saved.get(k) != current.get(k))
    if diff:
        differences = "; ".join(f"{k}: checkpoint {saved.get(k)!r}, this run {current.get(k)!r}" for k in diff)
        raise CheckpointError(f"{path}: written for another problem or other settings, refusing to resume: "
                              f"{differences}")
    try:
        return _decode(meta["state"], members, types)
    except Exception as exc:
        raise CheckpointError(f"{path}: unreadable state ({type(exc).__name__}: {exc})") from None


def _digest(members: dict) -> str:
    h = hashlib.sha256()
    for name in sorted(members):
        h.update(name.encode() + b"\0" + len(members[name]).to_bytes(8, "little") + members[name])
    return h.hexdigest()


def _encode(obj, arrays):
    """JSON tree of ``obj``; arrays go to ``arrays`` under a member name. Tagged forms: {"array": name},
    {"tuple": [...]}, {"dict": [[key, value], ...]}, {"type": class name, "fields": {...}},
    {"enum": class name, "value": the member's value}."""
    if isinstance(obj, enum.Enum):
        return {"enum": type(obj).__name__, "value": _encode(obj.value, arrays)}
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj)
    if isinstance(obj, np.ndarray):
        name = f"a{len(arrays)}"
        arrays[name] = obj
        return {"array": name}
    if isinstance(obj, list):
        return [_encode(x, arrays) for x in obj]
    if isinstance(obj, tuple):
        return {"tuple": [_encode(x, arrays) for x in obj]}
    if isinstance(obj, dict):
        return {"dict": [[_encode(k, arrays), _encode(v, arrays)] for k, v in obj.items()]}
    if dataclasses.is_dataclass(obj):
        return {"type": type(obj).__name__, "fields": {f.name: _encode(getattr(obj, f.name), arrays)
                                                        for f in dataclasses.fields(obj) if f.init}}
    raise TypeError(f"cannot checkpoint a {type(obj).__name__}")


def _decode(tree, members, types):
    if isinstance(tree, list):
        return [_decode(x, members, types) for x in tree]
    if not isinstance(tree, dict):
        return tree
    if "array" in tree:
        return np.lib.format.read_array(io.BytesIO(members[tree["array"] + ".npy"]), allow_pickle=False)
    if "tuple" in tree:
        return tuple(_decode(x, members, types) for x in tree["tuple"])
    if "dict" in tree:
        return {_decode(k, members, types): _decode(v, members, types) for k, v in tree["dict"]}
    if "enum" in tree:
        cls = types.get(tree["enum"])
        if not (isinstance(cls, type) and issubclass(cls, enum.Enum)):
            raise TypeError(f"enum {tree['enum']!r} is not part of the sampler state")
        return cls(_decode(tree["value"], members, types))
    cls = types.get(tree.get("type"))
    if cls is None:
        raise TypeError(f"type {tree.get('type')!r} is not part of the sampler state")
    return cls(**{k: _decode(v, members, types) for k, v in tree["fields"].items()})
