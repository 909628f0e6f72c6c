"""The Velocity Change Space (VCS) planner: expert policy and reward shaper."""

from .params import VCSParams
from .planner import VCSPlanner

__all__ = ["VCSParams", "VCSPlanner"]
