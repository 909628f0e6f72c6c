"""Initial-state generators: one world's starts, goals and obstacles from a scenario and a seed.

:func:`check_layout` rejects, at scenario construction, deterministic layouts that cannot be
placed without overlap; random layouts that cannot be sampled raise at reset. Both raise
``ValueError`` saying which fields to change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .scenario import Scenario

MIN_GOAL_DISTANCE = 1.0
"""Random layouts put every goal at least this far from its start [m]."""
MAX_TRIES = 2000
"""Rejection-sampling attempts per body before a random layout is declared impossible."""


@dataclass
class Layout:
    """One world's initial state (arrays without the batch axis)."""

    start: np.ndarray  # (n, 2) [m]
    goal: np.ndarray  # (n, 2) [m]
    heading: np.ndarray  # (n,) [rad]
    speed: np.ndarray  # (n,) [m/s]
    obs_pos: np.ndarray  # (m, 2) [m]
    obs_target: np.ndarray  # (m, 2) [m], second point for the motion model
    obs_radius: np.ndarray  # (m,) [m]


def _circle_points(n: int, radius: float, phase: float) -> np.ndarray:
    ang = phase + 2.0 * np.pi * np.arange(n) / n
    return radius * np.stack((np.cos(ang), np.sin(ang)), axis=-1)


def _swap_points(s: Scenario) -> tuple[np.ndarray, np.ndarray]:
    pairs = s.n_robots // 2
    y = (np.arange(pairs) - (pairs - 1) / 2.0) * s.lane_spacing
    x = np.full(pairs, s.circle_radius)
    left = np.stack((-x, y), axis=-1)
    right = np.stack((x, y), axis=-1)
    # robot 2k drives left -> right, robot 2k+1 right -> left, on lane k.
    start = np.empty((s.n_robots, 2))
    start[0::2], start[1::2] = left, right
    goal = np.empty((s.n_robots, 2))
    goal[0::2], goal[1::2] = right, left
    return start, goal


def _crossing_points(s: Scenario) -> tuple[np.ndarray, np.ndarray]:
    n1 = (s.n_robots + 1) // 2
    n2 = s.n_robots - n1
    r = s.circle_radius
    off1 = (np.arange(n1) - (n1 - 1) / 2.0) * s.lane_spacing
    off2 = (np.arange(n2) - (n2 - 1) / 2.0) * s.lane_spacing
    # Group 1 drives along +x, group 2 along +y; both paths cross near the origin.
    start = np.concatenate((np.stack((np.full(n1, -r), off1), -1), np.stack((off2, np.full(n2, -r)), -1)))
    goal = np.concatenate((np.stack((np.full(n1, r), off1), -1), np.stack((off2, np.full(n2, r)), -1)))
    return start, goal


def check_layout(s: Scenario) -> None:
    """Raise ``ValueError`` if a deterministic layout cannot be placed without overlap."""
    r = s.robot.radius
    need = 2.0 * r + s.min_separation + 2.0 * s.jitter
    if s.kind in ("circle", "crowd") and s.n_robots >= 2:
        chord = 2.0 * s.circle_radius * math.sin(math.pi / s.n_robots)
        if chord < need:
            raise ValueError(
                f"cannot place {s.n_robots} robots on a circle of radius {s.circle_radius:g} m without overlap: "
                f"neighbours are {chord:.3f} m apart, need {need:.3f} m (2 radius + min_separation + 2 jitter); "
                "increase layout_radius or reduce n_robots"
            )
    if s.kind in ("swap", "crossing"):
        if s.lane_spacing < need:
            raise ValueError(
                f"lane_spacing={s.lane_spacing:g} m is too small for robots of radius {r:g} m: need >= {need:.3f} m"
            )
        if s.kind == "swap" and 2.0 * s.circle_radius < need:
            raise ValueError(f"layout_radius={s.circle_radius:g} m is too short for a swap: need >= {need / 2:.3f} m")
        if s.kind == "crossing":
            spread = (math.ceil(s.n_robots / 2) - 1) / 2.0 * s.lane_spacing + r + s.jitter + s.min_separation
            if spread >= s.circle_radius:
                raise ValueError(
                    f"crossing groups overlap: layout_radius={s.circle_radius:g} m must exceed the half group "
                    f"width {spread:.3f} m; increase layout_radius or reduce n_robots / lane_spacing"
                )
    if s.kind in ("random", "dynamic", "crowd") or (s.kind != "custom" and s.n_obstacles):
        # A loose packing bound: the bodies' discs (with half the separation) must fit in the arena.
        r_obs = s.obstacle_radius[1]
        if s.kind == "crowd":
            ring = 2.0 * math.pi * s.circle_radius
            used = s.n_robots * (2 * r + s.min_separation) + s.n_obstacles * (2 * r_obs + s.min_separation)
            if used > ring:
                raise ValueError(
                    f"cannot place {s.n_robots} robots and {s.n_obstacles} obstacles on a crowd circle of radius "
                    f"{s.circle_radius:g} m: they need {used:.1f} m of its {ring:.1f} m; increase layout_radius"
                )
        else:
            side = 2.0 * s.arena_half_size
            area = math.pi * (
                2 * s.n_robots * (r + s.min_separation / 2) ** 2 + s.n_obstacles * (r_obs + s.min_separation / 2) ** 2
            )
            if area > 0.5 * side * side or s.arena_half_size <= max(r, r_obs) + s.min_separation:
                raise ValueError(
                    f"cannot place {s.n_robots} robots and {s.n_obstacles} obstacles in an arena of half size "
                    f"{s.arena_half_size:g} m without overlap; increase arena_half_size or reduce the counts"
                )
            if s.kind in ("random", "dynamic") and 2 * (s.arena_half_size - r) < MIN_GOAL_DISTANCE:
                raise ValueError(f"arena_half_size={s.arena_half_size:g} m leaves no room for goals >= 1 m away")
    if s.kind == "custom":
        lay = generate(s, np.random.default_rng(0))
        _check_no_overlap(
            np.concatenate((lay.start, lay.obs_pos)), np.concatenate((np.full(s.n_robots, r), lay.obs_radius))
        )


def _check_no_overlap(pos: np.ndarray, radius: np.ndarray) -> None:
    d = np.linalg.norm(pos[:, None] - pos[None], axis=-1) - radius[:, None] - radius[None]
    np.fill_diagonal(d, np.inf)
    if np.any(d < 0):
        i, j = np.unravel_index(np.argmin(d), d.shape)
        raise ValueError(
            f"custom layout overlaps at t=0: bodies {min(i, j)} and {max(i, j)} (robots first, then obstacles)"
        )


class _Sampler:
    """Rejection sampler of non-overlapping discs in a square."""

    def __init__(self, rng: np.random.Generator, half: float, sep: float):
        self.rng, self.half, self.sep = rng, half, sep
        self.pos: list[np.ndarray] = []
        self.rad: list[float] = []

    def add(self, p: np.ndarray, r: float) -> None:
        self.pos.append(np.asarray(p, dtype=np.float64))
        self.rad.append(r)

    def free(self, p: np.ndarray, r: float) -> bool:
        if not self.pos:
            return True
        d = np.linalg.norm(np.asarray(self.pos) - p, axis=-1) - np.asarray(self.rad) - r
        return bool(np.all(d >= self.sep))

    def sample(self, r: float, what: str, accept=lambda p: True) -> np.ndarray:
        lim = self.half - r
        for _ in range(MAX_TRIES):
            p = self.rng.uniform(-lim, lim, size=2)
            if self.free(p, r) and accept(p):
                self.add(p, r)
                return p
        raise ValueError(
            f"could not place {what} without overlap after {MAX_TRIES} tries; "
            "increase arena_half_size or reduce n_robots / n_obstacles / min_separation"
        )


def _jittered(rng: np.random.Generator, pts: np.ndarray, jitter: float) -> np.ndarray:
    if jitter <= 0.0:
        return pts
    ang = rng.uniform(0.0, 2.0 * np.pi, size=len(pts))
    rad = jitter * np.sqrt(rng.uniform(0.0, 1.0, size=len(pts)))
    return pts + rad[:, None] * np.stack((np.cos(ang), np.sin(ang)), -1)


def generate(s: Scenario, rng: np.random.Generator) -> Layout:
    """Draw one world's initial state for scenario ``s`` from ``rng``."""
    n, m, r = s.n_robots, s.n_obstacles, s.robot.radius
    obs_pos = np.zeros((m, 2))
    obs_target = np.zeros((m, 2))
    lo, hi = s.obstacle_radius
    obs_radius = rng.uniform(lo, hi, size=m) if s.kind != "custom" else np.zeros(m)
    heading = speed = None
    placed_obstacles = False

    if s.kind == "circle":
        start = _jittered(rng, _circle_points(n, s.circle_radius, 0.0), s.jitter)
        goal = -start
    elif s.kind == "swap":
        start, goal = _swap_points(s)
        start = _jittered(rng, start, s.jitter)
    elif s.kind == "crossing":
        start, goal = _crossing_points(s)
        start = _jittered(rng, start, s.jitter)
    elif s.kind == "crowd":
        start = _circle_points(n, s.circle_radius, -np.pi / 2)
        goal = -start
        obs_pos, obs_target = _crowd_obstacles(rng, s, start, goal, obs_radius)
        placed_obstacles = True
    elif s.kind in ("random", "dynamic"):
        half = s.arena_half_size
        starts = _Sampler(rng, half, s.min_separation)
        goals = _Sampler(rng, half, s.min_separation)
        start = np.array([starts.sample(r, f"the start of robot {i}") for i in range(n)]).reshape(n, 2)
        goal = np.array(
            [
                goals.sample(
                    r, f"the goal of robot {i}", lambda p, i=i: np.linalg.norm(p - start[i]) >= MIN_GOAL_DISTANCE
                )
                for i in range(n)
            ]
        ).reshape(n, 2)
    else:  # custom
        c = s.custom
        start = np.asarray(c.start, dtype=np.float64).reshape(n, 2)
        goal = np.asarray(c.goal, dtype=np.float64).reshape(n, 2)
        heading = None if c.heading is None else np.asarray(c.heading, dtype=np.float64)
        speed = None if c.speed is None else np.asarray(c.speed, dtype=np.float64)
        obs_pos = np.array([o.positions[0] for o in c.obstacles], dtype=np.float64).reshape(m, 2)
        obs_target = obs_pos.copy()
        obs_radius = np.array([o.radius for o in c.obstacles], dtype=np.float64)
        placed_obstacles = True

    if m and not placed_obstacles:
        sampler = _Sampler(rng, s.arena_half_size, s.min_separation)
        for p in np.concatenate((start, goal)):
            sampler.add(p, r)
        for k in range(m):
            obs_pos[k] = sampler.sample(obs_radius[k], f"obstacle {k}")
        lim = s.arena_half_size - obs_radius[:, None]
        obs_target = rng.uniform(-lim, lim, size=(m, 2))

    if heading is None:
        d = goal - start
        heading = np.arctan2(d[:, 1], d[:, 0])
    if speed is None:
        speed = np.full(n, float(s.initial_speed))
    return Layout(
        start=np.ascontiguousarray(start, dtype=np.float64),
        goal=np.ascontiguousarray(goal, dtype=np.float64),
        heading=np.asarray(heading, dtype=np.float64),
        speed=np.asarray(speed, dtype=np.float64),
        obs_pos=obs_pos,
        obs_target=obs_target,
        obs_radius=np.asarray(obs_radius, dtype=np.float64),
    )


def _crowd_obstacles(
    rng: np.random.Generator, s: Scenario, start: np.ndarray, goal: np.ndarray, radius: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """CrowdNav circle crossing: obstacles start on the circle (with +-0.5 m noise) and head for
    the antipodal point; starts and goals keep clear of the robots' and of each other's."""
    m = len(radius)
    pos = np.zeros((m, 2))
    target = np.zeros((m, 2))
    bodies = [(p, s.robot.radius) for p in np.concatenate((start, goal))]
    for k in range(m):
        for _ in range(MAX_TRIES):
            ang = rng.uniform(0.0, 2.0 * np.pi)
            noise = rng.uniform(-0.5, 0.5, size=2)
            p = s.circle_radius * np.array([np.cos(ang), np.sin(ang)]) + noise
            g = -p
            ok = all(np.linalg.norm(q - c) - rad - radius[k] >= s.min_separation for c, rad in bodies for q in (p, g))
            if ok:
                pos[k], target[k] = p, g
                bodies += [(p, radius[k]), (g, radius[k])]
                break
        else:
            raise ValueError(
                f"could not place crowd obstacle {k} without overlap after {MAX_TRIES} tries; "
                "increase layout_radius or reduce n_obstacles / min_separation"
            )
    return pos, target
