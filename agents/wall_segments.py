"""Wall points read with their segments (``Scenario.wall_segments``): a ``slots`` network trained on wall points
without them made to read them, in memory (:func:`read_wall_segments`) or as a copied checkpoint
(:func:`wall_segments_copy`, ``vcs-env wall-segments``). The weights are kept: a wall point is a slot of the same
fields either way, and only its time to contact changes meaning, from the point's (a still disc) to its wall
segment's (:func:`agents.features.segment_contact_time`). Importing this module does not import torch."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import gymnasium as gym
import numpy as np

from vcs_env.files import replacing
from vcs_env.observations import Layout, observation_config, observation_layout, with_sensors
from vcs_env.scenario import Scenario

from .checkpoint import config_path, load_model, open_checkpoint


def read_wall_segments(model, layout: Layout) -> None:
    """Make the ``slots`` encoders of an SB3 ``model`` (actor's and critic's) read observations of ``layout``, whose
    wall points have the segment fields (``Scenario.wall_segments``), and so take each wall point's time to contact from
    its segment (:func:`agents.features.segment_contact_time`), in place. The weights are kept: a wall point is a
    slot of the same fields either way, and only its contact time changes meaning (from the point's to the wall's). The
    model may have read wall points with or without the segment fields; ``ValueError`` for a model without ``slots``
    encoders over wall points, or a ``layout`` without the segment fields, with another number of wall points or
    another size before them than the model's observation (sizes are checked, not block names)."""
    policy = getattr(model, "policy", None)
    extractors = [getattr(policy, name, None) for name in ("pi_features_extractor", "vf_features_extractor")]
    if not all(getattr(e, "wall_slots", 0) for e in extractors):  # agents.features.SlotEncoder over wall points
        raise ValueError(
            "read_wall_segments takes an SB3 model with --features slots over wall points (--n-wall-points)"
        )
    if "wall_points" not in layout or "tx" not in layout.block("wall_points").fields:
        raise ValueError("read_wall_segments: the layout's wall points need their segment fields (wall_segments=True)")
    walls = layout.block("wall_points")
    old = extractors[0]
    rest = model.observation_space.shape[0] - old.wall_dim * old.wall_slots  # the floats before the wall points
    if walls.items != old.wall_slots or layout.dim - walls.size != rest:
        raise ValueError(
            f"read_wall_segments: the layout ({layout.dim} floats, {walls.items} wall points) is not the model's "
            f"observation ({model.observation_space.shape[0]} floats, {old.wall_slots} wall points) with segment fields"
        )
    kwargs = {**policy.features_extractor_kwargs, "wall_dim": walls.item_dim}
    state = policy.state_dict()
    low, high = layout.bounds()
    model.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
    model.policy_kwargs = {**model.policy_kwargs, "features_extractor_kwargs": kwargs}
    model._setup_model()  # the policy rebuilt for the new space (SB3's own constructor path), then its weights back
    model.policy.load_state_dict(state)


def wall_segments_copy(checkpoint, out) -> Path:
    """``vcs-env wall-segments``: copy an SB3 ``slots`` checkpoint over wall points (``--n-wall-points``, without
    their segment fields) into the directory ``out`` (``model.zip`` and its run record) as a network that reads the
    wall points' segment fields and takes each wall point's time to contact from its segment
    (:func:`read_wall_segments`; the weights are the checkpoint's). The run record keeps the rest (the command that
    trained it, its shield) and names the source (``wall_segments_from``). Returns the new ``model.zip``; ``ValueError``
    for an existing ``out/model.zip``, a checkpoint without a run record, without wall points or that reads their
    segments already (a copy would change nothing but the record's source)."""
    out = Path(out)
    if (out / "model.zip").exists():
        raise ValueError(f"{str(out / 'model.zip')!r} exists: give a new directory")
    ckpt = open_checkpoint(checkpoint)
    record = ckpt.record
    if not isinstance(record, dict) or "observation" not in record:
        raise ValueError(f"{ckpt.describe()} has no run record naming its observation: its sensing is unknown")
    own = with_sensors(Scenario(), record["observation"])
    if not own.n_wall_points:
        raise ValueError(f"{ckpt.describe()} was trained without wall points (--n-wall-points): no walls to read")
    if own.wall_segments:
        source = record.get("wall_segments_from")
        raise ValueError(
            f"{ckpt.describe()} reads its wall points' segments already"
            + (f" (a copy of {source!r})" if source else " (trained with --wall-segments)")
            + ": nothing to copy"
        )
    wide = dataclasses.replace(own, wall_segments=True)
    model = load_model(ckpt)  # its observation is its record's (read_wall_segments checks the sizes)
    if not hasattr(model, "policy"):
        raise ValueError(f"{ckpt.describe()} is not an SB3 checkpoint: vcs-env wall-segments copies SB3 networks")
    read_wall_segments(model, observation_layout(wide))
    record = {**record, "observation": observation_config(wide), "observation_dim": observation_layout(wide).dim}
    if isinstance(record.get("config"), dict):
        record["config"] = {**record["config"], "wall_segments": True}
    record["wall_segments_from"] = str(ckpt.path)
    with replacing(out / "model.zip") as part, replacing(config_path(out / "model.zip")) as record_part:
        model.save(str(part))  # SB3 keeps a name's own suffix; the record is renamed into place first
        record_part.write_text(json.dumps(record, indent=2) + "\n")
    return out / "model.zip"
