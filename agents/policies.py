"""Turn whatever names a policy into a controller for :func:`vcs_env.rollout.run_episodes`.

Accepted (:func:`resolve_policy`):

* a registered planner name (``"vcs"``, ``"straight"``, ...), or a
  :class:`~vcs_env.planning.Planner` instance: it sees the privileged world state;
* any object with the SB3 ``PolicyPredictor`` method
  ``predict(observation, state=None, episode_start=None, deterministic=False) -> (actions, state)``:
  it sees per-robot observations; each step it is called once with the observations of all
  robots of all worlds stacked, ``(B * n, D)``, and returns ``(B * n, 2)`` actions (rows of robots
  that are not active are ignored);
* a checkpoint of any format (:func:`agents.checkpoint.open_checkpoint`: an SB3 ``.zip`` or run
  directory, an RLlib checkpoint or run directory), loaded on the CPU; a checkpoint whose run record
  names a shield (:mod:`agents.shield`) runs with it unless ``shield=False``; one trained with
  ``--residual PLANNER`` runs as a :class:`ResidualPolicy` (the planner's action plus the network's
  bounded correction);
* a :class:`ResidualPolicy` (a predictor and the planner it corrects).

No torch or stable-baselines3 import at import time; loading a checkpoint does, inside
:func:`load_checkpoint` (through :meth:`agents.checkpoint.Checkpoint.load`).
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.checks import install_hint, user_stacklevel
from vcs_env.observations import sees_walls, with_sensors
from vcs_env.planning import PLANNERS, Planner, make_planner
from vcs_env.rollout import Controller, planner_controller
from vcs_env.scenario import Scenario, make_scenario
from vcs_env.state import WorldState

from .checkpoint import Checkpoint, CheckpointError, check_observation_space, find_checkpoint, open_checkpoint
from .residual import RULE, Residual, ResidualPolicy
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
    residual: Residual | None = None
    """The planner a residual policy corrects and the correction's bound, or None."""
    scenario: Scenario | None = None
    """The scenario as this policy observes it: a checkpoint's own sensing on the given scenario's worlds
    (:func:`vcs_env.observations.with_sensors`); None: as given."""


def policy_label(spec: str) -> str:
    """The name a policy goes by in tables: a planner by its name, a checkpoint by its run
    directory (``policies/circle8/model.zip`` -> ``circle8``) or else its file stem."""
    if not is_checkpoint_spec(spec):
        return spec
    path = Path(spec)
    return path.parent.name if path.stem in ("model", "best_model") and path.parent.name else path.stem


def is_checkpoint_spec(spec: Any) -> bool:
    """True if ``spec`` names a checkpoint rather than a registered planner: a path or
    :class:`~agents.checkpoint.Checkpoint` object, a string ending in ``.zip`` or holding a path
    separator, or any other string that is not a registered planner name but a checkpoint of some
    format (:func:`agents.checkpoint.find_checkpoint`)."""
    if isinstance(spec, (os.PathLike, Checkpoint)):
        return True
    if not isinstance(spec, str):
        return False
    if spec.endswith(".zip") or "/" in spec or os.sep in spec:
        return True
    return spec not in PLANNERS and find_checkpoint(spec) is not None


def _check_action_space(space: Any, what: str) -> None:
    shape = getattr(space, "shape", None)
    if shape is not None and tuple(shape) != (2,):
        raise ValueError(f"{what} produces actions of shape {tuple(shape)}, the env needs (2,)")


def load_checkpoint(
    path: str | os.PathLike | Checkpoint,
    scenario: Scenario,
    shield: bool = True,
    network_only: bool = False,
    warn: bool = True,
):
    """Load a checkpoint of any format on the CPU and check it fits ``scenario``.

    Args:
        path: the checkpoint (:func:`agents.checkpoint.open_checkpoint`: an SB3 ``.zip``, the suffix
            may be left out, or a run directory; an RLlib checkpoint or run directory).
        scenario: the scenario whose observation space the model must take (or a preset or suite name).
        shield: apply the safety shield the checkpoint's run record names, if any (:mod:`agents.shield`).
        network_only: load the network of a residual policy (``vcs-env train --residual``), whose actions are
            corrections of a planner's (:mod:`agents.residual`); without it such a checkpoint is refused, since
            an observation alone does not give the policy's action (:func:`resolve_policy` runs it whole).
        warn: warn as :func:`warn_misfits` where the policy runs robots of the other kind, or cannot see the
            scenario's walls (:func:`resolve_policy` has warned already, and passes False).

    Returns:
        The loaded model (a ``PolicyPredictor``: ``stable_baselines3.PPO`` or
        :class:`agents.checkpoint.RLlibPolicy`), inside an :class:`agents.shield.ShieldedPredictor`
        when its record names a shield and ``shield`` is true.

    Raises:
        agents.checkpoint.CheckpointError: (a ``ValueError``) the file is missing, corrupt or not
            a PPO checkpoint, or its spaces do not fit.
        ImportError: stable-baselines3 (or Ray RLlib, for an RLlib checkpoint) is not installed.
    """
    if not isinstance(scenario, (str, Scenario)):
        raise TypeError(
            f"scenario must be a Scenario or a preset or suite name, got {type(scenario).__name__} "
            "(an env's scenario is env.scenario)"
        )
    scenario = make_scenario(scenario)
    ckpt = open_checkpoint(path)
    residual = Residual.of(ckpt.record.get("config", {}))
    if residual is not None and not network_only:
        raise CheckpointError(
            f"{ckpt.describe()} is a residual policy: its network's action is a correction of the {residual.planner} "
            f"planner's action for the same world state ({RULE}, scale {residual.scale}), not an action; run it whole "
            "with agents.policies.resolve_policy (vcs-env evaluate, compare), or load the correction network with "
            "load_checkpoint(..., network_only=True)"
        )
    try:
        model = ckpt.load(scenario)
    except CheckpointError as e:
        if ckpt.record or "observation space" not in str(e):
            raise
        state = "holds no fields" if ckpt.record_path.is_file() else "is missing"
        raise CheckpointError(
            f"{e} (no run record beside it: {str(ckpt.record_path)!r} {state}, and a vcs-env run keeps there the "
            "sensing it was trained with, which would be used instead of the scenario's; copy it beside the checkpoint)"
        ) from None
    except ModuleNotFoundError as e:
        raise ImportError(
            f"loading the {ckpt.describe()} needs {e.name}; install it with: {install_hint('train')} ({e})"
        ) from None
    _check_action_space(model.action_space, ckpt.describe())
    if warn:
        warn_misfits(ckpt, scenario, policy_label(str(ckpt.path)))
    guard = shield_from_record(ckpt.record, str(ckpt.record_path)) if shield else None
    return model if guard is None else ShieldedPredictor(model, guard, scenario)


MIN_ROWS = 64
"""Fewest observation rows :func:`predictor_controller` hands a predictor in one call: fewer are padded with zero
rows (inactive, episodes starting), whose actions are dropped. torch's matrix products take another code path for
a handful of rows, whose float rounding differs from a larger batch's (here for fewer than 16 rows; 1e-6 in the
actions), and a learned policy's episode turned on it: a seed run alone or with a few others could end otherwise
than in a batch of many worlds. Padded, a seed plays the same episode whatever runs beside it, on one machine."""


def predictor_controller(predictor: Any, deterministic: bool = True, name: str = "policy") -> Controller:
    """A controller from an SB3-style ``PolicyPredictor``.

    Each call stacks the observations ``(B, n, D)`` into ``(B * n, D)`` (padded to :data:`MIN_ROWS` rows), calls
    ``predict`` once and reshapes the actions back to ``(B, n, 2)``. A recurrent state is threaded through the
    calls of one batch of episodes and reset (``episode_start``) when a new batch starts.
    Actions of robots that are not active are replaced by zeros (the simulator ignores them).
    """
    state = None

    def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
        nonlocal state
        B, n, D = obs.shape
        rows, pad = B * n, max(MIN_ROWS - B * n, 0)
        starts = np.repeat(np.asarray(world.steps) == 0, n)
        if starts.all():
            state = None
        flat = obs.reshape(rows, D)
        active = world.active.reshape(rows)
        if pad:
            flat = np.concatenate((flat, np.zeros((pad, D), dtype=flat.dtype)))
            starts = np.concatenate((starts, np.ones(pad, dtype=bool)))
            active = np.concatenate((active, np.zeros(pad, dtype=bool)))
        extra = {"active": active} if isinstance(predictor, ShieldedPredictor) else {}
        actions, state = predictor.predict(
            flat, state=state, episode_start=starts, deterministic=deterministic, **extra
        )
        actions = np.asarray(actions, dtype=np.float64)
        if not pad and actions.shape == (B, n, 2):
            actions = actions.reshape(rows, 2)
        if actions.shape != (rows + pad, 2):
            raise ValueError(
                f"policy {name!r} returned actions of shape {actions.shape} for observations of shape "
                f"{(rows + pad, D)}; expected {(rows + pad, 2)}"
            )
        return np.where(world.active[..., None], actions[:rows].reshape(B, n, 2), 0.0)

    return control


class BlindWarning(UserWarning):
    """A policy whose observation has no wall sensing runs (or trains) among walls."""


def blind(scenario: Scenario) -> bool:
    """``scenario`` has walls that its observation does not show (no lidar, no wall points)."""
    return scenario.has_walls and not sees_walls(scenario)


def warn_blind_training(scenarios: Sequence[Scenario]) -> None:
    """Warn (:class:`BlindWarning`) when a run trains among walls that its observation does not show."""
    kinds = sorted({s.kind for s in scenarios if blind(s)})
    if kinds:
        warnings.warn(
            f"this run trains on {', '.join(kinds)}, whose walls its observation does not show (no --n-wall-points, "
            "no --lidar-beams): its policy cannot learn to keep off them",
            BlindWarning,
            stacklevel=3,
        )


class RobotKindWarning(UserWarning):
    """A policy trained on unicycle robots runs holonomic ones, or the other way round."""


def sensed_as_trained(ckpt: Checkpoint, scenario: Scenario, label: str) -> Scenario:
    """``scenario``'s worlds observed with the sensing ``ckpt`` was trained with (its run record's
    observation config, :func:`vcs_env.observations.with_sensors`); ``scenario`` itself for a checkpoint
    without one. Warns as :func:`warn_misfits` (not when the record's sensing cannot be applied: the fit check
    then refuses the checkpoint, naming what differs)."""
    config = ckpt.record.get("observation")
    if isinstance(config, dict):
        try:
            scenario = with_sensors(scenario, config)
        except (ValueError, KeyError, TypeError):
            return scenario  # left to the fit check, which names what differs
    warn_misfits(ckpt, scenario, label)
    return scenario


def warn_misfits(ckpt: Checkpoint, scenario: Scenario, label: str) -> None:
    """Warn (:class:`RobotKindWarning`) when ``ckpt``'s record names the other robot kind than ``scenario``'s (an
    action's second number is a turn for unicycles and a sideways change of velocity for holonomic robots), and
    (:class:`BlindWarning`) when ``scenario`` (as the policy observes it) has walls the policy cannot see."""
    trained = ckpt.record.get("scenario")
    trained = trained.get("robot") if isinstance(trained, dict) else None
    trained = trained.get("holonomic") if isinstance(trained, dict) else None
    if isinstance(trained, bool) and trained != scenario.robot.holonomic:
        kinds, second = {True: "holonomic", False: "unicycle"}, {True: "a sideways velocity change", False: "a turn"}
        warnings.warn(
            f"policy {label!r} was trained on {kinds[trained]} robots (its run record) and runs "
            f"{kinds[scenario.robot.holonomic]} ones here: its second action means {second[trained]} to it and "
            f"{second[scenario.robot.holonomic]} to these robots",
            RobotKindWarning,
            stacklevel=user_stacklevel(),
        )
    if blind(scenario):
        seen = (
            "its observation has no lidar or wall-point block"
            if isinstance(ckpt.record.get("observation"), dict)
            else "no run record names its sensing, so it runs with this scenario's, which has no lidar or wall points"
        )
        warnings.warn(
            f"policy {label!r} cannot see walls ({seen}), but kind={scenario.kind!r} has walls: expect it to drive "
            "into them",
            BlindWarning,
            stacklevel=user_stacklevel(),
        )


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
    if isinstance(policy, ResidualPolicy):
        inner = resolve_policy(policy.predictor, scenario, action_mode, deterministic, name, shield)
        if inner.kind == "planner" or inner.residual is not None:  # a planner's actions, or a correction applied twice
            what = "a planner" if inner.kind == "planner" else f"a residual policy over {inner.residual.planner}"
            raise ValueError(
                f"ResidualPolicy corrects {policy.residual.planner} with a network's actions; its network "
                f"{inner.name!r} is {what}: give the network (a predictor or a plain checkpoint), or the residual "
                "checkpoint by itself"
            )
        return _residual(inner, policy.residual, action_mode)
    if is_checkpoint_spec(policy):
        ckpt = open_checkpoint(policy)
        if action_mode != "delta" and ckpt.record:  # vcs-env train, bc and rllib act in delta mode
            raise ValueError(
                f"{str(policy)!r} was trained by vcs-env (run record {ckpt.record_path.name}), whose policies act in "
                f"delta mode; --action-mode {action_mode} would read its actions in other units"
            )
        residual = Residual.of(ckpt.record.get("config", {}))
        if residual is not None and shield and ckpt.record.get("shield"):
            raise ValueError(
                f"{str(policy)!r} is a residual policy over {residual.planner} and its record names a shield, which "
                "filters a network's actions, not a planner's plus a correction: run it with --no-shield (shield=False)"
            )
        label = name or policy_label(str(policy))
        scenario = sensed_as_trained(ckpt, scenario, label)
        model = load_checkpoint(ckpt, scenario, shield, network_only=True, warn=False)
        guard = dataclasses.asdict(model.shield) if isinstance(model, ShieldedPredictor) else None
        controller = predictor_controller(model, deterministic, label)
        resolved = ResolvedPolicy(label, controller, "checkpoint", guard, scenario=scenario)
        return resolved if residual is None else _residual(resolved, residual, action_mode)
    if isinstance(policy, str):
        if os.path.exists(policy):  # a path, not a planner name: say which checkpoint is missing
            open_checkpoint(policy)
        planner = make_planner(policy)
        return ResolvedPolicy(name or policy, planner_controller(planner, action_mode), "planner")
    if callable(getattr(policy, "predict", None)):
        label = name or getattr(policy, "name", None) or type(policy).__name__
        if isinstance(policy, ShieldedPredictor) and action_mode != "delta":  # as a checkpoint path is refused
            raise ValueError(
                f"{label!r} is a shielded policy, whose shield reads its actions in delta mode; --action-mode "
                f"{action_mode} would read them in other units"
            )
        if getattr(policy, "observation_space", None) is not None:
            check_observation_space(policy.observation_space, scenario, f"policy {label!r}")
        guard = dataclasses.asdict(policy.shield) if isinstance(policy, ShieldedPredictor) else None  # as for a path
        return ResolvedPolicy(str(label), predictor_controller(policy, deterministic, str(label)), "predictor", guard)
    raise ValueError(
        "a policy must be a planner name, a vcs_env.planning.Planner, a ResidualPolicy, an object with an SB3-style "
        f"predict(observation, state, episode_start, deterministic) method, or a checkpoint path; got "
        f"{type(policy).__name__}"
    )


def _residual(network: ResolvedPolicy, residual: Residual, action_mode: str) -> ResolvedPolicy:
    """``network`` (its controller gives the correction) as the residual policy over its planner."""
    if action_mode != "delta":
        raise ValueError(f"a residual policy corrects delta-mode actions; --action-mode {action_mode} is not one")
    return dataclasses.replace(network, controller=residual.controller(network.controller), residual=residual)
