"""vcs-env: multi-robot navigation among moving obstacles, with a Velocity-Change-Space expert.

Make the PettingZoo env with :func:`parallel_env` (or :func:`env` for AEC) and the single-robot
Gymnasium env with ``gym.make("vcs_env/Navigation-v2")`` (registered on import).
"""

from __future__ import annotations

from . import kernel_cache  # noqa: F401  (first: marks kernels stale when a kernel source changed)
from .engine import NavEngine, StepResult
from .parallel import VcsNavParallelEnv, env, parallel_env, raw_env
from .planning import PLANNERS, Planner, make_planner, register_planner
from .registry import register as _register
from .scenario import (
    MAPS,
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
from .threads import get_threads, set_threads

__version__ = "0.2.0"

GYM_IDS = {
    "vcs_env/Navigation-v2": "circle",
    "vcs_env/Circle-v2": "circle",
    "vcs_env/Swap-v2": "swap",
    "vcs_env/Crossing-v2": "crossing",
    "vcs_env/Random-v2": "random",
    "vcs_env/Crowd-v2": "crowd",
    "vcs_env/Dynamic-v2": "dynamic",
    "vcs_env/Custom-v2": "custom",
}
"""Registered Gymnasium ids and the preset each starts from (override with ``scenario=``). Each id has a
``vector_entry_point`` (:class:`~vcs_env.gym_env.VcsNavVectorEnv`): ``gym.make_vec(id, num_envs,
vectorization_mode="vector_entry_point")`` steps all worlds in one engine call. The ``-v1`` ids stay
registered: the same envs with observation version 1 (:mod:`vcs_env.observations`); an id's version is
fixed, and ``observation=`` asking for the other one is refused (:mod:`vcs_env.registry`)."""

PZ_ID = "vcs_env/VcsNav-v2"
"""PettingZoo registry id: ``pettingzoo.make("parallel", PZ_ID, scenario="circle")`` (or "aec");
``vcs_env/VcsNav-v1`` is the same env with observation version 1."""
_register(GYM_IDS, PZ_ID)  # each id's entry point fixes its observation version (vcs_env.registry)

__all__ = [
    "PLANNERS",
    "SCENARIOS",
    "MAPS",
    "GYM_IDS",
    "PZ_ID",
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
    "get_threads",
    "make_planner",
    "make_scenario",
    "parallel_env",
    "raw_env",
    "register_planner",
    "set_threads",
]
