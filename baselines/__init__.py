"""Scripted planners. ``PLANNERS`` is the one registry; nobody mutates it from elsewhere."""

from __future__ import annotations

from collections.abc import Callable

from vcs_env.planning import Planner

from .straight import StraightPlanner


def _vcs(**kw):
    from .vcs import VCSPlanner

    return VCSPlanner(**kw)


PLANNERS: dict[str, Callable[..., Planner]] = {
    "straight": StraightPlanner,
    "vcs": _vcs,
}
"""Planner name -> factory (keyword arguments go to the planner)."""


def make_planner(name: str, **kwargs) -> Planner:
    """A planner by registered name."""
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; registered planners are {sorted(PLANNERS)}")
    return PLANNERS[name](**kwargs)


__all__ = ["PLANNERS", "Planner", "StraightPlanner", "make_planner"]
