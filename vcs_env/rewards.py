"""Named reward terms. The reward is ``sum(weight[name] * term[name])``; every term is reported.

See :class:`~vcs_env.scenario.RewardWeights` for the definitions and default weights.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .sim import StepEvents

BASE_TERMS = ("progress", "arrival", "collision", "time")
EXPERT_TERMS = ("vcs_imitation", "vcs_potential")


def base_terms(events: StepEvents, dt: float) -> dict[str, np.ndarray]:
    """The terms that need no expert, each ``(B, n)``; zero for robots that did not act."""
    acted = events.acted
    return {
        "progress": np.where(acted, events.goal_dist_before - events.goal_dist_after, 0.0),
        "arrival": events.reached.astype(np.float64),
        "collision": -events.collided.astype(np.float64),
        "time": np.where(acted, -dt, 0.0),
    }


def imitation_term(actions: np.ndarray, expert_actions: np.ndarray, acted: np.ndarray) -> np.ndarray:
    """``-|a - a_expert| / (2 sqrt 2)`` in [-1, 0]: distance of the taken and the expert action
    in the one-step velocity change window (both in action units, clipped to [-1, 1])."""
    diff = np.clip(actions, -1.0, 1.0) - expert_actions
    return np.where(acted, -np.sqrt(np.einsum("...i,...i->...", diff, diff)) / (2.0 * np.sqrt(2.0)), 0.0)


def potential_term(
    phi_before: np.ndarray,
    phi_after: np.ndarray,
    reached: np.ndarray,
    crashed: np.ndarray,
    acted: np.ndarray,
    gamma: float,
    floor: float,
):
    """``gamma * phi(s') - phi(s)`` per robot ``(B, n)``: potential-based shaping (Ng et al. 1999;
    with the learner's ``gamma`` it leaves the optimal policy unchanged). At the end of a robot's
    episode ``phi(s')`` is replaced by the best potential, 0, on reaching the goal (``reached``)
    and by the worst, ``floor`` (< 0), on a collision that ends it (``crashed``), so ending in a
    crash never pays; a truncated robot keeps ``phi(s')`` (its value is bootstrapped).

    With ``gamma = 1`` an episode's terms sum to ``phi(s_T) - phi(s_0)``, but a learner that
    discounts then pays about ``(1 - gamma) |phi|`` per step, most in crowded states (with
    weight 10, PPO learned to stand still on ``circle``; measured).
    """
    end = np.where(crashed, floor, np.where(reached, 0.0, phi_after))
    return np.where(acted, gamma * end - phi_before, 0.0)


def weighted_sum(terms: Mapping[str, np.ndarray], weights: Mapping[str, float]) -> np.ndarray:
    total = None
    for name, value in terms.items():
        w = weights.get(name, 0.0)
        if w:
            total = w * value if total is None else total + w * value
    if total is None:
        total = np.zeros_like(next(iter(terms.values())))
    return total
