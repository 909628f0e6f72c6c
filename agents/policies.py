"""Turn whatever names a policy into a controller for :func:`vcs_env.rollout.run_episodes`.

Accepted (:func:`resolve_policy`):

* a registered planner name (``"vcs"``, ``"straight"``, ...), or a
  :class:`~vcs_env.planning.Planner` instance: it sees the privileged world state;
* any object with the SB3 ``PolicyPredictor`` method
  ``predict(observation, state=None, episode_start=None, deterministic=False) -> (actions, state)``:
  it sees per-robot observations; each step it is called once with the observations of all
  robots of all worlds stacked, ``(B * n, D)``, and returns ``(B * n, 2)`` actions (rows of robots
  that are not active are ignored);
* the path of a stable-baselines3 PPO checkpoint (``.zip``), loaded on the CPU; a checkpoint
  whose run record names a shield (:mod:`agents.shield`) runs with it unless ``shield=False``.

No torch or stable-baselines3 import at import time; loading a checkpoint does, inside
:func:`load_checkpoint` (through :func:`agents.checkpoint.load_model`).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.planning import Planner, make_planner
from vcs_env.rollout import Controller, planner_controller
from vcs_env.scenario import Scenario
from vcs_env.state import WorldState

from .checkpoint import check_observation_space, config_path, load_model, read_metadata, resolve
from .shield import ShieldedPredictor, shield_from_record


@dataclass
class ResolvedPolicy:
    """A policy made ready to drive :func:`~vcs_env.rollout.run_episodes`."""

    name: str
    """Display name (planner name, checkpoint file stem, class name)."""
    controller: Controller
    """``controller(world, obs (B, n, D)) -> actions (B, n, 2)``."""
    kind: str
    """``planner``, ``predictor`` or ``checkpoint``."""
    shield: dict[str, float] | None = None
    """Parameters of the safety shield a checkpoint runs with (:mod:`agents.shield`), or None."""


def policy_label(spec: str) -> str:
    """The name a policy goes by in tables: a planner by its name, a checkpoint by its run
    directory (``policies/circle8/model.zip`` -> ``circle8``) or else its file stem."""
    if not is_checkpoint_spec(spec):
        return spec
    path = Path(spec)
    return path.parent.name if path.stem in ("model", "best_model") and path.parent.name else path.stem


def is_checkpoint_spec(spec: Any) -> bool:
    """True if ``spec`` names a file rather than a registered planner: a path object, a string
    ending in ``.zip`` or holding a path separator, or any other string that is not a
    registered planner name but an existing file (with or without ``.zip``) or a run directory
    holding ``model.zip``."""
    if isinstance(spec, os.PathLike):
        return True
    if not isinstance(spec, str):
        return False
    if spec.endswith(".zip") or "/" in spec or os.sep in spec:
        return True
    from baselines import PLANNERS  # lazy, like vcs_env.planning.make_planner

    from .rllib_train import is_rllib_checkpoint

    exists = os.path.isfile(spec) or os.path.isfile(spec + ".zip") or os.path.isfile(os.path.join(spec, "model.zip"))
    return spec not in PLANNERS and (exists or is_rllib_checkpoint(spec))


def _check_action_space(space: Any, what: str) -> None:
    shape = getattr(space, "shape", None)
    if shape is not None and tuple(shape) != (2,):
        raise ValueError(f"{what} produces actions of shape {tuple(shape)}, the env needs (2,)")


def load_checkpoint(path: str | os.PathLike, scenario: Scenario, shield: bool = True):
    """Load a stable-baselines3 PPO checkpoint on the CPU and check it fits ``scenario``.

    Args:
        path: the ``.zip`` file (the suffix may be left out) or a run directory with ``model.zip``.
        scenario: the scenario whose observation space the model must take.
        shield: apply the safety shield the checkpoint's run record names, if any (:mod:`agents.shield`).

    Returns:
        The loaded ``stable_baselines3.PPO`` model (a ``PolicyPredictor``), inside an
        :class:`agents.shield.ShieldedPredictor` when its record names a shield and ``shield`` is true.

    Raises:
        agents.checkpoint.CheckpointError: (a ``ValueError``) the file is missing, corrupt or not
            a PPO checkpoint, or its spaces do not fit.
        ImportError: stable-baselines3 is not installed.
    """
    try:
        import stable_baselines3  # noqa: F401
    except ImportError as e:
        raise ImportError(
            f"loading the checkpoint {str(path)!r} needs stable-baselines3; install it with: "
            f"pip install 'vcs-env[train]' ({e})"
        ) from None
    from .rllib_train import is_rllib_checkpoint

    model = load_model(path, scenario)
    _check_action_space(model.action_space, f"checkpoint {str(path)!r}")
    guard = None
    if shield and not is_rllib_checkpoint(path):
        guard = shield_from_record(read_metadata(path), str(config_path(resolve(path))))
    return model if guard is None else ShieldedPredictor(model, guard, scenario)


def predictor_controller(predictor: Any, deterministic: bool = True, name: str = "policy") -> Controller:
    """A controller from an SB3-style ``PolicyPredictor``.

    Each call stacks the observations ``(B, n, D)`` into ``(B * n, D)``, calls ``predict`` once
    and reshapes the actions back to ``(B, n, 2)``. A recurrent state is threaded through the
    calls of one batch of episodes and reset (``episode_start``) when a new batch starts.
    Actions of robots that are not active are replaced by zeros (the simulator ignores them).
    """
    state = None

    def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
        nonlocal state
        B, n, D = obs.shape
        starts = np.repeat(np.asarray(world.steps) == 0, n)
        if starts.all():
            state = None
        actions, state = predictor.predict(
            obs.reshape(B * n, D), state=state, episode_start=starts, deterministic=deterministic
        )
        actions = np.asarray(actions, dtype=np.float64)
        if actions.shape not in ((B * n, 2), (B, n, 2)):
            raise ValueError(
                f"policy {name!r} returned actions of shape {actions.shape} for observations of shape "
                f"{(B * n, D)}; expected {(B * n, 2)}"
            )
        return np.where(world.active[..., None], actions.reshape(B, n, 2), 0.0)

    return control


def resolve_policy(
    policy: Any,
    scenario: Scenario,
    action_mode: str = "delta",
    deterministic: bool = True,
    name: str | None = None,
    shield: bool = True,
) -> ResolvedPolicy:
    """Turn a planner name, :class:`Planner`, ``PolicyPredictor`` or checkpoint path into a controller.

    ``shield=False`` runs a checkpoint's network without the shield its run record names.

    Raises:
        ValueError: unknown planner name, bad checkpoint, observation space mismatch, or an
            object that is none of the accepted kinds.
        ImportError: a planner or checkpoint needs an optional extra that is not installed.
    """
    if isinstance(policy, Planner):
        return ResolvedPolicy(name or policy.name, planner_controller(policy, action_mode), "planner")
    if is_checkpoint_spec(policy):
        if action_mode != "delta":
            from .rllib_train import METADATA, is_rllib_checkpoint

            rllib = is_rllib_checkpoint(policy)
            record = Path(METADATA) if rllib else config_path(resolve(policy))
            if rllib or record.is_file():  # vcs-env train, bc and rllib act in delta mode
                raise ValueError(
                    f"{str(policy)!r} was trained by vcs-env (run record {record.name}), whose policies act in "
                    f"delta mode; --action-mode {action_mode} would read its actions in other units"
                )
        model = load_checkpoint(policy, scenario, shield)
        label = name or policy_label(str(policy))
        guard = dataclasses.asdict(model.shield) if isinstance(model, ShieldedPredictor) else None
        return ResolvedPolicy(label, predictor_controller(model, deterministic, label), "checkpoint", guard)
    if isinstance(policy, str):
        planner = make_planner(policy)
        return ResolvedPolicy(name or policy, planner_controller(planner, action_mode), "planner")
    if callable(getattr(policy, "predict", None)):
        label = name or getattr(policy, "name", None) or type(policy).__name__
        if getattr(policy, "observation_space", None) is not None:
            check_observation_space(policy.observation_space, scenario, f"policy {label!r}")
        return ResolvedPolicy(str(label), predictor_controller(policy, deterministic, str(label)), "predictor")
    raise ValueError(
        "a policy must be a planner name, a vcs_env.planning.Planner, an object with an SB3-style "
        f"predict(observation, state, episode_start, deterministic) method, or a checkpoint path; got "
        f"{type(policy).__name__}"
    )
