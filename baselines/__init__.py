"""Scripted planners, offered to ``vcs_env`` as plug-ins.

``pyproject.toml`` registers the factories below under the entry-point group
``vcs_env.planners``, so ``vcs_env.make_planner("hrvo")`` and ``expert="vcs"`` find them without
``vcs_env`` importing this package. ``PLANNERS`` and ``make_planner`` are the registry of
:mod:`vcs_env.planning`, re-exported (there is one registry).
"""

from __future__ import annotations

from vcs_env.planning import PLANNERS, Planner, make_planner

from .straight import StraightPlanner

# Factories named by the entry points; each imports its planner on first use (numba, pyrvo).
# (Not named like the submodules: importing `baselines.vo` would replace a function `vo`.)


def make_vcs(**kw) -> Planner:
    """A :class:`baselines.vcs.VCSPlanner` (keyword arguments: :class:`baselines.vcs.VCSParams` fields)."""
    from .vcs import VCSPlanner

    return VCSPlanner(**kw)


def make_vo(**kw) -> Planner:
    """A ``vo`` :class:`baselines.vo.SamplingVOPlanner` (passive velocity obstacles)."""
    from .vo import SamplingVOPlanner

    return SamplingVOPlanner("vo", **kw)


def make_rvo(**kw) -> Planner:
    """An ``rvo`` :class:`baselines.vo.SamplingVOPlanner` (reciprocal velocity obstacles)."""
    from .vo import SamplingVOPlanner

    return SamplingVOPlanner("rvo", **kw)


def make_hrvo(**kw) -> Planner:
    """An ``hrvo`` :class:`baselines.vo.SamplingVOPlanner` (hybrid reciprocal velocity obstacles)."""
    from .vo import SamplingVOPlanner

    return SamplingVOPlanner("hrvo", **kw)


def make_orca(**kw) -> Planner:
    """A :class:`baselines.orca.OrcaPlanner` (needs the optional ``pyrvo``, extra ``orca``)."""
    from .orca import OrcaPlanner

    return OrcaPlanner(**kw)


__all__ = ["PLANNERS", "Planner", "StraightPlanner", "make_planner"]
