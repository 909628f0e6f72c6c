"""Navigation metrics of recorded episodes (:class:`~vcs_env.rollout.Episode`).

Episode outcomes (exactly one is true): ``success`` (every robot arrived, nothing touched),
``collision`` (some robot touched a robot or obstacle), ``deadlock`` (time out with some
unfinished robot stuck: it moved less than ``DEADLOCK_DISTANCE`` over the last
``DEADLOCK_WINDOW`` seconds), ``timeout`` (any other time out).

Per-robot quantities are averaged over the robots of the episode: arrival time, extra time
over the straight-line time at ``v_max``, path length and its ratio to the straight line,
total heading change, speed-change reversals and mean absolute jerk. Time and path metrics
are NaN for robots that did not arrive.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from .rollout import Episode

DEADLOCK_WINDOW = 10.0
"""[s] see module docstring."""
DEADLOCK_DISTANCE = 0.5
"""[m] see module docstring."""
REVERSAL_EPS = 1e-6
"""Speed changes smaller than this [m/s] do not count as a direction of change."""


def path_lengths(ep: Episode) -> np.ndarray:
    """Distance each robot drove ``(n,)`` [m]."""
    return np.linalg.norm(np.diff(ep.pos, axis=0), axis=-1).sum(axis=0)


def heading_change(ep: Episode) -> np.ndarray:
    """Total absolute heading change per robot ``(n,)`` [rad]."""
    d = np.diff(np.unwrap(ep.heading, axis=0), axis=0)
    return np.abs(d).sum(axis=0)


def driving_steps(ep: Episode) -> np.ndarray:
    """Steps a robot drove through ``(T, n)`` bool: active at the start and still active after.

    The step on which a robot stops (arrives, or crashes under ``on_collision="terminate"``)
    is left out: the simulator sets the speed of a stopped robot to 0 at once, a parking
    jump (e.g. 0.5 m/s in one 0.1 s step) that no controller commanded and that would
    otherwise dominate jerk and count as a speed reversal.
    """
    after = np.zeros_like(ep.acted)
    after[:-1] = ep.acted[1:]
    if ep.steps:
        # Last step: still active unless it arrived or touched something then (a contact in
        # the last step of a "continue" episode drops one sample; harmless).
        after[-1] = ep.acted[-1] & (ep.reached_step != ep.steps) & ~ep.collided[-1]
    return ep.acted & after


def speed_reversals(ep: Episode) -> np.ndarray:
    """How often each robot switched between speeding up and slowing down ``(n,)``, over the
    steps it drove (:func:`driving_steps`)."""
    dv = np.where(driving_steps(ep), np.diff(ep.speed, axis=0), 0.0)
    sign = np.where(np.abs(dv) > REVERSAL_EPS, np.sign(dv), 0.0)
    out = np.zeros(ep.n_robots, dtype=np.int64)
    for i in range(ep.n_robots):
        s = sign[:, i][sign[:, i] != 0]
        out[i] = int(np.count_nonzero(s[1:] != s[:-1]))
    return out


def mean_jerk(ep: Episode) -> np.ndarray:
    """Mean absolute jerk of the speed profile while driving, per robot ``(n,)`` [m/s^3].

    Jerk of step pair (t, t+1) is ``|dv[t+1] - dv[t]| / dt^2``; it counts when the robot drove
    through both steps (:func:`driving_steps`). 0 for a robot without such a pair.
    """
    if ep.steps < 2:
        return np.zeros(ep.n_robots)
    acc = np.diff(ep.speed, axis=0) / ep.dt
    jerk = np.abs(np.diff(acc, axis=0)) / ep.dt
    driving = driving_steps(ep)
    mask = driving[:-1] & driving[1:]
    return np.where(mask.any(axis=0), (jerk * mask).sum(axis=0) / np.maximum(mask.sum(axis=0), 1), 0.0)


def _stuck(ep: Episode, unfinished: np.ndarray) -> bool:
    k = max(1, int(round(DEADLOCK_WINDOW / ep.dt)))
    if not unfinished.any():
        return False
    window = ep.pos[-min(k + 1, len(ep.pos)) :]
    moved = np.linalg.norm(np.diff(window, axis=0), axis=-1).sum(axis=0)
    return bool(np.any(moved[unfinished] < DEADLOCK_DISTANCE))


def episode_metrics(ep: Episode) -> dict[str, float]:
    """All metrics of one episode (see the module docstring)."""
    arrived = ep.reached_step >= 0
    robot_hit = ep.robot_contact.any(axis=0)
    obstacle_hit = ep.obstacle_contact.any(axis=0)
    collided = bool(robot_hit.any() or obstacle_hit.any())
    success = bool(arrived.all() and not collided)
    unfinished = ~arrived & ~(robot_hit | obstacle_hit)
    deadlock = (not success) and (not collided) and _stuck(ep, unfinished)
    arrival_time = np.where(arrived, ep.reached_step * ep.dt, np.nan)
    straight = np.linalg.norm(ep.goal - ep.pos[0], axis=-1)
    paths = path_lengths(ep)
    with np.errstate(invalid="ignore", divide="ignore"):
        path_ratio = np.where(arrived & (straight > 0), paths / straight, np.nan)
    finite_sep = ep.min_separation[np.isfinite(ep.min_separation)]

    def mean(x):
        x = np.asarray(x, dtype=np.float64)
        return float(np.nanmean(x)) if np.isfinite(x).any() else math.nan

    return {
        "success": float(success),
        "collision": float(collided),
        "robot_collision": float(robot_hit.any()),
        "obstacle_collision": float(obstacle_hit.any()),
        "deadlock": float(deadlock),
        "timeout": float(not success and not collided and not deadlock),
        "arrived_fraction": float(arrived.mean()),
        "time_to_goal": mean(arrival_time),
        "makespan": float(np.max(arrival_time)) if arrived.all() else math.nan,
        "extra_time": mean(arrival_time - ep.straight_time),
        "path_length": mean(np.where(arrived, paths, np.nan)),
        "path_ratio": mean(path_ratio),
        "min_separation": float(finite_sep.min()) if finite_sep.size else math.nan,
        "heading_change": float(heading_change(ep).mean()),
        "speed_reversals": float(speed_reversals(ep).mean()),
        "jerk": float(mean_jerk(ep).mean()),
        "compute_per_decision": ep.compute_time / max(ep.decisions, 1),
        "steps": float(ep.steps),
    }


RATE_METRICS = ("success", "collision", "robot_collision", "obstacle_collision", "deadlock", "timeout")
"""Metrics that are 0/1 per episode; aggregated as rates with Wilson intervals."""


def wilson_interval(successes: float, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a rate."""
    if n == 0:
        return (math.nan, math.nan)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


def aggregate(
    rows: Sequence[Mapping[str, float]], solved_mask: Sequence[bool] | None = None
) -> dict[str, dict[str, float]]:
    """Mean and 95 % interval of every metric over episodes.

    Rates use the Wilson interval; other metrics the normal interval of the mean over the
    episodes where they are defined. With ``solved_mask``, time and path metrics are taken
    over the masked episodes only (e.g. those every compared policy solved).

    Returns:
        ``{metric: {"mean", "low", "high", "n"}}``.
    """
    out: dict[str, dict[str, float]] = {}
    if not rows:
        return out
    keys = list(rows[0])
    mask = np.ones(len(rows), dtype=bool) if solved_mask is None else np.asarray(solved_mask, dtype=bool)
    for k in keys:
        vals = np.array([r[k] for r in rows], dtype=np.float64)
        if k in RATE_METRICS:
            n = len(vals)
            lo, hi = wilson_interval(float(vals.sum()), n)
            out[k] = {"mean": float(vals.mean()), "low": lo, "high": hi, "n": n}
            continue
        if k in ("time_to_goal", "makespan", "extra_time", "path_length", "path_ratio"):
            vals = vals[mask]
        vals = vals[np.isfinite(vals)]
        n = len(vals)
        if n == 0:
            out[k] = {"mean": math.nan, "low": math.nan, "high": math.nan, "n": 0}
            continue
        m = float(vals.mean())
        half = 1.96 * float(vals.std(ddof=1)) / math.sqrt(n) if n > 1 else 0.0
        out[k] = {"mean": m, "low": m - half, "high": m + half, "n": n}
    return out


def summarize(episodes: Iterable[Episode]) -> dict[str, dict[str, float]]:
    """``aggregate`` of ``episode_metrics`` over episodes."""
    return aggregate([episode_metrics(e) for e in episodes])
