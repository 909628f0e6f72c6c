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
"""The action of a residual policy, in the env's action units (delta mode)."""


@dataclass(frozen=True)
class Residual:
    """A residual policy's action, :data:`RULE`: the action of the planner ``planner`` (delta mode,
    :mod:`vcs_env.dynamics`) for the same state plus the network's action times ``scale``. An
    untrained residual (network output 0) is the planner, bit for bit."""

    planner: str = "vcs"
    """Registered planner name whose action is corrected (:data:`vcs_env.planning.PLANNERS`)."""
    scale: float = 0.5
    """Largest correction per action component, in units of the action range [-1, 1]."""

    def __post_init__(self):
        if self.planner not in PLANNERS:
            raise ValueError(
                f"--residual {self.planner!r}: a residual corrects the actions of a planner, one of "
                f"{', '.join(sorted(PLANNERS))}"
            )
        if isinstance(self.scale, bool) or not isinstance(self.scale, (int, float)) or not 0 < self.scale <= 2:
            raise ValueError(f"--residual-scale must be in (0, 2] (units of the action range), got {self.scale!r}")

    @classmethod
    def of(cls, config: Any) -> Residual | None:
        """The residual a run config (or its JSON record's ``config``) names, or None."""
        get = config.get if isinstance(config, dict) else lambda k, d=None: getattr(config, k, d)
        planner = get("residual")
        return None if planner in (None, "", "none") else cls(planner, float(get("residual_scale", 0.5)))

    def actions(self, base: np.ndarray, network: np.ndarray) -> np.ndarray:
        """``(..., 2)`` actions from the planner's ``base`` and the network's ``network`` (same shape)."""
        correction = self.scale * np.clip(np.asarray(network, dtype=np.float64), -1.0, 1.0)
        return np.clip(np.asarray(base, dtype=np.float64) + correction, -1.0, 1.0)

    def controller(self, network: Controller) -> Controller:
        """The controller that adds ``network``'s correction to a fresh planner's action."""
        base = planner_controller(make_planner(self.planner), "delta")

        def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
            return np.where(world.active[..., None], self.actions(base(world, obs), network(world, obs)), 0.0)

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
