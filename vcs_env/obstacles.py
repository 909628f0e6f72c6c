"""Obstacle motion models: how obstacles move. Passive ones never react to robots; pedestrians
(:class:`Pedestrians`, :mod:`vcs_env.pedestrians`) walk to goals and avoid each other and, if they
see them, the robots.

A model draws everything random once, per world, in :meth:`ObstacleMotion.place` and
:meth:`ObstacleMotion.init` at reset (from the world's generator), so stepping is deterministic
and stepping B worlds together equals stepping them one by one. Parameters are a dict of arrays
with leading shape ``(m, ...)`` per world, stacked to ``(B, m, ...)`` by the simulator.

Each step the simulator asks :meth:`ObstacleMotion.world_velocity` (by default
:meth:`ObstacleMotion.velocity`, which sees only time and obstacle positions) for the velocity
over the coming step; obstacles then move on a straight line for ``dt`` (so swept collision checks are exact).
Write your own model by subclassing :class:`ObstacleMotion` and passing an instance as
``obstacle_motion=`` to the simulator or the envs.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from . import kernels
from .checks import user_stacklevel
from .orca_kernel import orca_velocities
from .pedestrians import SF_MAX_SPEED, PedestrianSpec, preferred_velocity, social_force
from .placement import MAX_TRIES, Layout
from .scenario import ObstacleTrajectory, Scenario
from .state import WorldState
from .walls import clearance

Params = dict[str, np.ndarray]


class ObstacleMotion:
    """Base class: static obstacles."""

    name = "static"
    reads: frozenset[str] = frozenset()
    """The fields of :data:`MOTION_FIELDS` this model reads from the scenario (a field it does not read is refused
    when given: :func:`check_motion_fields`)."""

    def init(self, rng: np.random.Generator, scenario: Scenario, pos: np.ndarray, target: np.ndarray) -> Params:
        """Draw one world's parameters.

        Args:
            rng: the world's generator.
            scenario: the scenario (speed ranges, periods, episode length).
            pos: initial obstacle positions ``(m, 2)`` [m].
            target: a second point per obstacle ``(m, 2)`` [m] (destination or initial direction).

        Returns:
            Parameter arrays with leading shape ``(m,)``, one row per obstacle, the same names and shapes in every
            world (a number is one value for every obstacle: ``np.full(m, value)``).
        """
        return {}

    def velocity(self, params: Params, t: np.ndarray, pos: np.ndarray, dt: float) -> np.ndarray:
        """Velocity over the step of ``dt`` [s] starting at time ``t`` ``(B,)`` [s]; ``pos`` ``(B, m, 2)`` [m].

        May update ``params`` (it is called exactly once per step). Returns ``(B, m, 2)`` [m/s].
        """
        return np.zeros_like(pos)

    def reflect(self, params: Params, flip: np.ndarray) -> None:
        """The arena wall flipped the velocity components marked in ``flip`` ``(B, m, 2)``."""

    def place(self, rng: np.random.Generator, scenario: Scenario, layout: Layout) -> None:
        """Change one world's generated ``layout`` in place before :meth:`init` (default: keep it).
        Pedestrians crossing a square are placed here."""

    def world_velocity(self, params: Params, world: WorldState, dt: float) -> np.ndarray:
        """:meth:`velocity` for models that see the whole world (robots, walls), over the step of ``dt`` [s]:
        ``(B, m, 2)`` [m/s].

        The simulator calls this; the default passes the time and obstacle positions to
        :meth:`velocity`. Models that react to robots override it."""
        return self.velocity(params, world.time, world.obs_pos, dt)


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
    reads = frozenset({"obstacle_speed"})

    def init(self, rng, scenario, pos, target):
        return {"vel": _direction(pos, target) * _draw_speed(rng, scenario, len(pos))[:, None]}

    def velocity(self, params, t, pos, dt):
        return params["vel"].copy()

    def reflect(self, params, flip):
        params["vel"] = np.where(flip, -params["vel"], params["vel"])


class Patrol(ObstacleMotion):
    """Back and forth between the start and the target point at a constant speed."""

    name = "patrol"
    reads = frozenset({"obstacle_speed"})

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


MAX_PERIODS = 4096
"""Turn periods (``arbitrary``) and phases (``stop_and_go``) drawn per obstacle at reset, at most: after them the
last turn rate holds, and a stop-and-go obstacle keeps moving (no suite comes near: a tiny period or a very long
episode would otherwise draw gigabytes per world). A scenario whose episodes outlast them is warned of
(:func:`warn_short_script`)."""


class ShortScriptWarning(UserWarning):
    """The obstacles' random script, drawn at reset, ends before the episode may (:data:`MAX_PERIODS`)."""


def warn_short_script(scenario: Scenario, covered: float, after: str) -> None:
    """Warn that the obstacles' script covers only ``covered`` [s] of ``scenario``'s episodes, and what ``after``."""
    if covered < scenario.max_time:
        warnings.warn(
            f"{scenario.obstacle_motion} obstacles draw their motion for the first {covered:.3g} s of the "
            f"{scenario.max_time:.3g} s an episode may last (max_steps x dt); after that {after}",
            ShortScriptWarning,
            stacklevel=user_stacklevel(),
        )


class Arbitrary(ObstacleMotion):
    """Constant speed, piecewise-constant random turn rate U(-turn_rate, turn_rate), redrawn
    every ``turn_period`` (vcs-method §4.1, CF2: "obstacles moving along arbitrary trajectories"),
    for the first :data:`MAX_PERIODS` periods."""

    name = "arbitrary"
    reads = frozenset({"obstacle_speed", "turn_rate", "turn_period"})

    def init(self, rng, scenario, pos, target):
        m = len(pos)
        periods = min(int(math.ceil(scenario.max_time / scenario.turn_period)) + 1, MAX_PERIODS)
        warn_short_script(scenario, periods * scenario.turn_period, "each keeps its last turn rate (drives a circle)")
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
    (``stop_time``) phases, starting with a moving one (a pedestrian who hesitates), for the first
    :data:`MAX_PERIODS` phases."""

    name = "stop_and_go"
    reads = frozenset({"obstacle_speed", "go_time", "stop_time"})

    def init(self, rng, scenario, pos, target):
        m = len(pos)
        lo_go, hi_go = scenario.go_time
        lo_st, hi_st = scenario.stop_time
        phases = min(int(math.ceil(scenario.max_time / max(lo_go + lo_st, 1e-3))) * 2 + 2, MAX_PERIODS)
        warn_short_script(scenario, phases // 2 * (lo_go + lo_st), "they may keep moving without stopping")
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


class Pedestrians(ObstacleMotion):
    """Pedestrians with a preferred speed and goals, avoiding each other by ORCA or the social force
    model and the robots if they see them (:mod:`vcs_env.pedestrians`; holonomic).

    Parameters per world: ``vel`` ``(m, 2)`` [m/s] the current velocity, ``goals`` ``(m, K, 2)``
    [m] the goals in order, ``goal_idx`` ``(m,)`` the current one, ``v_pref`` ``(m,)`` [m/s]."""

    name = "pedestrians"

    def __init__(self, spec: PedestrianSpec | None = None):
        if spec is not None and not isinstance(spec, PedestrianSpec):
            raise ValueError(f"pedestrians must be a vcs_env.pedestrians.PedestrianSpec, got {type(spec).__name__}")
        self.spec = spec if spec is not None else PedestrianSpec()

    def place(self, rng, scenario, layout):
        if self.spec.goal_policy == "square":
            layout.obs_pos, layout.obs_target = _square_crossing(rng, scenario, layout)
        if len(layout.segments) and len(layout.obs_pos):
            gap = clearance(layout.obs_pos, layout.segments) - layout.obs_radius
            if np.any(gap < 0.0):
                k = int(np.argmin(gap))
                raise ValueError(
                    f"pedestrians: obstacle {k} at {np.round(layout.obs_pos[k], 3).tolist()} is inside a wall "
                    f"(its edge is {-gap[k]:.3f} m into it); the layout must keep pedestrians out of walls"
                )

    def init(self, rng, scenario, pos, target):
        m, spec = len(pos), self.spec
        goals = target[:, None, :].copy()
        if spec.goal_policy == "wander":  # the layout's point, then random points in the arena
            # Enough legs of 0.5 m or more for the whole episode (at most 256; then they repeat).
            legs = min(256, 2 + int(math.ceil(scenario.max_time * spec.v_pref / 0.5)))
            warn_short_script(scenario, legs * 0.5 / spec.v_pref, "they walk the same legs again")
            lo = -scenario.arena_half_size + scenario.obstacle_radius[1]
            more = rng.uniform(lo, -lo, size=(m, legs, 2))
            goals = np.concatenate((goals, more), axis=1)
        return {
            "vel": np.zeros((m, 2)),
            "goals": goals,
            "goal_idx": np.zeros(m, dtype=np.int64),
            "v_pref": np.full(m, spec.v_pref),
        }

    def world_velocity(self, params, world, dt):
        spec, pos = self.spec, world.obs_pos
        B, m = pos.shape[:2]
        goals, idx = params["goals"], params["goal_idx"]
        if goals.shape[-2] > 1:  # wander: on arrival (centre within the radius) head for the next goal
            goal = np.take_along_axis(goals, idx[..., None, None], axis=-2)[..., 0, :]
            arrived = np.linalg.norm(goal - pos, axis=-1) < world.obs_radius
            idx = np.where(arrived, (idx + 1) % goals.shape[-2], idx)
            params["goal_idx"] = idx
        goal = np.take_along_axis(goals, idx[..., None, None], axis=-2)[..., 0, :]
        pref = preferred_velocity(pos, goal, params["v_pref"])
        # The agents a pedestrian sees: the pedestrians, then the present robots if it sees them.
        agents = [(pos, params["vel"], world.obs_radius, np.ones((B, m), dtype=bool))]
        if spec.sees_robots:
            agents.append((world.pos, world.vel, world.radius, world.present))
        a_pos, a_vel, a_radius, present = (np.concatenate(x, axis=1) for x in zip(*agents))
        if spec.model == "orca":
            max_speed = np.concatenate((params["v_pref"], world.v_max), axis=1)[:, : a_pos.shape[1]]
            vel = orca_velocities(
                a_pos, a_vel, a_radius + spec.radius_margin, max_speed, pref, present, m,
                spec.time_horizon, dt, spec.neighbor_dist, spec.max_neighbors,
            )  # fmt: skip
        else:  # social force: one Euler step of the acceleration, speed capped
            vel = params["vel"] + social_force(a_pos, a_vel, pref, present, m) * dt
            top = SF_MAX_SPEED * params["v_pref"]
            speed = np.linalg.norm(vel, axis=-1)
            vel = vel * np.minimum(1.0, top / np.maximum(speed, 1e-12))[..., None]
        params["vel"] = vel
        return vel.copy()

    def reflect(self, params, flip):
        params["vel"] = np.where(flip, -params["vel"], params["vel"])


def check_square_crossing(s: Scenario) -> None:
    """Pedestrians crossing the square are placed at reset (:func:`_square_crossing`); a scenario whose square has no
    room for them is refused here, with the first of the trial layouts of the maps (seeds 0-7) that fails, not by a
    reset that fails at random (an autoreset in the middle of training)."""
    from .layouts import generate  # late: layouts imports the scenario module too
    from .map_kinds import TRIAL_LAYOUTS

    for seed in range(TRIAL_LAYOUTS):
        rng = np.random.default_rng(seed)
        try:
            _square_crossing(rng, s, generate(s, rng))
        except ValueError as e:
            raise ValueError(
                f"pedestrians crossing the square: trial layout {seed} of {TRIAL_LAYOUTS} found no place for them, so "
                f"resets would fail at random; increase arena_half_size or reduce n_obstacles ({e})"
            ) from None


def _square_crossing(rng: np.random.Generator, s: Scenario, lay: Layout) -> tuple[np.ndarray, np.ndarray]:
    """CrowdNav's square crossing: each pedestrian starts on a random half (x < 0 or x > 0) of the
    square ``[-h, h]^2`` (``h = arena_half_size``; its disc inside it where obstacles bounce off its edges) and walks
    to a point on the other half; starts keep
    ``min_separation`` from the robots' starts and earlier starts, goals from the robots' goals and
    earlier goals, and both from the layout's walls (a map kind). Returns ``(start, goal)``, ``(m, 2)`` each [m]."""
    radius = lay.obs_radius
    starts = [(p, s.robot.radius) for p in lay.start]
    goals = [(p, s.robot.radius) for p in lay.goal]

    def draw(side: float, taken: list, k: int, what: str) -> np.ndarray:
        # Centres in the square, as CrowdNav's; discs inside it where they bounce off its edges.
        h = s.arena_half_size - (radius[k] if s.bounce else 0.0)
        for _ in range(MAX_TRIES):
            p = np.array([rng.random() * h * side, (rng.random() - 0.5) * 2.0 * h])
            walls_ok = not len(lay.segments) or clearance(p, lay.segments) >= radius[k] + s.min_separation
            if walls_ok and all(np.linalg.norm(p - c) >= r + radius[k] + s.min_separation for c, r in taken):
                return p
        raise ValueError(f"could not place the {what} of pedestrian {k} in the square; increase arena_half_size")

    start, goal = np.zeros((len(radius), 2)), np.zeros((len(radius), 2))
    for k in range(len(radius)):
        side = -1.0 if rng.random() > 0.5 else 1.0
        start[k] = draw(side, starts, k, "start")
        goal[k] = draw(-side, goals, k, "goal")
        starts.append((start[k], radius[k]))
        goals.append((goal[k], radius[k]))
    return start, goal


MOTION_MODELS: dict[str, type[ObstacleMotion]] = {
    "static": ObstacleMotion,
    "constant": ConstantVelocity,
    "patrol": Patrol,
    "arbitrary": Arbitrary,
    "stop_and_go": StopAndGo,
    "pedestrians": Pedestrians,
}


MOTION_FIELDS = ("obstacle_speed", "turn_rate", "turn_period", "go_time", "stop_time")
"""The scenario fields that set the built-in motion models (each model's ``reads``)."""


def check_motion_fields(scenario: Scenario, given) -> None:
    """A ``ValueError`` for a field of :data:`MOTION_FIELDS` in ``given`` (set by a flag, a mixture entry or an env
    keyword) that the motion ``scenario.obstacle_motion`` names does not read (the preset's own values are left
    alone: ``scenario="crowd", obstacle_motion="pedestrians"`` keeps the crowd's unread speeds)."""
    motion = MOTION_MODELS[scenario.obstacle_motion]
    for name in MOTION_FIELDS:
        if name in given and name not in motion.reads:
            reads = f"it reads {', '.join(sorted(motion.reads))} only" if motion.reads else "it reads none of them"
            walk = "; pedestrians walk at PedestrianSpec.v_pref (pedestrians=...)" if motion is Pedestrians else ""
            fields = ", ".join(MOTION_FIELDS)
            raise ValueError(
                f"{name} does not apply to obstacle_motion={scenario.obstacle_motion!r} (of {fields}, {reads}{walk}); "
                "leave it out or choose another obstacle_motion"
            )


def make_motion(scenario: Scenario) -> ObstacleMotion:
    """The motion model a scenario asks for."""
    if scenario.kind == "custom":
        return Trajectory(scenario.custom.obstacles)
    if scenario.obstacle_motion == "pedestrians":
        return Pedestrians(scenario.pedestrians)
    return MOTION_MODELS[scenario.obstacle_motion]()
