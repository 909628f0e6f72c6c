"""Navigation metrics of recorded episodes (:class:`~vcs_env.rollout.Episode`).

Episode outcomes (exactly one is true): ``success`` (every robot arrived, nothing touched),
``collision`` (some robot touched a robot or obstacle while it drove: a robot that arrived or crashed is parked,
and a body passing through it later is no contact of its), ``deadlock`` (time out with some unfinished robot stuck:
its path over the last ``DEADLOCK_WINDOW`` seconds, the fewest whole steps that cover them, is shorter than
``DEADLOCK_DISTANCE``; an episode shorter than that window is never a deadlock), ``timeout`` (any other time out:
a robot that circles without progress is one). Collisions split into
``at_fault_collision`` (some contact was a robot's fault) and ``not_at_fault_collision`` (none
was); ``parked_collision``: some robot touched a parked one (:mod:`vcs_env.contacts`).

Per-robot quantities are averaged over the robots of the episode: arrival time, extra time
over the straight-line time at ``v_max``, path length and its ratio to the straight line,
total heading change, speed-change reversals and mean absolute jerk. Time and path metrics
are NaN for robots that did not arrive. Social metrics (:mod:`vcs_env.social_metrics`,
``docs/social-metrics.md``): intrusions into intimate and personal space, the smallest gap to a
person (an obstacle) and time to collision with one, path irregularity and SPL.

Each metric is one :class:`Metric` in :data:`METRICS`: its name, label, how it is computed from
an episode and how the evaluation harness, its report and plots treat it (rate or mean,
solved-only, table column, bar chart). ``docs/extending.md`` shows how to add one.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .contacts import contact_events
from .rollout import Episode
from .social_metrics import (
    INTIMATE_ZONE,
    PERSONAL_ZONE,
    TTC_CAP,
    intrusion_share,
    min_human_gap,
    min_time_to_collision,
    path_irregularity,
    spl,
)

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
    k = max(1, math.ceil(DEADLOCK_WINDOW / ep.dt - 1e-9))  # whole steps covering the window: never a shorter one
    if not unfinished.any() or len(ep.pos) < k + 1:  # shorter than the window: a plain time out
        return False
    window = ep.pos[-(k + 1) :]
    moved = np.linalg.norm(np.diff(window, axis=0), axis=-1).sum(axis=0)
    return bool(np.any(moved[unfinished] < DEADLOCK_DISTANCE))


def robots_succeeded(arrived: np.ndarray, touched: np.ndarray) -> np.ndarray:
    """``(..., n)`` bool: the robot arrived and touched nothing on the way. The one definition of
    success: an episode succeeds when every robot does (the ``success`` metric); the training
    VecEnv reports it per robot."""
    return arrived & ~touched


def _min(x) -> float:
    """Minimum over the finite entries; NaN if there is none."""
    x = np.asarray(x, dtype=np.float64)
    return float(np.min(x[np.isfinite(x)])) if np.isfinite(x).any() else math.nan


def _mean(x) -> float:
    """Mean over the finite entries; NaN if there is none."""
    x = np.asarray(x, dtype=np.float64)
    return float(np.nanmean(x)) if np.isfinite(x).any() else math.nan


class EpisodeFacts:
    """Per-robot quantities of one :class:`~vcs_env.rollout.Episode` that several metrics share,
    each computed once, on first use."""

    def __init__(self, ep: Episode):
        ep.check()
        self.ep = ep

    @functools.cached_property
    def arrived(self) -> np.ndarray:
        """``(n,)`` bool: the robot reached its goal."""
        return self.ep.reached_step >= 0

    @functools.cached_property
    def robot_hit(self) -> np.ndarray:
        """``(n,)`` bool: the robot touched another robot."""
        return self.ep.robot_contact.any(axis=0)

    @functools.cached_property
    def obstacle_hit(self) -> np.ndarray:
        """``(n,)`` bool: the robot touched an obstacle or a wall."""
        return self.ep.obstacle_contact.any(axis=0)

    @functools.cached_property
    def collided(self) -> bool:
        """Some robot touched something."""
        return bool(self.robot_hit.any() or self.obstacle_hit.any())

    @functools.cached_property
    def contacts(self) -> list | None:
        """Every contact explained (:func:`~vcs_env.contacts.contact_events`); None when the
        episode was recorded without the hit matrices."""
        if self.ep.robot_hits is None or self.ep.obstacle_hits is None:
            return None
        return contact_events(self.ep)

    def contact_rate(self, pick: Callable) -> float:
        """1 if some contact satisfies ``pick``, else 0; NaN without the record."""
        return math.nan if self.contacts is None else float(any(pick(c) for c in self.contacts))

    @functools.cached_property
    def robot_success(self) -> np.ndarray:
        """``(n,)`` bool: the robot arrived and touched nothing (:func:`robots_succeeded`)."""
        return robots_succeeded(self.arrived, self.robot_hit | self.obstacle_hit)

    @functools.cached_property
    def success(self) -> bool:
        return bool(self.robot_success.all())

    @functools.cached_property
    def deadlock(self) -> bool:
        unfinished = ~self.arrived & ~(self.robot_hit | self.obstacle_hit)
        return (not self.success) and (not self.collided) and _stuck(self.ep, unfinished)

    @functools.cached_property
    def arrival_time(self) -> np.ndarray:
        """``(n,)`` [s], NaN for robots that did not arrive."""
        return np.where(self.arrived, self.ep.reached_step * self.ep.dt, np.nan)

    @functools.cached_property
    def paths(self) -> np.ndarray:
        """``(n,)`` distance driven [m]."""
        return path_lengths(self.ep)

    @functools.cached_property
    def path_ratio(self) -> np.ndarray:
        """``(n,)`` path length over the straight start-goal distance, NaN if not arrived. A robot parks where it
        enters its goal disc (radius ``r_goal``), so a straight run reads ``(d - r_goal) / d``, just under 1."""
        straight = np.linalg.norm(self.ep.goal - self.ep.pos[0], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.arrived & (straight > 0), self.paths / straight, np.nan)


@dataclass(frozen=True)
class Metric:
    """One metric of an episode: how it is computed and how the harness, the report and the
    plots treat it. Adding a metric is one :class:`Metric` in :data:`METRICS` (plus its test)."""

    name: str
    """Key in the metric rows, the summaries and the JSON."""
    label: str
    """Column header and axis label, with the unit."""
    compute: Callable[[EpisodeFacts], float]
    """The value of one episode, from its :class:`EpisodeFacts` (``facts.ep`` is the episode)."""
    rate: bool = False
    """0 or 1 per episode: aggregated as a rate with a Wilson interval."""
    solved_only: bool = False
    """Compared only over the episodes every policy solved (``aggregate``'s ``solved_mask``)."""
    table: bool = True
    """A column of the comparison table and a line of the ``evaluate`` summary."""
    plot: bool = True
    """A bar chart in the comparison report."""
    bounds: tuple[float, float] = (-math.inf, math.inf)
    """The range of an episode's value: the interval of the mean is kept within it (with few episodes it could
    leave it, e.g. a negative share)."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.name):
            raise ValueError(
                f"metric name {self.name!r} must be an identifier (letters, digits, _): it is a key of the rows and "
                "the JSON, and a plot's file name"
            )
        if self.name in RESERVED:
            raise ValueError(f"metric name {self.name!r} is a key the harness writes beside the metrics: pick another")


RESERVED = frozenset({"seed", "ms_per_decision"})
"""Keys the evaluation harness writes beside the metrics (an episode's seed; the report's time per decision)."""


UNIT, PLUS = (0.0, 1.0), (0.0, math.inf)
"""The ranges of shares and of non-negative quantities (:attr:`Metric.bounds`)."""

METRICS: tuple[Metric, ...] = (
    Metric("success", "success", lambda f: float(f.success), rate=True),
    Metric("collision", "collision", lambda f: float(f.collided), rate=True),
    Metric("robot_collision", "robot-robot", lambda f: float(f.robot_hit.any()), rate=True, plot=False),
    Metric("obstacle_collision", "robot-obstacle", lambda f: float(f.obstacle_hit.any()), rate=True, plot=False),
    Metric("at_fault_collision", "at fault", lambda f: f.contact_rate(lambda c: c.at_fault), rate=True, plot=False),
    Metric(
        "not_at_fault_collision",
        "not at fault",
        lambda f: math.nan if f.contacts is None else float(f.collided and not any(c.at_fault for c in f.contacts)),
        rate=True,
        plot=False,
    ),
    Metric(
        "parked_collision",
        "hit parked",
        lambda f: f.contact_rate(lambda c: c.kind == "parked"),
        rate=True,
        table=False,
        plot=False,
    ),
    Metric("timeout", "timeout", lambda f: float(not f.success and not f.collided and not f.deadlock), rate=True),
    Metric("deadlock", "deadlock", lambda f: float(f.deadlock), rate=True),
    Metric(
        "arrived_fraction", "arrived fraction", lambda f: float(f.arrived.mean()), table=False, plot=False, bounds=UNIT
    ),
    Metric("time_to_goal", "time to goal [s]", lambda f: _mean(f.arrival_time), solved_only=True, bounds=PLUS),
    Metric(
        "makespan",
        "makespan [s]",
        lambda f: float(np.max(f.arrival_time)) if f.arrived.all() else math.nan,
        solved_only=True,
        table=False,
        plot=False,
        bounds=PLUS,
    ),
    Metric("extra_time", "extra time [s]", lambda f: _mean(f.arrival_time - f.ep.straight_time), solved_only=True),
    Metric(
        "path_length",
        "path length [m]",
        lambda f: _mean(np.where(f.arrived, f.paths, np.nan)),
        solved_only=True,
        table=False,
        plot=False,
        bounds=PLUS,
    ),
    Metric("path_ratio", "path ratio", lambda f: _mean(f.path_ratio), solved_only=True, bounds=PLUS),
    Metric("min_separation", "min separation [m]", lambda f: _min_separation(f.ep)),
    Metric("heading_change", "heading change [rad]", lambda f: float(heading_change(f.ep).mean()), bounds=PLUS),
    Metric("speed_reversals", "speed reversals", lambda f: float(speed_reversals(f.ep).mean()), bounds=PLUS),
    Metric("jerk", "jerk [m/s^3]", lambda f: float(mean_jerk(f.ep).mean()), bounds=PLUS),
    Metric(
        "intimate_intrusion",
        "intimate intrusion",
        lambda f: _mean(intrusion_share(f.ep, INTIMATE_ZONE)),
        plot=False,
        bounds=UNIT,
    ),
    Metric(
        "personal_intrusion", "personal intrusion", lambda f: _mean(intrusion_share(f.ep, PERSONAL_ZONE)), bounds=UNIT
    ),
    Metric("min_human_distance", "min person gap [m]", lambda f: _min(min_human_gap(f.ep)), plot=False),
    Metric("min_ttc", "min TTC [s]", lambda f: _min(min_time_to_collision(f.ep)), bounds=(0.0, TTC_CAP)),
    Metric(
        "path_irregularity",
        "path irregularity [rad/m]",
        lambda f: _mean(path_irregularity(f.ep, f.paths)),
        plot=False,
        bounds=PLUS,
    ),
    Metric("spl", "SPL", lambda f: _mean(spl(f.ep, f.robot_success, f.paths)), bounds=UNIT),
    Metric(
        "compute_per_decision",
        "compute per decision [s]",
        lambda f: f.ep.compute_time / max(f.ep.decisions, 1),
        table=False,
        plot=False,
        bounds=PLUS,
    ),
    Metric("steps", "steps", lambda f: float(f.ep.steps), table=False, plot=False, bounds=PLUS),
)
"""Every metric of an episode, in the order of the rows, the table and the plots."""

OUTCOMES = ("success", "collision", "deadlock", "timeout")
"""The outcome metrics: exactly one of them is 1 in every episode (module docstring)."""


def _min_separation(ep: Episode) -> float:
    finite = ep.min_separation[np.isfinite(ep.min_separation)]
    return float(finite.min()) if finite.size else math.nan


def episode_metrics(ep: Episode) -> dict[str, float]:
    """All metrics of one episode (:data:`METRICS`, see the module docstring); a metric that gives other than one
    number, or a name given twice, is a ``ValueError`` naming it."""
    facts = EpisodeFacts(ep)
    out: dict[str, float] = {}
    for m in METRICS:
        if m.name in out:
            raise ValueError(f"two metrics in METRICS are named {m.name!r}: a name is the key of a row's value")
        value = m.compute(facts)
        try:
            if np.ndim(value) != 0 or value is None or isinstance(value, (str, bytes, np.str_, np.bytes_)):
                raise TypeError
            out[m.name] = float(value)
        except (TypeError, ValueError):
            raise ValueError(
                f"metric {m.name!r} gave {value!r}: a metric gives one number per episode (average per-robot values)"
            ) from None
        if m.rate and not (0.0 <= out[m.name] <= 1.0 or math.isnan(out[m.name])):
            raise ValueError(f"metric {m.name!r} is a rate (rate=True) and gave {value!r}: a rate's value is in [0, 1]")
    return out


def wilson_interval(successes: float, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a rate: ``successes`` in ``[0, n]`` (a count, or a sum of per-episode rates) of
    ``n >= 0`` episodes (``n = 0``: NaN bounds); ``z`` the normal quantile (1.96 for 95 %)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"n must be a count of episodes (an integer >= 0), got {n!r}")
    if not 0.0 <= successes <= n:
        raise ValueError(f"successes must lie in [0, n] = [0, {n}], got {successes!r}")
    if n == 0:
        return (math.nan, math.nan)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (max(0.0, centre - half), min(1.0, centre + half))


T95 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
       2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045,
       2.042)  # fmt: skip
"""Student's t at 0.975 for 1 to 30 degrees of freedom (the half-width of a 95 % interval of a mean, in standard
errors)."""


def t95(df: int) -> float:
    """Student's t quantile 0.975 for ``df`` >= 1 degrees of freedom: :data:`T95`, then ``1.96 + 2.37 / df`` (within
    0.004 of the exact value beyond 30; 1.96 in the limit)."""
    if isinstance(df, bool) or not isinstance(df, (int, np.integer)) or df < 1:
        raise ValueError(f"df must be an integer >= 1 (degrees of freedom), got {df!r}")
    return T95[df - 1] if df <= len(T95) else 1.959964 + 2.37 / df


def aggregate(
    rows: Sequence[Mapping[str, float]], solved_mask: Sequence[bool] | None = None
) -> dict[str, dict[str, float]]:
    """Mean and 95 % interval of every metric over episodes.

    Rates use the Wilson interval; other metrics the Student's t interval of the mean over the
    episodes where they are defined (:attr:`Metric.rate`; none from a single episode: NaN bounds), kept within the
    metric's range (:attr:`Metric.bounds`). With ``solved_mask``, the :attr:`Metric.solved_only` metrics (time and
    path) are taken over the masked episodes only (e.g. those every compared policy solved).

    Returns:
        ``{metric: {"mean", "low", "high", "n"}}``.
    """
    out: dict[str, dict[str, float]] = {}
    if not rows:
        return out
    keys = list(rows[0])
    for i, r in enumerate(rows):
        if set(r) != set(keys):
            raise ValueError(
                f"every row must have the same metrics: row {i} has {sorted(set(r) ^ set(keys))} where row 0 "
                "differs (rows of episode_metrics with other metric sets, or of other planners' extra metrics)"
            )
    mask = np.ones(len(rows), dtype=bool) if solved_mask is None else np.asarray(solved_mask, dtype=bool)
    if mask.shape != (len(rows),):
        raise ValueError(f"solved_mask must have one entry per row ({len(rows)}), got shape {mask.shape}")
    by_name = {m.name: m for m in METRICS}
    for k in keys:
        vals = np.array([r[k] for r in rows], dtype=np.float64)
        metric = by_name.get(k)
        if metric is not None and metric.rate:
            vals = vals[~np.isnan(vals)]  # undefined in an episode (e.g. fault without the hit matrices)
            n = len(vals)
            if n == 0:
                out[k] = {"mean": math.nan, "low": math.nan, "high": math.nan, "n": 0}
                continue
            lo, hi = wilson_interval(float(vals.sum()), n)
            out[k] = {"mean": float(vals.mean()), "low": lo, "high": hi, "n": n}
            continue
        if metric is not None and metric.solved_only:
            vals = vals[mask]
        vals = vals[np.isfinite(vals)]
        n = len(vals)
        if n == 0:
            out[k] = {"mean": math.nan, "low": math.nan, "high": math.nan, "n": 0}
            continue
        m = float(vals.mean())
        lo, hi = metric.bounds if metric is not None else (-math.inf, math.inf)
        if n > 1:
            half = t95(n - 1) * float(vals.std(ddof=1)) / math.sqrt(n)
            lo, hi = max(lo, m - half), min(hi, m + half)
        else:  # no interval from one value
            lo = hi = math.nan
        out[k] = {"mean": m, "low": lo, "high": hi, "n": n}
    return out
