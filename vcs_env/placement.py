"""Building blocks of the scenario kinds (:mod:`vcs_env.layouts`, :mod:`vcs_env.map_kinds`):
the :class:`Layout` record, placement on rings, lanes and arenas with jitter, obstacle
placement clear of starts, goals and walls, the layout checks, and the rejection sampler of discs
(:func:`place_discs`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from .routes import _clearance
from .walls import clearance

if TYPE_CHECKING:
    from .scenario import Scenario

MIN_GOAL_DISTANCE = 1.0
"""Random layouts put every goal at least this far from its start [m]."""
MAX_TRIES = 2000
"""Rejection-sampling attempts per body before a random layout is declared impossible."""
OBSTACLE_ROUNDS = 20
"""Times :func:`place_obstacles` starts its obstacles over when one finds no place (sequential placement
can wedge itself in a dense arena where a fresh draw fits); the first round is the layout of every seed
whose first draw fits."""


@dataclass
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
    segments: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))  # (s, 2, 2) walls [m]


def _view(s: Scenario, half: float) -> float:
    """Drawn half size [m] around robots reaching ``half`` [m], widened to the arena if it holds obstacles."""
    if s.n_obstacles:
        half = max(half, s.arena_half_size)
    return half + s.robot.radius + 0.5


RING_NOISE = 0.5
"""[m] Crowd obstacles start on the ring with up to this much uniform noise per axis (CrowdNav's circle crossing)."""
CROWD_REDRAWS = 20
"""Times a crowd layout places all its obstacles afresh (same generator) when the ones placed first
left no room on the ring for the next, before reset gives up with ``ValueError``."""


def pedestrian_goals(s: Scenario) -> str | None:
    """The goal policy of the obstacles if they walk as pedestrians (``PedestrianSpec.goal_policy``; no spec is
    ``PedestrianSpec()``'s ``"circle"``), else None."""
    if s.obstacle_motion != "pedestrians":
        return None
    return "circle" if s.pedestrians is None else s.pedestrians.goal_policy


def walks_square(s: Scenario) -> bool:
    """Whether the obstacles are pedestrians crossing the square (CrowdNav's square crossing): they are placed in
    the square (:meth:`vcs_env.obstacles.Pedestrians.place`), whatever places their layout kind gave them."""
    return pedestrian_goals(s) == "square"


def crowd_ring(s: Scenario, m: int) -> tuple[float, float]:
    """The length [m] of a crowd's ring that its robots and ``m`` obstacles take, starts and antipodal goals (with
    an even robot count the robots' goals are each other's starts), and the ring's length [m]."""
    robot_places = s.n_robots if s.n_robots % 2 == 0 else 2 * s.n_robots
    sep = s.min_separation
    used = robot_places * (2 * s.robot.radius + sep) + 2 * m * (2 * s.obstacle_radius[1] + sep)
    return used, 2.0 * math.pi * s.circle_radius


def on_ring(s: Scenario) -> bool:
    """Whether a crowd's kind places its obstacles on its ring: always, but for pedestrians crossing the square for
    whom the ring has no room (their places there would be replaced anyway; where it has, the draws stay as they
    were)."""
    return not walks_square(s) or bool(np.less_equal(*crowd_ring(s, s.n_obstacles)))


def arena_moves(s: Scenario) -> bool:
    """Whether obstacles move in the arena, so that its size (``arena_half_size``) shapes the episodes whatever the
    layout kind: they bounce off its edges, or walk as pedestrians with goals in it (crossing the square or
    wandering; pedestrians crossing the circle never read it)."""
    return bool(s.n_obstacles) and (s.bounce or pedestrian_goals(s) in ("square", "wander"))


def crowd_view(s: Scenario) -> float:
    """Drawn half size [m] of a crowd: its ring with the obstacles' 0.5 m of start noise, and the arena where the
    obstacles move in it (:func:`arena_moves`)."""
    half = s.circle_radius + s.jitter + RING_NOISE
    if arena_moves(s):
        half = max(half, s.arena_half_size)
    return half + s.robot.radius + 0.5


def check_ring(s: Scenario) -> None:
    """Neighbours on the layout circle must not overlap."""
    need = 2.0 * s.robot.radius + s.min_separation + 2.0 * s.jitter
    if s.n_robots >= 2:
        chord = 2.0 * s.circle_radius * math.sin(math.pi / s.n_robots)
        if chord < need - 1e-9:
            raise ValueError(
                f"cannot place {s.n_robots} robots on a circle of radius {s.circle_radius:g} m without overlap: "
                f"neighbours are {chord:.3f} m apart, need {need:.3f} m (2 radius + min_separation + 2 jitter); "
                "increase layout_radius, or reduce n_robots" + (" or jitter" if s.jitter else "")
            )


def check_lanes(s: Scenario) -> float:
    """Neighbouring lanes must not overlap; returns the body spacing needed [m]."""
    r = s.robot.radius
    need = 2.0 * r + s.min_separation + 2.0 * s.jitter
    if s.lane_spacing < need - 1e-9:  # 0.5 + 0.3 + 2 * 0.2 is 1.2000000000000002: not a real overlap
        raise ValueError(
            f"lane_spacing={s.lane_spacing:g} m is too small for robots of radius {r:g} m: need >= {need:.3f} m "
            f"(2 radius + min_separation + 2 jitter, jitter={s.jitter:g} m); reduce jitter or min_separation, or "
            "increase lane_spacing"
        )
    return need


def check_arena(s: Scenario) -> None:
    """A loose packing bound: the bodies' discs (with half the separation) must fit in the arena."""
    r, r_obs = s.robot.radius, s.obstacle_radius[1]
    side = 2.0 * s.arena_half_size
    area = math.pi * (
        2 * s.n_robots * (r + s.min_separation / 2) ** 2 + s.n_obstacles * (r_obs + s.min_separation / 2) ** 2
    )
    if area > 0.5 * side * side or s.arena_half_size <= max(r, r_obs) + s.min_separation:
        raise ValueError(
            f"cannot place {s.n_robots} robots and {s.n_obstacles} obstacles in an arena of half size "
            f"{s.arena_half_size:g} m without overlap (min_separation={s.min_separation:g} m between bodies); increase "
            "arena_half_size or reduce the counts or min_separation"
        )


def check_walls(s: Scenario, lay: Layout, segments: np.ndarray | None = None, extra: float = 0.0) -> None:
    """Starts, goals and obstacles must be clear of the walls (``segments``, default
    ``lay.segments``) by ``min_separation`` (plus ``extra`` [m] for starts), and every robot must
    have a route to its goal (:mod:`vcs_env.routes`); ``ValueError`` otherwise."""
    seg = lay.segments if segments is None else segments
    if len(seg) == 0:
        return
    r = s.robot.radius
    for what, pts, rad, more in (
        ("start", lay.start, r, extra),
        ("goal", lay.goal, r, 0.0),
        ("obstacle", lay.obs_pos, lay.obs_radius, 0.0),
    ):
        gap = clearance(pts, seg) - rad
        if np.any(gap < s.min_separation + more - 1e-9):  # a gap of exactly the need passes (0.3 + 0.1 rounds up)
            i = int(np.argmin(gap))
            body = float(np.broadcast_to(rad, gap.shape)[i])
            raise ValueError(
                f"{s.kind} layout: the body at {what} {i} ({np.round(pts[i], 3).tolist()}, radius {body:g} m) "
                f"is {gap[i]:.3f} m from a wall{' (it overlaps the wall)' if gap[i] < 0 else ''}, "
                f"need >= min_separation = {s.min_separation} m" + (f" + jitter = {more} m" if more else "")
            )
    from .routes import Roadmap

    roadmap = Roadmap(seg, r)
    for i in range(s.n_robots):
        if not np.isfinite(roadmap.route_length(lay.start[i], lay.goal[i])):
            raise ValueError(
                f"{s.kind} layout: no route for robot {i} from {np.round(lay.start[i], 3).tolist()} to "
                f"{np.round(lay.goal[i], 3).tolist()} between the walls (robot radius {r} m: gaps and doors "
                f"narrower than about a robot diameter + 0.2 m = {2 * r + 0.2:.2f} m hold no route, vcs_env.routes)"
            )


def check_spacing(s: Scenario, start: np.ndarray, goal: np.ndarray, hint: str) -> None:
    """Starts ``(n, 2)`` [m] (before their ``jitter``) at least 2 radius + ``min_separation`` + 2 jitter apart, goals
    2 radius + ``min_separation``; a ``ValueError`` naming the closest pair and ``hint`` (the fields to change, and
    ``jitter`` where it counts) otherwise: robots would start in contact, or park on one another."""
    base = 2.0 * s.robot.radius + s.min_separation
    for what, pts, need in (("start", start, base + 2.0 * s.jitter), ("goal", goal, base)):
        if len(pts) < 2:
            continue
        d = np.linalg.norm(pts[:, None] - pts[None], axis=-1) + np.diag(np.full(len(pts), np.inf))
        if d.min() < need - 1e-9:  # a spacing of exactly the need passes, as check_lanes
            i, j = sorted(np.unravel_index(np.argmin(d), d.shape))
            jitter = what == "start" and s.jitter > 0.0  # a jitter of 0, or the goals' spacing, has no jitter to reduce
            raise ValueError(
                f"{s.kind}: the {what}s of robots {i} and {j} are {d[i, j]:.3f} m apart, need >= {need:.3f} m "
                f"(2 radius + min_separation{' + 2 jitter' if jitter else ''}); {hint}"
                + (", or reduce jitter" if jitter else "")
            )


def circle_points(n: int, radius: float, phase: float) -> np.ndarray:
    """``(n, 2)`` points evenly spaced on a circle [m], the first at angle ``phase`` [rad]."""
    ang = phase + 2.0 * np.pi * np.arange(n) / n
    return radius * np.stack((np.cos(ang), np.sin(ang)), axis=-1)


def jittered(rng: np.random.Generator, pts: np.ndarray, jitter: float) -> np.ndarray:
    """``pts (n, 2)`` moved uniformly within discs of radius ``jitter`` [m] (unchanged, no draw, at 0)."""
    if jitter <= 0.0:
        return pts
    ang = rng.uniform(0.0, 2.0 * np.pi, size=len(pts))
    rad = jitter * np.sqrt(rng.uniform(0.0, 1.0, size=len(pts)))
    return pts + rad[:, None] * np.stack((np.cos(ang), np.sin(ang)), -1)


def obstacle_radii(s: Scenario, rng: np.random.Generator) -> np.ndarray:
    """Obstacle radii ``(m,)`` [m] drawn from ``obstacle_radius`` (the first draw of a layout)."""
    lo, hi = s.obstacle_radius
    return rng.uniform(lo, hi, size=s.n_obstacles)


def place_obstacles(
    s: Scenario,
    rng: np.random.Generator,
    start: np.ndarray,
    goal: np.ndarray,
    radius: np.ndarray,
    segments: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Obstacles at random in the arena, clear of every start and goal (and of the wall
    ``segments`` ``(s, 2, 2)``, if given, by ``min_separation``), each with a random second point
    for the motion model: ``(obs_pos (m, 2), obs_target (m, 2), radius (m,))``."""
    m = s.n_obstacles
    obs_pos, obs_target = np.zeros((m, 2)), np.zeros((m, 2))
    if m:
        bodies = np.concatenate((start, goal))
        for rounds in range(1, OBSTACLE_ROUNDS + 1):
            try:
                obs_pos = place_discs(
                    rng, s.arena_half_size, radius, s.min_separation, "obstacle {}", bodies, s.robot.radius, segments
                )
                break
            except ValueError as e:
                if rounds == OBSTACLE_ROUNDS:
                    raise ValueError(f"{e} (the obstacles started over {OBSTACLE_ROUNDS} times)") from None
        lim = s.arena_half_size - radius[:, None]
        obs_target = rng.uniform(-lim, lim, size=(m, 2))
    return obs_pos, obs_target, radius


def _points(x) -> np.ndarray:
    """Points ``(k, 2)`` [m] as float64; an empty list is ``(0, 2)``."""
    x = np.asarray(x, dtype=np.float64)
    return x.reshape(0, 2) if x.size == 0 else x


def finish(
    s: Scenario,
    start: np.ndarray,
    goal: np.ndarray,
    obs_pos: np.ndarray,
    obs_target: np.ndarray,
    obs_radius: np.ndarray,
    heading=None,
    speed=None,
) -> Layout:
    """The :class:`Layout`; robots face their goal at ``initial_speed`` unless given. Arrays or nested lists of
    numbers (a kind of one's own is held to its sizes by ``layouts.check_generated``)."""
    start, goal = np.asarray(start, dtype=np.float64), np.asarray(goal, dtype=np.float64)
    if heading is None:
        d = goal - start if start.shape == goal.shape else np.zeros((len(start), 2))
        heading = np.arctan2(d[..., 1], d[..., 0]) if d.ndim == 2 and d.shape[-1] == 2 else np.zeros(len(start))
    if speed is None:
        speed = np.full(s.n_robots, float(s.initial_speed))
    return Layout(
        start=np.ascontiguousarray(start, dtype=np.float64),
        goal=np.ascontiguousarray(goal, dtype=np.float64),
        heading=np.asarray(heading, dtype=np.float64),
        speed=np.asarray(speed, dtype=np.float64),
        obs_pos=_points(obs_pos),
        obs_target=_points(obs_target),
        obs_radius=np.asarray(obs_radius, dtype=np.float64),
    )


class Ahead:
    """Uniform doubles in [0, 1) drawn ahead from ``rng`` (``u``, ``(count,)``), for a compiled loop that
    consumes them in order and cannot take the generator itself; ``settle(used)`` then leaves ``rng``
    exactly where ``used`` draws of its own would have (its state is put back and ``used`` doubles drawn
    again: any bit generator). ``rng.uniform(lo, hi)`` is ``lo + (hi - lo) * u`` for the next ``u``, bit for
    bit (numpy's own formula)."""

    def __init__(self, rng: np.random.Generator, count: int):
        self.rng, self.state = rng, rng.bit_generator.state
        self.u = rng.random(count)

    def settle(self, used: int) -> None:
        if used < len(self.u):
            self.rng.bit_generator.state = self.state
            if used:
                self.rng.random(used)


@njit(cache=True)
def ring_crossers(px, py, centre, rad, radius, k, tries, sep, max_tries, pos):
    """The rejection loop of the crowd kind's obstacles (:meth:`vcs_env.layouts.Crowd._obstacles`) over drawn
    candidate starts ``(px, py)`` ``(T,)`` [m], taken in order: obstacle ``k`` (of radius ``radius[k]``
    [m]) goes to the first candidate whose start and antipodal goal keep ``sep`` [m] from every body so far
    (``centre`` ``(K, 2)`` [m], ``rad`` ``(K,)`` [m]: the robots' starts and their goals, the starts negated,
    then each placed obstacle's start and goal, appended here; antipodal pairs, so checking the start is
    checking both); ``tries`` candidates were already spent on it. Fills ``pos`` ``(m, 2)``.
    Returns ``(k, used, tries, status)``: the next obstacle to place, the candidates used, those spent on it,
    and 0 (all placed), 1 (candidates ran out) or 2 (``max_tries`` spent on obstacle ``k``)."""
    m, n0 = radius.shape[0], centre.shape[0] - 2 * radius.shape[0]
    t = 0
    while k < m:
        if tries == max_tries:
            return k, t, tries, 2
        if t == px.shape[0]:
            return k, t, tries, 1
        x, y, r = px[t], py[t], radius[k]
        t += 1
        tries += 1
        ok = True
        # The bodies come in antipodal pairs of one radius (the robots' starts and goals, each obstacle's), so
        # the goal -p keeps clear of every body exactly when p does (|-p - c| is |p - (-c)|, bit for bit).
        for b in range(n0 + 2 * k):
            dx, dy = x - centre[b, 0], y - centre[b, 1]
            if not math.sqrt(dx * dx + dy * dy) - rad[b] - r >= sep:  # a NaN gap is not clear either
                ok = False
                break
        if ok:
            pos[k, 0], pos[k, 1] = x, y
            j = n0 + 2 * k
            centre[j, 0], centre[j, 1], centre[j + 1, 0], centre[j + 1, 1] = x, y, -x, -y
            rad[j] = rad[j + 1] = r
            k += 1
            tries = 0
    return k, t, tries, 0


@njit(cache=True)
def _free(x, y, r, centre, rad, count, sep):
    """No disc of the first ``count`` (``centre`` ``(K, 2)`` [m], ``rad`` ``(K,)`` [m]) within ``sep`` [m] of the
    disc at ``(x, y)`` of radius ``r`` [m]: every gap ``|q - p| - r_q - r`` is at least ``sep`` (a NaN gap is not)."""
    for b in range(count):
        dx, dy = centre[b, 0] - x, centre[b, 1] - y
        if not math.sqrt(dx * dx + dy * dy) - rad[b] - r >= sep:
            return False
    return True


@njit(cache=True)
def _place_discs(u, lims, radius, centre, rad, n_fixed, sep, seg, anchor, min_anchor, k, tries, max_tries):
    """The rejection loop of :func:`place_discs` over drawn doubles ``u`` ``(2 T,)``, taken in order: disc ``k``
    goes to the first draw ``(-lim + 2 lim u, -lim + 2 lim u')``, ``lim = lims[k]`` [m], that keeps ``sep``
    [m] from the ``n_fixed`` discs and the ``k`` placed (``centre``, ``rad``: the fixed ones, then the placed,
    appended here), from the walls ``seg`` ``(S, 2, 2)`` (with any) and, with ``min_anchor`` > 0, at least that
    far [m] from ``anchor[k]``; ``tries`` draws were already spent on it. Returns ``(k, used, tries, status)``:
    the next disc, the draws used, those spent on it, and 0 (all placed), 1 (draws ran out) or 2
    (``max_tries`` spent on disc ``k``)."""
    t = 0
    while k < radius.shape[0]:
        if tries == max_tries:
            return k, t, tries, 2
        if 2 * t == u.shape[0]:
            return k, t, tries, 1
        r, lim = radius[k], lims[k]
        lo = -lim
        x, y = lo + (lim - lo) * u[2 * t], lo + (lim - lo) * u[2 * t + 1]  # rng.uniform(-lim, lim, size=2)
        t += 1
        tries += 1
        if not _free(x, y, r, centre, rad, n_fixed + k, sep):
            continue
        if seg.shape[0] and not _clearance(x, y, seg) - r >= sep:
            continue
        if min_anchor > 0.0:
            dx, dy = x - anchor[k, 0], y - anchor[k, 1]
            if not math.sqrt(dx * dx + dy * dy) >= min_anchor:
                continue
        centre[n_fixed + k, 0], centre[n_fixed + k, 1], rad[n_fixed + k] = x, y, r
        k += 1
        tries = 0
    return k, t, tries, 0


NO_WALLS = np.zeros((0, 2, 2))


def place_discs(
    rng: np.random.Generator,
    half: float,
    radius: np.ndarray,
    sep: float,
    what: str,
    fixed: np.ndarray | None = None,
    fixed_radius: float = 0.0,
    segments: np.ndarray | None = None,
    anchor: np.ndarray | None = None,
    min_anchor: float = 0.0,
) -> np.ndarray:
    """Discs of radii ``radius`` ``(k,)`` [m] placed one after the other, each at the first of its uniform draws
    in the square of half size ``half`` [m] (its centre within ``half - radius``) whose gap to every disc so far
    (the ``fixed`` centres ``(F, 2)`` [m] of radius ``fixed_radius`` [m], then the placed) is at least ``sep``
    [m], that keeps ``sep`` from the walls ``segments`` ``(S, 2, 2)`` and, with ``min_anchor`` > 0, lies at least
    ``min_anchor`` [m] from ``anchor[i]`` ``(k, 2)``: the centres ``(k, 2)`` [m]. ``ValueError`` naming the disc
    (``what.format(i)``) when one finds no place in :data:`MAX_TRIES` draws, or when its radius leaves no room
    in the square. Each draw is ``rng.uniform(-lim, lim, size=2)``, ``lim = half - radius[i]`` in the radii's
    own precision (float32 radii give a float32 ``lim``, as numpy computes it), drawn ahead (:class:`Ahead`), the
    loop compiled."""
    radius = np.asarray(radius).reshape(-1)
    lims = np.ascontiguousarray(half - radius, dtype=np.float64)  # numpy's promotion: float32 radii, float32 lim
    bad = np.flatnonzero(~(lims >= 0.0))  # also NaN
    if len(bad):
        i = int(bad[0])
        raise ValueError(
            f"cannot place {what.format(i)}: its radius {float(radius[i]):g} m leaves no room in a square of half "
            f"size {float(half):g} m"
        )
    radius = np.ascontiguousarray(radius, dtype=np.float64)
    fixed = np.zeros((0, 2)) if fixed is None else np.asarray(fixed, dtype=np.float64).reshape(-1, 2)
    n_fixed, count = len(fixed), len(radius)
    if min_anchor > 0.0 and (anchor is None or np.shape(anchor) != (count, 2)):
        raise ValueError(f"place_discs: min_anchor > 0 needs an anchor of shape ({count}, 2), got {np.shape(anchor)}")
    centre = np.zeros((n_fixed + count, 2))
    centre[:n_fixed] = fixed
    rad = np.zeros(n_fixed + count)
    rad[:n_fixed] = fixed_radius
    seg = NO_WALLS if segments is None or len(segments) == 0 else np.ascontiguousarray(segments, dtype=np.float64)
    anchor = centre if anchor is None else np.ascontiguousarray(anchor, dtype=np.float64)
    k = tries = 0
    chunk = 2 * count + 4
    while k < count:
        ahead = Ahead(rng, 2 * chunk)
        k, used, tries, status = _place_discs(
            ahead.u, lims, radius, centre, rad, n_fixed, float(sep), seg, anchor, float(min_anchor), k, tries,
            MAX_TRIES,
        )  # fmt: skip
        ahead.settle(2 * used)
        if status == 2:
            raise ValueError(
                f"could not place {what.format(k)} without overlap after {MAX_TRIES} tries; "
                "increase arena_half_size or reduce n_robots / n_obstacles / min_separation"
            )
        chunk *= 2
    return centre[n_fixed:].copy()
