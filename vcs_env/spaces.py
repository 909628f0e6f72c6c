"""Gymnasium spaces of the API adapters (the simulator core is array-only).

The bounds and sizes come from :mod:`vcs_env.observations`; this module only wraps them.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from .observations import observation_bounds, state_dim
from .scenario import Scenario


def observation_space(scenario: Scenario) -> spaces.Box:
    """The Box every robot's observation lives in."""
    low, high = observation_bounds(scenario)
    return spaces.Box(low=low, high=high, dtype=np.float32)


def state_space(scenario: Scenario) -> spaces.Box:
    """The Box of the global state (:func:`vcs_env.observations.state_vector`)."""
    return spaces.Box(low=-np.inf, high=np.inf, shape=(state_dim(scenario),), dtype=np.float32)


def action_space() -> spaces.Box:
    """Every robot's action: ``Box(-1, 1, (2,), float32)``; a holonomic robot's is cut to the unit disc where it
    drives (:mod:`vcs_env.dynamics`)."""
    return spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
