"""A trained network copied to read what it sees differently, its weights kept: the copy step shared by ``vcs-env
wall-segments`` (:mod:`agents.wall_segments`) and ``vcs-env braking`` (:func:`braking_copy`: a still object's time to
contact read as the time left to brake, :func:`agents.features.braking_time`). Importing this module does not import
torch."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from .checkpoint import Checkpoint, config_path, load_model, open_checkpoint


def copy_network(checkpoint, out, adapt: Callable[[object, Checkpoint, dict], dict], source_key: str) -> Path:
    """Copy the SB3 ``checkpoint`` into the directory ``out`` (``model.zip`` and its run record): ``adapt(model, ckpt,
    record)`` changes the loaded model in place and returns the new record, which also names the source under
    ``source_key``. Returns the new ``model.zip``; ``ValueError`` for an existing ``out/model.zip``, a checkpoint
    without a run record naming its observation, or one that is not SB3's (or what ``adapt`` refuses)."""
    out = Path(out)
    if (out / "model.zip").exists():
        raise ValueError(f"{str(out / 'model.zip')!r} exists: give a new directory")
    ckpt = open_checkpoint(checkpoint)
    if not isinstance(ckpt.record, dict) or "observation" not in ckpt.record:
        raise ValueError(f"{ckpt.describe()} has no run record naming its observation: its sensing is unknown")
    model = load_model(ckpt)
    if not hasattr(model, "policy"):
        raise ValueError(f"{ckpt.describe()} is not an SB3 checkpoint: only SB3 networks are copied this way")
    record = {**adapt(model, ckpt, ckpt.record), source_key: str(ckpt.path)}
    out.mkdir(parents=True, exist_ok=True)
    model.save(str(out / "model.zip"))
    config_path(out / "model.zip").write_text(json.dumps(record, indent=2) + "\n")
    return out / "model.zip"


def braking_copy(checkpoint, out) -> Path:
    """``vcs-env braking``: copy an SB3 ``slots`` checkpoint into the directory ``out`` as a network that reads a still
    object's time to contact as the time left to brake (:func:`agents.features.read_braking`; the weights are the
    checkpoint's; the run record keeps the rest and names the source, ``braking_from``). :func:`copy_network` says what
    is refused; so are networks without ``slots`` encoders and those that read so already."""

    from .features import read_braking  # torch

    def adapt(model, ckpt, record):
        try:
            read_braking(model)
        except ValueError as e:
            source = record.get("braking_from")
            raise ValueError(f"{ckpt.describe()}: {e}" + (f" (a copy of {source!r})" if source else "")) from None
        return record

    return copy_network(checkpoint, out, adapt, "braking_from")
