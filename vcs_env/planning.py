"""The planner protocol the env understands, and lazy lookup of planners by name.

A planner sees the privileged :class:`~vcs_env.state.WorldState` of ``B`` worlds and returns a
*target* per robot: a desired velocity in polar form ``(speed [m/s], heading [rad])``. Every
consumer (expert actions, rollouts, evaluation) turns targets into actions through the same
:func:`~vcs_env.dynamics.target_to_action`, so planners differ by method only.

The env never imports :mod:`baselines` at module level: ``expert="vcs"`` is resolved here,
lazily, through :func:`make_planner`.
"""

from __future__ import annotations

import numpy as np

from .dynamics import target_to_action
from .state import WorldState


class Planner:
    """Base class of scripted planners (decentralised: each robot plans for itself, but all
    robots of all worlds are planned in one call).

    A plan must depend only on the world state (randomness comes from :mod:`vcs_env.noise`
    keyed by ``world.key`` and ``world.steps``). A planner with memory across steps (e.g.
    hysteresis) must clear it for worlds whose ``steps`` is 0 and give the same answer when
    called twice on the same state.
    """

    name: str = "planner"

    def plan(self, world: WorldState) -> np.ndarray:
        """Targets ``(B, n, 2)`` = (speed [m/s], heading [rad]) for every robot."""
        raise NotImplementedError

    def act(self, world: WorldState, action_mode: str = "delta") -> np.ndarray:
        """Actions ``(B, n, 2)`` for the env, from :meth:`plan`."""
        return target_to_action(world, self.plan(world), action_mode)

    def potential(self, world: WorldState) -> np.ndarray:
        """Optional state value estimate ``(B, n)`` used by potential-based shaping."""
        raise NotImplementedError(f"planner {self.name!r} does not provide a potential")


def make_planner(spec: str | Planner, **kwargs) -> Planner:
    """A planner instance from a registered name (see ``baselines.PLANNERS``) or as given."""
    if isinstance(spec, Planner):
        if kwargs:
            raise ValueError("planner keyword arguments can only be given with a planner name")
        return spec
    if not isinstance(spec, str):
        raise ValueError(f"a planner must be a name or a vcs_env.planning.Planner, got {type(spec).__name__}")
    from baselines import make_planner as _make  # lazy: the env does not depend on baselines

    return _make(spec, **kwargs)
