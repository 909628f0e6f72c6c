"""Residual policies (``vcs-env train --residual PLANNER``): a network's action is a bounded
correction added to a planner's action for the same state.

:class:`Residual` is the rule (which planner, how large a correction) and the one place that
combines the two actions; :class:`ResidualPolicy` pairs a network (an SB3-style predictor) with its
rule. The training VecEnv (:class:`agents.vec_env.NavVecEnv`) drives ``Residual.actions(expert,
action)``; the harness (:func:`agents.policies.resolve_policy`) runs a residual checkpoint as
``Residual.controller`` over the network's controller; the ONNX export names the rule beside the
network (:mod:`agents.export`). Imports only :mod:`vcs_env` (the bottom layer of ``agents``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vcs_env.planning import PLANNERS, make_planner
from vcs_env.rollout import Controller, planner_controller
from vcs_env.state import WorldState

RULE = "clip(planner_action + scale * clip(network_action, -1, 1), -1, 1)"
"""The action of a residual policy, in the env's action units (delta mode); with the gate, the
planner's action alone while it falls back (:attr:`Residual.gate`, :data:`GATE_RULE`)."""
GATE_RULE = "clip(planner_action, -1, 1) for a robot whose VCS planner has no admissible velocity (its fallback)"
"""What the gate changes in :data:`RULE`."""


@dataclass(frozen=True)
class Residual:
    """A residual policy's action, :data:`RULE`: the action of the planner ``planner`` (delta mode,
    :mod:`vcs_env.dynamics`) for the same state plus the network's action times ``scale``. An
    untrained residual (network output 0) is the planner, bit for bit."""

    planner: str = "vcs"
    """Registered planner name whose action is corrected (:data:`vcs_env.planning.PLANNERS`)."""
    scale: float = 0.5
    """Largest correction per action component, in units of the action range [-1, 1]."""
    gate: bool = False
    """Hold the correction of a robot whose planner found no admissible velocity this step (the VCS
    fallback, ``VCSPlanner.last["fallback"]``): there the planner's action alone drives, so the
    network corrects the expert where the expert is safe and never steers its escapes."""

    def __post_init__(self):
        if self.planner not in PLANNERS:
            raise ValueError(
                f"--residual {self.planner!r}: a residual corrects the actions of a planner, one of "
                f"{', '.join(sorted(PLANNERS))}"
            )
        if isinstance(self.scale, bool) or not isinstance(self.scale, (int, float)) or not 0 < self.scale <= 2:
            raise ValueError(f"--residual-scale must be in (0, 2] (units of the action range), got {self.scale!r}")
        if not isinstance(self.gate, bool):
            raise ValueError(f"--residual-gate must be a bool, got {self.gate!r}")
        if self.gate and self.planner != "vcs":
            raise ValueError(
                f"--residual-gate holds the correction while the planner falls back, which only vcs reports; "
                f"--residual {self.planner} has no fallback to gate on"
            )

    @classmethod
    def of(cls, config: Any) -> Residual | None:
        """The residual a run config (or its JSON record's ``config``) names, or None."""
        get = config.get if isinstance(config, dict) else lambda k, d=None: getattr(config, k, d)
        planner = get("residual")
        if planner in (None, "", "none"):
            return None
        return cls(planner, float(get("residual_scale", 0.5)), bool(get("residual_gate", False)))

    def held(self, planner) -> np.ndarray | None:
        """``(B, n)`` robots whose correction the gate holds after ``planner`` acted (its last plan),
        or None without the gate."""
        return np.asarray(planner.last["fallback"], dtype=bool) if self.gate else None

    def actions(self, base: np.ndarray, network: np.ndarray, held: np.ndarray | None = None) -> np.ndarray:
        """``(..., 2)`` actions from the planner's ``base`` and the network's ``network`` (same shape);
        ``held`` ``(...)``: robots that take ``base`` alone (:meth:`held`)."""
        base = np.asarray(base, dtype=np.float64)
        correction = self.scale * np.clip(np.asarray(network, dtype=np.float64), -1.0, 1.0)
        action = base + correction if held is None else np.where(held[..., None], base, base + correction)
        return np.clip(action, -1.0, 1.0)

    def controller(self, network: Controller) -> Controller:
        """The controller that adds ``network``'s correction to a fresh planner's action."""
        planner = make_planner(self.planner)
        base = planner_controller(planner, "delta")

        def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
            action = base(world, obs)
            return np.where(world.active[..., None], self.actions(action, network(world, obs), self.held(planner)), 0.0)

        return control


@dataclass
class ResidualPolicy:
    """A network (an SB3-style predictor) and the rule by which its actions correct a planner's;
    :func:`agents.policies.resolve_policy` runs the two together (training's periodic evaluation
    passes its model this way)."""

    predictor: Any
    residual: Residual

    @property
    def observation_space(self):
        return getattr(self.predictor, "observation_space", None)


def refuse_residual(record: Any, src: str, what: str, why: str = "not a policy of its own to start from") -> None:
    """A ``ValueError`` when the run record ``record`` of checkpoint ``src`` names a residual policy, for a use of it
    (``what``: ``bc --init``, ``distil --init``, a shield) that reads its network as a policy's: a residual's network
    corrects its planner's actions, and taken as a policy it drove no robot home; ``why`` says what the use needs
    (``train --init`` keeps the rule: its own check)."""
    theirs = Residual.of(record.get("config") or {}) if isinstance(record, dict) else None
    if theirs is not None:
        raise ValueError(
            f"{what} {src}: it is a residual policy over {theirs.planner} (its network corrects that planner's "
            f"actions), {why}"
        )
