"""Save and load policy checkpoints with clear errors.

A checkpoint is an SB3 PPO ``.zip`` plus a JSON file beside it with the same stem
(``runs/x/model.zip`` + ``runs/x/model.json``): the typed config that produced it, the scenario
(field by field), the observation config (:func:`vcs_env.observations.observation_config`:
version, sizes, scales), the scenario family it was trained on (the layout kinds) and what kind
of run wrote it (``ppo``, ``bc``). Both ``vcs-env train --init/--resume`` and the evaluation
harness load through :func:`load_model`, which turns every failure into a
:class:`CheckpointError` naming the file and the problem: missing file, not a zip / truncated /
unreadable, a policy made for observation v0 (before the fixed physical scales of v1), or for
another observation config (e.g. another ``n_neighbors``). Using a policy on a scenario family
it was not trained on is allowed, with a :class:`FamilyWarning` naming both.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import warnings
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.observations import EGO_DIM, NEIGHBOR_DIM, OBSERVATION_VERSION, observation_config, observation_dim
from vcs_env.scenario import Scenario
from vcs_env.spaces import observation_space

from .config import config_command

SIZE_HINT = (
    f"(observation size = {EGO_DIM} + {NEIGHBOR_DIM} * n_neighbors, then the lidar and wall-point blocks if the "
    "scenario has them)"
)
"""How an observation's size follows from the scenario, for error messages."""


class CheckpointError(ValueError):
    """A checkpoint cannot be used: missing, corrupt, or made for another observation space."""


class FamilyWarning(UserWarning):
    """A policy runs on a scenario family (layout kind) it was not trained on."""


class UncheckedWarning(UserWarning):
    """A checkpoint without observation config: only its observation size could be checked."""


V0_EGO_DIM = 8
"""Ego features of observation v0 (``8 + 8 K`` floats; v1 has ``EGO_DIM + 8 K``)."""


def scenario_family(scenarios: Scenario | list[Scenario] | tuple[Scenario, ...]) -> list[str]:
    """The scenario family of a run: the sorted layout kinds it trains on (``["circle", "crowd"]``)."""
    if isinstance(scenarios, Scenario):
        scenarios = [scenarios]
    return sorted({s.kind for s in scenarios})


def config_path(checkpoint: str | os.PathLike) -> Path:
    """The JSON file beside a checkpoint (``model.zip`` -> ``model.json``)."""
    p = Path(checkpoint)
    return p.with_suffix(".json") if p.suffix == ".zip" else p.with_name(p.name + ".json")


def jsonable(x: Any) -> Any:
    """Nested copy for strict JSON: dataclasses as dicts, numpy scalars and arrays as Python
    numbers and lists, NaN and inf as ``None``, paths as strings."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return jsonable(dataclasses.asdict(x))
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, os.PathLike):
        return os.fspath(x)
    return x


def save_model(
    model,
    path: str | os.PathLike,
    kind: str,
    config: Any,
    scenario: Scenario,
    family: list[str] | None = None,
    **extra: Any,
) -> Path:
    """Save ``model`` (an SB3 PPO) to ``path`` (``.zip``) and its metadata JSON beside it.

    The JSON also holds ``command``: the ``vcs-env`` line that rebuilds ``config``.

    Args:
        kind: what produced it (``"ppo"`` from ``vcs-env train``, ``"bc"`` from ``vcs-env bc``).
        config: the run's config dataclass (saved field by field).
        scenario: the scenario the policy observes (defines the observation config); for a
            mixture, its first scenario (all share one observation config).
        family: the layout kinds it was trained on (default: ``[scenario.kind]``).
        extra: more JSON-able entries (timesteps, evaluation results, wall time ...).

    Returns:
        The ``.zip`` path.
    """
    path = Path(path)
    if path.suffix != ".zip":
        path = path.with_name(path.name + ".zip")
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(str(path))
    meta = {
        "kind": kind,
        "observation_dim": int(observation_space(scenario).shape[0]),
        "observation": observation_config(scenario),
        "scenario_family": list(family) if family is not None else scenario_family(scenario),
        "num_timesteps": int(getattr(model, "num_timesteps", 0)),
        "config": jsonable(config),
        "command": config_command({"ppo": "train"}.get(kind, kind), config),
        "scenario": jsonable(scenario),
        **jsonable(extra),
    }
    config_path(path).write_text(json.dumps(meta, indent=2, sort_keys=False, allow_nan=False) + "\n")
    return path


def read_metadata(checkpoint: str | os.PathLike) -> dict[str, Any]:
    """The JSON beside a checkpoint; ``{}`` if there is none (a plain SB3 zip is still loadable)."""
    p = config_path(resolve(checkpoint))
    if not p.exists():
        return {}
    try:
        return json.loads(p.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise CheckpointError(f"checkpoint metadata {p} is not valid JSON: {e}") from None


def resolve(checkpoint: str | os.PathLike) -> Path:
    """The existing ``.zip`` path of a checkpoint (the suffix may be left out)."""
    p = Path(checkpoint)
    if p.is_file():
        return p
    if p.suffix != ".zip" and p.with_name(p.name + ".zip").is_file():
        return p.with_name(p.name + ".zip")
    if p.is_dir() and (p / "model.zip").is_file():
        return p / "model.zip"
    raise CheckpointError(
        f"checkpoint not found: {str(p)!r} (expected an SB3 .zip file, or a run directory with model.zip)"
    )


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
    v0_form = dim is not None and dim >= V0_EGO_DIM and (dim - V0_EGO_DIM) % NEIGHBOR_DIM == 0
    if saved is None and v0_form and dim != observation_dim(scenario):
        command = meta.get("command")
        raise CheckpointError(
            f"{what} was made for observation v0 (vcs_nav_v0: {dim} = {V0_EGO_DIM} + {NEIGHBOR_DIM} K floats, "
            f"scaled by the world size); observations changed in v1 (vcs_nav_v1: fixed physical scales and "
            f"scenario features, {EGO_DIM} + {NEIGHBOR_DIM} K floats), so its inputs would mean something else. "
            "Retrain it on v1" + (f" with its command: {command}" if command else "")
        )
    if saved is not None:
        expected = jsonable(observation_config(scenario))
        if saved != expected:
            version = saved.get("version") if isinstance(saved, dict) else None
            hint = (
                f"observation version {version}, this vcs-env has {OBSERVATION_VERSION}; retrain it"
                if version != OBSERVATION_VERSION
                else "use a policy trained with this observation config"
            )
            if isinstance(saved, dict):
                keys = sorted(set(saved) | set(expected), key=str)
                diff = "; ".join(
                    f"{k}: {json.dumps(saved.get(k))} (scenario: {json.dumps(expected.get(k))})"
                    for k in keys
                    if saved.get(k) != expected.get(k)
                )
            else:
                diff = f"{json.dumps(saved)} (scenario: {json.dumps(expected, sort_keys=True)})"
            raise CheckpointError(
                f"{what} was trained with another observation config than scenario kind={scenario.kind!r} gives: "
                f"{diff} ({hint})"
            )
    check_observation_space(space, scenario, what)
    if saved is None:
        warnings.warn(
            f"{what} has no observation config in its run record (no model.json beside it?): only its "
            "observation size was checked, not what the numbers mean",
            UncheckedWarning,
            stacklevel=3,
        )
    family = meta.get("scenario_family")
    if family and scenario.kind not in family:
        warnings.warn(
            f"{what} was trained on scenario family {family}, but runs on kind={scenario.kind!r}: "
            "expect it to do worse than on its own family",
            FamilyWarning,
            stacklevel=3,
        )


def load_model(checkpoint: str | os.PathLike, scenario: Scenario | None = None, env=None, device: str = "cpu"):
    """Load an SB3 PPO checkpoint, checking it first.

    Args:
        checkpoint: path to the ``.zip`` (suffix optional) or a run directory holding ``model.zip``;
            an RLlib checkpoint directory of ``vcs-env train --backend rllib`` gives an
            :class:`agents.rllib_train.RLlibPolicy` (``predict`` only).
        scenario: if given, the policy must fit this scenario (:func:`check_checkpoint_fits`:
            same observation config, else :class:`CheckpointError`; another scenario family
            gives a :class:`FamilyWarning`; an RLlib policy: the same observation size).
        env: optional VecEnv to attach (for continuing training).
        device: torch device.

    Raises:
        CheckpointError: missing, corrupt, saved by another SB3 algorithm than PPO, made for
            observation v0, or for another observation config.
    """
    from .rllib_train import is_rllib_checkpoint, load_policy

    if is_rllib_checkpoint(checkpoint):  # an RLlib run: a predictor, not an SB3 model
        if env is not None:
            raise CheckpointError(f"{str(checkpoint)!r} is an RLlib checkpoint; SB3 training cannot continue it")
        return load_policy(checkpoint, scenario)
    from stable_baselines3 import PPO
    from stable_baselines3.common.save_util import load_from_zip_file

    path = resolve(checkpoint)
    if not zipfile.is_zipfile(path):
        raise CheckpointError(f"checkpoint {str(path)!r} is corrupt: not a zip archive (an SB3 .zip is expected)")
    try:
        data, params, _ = load_from_zip_file(path, device=device, print_system_info=False)
    except Exception as e:  # truncated members, bad pickles, bad tensors ...
        raise CheckpointError(f"checkpoint {str(path)!r} is corrupt or unreadable: {type(e).__name__}: {e}") from None
    if not data or "observation_space" not in data or not params or "policy" not in params:
        raise CheckpointError(
            f"checkpoint {str(path)!r} is not an SB3 policy checkpoint (no observation space or policy weights)"
        )
    if "clip_range" not in data:  # A2C shares PPO's policy class; SAC, TD3, DQN have their own
        cls = getattr(data.get("policy_class"), "__name__", "unknown")
        raise CheckpointError(
            f"checkpoint {str(path)!r} was saved by another SB3 algorithm than PPO (policy class {cls}, no "
            "clip_range): vcs-env loads the PPO checkpoints of `vcs-env train` and `vcs-env bc`"
        )
    if scenario is not None:
        check_checkpoint_fits(read_metadata(path), data["observation_space"], scenario, f"checkpoint {str(path)!r}")
    try:
        return PPO.load(str(path), env=env, device=device)
    except Exception as e:
        raise CheckpointError(f"checkpoint {str(path)!r} could not be loaded: {type(e).__name__}: {e}") from None


def load_policy_weights(model, checkpoint: str | os.PathLike, scenario: Scenario) -> dict[str, Any]:
    """Copy the policy weights of ``checkpoint`` into ``model.policy`` (``train --init``).

    The architecture must match (same ``net_arch``); a mismatch raises :class:`CheckpointError`
    naming the differing tensors. Returns the checkpoint's metadata.
    """
    src = load_model(checkpoint, scenario)
    theirs, ours = src.policy.state_dict(), model.policy.state_dict()
    diff = sorted(
        k for k in set(theirs) | set(ours) if k not in theirs or k not in ours or theirs[k].shape != ours[k].shape
    )
    if diff:

        def shape(d, k):
            return tuple(d[k].shape) if k in d else "missing"

        detail = ", ".join(f"{k}: {shape(theirs, k)} vs {shape(ours, k)}" for k in diff[:4])
        raise CheckpointError(
            f"checkpoint {str(checkpoint)!r} has another policy architecture than this run "
            f"(checkpoint vs run: {detail}); use the same --net-arch and --features"
        )
    model.policy.load_state_dict(theirs)
    return read_metadata(checkpoint)
