"""``straight``: drive at the goal, no avoidance (a lower bound and a sanity check)."""

from __future__ import annotations

import numpy as np

from vcs_env.planning import Planner
from vcs_env.state import WorldState

from .common import goal_heading, preferred_velocity, velocity_to_target


class StraightPlanner(Planner):
    """Preferred velocity toward the goal, ignoring everything else."""

    name = "straight"

    def plan(self, world: WorldState) -> np.ndarray:
        return velocity_to_target(world, preferred_velocity(world), goal_heading(world))
