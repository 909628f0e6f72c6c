"""The Velocity Change Space (VCS) planner: expert policy and reward shaper."""

from .params import VCSParams
from .planner import CoarseStepWarning, VCSPlanner

__all__ = ["CoarseStepWarning", "VCSParams", "VCSPlanner"]
