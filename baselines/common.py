"""Pieces every planner shares."""

from __future__ import annotations

import numpy as np

from vcs_env.planning import Planner
from vcs_env.routes import route_direction
from vcs_env.state import WorldState


def preferred_velocity(
    world: WorldState, v_pref_max: np.ndarray | None = None, route: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """Velocity toward the goal, capped so the robot can stop there (vcs-method §2.5).

    ``s = min(v_pref_max, d / dt, sqrt(2 a_max d))`` toward the goal, and 0 within ``r_goal``.
    Unicycles are also capped so that they can turn onto the goal, ``s <= omega_max d /
    (2 |sin(beta)|)`` (pure-pursuit curvature 2 sin(beta) / d for a goal at bearing beta;
    ``|sin(beta)|`` counts as 1 for goals behind): without it a fast robot can orbit its goal
    (a limit cycle of radius v / omega_max) [reconstructed].

    With walls, the robot aims at its next visible waypoint and ``d`` is the remaining route
    length (:func:`vcs_env.routes.route_direction`, or ``route`` when the caller has it already);
    without walls this is the goal itself.

    Returns:
        ``(B, n, 2)`` [m/s].
    """
    e = world.goal - world.pos
    if world.n_segments:
        e = (route_direction(world) if route is None else route)[0]
    d = np.sqrt(np.einsum("...i,...i->...", e, e))
    cap = world.v_max if v_pref_max is None else v_pref_max
    s = np.minimum(np.minimum(cap, d / world.dt), np.sqrt(2.0 * world.a_max * d))
    if not world.holonomic:
        beta = np.arctan2(e[..., 1], e[..., 0]) - world.heading
        sin_b = np.where(np.cos(beta) >= 0.0, np.abs(np.sin(beta)), 1.0)
        s = np.minimum(s, world.omega_max * d / (2.0 * np.maximum(sin_b, 1e-9)))
    s = np.where(d > world.r_goal, s, 0.0)
    return e * (s / np.maximum(d, 1e-12))[..., None]


def velocity_to_target(world: WorldState, vel: np.ndarray, keep_heading: np.ndarray | None = None) -> np.ndarray:
    """Polar targets ``(B, n, 2)`` = (speed, heading) from velocities ``(B, n, 2)``; a zero
    velocity keeps ``keep_heading`` (default: the current heading)."""
    speed = np.sqrt(np.einsum("...i,...i->...", vel, vel))
    fallback = world.heading if keep_heading is None else keep_heading
    heading = np.where(speed > 1e-9, np.arctan2(vel[..., 1], vel[..., 0]), fallback)
    return np.stack((speed, heading), axis=-1)


def goal_heading(world: WorldState) -> np.ndarray:
    """Direction of the goal ``(B, n)`` [rad] (the current heading at the goal)."""
    e = world.goal - world.pos
    d = np.sqrt(np.einsum("...i,...i->...", e, e))
    return np.where(d > 1e-9, np.arctan2(e[..., 1], e[..., 0]), world.heading)


def hold_inactive(world: WorldState, target: np.ndarray) -> np.ndarray:
    """Targets ``(B, n, 2)`` with robots that are done held still (speed 0, current heading)."""
    target[..., 0] = np.where(world.active, target[..., 0], 0.0)
    target[..., 1] = np.where(world.active, target[..., 1], world.heading)
    return target


class VelocityPlanner(Planner):
    """A planner that chooses a desired velocity; the target keeps the goal heading when the
    velocity is zero, and robots that are done stay put."""

    def desired_velocity(self, world: WorldState) -> np.ndarray:
        """Desired velocity of every robot ``(B, n, 2)`` [m/s]."""
        raise NotImplementedError

    def plan(self, world: WorldState) -> np.ndarray:
        target = velocity_to_target(world, self.desired_velocity(world), goal_heading(world))
        return hold_inactive(world, target)
