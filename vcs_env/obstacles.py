"""Obstacle motion models: how passive obstacles move. They never react to robots.

A model draws everything random once, per world, in :meth:`ObstacleMotion.init` (from the
world's generator), so stepping is deterministic and stepping B worlds together equals
stepping them one by one. Parameters are a dict of arrays with leading shape ``(m, ...)`` per
world, stacked to ``(B, m, ...)`` by the simulator.

Each step the simulator asks :meth:`ObstacleMotion.velocity` for the velocity over the coming
step; obstacles then move on a straight line for ``dt`` (so swept collision checks are exact).
Write your own model by subclassing :class:`ObstacleMotion` and passing an instance as
``obstacle_motion=`` to the simulator or the envs.
"""

from __future__ import annotations

import math

import numpy as np

from . import kernels
from .scenario import ObstacleTrajectory, Scenario

Params = dict[str, np.ndarray]


class ObstacleMotion:
    """Base class: static obstacles."""

    name = "static"

    def init(self, rng: np.random.Generator, scenario: Scenario, pos: np.ndarray, target: np.ndarray) -> Params:
        """Draw one world's parameters.

        Args:
            rng: the world's generator.
            scenario: the scenario (speed ranges, periods, episode length).
            pos: initial obstacle positions ``(m, 2)`` [m].
            target: a second point per obstacle ``(m, 2)`` [m] (destination or initial direction).

        Returns:
            Parameter arrays with leading shape ``(m,)``.
        """
        return {}

    def velocity(self, params: Params, t: np.ndarray, pos: np.ndarray, dt: float) -> np.ndarray:
        """Velocity over the step starting at time ``t`` ``(B,)`` [s]; ``pos`` is ``(B, m, 2)``.

        May update ``params`` (it is called exactly once per step). Returns ``(B, m, 2)`` [m/s].
        """
        return np.zeros_like(pos)

    def reflect(self, params: Params, flip: np.ndarray) -> None:
        """The arena wall flipped the velocity components marked in ``flip`` ``(B, m, 2)``."""


def _draw_speed(rng: np.random.Generator, scenario: Scenario, m: int) -> np.ndarray:
    lo, hi = scenario.obstacle_speed
    return rng.uniform(lo, hi, size=m)


def _direction(pos: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Unit vectors from pos to target ``(m, 2)``; +x where they coincide."""
    d = target - pos
    norm = np.linalg.norm(d, axis=-1, keepdims=True)
    return np.where(norm > 1e-12, d / np.maximum(norm, 1e-12), np.array([1.0, 0.0]))


class ConstantVelocity(ObstacleMotion):
    """Straight line at a constant speed toward (and past) the target point."""

    name = "constant"

    def init(self, rng, scenario, pos, target):
        return {"vel": _direction(pos, target) * _draw_speed(rng, scenario, len(pos))[:, None]}

    def velocity(self, params, t, pos, dt):
        return params["vel"].copy()

    def reflect(self, params, flip):
        params["vel"] = np.where(flip, -params["vel"], params["vel"])


class Patrol(ObstacleMotion):
    """Back and forth between the start and the target point at a constant speed."""

    name = "patrol"

    def init(self, rng, scenario, pos, target):
        return {
            "waypoints": np.stack((pos, target), axis=1),
            "next": np.ones(len(pos), dtype=np.int64),
            "speed": _draw_speed(rng, scenario, len(pos)),
        }

    def velocity(self, params, t, pos, dt):
        wp = params["waypoints"]
        nxt = params["next"]
        to = np.take_along_axis(wp, nxt[..., None, None], axis=-2)[..., 0, :]
        delta = to - pos
        dist = np.linalg.norm(delta, axis=-1)
        step = params["speed"] * dt
        arrive = dist <= step
        # Land exactly on the waypoint, then head for the next one.
        with np.errstate(invalid="ignore", divide="ignore"):
            vel = np.where(
                arrive[..., None], delta / dt, delta / np.maximum(dist, 1e-12)[..., None] * params["speed"][..., None]
            )
        params["next"] = np.where(arrive, (nxt + 1) % wp.shape[-2], nxt)
        return vel


class Arbitrary(ObstacleMotion):
    """Constant speed, piecewise-constant random turn rate U(-turn_rate, turn_rate), redrawn
    every ``turn_period`` (vcs-method §4.1, CF2: "obstacles moving along arbitrary trajectories")."""

    name = "arbitrary"

    def init(self, rng, scenario, pos, target):
        m = len(pos)
        periods = int(math.ceil(scenario.max_time / scenario.turn_period)) + 1
        d = _direction(pos, target)
        return {
            "heading": np.arctan2(d[:, 1], d[:, 0]),
            "speed": _draw_speed(rng, scenario, m),
            "rates": rng.uniform(-scenario.turn_rate, scenario.turn_rate, size=(m, periods)),
            "period": np.full(m, scenario.turn_period),
        }

    def velocity(self, params, t, pos, dt):
        # Compiled: turn at the rate of the current period, then move at constant speed.
        heading = params["heading"].copy()  # a new array: snapshots of params stay unchanged
        vel = kernels.arbitrary_velocity(heading, params["speed"], params["rates"], params["period"], t, dt)
        params["heading"] = heading
        return vel

    def reflect(self, params, flip):
        h = params["heading"]
        h = np.where(flip[..., 0], np.pi - h, h)
        params["heading"] = np.where(flip[..., 1], -h, h)


class StopAndGo(ObstacleMotion):
    """Straight line toward the target that alternates moving (``go_time``) and stopped
    (``stop_time``) phases, starting with a moving one (a pedestrian who hesitates)."""

    name = "stop_and_go"

    def init(self, rng, scenario, pos, target):
        m = len(pos)
        lo_go, hi_go = scenario.go_time
        lo_st, hi_st = scenario.stop_time
        phases = int(math.ceil(scenario.max_time / max(lo_go + lo_st, 1e-3))) * 2 + 2
        durations = np.empty((m, phases))
        durations[:, 0::2] = rng.uniform(lo_go, hi_go, size=(m, phases // 2))
        durations[:, 1::2] = rng.uniform(lo_st, hi_st, size=(m, phases // 2))
        return {
            "dir": _direction(pos, target),
            "speed": _draw_speed(rng, scenario, m),
            "switch": np.cumsum(durations, axis=-1),
        }

    def velocity(self, params, t, pos, dt):
        # Number of phase switches before t: even means moving.
        phase = np.sum(params["switch"] <= t[:, None, None] + 1e-9, axis=-1)
        moving = (phase % 2) == 0
        return params["dir"] * (params["speed"] * moving)[..., None]

    def reflect(self, params, flip):
        params["dir"] = np.where(flip, -params["dir"], params["dir"])


class Trajectory(ObstacleMotion):
    """Scripted timed waypoints (:class:`~vcs_env.scenario.ObstacleTrajectory`), used by custom
    scenarios. Positions are exact at every waypoint time on the step grid."""

    name = "trajectory"

    def __init__(self, trajectories: tuple[ObstacleTrajectory, ...]):
        self.trajectories = tuple(trajectories)

    def init(self, rng, scenario, pos, target):
        m = len(self.trajectories)
        w = max((len(o.times) for o in self.trajectories), default=1)
        times = np.zeros((m, w))
        points = np.zeros((m, w, 2))
        for i, o in enumerate(self.trajectories):
            k = len(o.times)
            times[i, :k] = o.times
            points[i, :k] = o.positions
            # Pad by holding the last waypoint at later times.
            times[i, k:] = o.times[-1] + 1.0 + np.arange(w - k)
            points[i, k:] = o.positions[-1]
        return {"times": times, "points": points}

    @staticmethod
    def position(params: Params, t: np.ndarray) -> np.ndarray:
        """Scripted positions at times ``t`` ``(B,)`` -> ``(B, m, 2)`` [m]."""
        times, points = params["times"], params["points"]
        if times.shape[-1] == 1:
            return points[..., 0, :].copy()
        tt = t[:, None]
        idx = np.clip(np.sum(times <= tt[..., None], axis=-1) - 1, 0, times.shape[-1] - 2)
        t0 = np.take_along_axis(times, idx[..., None], axis=-1)[..., 0]
        t1 = np.take_along_axis(times, idx[..., None] + 1, axis=-1)[..., 0]
        p0 = np.take_along_axis(points, idx[..., None, None], axis=-2)[..., 0, :]
        p1 = np.take_along_axis(points, idx[..., None, None] + 1, axis=-2)[..., 0, :]
        frac = np.clip((tt - t0) / (t1 - t0), 0.0, 1.0)
        return p0 + frac[..., None] * (p1 - p0)

    def velocity(self, params, t, pos, dt):
        # Aim at the scripted position at the end of the step (also removes rounding drift).
        return (self.position(params, t + dt) - pos) / dt


MOTION_MODELS: dict[str, type[ObstacleMotion]] = {
    "static": ObstacleMotion,
    "constant": ConstantVelocity,
    "patrol": Patrol,
    "arbitrary": Arbitrary,
    "stop_and_go": StopAndGo,
}


def make_motion(scenario: Scenario) -> ObstacleMotion:
    """The motion model a scenario asks for."""
    if scenario.kind == "custom":
        return Trajectory(scenario.custom.obstacles)
    return MOTION_MODELS[scenario.obstacle_motion]()
