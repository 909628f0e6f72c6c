"""``straight``: drive at the goal, no avoidance (a lower bound and a sanity check)."""

from __future__ import annotations

import numpy as np

from vcs_env.state import WorldState

from .common import VelocityPlanner, preferred_velocity


class StraightPlanner(VelocityPlanner):
    """Preferred velocity toward the goal, ignoring everything else."""

    name = "straight"

    def desired_velocity(self, world: WorldState) -> np.ndarray:
        return preferred_velocity(world)
