"""Atomic sampler checkpoints: write to a temporary file, fsync, rename, fsync the folder.

A checkpoint holds the whole sampler state (population, stage records, the MCMC position inside a stage, finished
evaluations of the batch under way) and a fingerprint of the problem. Random numbers come from streams keyed by
(seed, stage, sweep, move), so nothing else is needed to continue exactly where the run stopped.
"""
from __future__ import annotations

import os
import pickle
from pathlib import Path

__all__ = ["CheckpointError", "save_checkpoint", "load_checkpoint"]

FORMAT = 1


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be used for this run (other problem, other settings, unreadable)."""


def save_checkpoint(path, state: dict, fingerprint: dict) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as fh:
        pickle.dump({"format": FORMAT, "fingerprint": fingerprint, "state": state}, fh,
                    protocol=pickle.HIGHEST_PROTOCOL)
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


def load_checkpoint(path, fingerprint: dict) -> dict:
    """Return the saved state, refusing a checkpoint written for another problem or other settings."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            blob = pickle.load(fh)
    except Exception as exc:
        raise CheckpointError(f"{path}: unreadable checkpoint ({exc})") from exc
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a checkpoint of this sampler (format {blob.get('format')!r})")
    saved = blob["fingerprint"]
    diff = sorted(k for k in set(saved) | set(fingerprint) if saved.get(k) != fingerprint.get(k))
    if diff:
        lines = [f"  {k}: checkpoint {saved.get(k)!r} vs this run {fingerprint.get(k)!r}" for k in diff]
        raise CheckpointError(f"{path} was written for a different problem or settings; refusing to resume:\n"
                              + "\n".join(lines))
    return blob["state"]
