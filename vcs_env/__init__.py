"""vcs-env: multi-robot navigation among moving obstacles, with a Velocity-Change-Space expert.

Make the PettingZoo env with :func:`parallel_env` (or :func:`env` for AEC) and the single-robot
Gymnasium env with ``gym.make("vcs_env/Navigation-v0")`` (registered on import).
"""

from __future__ import annotations

import gymnasium

from .engine import NavEngine, StepResult
from .parallel import VcsNavParallelEnv, env, parallel_env, raw_env
from .planning import Planner, make_planner
from .scenario import (
    SCENARIOS,
    CustomLayout,
    ObstacleTrajectory,
    RewardWeights,
    RobotSpec,
    Scenario,
    make_scenario,
)
from .sim import Simulator, StepEvents
from .state import WorldState

__version__ = "0.1.0"

GYM_IDS = {
    "vcs_env/Navigation-v0": "circle",
    "vcs_env/Circle-v0": "circle",
    "vcs_env/Swap-v0": "swap",
    "vcs_env/Crossing-v0": "crossing",
    "vcs_env/Random-v0": "random",
    "vcs_env/Crowd-v0": "crowd",
    "vcs_env/Dynamic-v0": "dynamic",
    "vcs_env/Custom-v0": "custom",
}
"""Registered Gymnasium ids and the preset each starts from (override with ``scenario=``)."""

for _id, _preset in GYM_IDS.items():
    if _id not in gymnasium.registry:
        gymnasium.register(id=_id, entry_point="vcs_env.gym_env:VcsNavEnv", kwargs={"scenario": _preset})

__all__ = [
    "SCENARIOS",
    "GYM_IDS",
    "CustomLayout",
    "NavEngine",
    "ObstacleTrajectory",
    "Planner",
    "RewardWeights",
    "RobotSpec",
    "Scenario",
    "Simulator",
    "StepEvents",
    "StepResult",
    "VcsNavParallelEnv",
    "WorldState",
    "env",
    "make_planner",
    "make_scenario",
    "parallel_env",
    "raw_env",
]
