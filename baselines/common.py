"""Pieces every planner shares."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vcs_env.planning import Planner
from vcs_env.routes import route_direction
from vcs_env.state import WorldState


def preferred_velocity(world: WorldState, route: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Velocity toward the goal, capped so the robot can stop there (vcs-method §2.5).

    ``s = min(v_max, d / dt, sqrt(2 a_max d))`` toward the goal, and 0 within ``r_goal``.
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
    if world.holonomic:
        cos_b = sin_b = world.v_max  # not read
    else:  # numpy's trigonometry (baselines.vcs.kernel.period's module docstring)
        beta = np.arctan2(e[..., 1], e[..., 0]) - world.heading
        cos_b, sin_b = np.cos(beta), np.sin(beta)
    out = np.empty(e.shape)
    dt, r_goal = float(world.dt), float(world.r_goal)
    _preferred(e, world.v_max, dt, world.a_max, world.omega_max, r_goal, world.holonomic, cos_b, sin_b, out)
    return out


@njit(cache=True)
def _preferred(e, cap, dt, a_max, omega_max, r_goal, holonomic, cos_b, sin_b, out):
    """:func:`preferred_velocity` into ``out`` ``(B, n, 2)`` [m/s] from the offsets ``e`` ``(B, n, 2)``
    [m] to the goals (or waypoints), the robots' top speeds ``cap`` [m/s] and, for unicycles, the
    cosines and sines of the goals' bearings ``(B, n)``."""
    B, n = cap.shape
    for b in range(B):
        for i in range(n):
            ex, ey = e[b, i, 0], e[b, i, 1]
            d = math.sqrt(ex * ex + ey * ey)
            s = min(min(cap[b, i], d / dt), math.sqrt(2.0 * a_max[b, i] * d))
            if not holonomic:
                sb = abs(sin_b[b, i]) if cos_b[b, i] >= 0.0 else 1.0
                s = min(s, omega_max[b, i] * d / (2.0 * max(sb, 1e-9)))
            if not d > r_goal:
                s = 0.0
            f = s / max(d, 1e-12)
            out[b, i, 0] = ex * f
            out[b, i, 1] = ey * f


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
        world.check_shapes()  # the kernels index every field by its sizes
        world.check_limits()  # and divide by dt and the robots' limits
        target = velocity_to_target(world, self.desired_velocity(world), goal_heading(world))
        return hold_inactive(world, target)
