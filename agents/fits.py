"""Whether a checkpoint fits a scenario: its observation config, size and family.

:func:`check_checkpoint_fits` is what every checkpoint format (:mod:`agents.checkpoint`) asks before it
loads a policy for a scenario; :func:`check_observation_space` checks any policy object's space. A
misfit is a one-line :class:`CheckpointError` naming the checkpoint, what it was made for and what the
scenario gives; another scenario family is a :class:`FamilyWarning`, a checkpoint without observation
config an :class:`UncheckedWarning`.
"""

from __future__ import annotations

import json
import warnings
from typing import Any

import numpy as np

from vcs_env.checks import user_stacklevel
from vcs_env.observations import (
    EGO_DIM,
    NEIGHBOR_DIM,
    OBSERVATION_VERSION,
    OBSERVATION_VERSIONS,
    observation_config,
    observation_dim,
)
from vcs_env.scenario import Scenario
from vcs_env.spaces import observation_space

from .runs import jsonable

SIZE_HINT = (
    f"(observation size = {EGO_DIM} + {NEIGHBOR_DIM} * n_neighbors in v2 ({NEIGHBOR_DIM - 1} in v1), then the lidar "
    "and wall-point blocks if the scenario has them)"
)
"""How an observation's size follows from the scenario, for error messages."""
V0_EGO_DIM = 8
"""Ego features of observation v0 (``8 + 8 K`` floats; v1 has ``EGO_DIM + 8 K``, v2 ``EGO_DIM + 9 K``)."""
V0_NEIGHBOR_DIM = 8
"""Features per neighbour slot of observation v0."""


class CheckpointError(ValueError):
    """A checkpoint cannot be used: missing, corrupt, or made for another observation space."""


def cause(e: BaseException) -> str:
    """``e`` for a one-line error message: its type and the first line of its text (torch and onnx write pages)."""
    text = str(e).strip()
    return f"{type(e).__name__}: {text.splitlines()[0] if text else ''}"


class FamilyWarning(UserWarning):
    """A policy runs on a scenario family (layout kind) it was not trained on."""


class UncheckedWarning(UserWarning):
    """A checkpoint without observation config: only its observation size could be checked."""


def _describe(space) -> str:
    shape = getattr(space, "shape", None)
    return f"{type(space).__name__}{tuple(shape) if shape is not None else ''}"


def check_observation_space(space: Any, scenario: Scenario, what: str) -> None:
    """Raise :class:`CheckpointError` unless ``space`` is the per-robot observation Box of ``scenario``.

    Args:
        space: a Gymnasium space (a checkpoint's or a policy object's ``observation_space``).
        scenario: the scenario the policy will observe.
        what: how to name the policy in the message (``"checkpoint 'runs/x/model.zip'"``).
    """
    expected = observation_space(scenario)
    shape = getattr(space, "shape", None)
    low, high = getattr(space, "low", None), getattr(space, "high", None)
    same_shape = shape is not None and tuple(shape) == expected.shape
    same_bounds = (
        not same_shape
        or low is None
        or high is None
        or (np.allclose(low, expected.low) and np.allclose(high, expected.high))
    )
    if not (same_shape and same_bounds):
        bounds = "" if not same_shape else " with other bounds"
        raise CheckpointError(
            f"{what} was made for observation space {_describe(space)}{bounds}, but scenario "
            f"kind={scenario.kind!r} with n_neighbors={scenario.n_neighbors} gives {_describe(expected)} "
            f"{SIZE_HINT}; use a policy trained for this observation layout"
        )


def _config_diff(saved: dict, expected: dict) -> str:
    """What differs between two observation configs, block by block where both have blocks."""
    parts = []
    for k in sorted(set(saved) | set(expected), key=str):
        a, b = saved.get(k), expected.get(k)
        if a == b:
            continue
        if k == "blocks" and isinstance(a, list) and isinstance(b, list):
            mine = {blk.get("name"): blk for blk in a if isinstance(blk, dict)}
            theirs = {blk.get("name"): blk for blk in b if isinstance(blk, dict)}
            for name in list(mine) + [n for n in theirs if n not in mine]:
                if mine.get(name) != theirs.get(name):
                    parts.append(f"block {name!r}: {_block(mine.get(name))} (scenario: {_block(theirs.get(name))})")
        else:
            parts.append(f"{k}: {json.dumps(a)} (scenario: {json.dumps(b)})")
    return "; ".join(parts)


def _block(blk: dict | None) -> str:
    if blk is None:
        return "absent"
    return f"{blk.get('items')} x {len(blk.get('fields', []))} floats {blk.get('fields')}"


def check_checkpoint_fits(meta: dict[str, Any], space: Any, scenario: Scenario, what: str) -> None:
    """Raise :class:`CheckpointError` unless a checkpoint (its metadata ``meta`` and observation
    ``space``) may observe ``scenario``; warn (:class:`FamilyWarning`) if it was trained on
    another scenario family.

    A checkpoint without observation config in its metadata (or without metadata) whose size
    has the v0 form ``8 + 8 K`` and is not the size ``scenario`` observes is a v0 checkpoint:
    refused with the reason (one of the scenario's size, e.g. with lidar, goes on to the size check).
    """
    saved = meta.get("observation")
    dim = getattr(space, "shape", (None,))[0]
    v0_form = dim is not None and dim >= V0_EGO_DIM and (dim - V0_EGO_DIM) % V0_NEIGHBOR_DIM == 0
    if saved is None and v0_form and dim != observation_dim(scenario):
        command = meta.get("command")
        raise CheckpointError(
            f"{what} was made for observation v0 (vcs_nav_v0: {dim} = {V0_EGO_DIM} + {V0_NEIGHBOR_DIM} K floats, "
            f"scaled by the world size); observations changed in v1 (fixed physical scales and scenario features) "
            f"and v2 (vcs_nav_v2: {EGO_DIM} + {NEIGHBOR_DIM} K floats), so its inputs would mean something else. "
            f"Retrain it on v{OBSERVATION_VERSION}" + (f" with its command: {command}" if command else "")
        )
    if saved is not None:
        expected = jsonable(observation_config(scenario))
        if saved != expected:
            version = saved.get("version") if isinstance(saved, dict) else None
            if version != expected["version"]:
                produced = version in OBSERVATION_VERSIONS
                raise CheckpointError(
                    f"{what} reads observation v{version}, but scenario kind={scenario.kind!r} gives "
                    f"v{expected['version']}: "
                    + (
                        f"run it on Scenario(observation={version}, ...) (the -v{version} env ids), or let "
                        "vcs-env evaluate / compare / probe choose its sensing, or retrain it (vcs-env train, bc and "
                        "distil observe v2 only: start them from a v2 checkpoint such as policies/generalist-v2)"
                        if produced
                        else f"this vcs-env produces versions {list(OBSERVATION_VERSIONS)}; retrain it"
                    )
                )
            if isinstance(saved, dict):
                diff = _config_diff(saved, expected)
            else:
                diff = f"{json.dumps(saved)} (scenario: {json.dumps(expected, sort_keys=True)})"
            raise CheckpointError(
                f"{what} was trained with another observation config than scenario kind={scenario.kind!r} gives: "
                f"{diff}: observe as it was trained (its run record's observation: "
                "vcs_env.observations.with_sensors(scenario, record['observation']), or the scenario's sensing fields "
                "such as n_wall_points, wall_segments, stall_clock, lidar, n_neighbors; vcs-env evaluate / compare / "
                "probe do this themselves), or use a policy trained with this observation config"
            )
    check_observation_space(space, scenario, what)
    if saved is None:
        warnings.warn(
            f"{what} has no observation config in its run record (no model.json beside it?): only its "
            "observation size was checked, not what the numbers mean",
            UncheckedWarning,
            stacklevel=user_stacklevel(),
        )
    family = meta.get("scenario_family")
    if family and scenario.kind not in family:
        warnings.warn(
            f"{what} was trained on scenario family {family}, but runs on kind={scenario.kind!r}: "
            "expect it to do worse than on its own family",
            FamilyWarning,
            stacklevel=user_stacklevel(),
        )


def check_layout_fits(layout: dict[str, Any], scenario: Scenario, what: str = "the exported policy") -> None:
    """Raise :class:`CheckpointError` unless ``scenario`` gives the observations an exported policy reads (the JSON
    ``vcs-env export`` writes beside the ONNX file), naming the block that differs; warn as for a checkpoint when it
    runs outside its training family. Numpy only: for a program that runs the ONNX file without torch."""
    space = type("Exported", (), {"shape": (int(layout["observation_dim"]),), "low": None, "high": None})()
    family = (layout.get("record") or {}).get("scenario_family")
    meta = {"observation": layout["observation"], "scenario_family": family}
    check_checkpoint_fits(meta, space, scenario, what)
