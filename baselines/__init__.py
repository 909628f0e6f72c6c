"""Scripted planners. ``PLANNERS`` is the one registry; nobody mutates it from elsewhere."""

from __future__ import annotations

from collections.abc import Callable

from vcs_env.planning import Planner

from .straight import StraightPlanner


def _sampling_vo(method: str) -> Callable[..., Planner]:
    def make(**kw):
        from .vo import SamplingVOPlanner  # lazy, like the VCS planner: numba loads on first use

        return SamplingVOPlanner(method, **kw)

    make.__doc__ = f"A ``{method}`` :class:`baselines.vo.SamplingVOPlanner`."
    return make


def _orca(**kw):
    from .orca import OrcaPlanner  # needs the optional pyrvo (extra "orca")

    return OrcaPlanner(**kw)


def _vcs(**kw):
    from .vcs import VCSPlanner

    return VCSPlanner(**kw)


PLANNERS: dict[str, Callable[..., Planner]] = {
    "straight": StraightPlanner,
    "vcs": _vcs,
    "vo": _sampling_vo("vo"),
    "rvo": _sampling_vo("rvo"),
    "hrvo": _sampling_vo("hrvo"),
    "orca": _orca,
}
"""Planner name -> factory (keyword arguments go to the planner)."""


def make_planner(name: str, **kwargs) -> Planner:
    """A planner by registered name."""
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; registered planners are {sorted(PLANNERS)}")
    return PLANNERS[name](**kwargs)


__all__ = ["PLANNERS", "Planner", "StraightPlanner", "make_planner"]
