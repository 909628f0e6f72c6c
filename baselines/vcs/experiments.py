"""The test scenarios of the VCS method (vcs-method §4), as reusable builders.

Each builder returns a :class:`~vcs_env.scenario.Scenario` (``kind="custom"``, scripted
obstacles); :func:`run` drives it with a planner and records what the property tests measure
(collisions, arrival, path, lateral deviation, avoidance onset, fallback events, heading
changes). The behaviour tests and the VCS notebook both use these.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vcs_env.engine import NavEngine
from vcs_env.scenario import CustomLayout, ObstacleTrajectory, RobotSpec, Scenario

from .planner import VCSPlanner, planning_period

DT = 0.1
WEAK = RobotSpec(a_max=0.3, omega_max=0.6)
"""The weak dynamics of vcs-method §4.4 (a_max 0.3 m/s^2, omega_max 0.6 rad/s)."""


def _scenario(
    starts, goals, obstacles, r_ca, max_time=60.0, robot: RobotSpec | None = None, speeds=None, headings=None
) -> Scenario:
    layout = CustomLayout(start=starts, goal=goals, heading=headings, speed=speeds, obstacles=tuple(obstacles))
    return Scenario(
        kind="custom",
        n_robots=len(starts),
        n_obstacles=len(obstacles),
        custom=layout,
        r_ca=r_ca,
        max_steps=int(round(max_time / DT)),
        on_collision="continue",
        r_goal=0.1,
        dt=DT,
        robot=robot if robot is not None else RobotSpec(),
        min_separation=0.0,
    )


def _sampled(path: np.ndarray, radius: float) -> ObstacleTrajectory:
    """An obstacle following ``path`` ``(T+1, 2)`` sampled every DT."""
    times = tuple(DT * k for k in range(len(path)))
    return ObstacleTrajectory(times=times, positions=tuple(map(tuple, path)), radius=radius)


def corridor_obstacles(seed: int, turning: bool, count: int = 6, horizon: float = 60.0) -> list[ObstacleTrajectory]:
    """CF1/CF2: obstacles spawned at x in [6, 16], y in [-6, 6], aimed at random points of the
    corridor y = 0, x in [6, 16]; speed U(0.2, 0.7) m/s, radius U(0.2, 0.5) m. With ``turning``
    each turns at a piecewise-constant rate U(-0.6, 0.6) rad/s redrawn every 2 s."""
    rng = np.random.default_rng(seed)
    out = []
    placed: list[tuple[np.ndarray, float]] = []
    steps = int(round(horizon / DT))
    for _ in range(count):
        radius = rng.uniform(0.2, 0.5)
        for _ in range(1000):  # spawn off the corridor and clear of the others
            p0 = np.array([rng.uniform(6, 16), rng.uniform(-6, 6)])
            if abs(p0[1]) > 1.0 and all(np.linalg.norm(p0 - q) > radius + rq + 0.1 for q, rq in placed):
                break
        placed.append((p0, radius))
        aim = np.array([rng.uniform(6, 16), 0.0])
        speed = rng.uniform(0.2, 0.7)
        heading = math.atan2(*(aim - p0)[::-1])
        rates = rng.uniform(-0.6, 0.6, size=steps // 20 + 2) if turning else np.zeros(steps // 20 + 2)
        path = np.empty((steps + 1, 2))
        path[0] = p0
        for k in range(steps):
            heading += rates[k // 20] * DT
            path[k + 1] = path[k] + speed * DT * np.array([math.cos(heading), math.sin(heading)])
        out.append(_sampled(path, radius))
    return out


def cf_scenario(seed: int, turning: bool = False, robot: RobotSpec | None = None) -> Scenario:
    """CF1 (straight movers) / CF2 (arbitrary trajectories): goal (22, 0), r_ca 8 m, v0 1 m/s."""
    return _scenario(
        ((0.0, 0.0),),
        ((22.0, 0.0),),
        corridor_obstacles(seed, turning),
        r_ca=8.0,
        robot=robot,
        speeds=(1.0,),
        headings=(0.0,),
    )


def circle_scenario(n: int, radius: float, max_time: float = 150.0) -> Scenario:
    """CF3: antipodal circle swap, perfectly symmetric, v0 = 0."""
    ang = 2 * np.pi * np.arange(n) / n
    start = radius * np.stack((np.cos(ang), np.sin(ang)), -1)
    return _scenario(tuple(map(tuple, start)), tuple(map(tuple, -start)), (), r_ca=8.0, max_time=max_time)


def crossing_scenario() -> Scenario:
    """IN1: 90 degree crossing; A (0, 0) -> (12, 0), B (6, -6) -> (6, 6), both at 1 m/s."""
    return _scenario(
        ((0.0, 0.0), (6.0, -6.0)),
        ((12.0, 0.0), (6.0, 6.0)),
        (),
        r_ca=8.0,
        max_time=40.0,
        speeds=(1.0, 1.0),
        headings=(0.0, math.pi / 2),
    )


def head_on_scenario(offset: float) -> Scenario:
    """IN2: head-on swap along the x axis; B is offset laterally by ``offset`` [m]."""
    return _scenario(
        ((0.0, 0.0), (12.0, offset)),
        ((12.0, 0.0), (0.0, offset)),
        (),
        r_ca=8.0,
        max_time=40.0,
        speeds=(1.0, 1.0),
        headings=(0.0, math.pi),
    )


def onset_scenario() -> Scenario:
    """UC1: one obstacle at (10, -5) moving (0, 0.5) m/s, radius 0.3, on a collision course at
    perception (t_c about 9.5 s); r_ca 12 m; goal (20, 0)."""
    path = np.array([[10.0, -5.0 + 0.5 * DT * k] for k in range(601)])
    return _scenario(((0.0, 0.0),), ((20.0, 0.0),), [_sampled(path, 0.3)], r_ca=12.0, speeds=(1.0,), headings=(0.0,))


def phantom_scenario() -> Scenario:
    """UC2: a pedestrian from (10, -6) at (0, 0.6) m/s stops at t = 7.5 s, 1.5 m short of the
    path; goal (20, 0)."""
    path = np.array([[10.0, -6.0 + 0.6 * DT * min(k, 75)] for k in range(601)])
    return _scenario(((0.0, 0.0),), ((20.0, 0.0),), [_sampled(path, 0.3)], r_ca=12.0, speeds=(1.0,), headings=(0.0,))


def big_obstacle_scenario() -> Scenario:
    """FS2: static obstacle of radius 1.5 m at (6, 0), goal (14, 0), weak dynamics, r_ca 8 m."""
    return _scenario(
        ((0.0, 0.0),),
        ((14.0, 0.0),),
        [_sampled(np.array([[6.0, 0.0]]), 1.5)],
        r_ca=8.0,
        robot=WEAK,
        speeds=(1.0,),
        headings=(0.0,),
    )


@dataclass
class Run:
    """What one episode shows (robot-wise arrays have shape (n,))."""

    collided: bool
    arrived: np.ndarray  # (n,) bool
    time: np.ndarray  # (n,) arrival time [s] (nan if not arrived)
    path: np.ndarray  # (n,) path length [m]
    min_sep: float  # smallest swept gap to anything [m]
    fallbacks: int  # periods with no admissible candidate (all robots)
    pos: np.ndarray  # (T+1, n, 2) [m]
    heading_change: np.ndarray  # (n,) total |dtheta| [rad]
    heading_flips: np.ndarray  # (n,) sign changes of the heading command
    onset_step: np.ndarray  # (n,) first period whose command differs from the one-step goal point
    onset_tc: np.ndarray  # (n,) current-course time to collision with any obstacle at onset [s]
    window_ok: bool = True  # FS3: p* inside W_k* and k* >= 2 whenever there is a threat
    extra: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return bool(self.arrived.all() and not self.collided)


def run(scenario: Scenario, planner: VCSPlanner | None = None, check_window: bool = False, seed: int = 0) -> Run:
    """Drive every robot of ``scenario`` with ``planner`` (default VCS) and record a :class:`Run`.
    The layouts are fixed; ``seed`` only changes the planner's symmetry-breaking noise."""
    planner = planner if planner is not None else VCSPlanner()
    eng = NavEngine(scenario)
    eng.reset([seed])
    w = eng.world
    n = w.n_robots
    pos = [w.pos[0].copy()]
    arrived_at = np.full(n, np.nan)
    collided, min_sep, fallbacks = False, math.inf, 0
    heading_change = np.zeros(n)
    flips = np.zeros(n, dtype=int)
    last_sign = np.zeros(n)
    onset = np.full(n, -1)
    onset_tc = np.full(n, math.nan)
    window_ok = True
    while w.active.any() and w.steps[0] < eng.max_steps:
        act = planner.act(w)
        info = planner.last
        fallbacks += int(info["fallback"][0][w.active[0]].sum())
        # Avoidance onset: the command differs from the one-step-clipped goal point.
        period = planning_period(w)[0]  # (n,) [s]: goal_step is clipped to one period's window
        dv1 = w.a_max[0] * period
        dth1 = w.omega_max[0] * period
        cmd = np.stack((np.clip(info["target"][0, :, 0], -dv1, dv1), np.clip(info["target"][0, :, 1], -dth1, dth1)), -1)
        differs = (np.abs(cmd[:, 0] - info["goal_step"][0, :, 0]) > 1e-6) | (
            np.abs(cmd[:, 1] - info["goal_step"][0, :, 1]) > 1e-3
        )
        new = differs & (onset < 0) & w.active[0]
        if new.any():
            tc = _current_course_tc(w)
            onset[new] = w.steps[0]
            onset_tc[new] = tc[new]
        sign = np.sign(np.where(np.abs(cmd[:, 1]) > 1e-3, cmd[:, 1], 0.0))
        flips += ((sign != 0) & (last_sign != 0) & (sign != last_sign) & w.active[0]).astype(int)
        last_sign = np.where(sign != 0, sign, last_sign)
        if check_window:
            window_ok &= _window_consistent(w, info)
        heading_before = w.heading[0].copy()
        res = eng.step(act)
        heading_change += np.abs(np.angle(np.exp(1j * (w.heading[0] - heading_before))))
        collided |= bool(res.events.collided.any())
        min_sep = min(min_sep, float(res.events.min_separation.min()))
        arrived_at = np.where(res.events.reached[0], w.time[0], arrived_at)
        pos.append(w.pos[0].copy())
    pos = np.array(pos)
    path = np.linalg.norm(np.diff(pos, axis=0), axis=-1).sum(axis=0)
    return Run(
        collided=collided,
        arrived=~np.isnan(arrived_at),
        time=arrived_at,
        path=path,
        min_sep=min_sep,
        fallbacks=fallbacks,
        pos=pos,
        heading_change=heading_change,
        heading_flips=flips,
        onset_step=onset,
        onset_tc=onset_tc,
        window_ok=window_ok,
    )


def _current_course_tc(w) -> np.ndarray:
    """Each robot's current-course time to collision with any obstacle (physical radii) ``(n,)``."""
    from vcs_env.geometry import time_to_collision

    p = w.obs_pos[0][None] - w.pos[0][:, None]
    v = w.vel[0][:, None] - w.obs_vel[0][None]
    r = w.radius[0][:, None] + w.obs_radius[0][None]
    tc = time_to_collision(p, v, r)
    return tc.min(axis=1) if tc.shape[1] else np.full(w.n_robots, math.inf)


def _window_consistent(w, info) -> bool:
    """FS3: the target lies in W_k* and k* >= 2 whenever a threat is present."""
    k = info["k"][0]
    tgt = info["target"][0]
    act = w.active[0]
    period = planning_period(w)[0]  # (n,) [s]: k counts periods
    dv1 = w.a_max[0] * period
    dth1 = w.omega_max[0] * period
    lo = np.maximum(-w.speed[0], -k * dv1) - 1e-9
    hi = np.minimum(w.v_max[0] - w.speed[0], k * dv1) + 1e-9
    half = np.minimum(np.pi, k * dth1) + 1e-9
    threat_ok = (info["threats"][0] == 0) | (k >= 2)
    inside = (tgt[:, 0] >= lo) & (tgt[:, 0] <= hi) & (np.abs(tgt[:, 1]) <= half)
    return bool(np.all((threat_ok & inside) | ~act))
