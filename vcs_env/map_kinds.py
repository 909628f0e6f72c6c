"""Scenario kinds with static walls (:mod:`vcs_env.walls`): corridor, doorway, room, intersection
and random walls. Each is one :class:`~vcs_env.layouts.ScenarioKind` listed in
:data:`vcs_env.layouts.KINDS`, built from the shared blocks of :mod:`vcs_env.layouts`."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .layouts import ScenarioKind
from .placement import (
    MAX_TRIES,
    MIN_GOAL_DISTANCE,
    Layout,
    _view,
    check_arena,
    check_spacing,
    check_walls,
    circle_points,
    finish,
    jittered,
    obstacle_radii,
    place_discs,
    place_obstacles,
)
from .walls import box_segments as box_walls

if TYPE_CHECKING:
    from .scenario import Scenario


class MapKind(ScenarioKind):
    """A kind with static walls (:mod:`vcs_env.walls`). Its obstacles are placed at random in
    the arena, clear of the walls (they move through walls: walls stop robots only);
    :meth:`check_layout` requires starts, goals and obstacles clear of the walls and a route for
    every robot (:func:`check_walls`)."""

    spacing_hint = "increase lane_spacing or layout_radius"
    """What to change when robots would start in contact (:func:`~vcs_env.placement.check_spacing` adds ``jitter``
    where it counts)."""

    def default_radius(self, s: Scenario) -> float:
        return 3.0

    def walls(self, s: Scenario, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """The wall segments ``(s, 2, 2)`` [m] around the given starts and goals."""
        raise NotImplementedError

    def places(self, s: Scenario, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Starts and goals ``(n, 2)`` [m]."""
        raise NotImplementedError

    def n_segments(self, s: Scenario) -> int:
        start, goal = self.places(s, np.random.default_rng(0))
        return len(self.walls(s, start, goal))

    def check_layout(self, s: Scenario) -> None:
        if s.n_obstacles:
            check_arena(s)
        start, goal = self.places(s, np.random.default_rng(0))
        seg = self.walls(s, start, goal)
        # Jitter moves starts by up to ``jitter``: the unjittered places keep that much more room.
        check_walls(s, finish(s, start, goal, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0)), seg, s.jitter)
        check_spacing(s, start, goal, self.spacing_hint)
        if s.n_obstacles:  # obstacles between the walls: a map too dense for them is refused here, not at reset
            check_trial_layouts(self, s, "reduce n_obstacles / obstacle_radius or increase arena_half_size")

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        start, goal = self.places(s, rng)
        seg = self.walls(s, start, goal)
        start = jittered(rng, start, s.jitter)
        lay = finish(s, start, goal, *place_obstacles(s, rng, start, goal, obs_radius, seg))
        lay.segments = seg
        return lay

    def view_extent(self, s: Scenario) -> float:
        start, goal = self.places(s, np.random.default_rng(0))
        pts = np.concatenate((self.walls(s, start, goal).reshape(-1, 2), start, goal))
        return _view(s, float(np.abs(pts).max()))


def lane_block(s: Scenario, count: int, width: float, x_near: float, away: float) -> np.ndarray:
    """``count`` robots ``(count, 2)`` [m] in lanes ``lane_spacing`` apart across a passage of
    ``width`` [m] centred on y = 0, the first column at x = ``x_near``, further columns
    ``lane_spacing`` apart in the direction ``away`` (+1 or -1). The outer lanes keep ``min_separation``
    plus the start ``jitter`` from the passage's sides."""
    r, sp = s.robot.radius, s.lane_spacing
    room = width - 2.0 * (r + s.min_separation + s.jitter)
    if width - 2.0 * (r + s.min_separation) < 0.0:
        raise ValueError(
            f"{s.kind}: a passage of {width:g} m does not fit a robot of radius {r:g} m with min_separation "
            f"{s.min_separation:g} m on both sides; widen it (corridor_width / arena_half_size)"
        )
    lanes = max(1, min(count, 1 + int(max(room, 0.0) // sp)))
    j = np.arange(count)
    y = (j % lanes - (lanes - 1) / 2.0) * sp
    x = x_near + away * (j // lanes) * sp
    return np.stack((x, y), axis=-1).reshape(count, 2)


def _two_way(s: Scenario, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Two groups in lanes across a passage along x: the first ``ceil(n/2)`` robots from the
    left (x = -layout_radius and beyond) to the mirrored places on the right, the others from
    the right to the left."""
    n1 = (s.n_robots + 1) // 2
    left = lane_block(s, n1, width, -s.circle_radius, -1.0)
    right = lane_block(s, s.n_robots - n1, width, s.circle_radius, 1.0)
    start = np.concatenate((left, right))
    return start, start * [-1.0, 1.0]


class Corridor(MapKind):
    name = "corridor"
    summary = (
        "two-way traffic in a corridor ``corridor_width`` wide along x: half the robots from x = -layout_radius "
        "to +layout_radius, half back, in lanes ``lane_spacing`` apart."
    )

    def places(self, s, rng):
        return _two_way(s, s.corridor_width)

    def walls(self, s, start, goal):
        x, h = float(np.abs(start[:, 0]).max()) + 1.0, s.corridor_width / 2.0
        return np.array([[[-x, -h], [x, -h]], [[-x, h], [x, h]]])


class Doorway(MapKind):
    name = "doorway"
    summary = (
        "a bottleneck: a wall across the arena (half size ``arena_half_size``) at x = 0 with a door "
        "``door_width`` wide; groups on both sides at x = -+layout_radius swap sides."
    )
    reads = frozenset({"jitter", "layout_radius", "arena_half_size"})

    def places(self, s, rng):
        return _two_way(s, 2.0 * s.arena_half_size)

    def check_layout(self, s):
        start, goal = self.places(s, np.random.default_rng(0))
        far = float(np.abs(np.concatenate((start, goal))).max()) + s.robot.radius + s.jitter
        if far > s.arena_half_size:
            raise ValueError(
                f"doorway: {s.n_robots} robots from x = -+layout_radius ({s.circle_radius:g} m) outward in lanes "
                f"{s.lane_spacing:g} m apart reach {far:g} m from the centre, outside the arena's walls at "
                f"arena_half_size={s.arena_half_size:g} m; increase arena_half_size or reduce layout_radius / n_robots"
            )
        super().check_layout(s)

    def walls(self, s, start, goal):
        h, d = s.arena_half_size, s.door_width / 2.0
        if d >= h:
            raise ValueError(f"door_width={s.door_width:g} m must be below the arena side 2 arena_half_size")
        return np.concatenate((box_walls(h), [[[0.0, -h], [0.0, -d]], [[0.0, d], [0.0, h]]]))


class Room(MapKind):
    name = "room"
    spacing_hint = "increase layout_radius, or reduce n_robots"  # its robots sit on a circle
    summary = (
        "a square room of half size ``layout_radius`` with a door ``door_width`` wide in the middle of each "
        "side; robots start on a circle of radius layout_radius / 2 inside and leave for the antipodal point "
        "on a circle 1 m beyond the room's corners."
    )

    def places(self, s, rng):
        inner = 0.5 * s.circle_radius
        need = 2.0 * s.robot.radius + s.min_separation
        if s.n_robots >= 2 and 2.0 * inner * math.sin(math.pi / s.n_robots) < need:
            raise ValueError(
                f"room: {s.n_robots} robots do not fit on a circle of radius {inner:g} m (layout_radius / 2); "
                "increase layout_radius"
            )
        start = circle_points(s.n_robots, inner, 0.0)
        return start, -start / inner * self._outer(s)

    @staticmethod
    def _outer(s: Scenario) -> float:
        """Radius of the goal circle [m]: 1 m beyond the room's corners."""
        return s.circle_radius * math.sqrt(2.0) + 1.0

    def walls(self, s, start, goal):
        h, d = s.circle_radius, s.door_width / 2.0
        if d >= h:
            raise ValueError(f"door_width={s.door_width:g} m must be below the room side 2 layout_radius")
        out = []
        for k in range(4):  # each side: two segments from the corners to the door
            c, sn = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
            for a, b in (((h, -h), (h, -d)), ((h, d), (h, h))):
                out.append([[c * a[0] - sn * a[1], sn * a[0] + c * a[1]], [c * b[0] - sn * b[1], sn * b[0] + c * b[1]]])
        return np.array(out)

    def view_extent(self, s: Scenario) -> float:
        return _view(s, self._outer(s))


class Intersection(MapKind):
    name = "intersection"
    summary = (
        "two corridors ``corridor_width`` wide crossing at the origin: half the robots drive along +x, half "
        "along +y, from -layout_radius to +layout_radius, in lanes ``lane_spacing`` apart."
    )

    def places(self, s, rng):
        n1 = (s.n_robots + 1) // 2
        a = lane_block(s, n1, s.corridor_width, -s.circle_radius, -1.0)
        b = lane_block(s, s.n_robots - n1, s.corridor_width, -s.circle_radius, -1.0)[:, ::-1]
        start = np.concatenate((a, b))
        return start, np.concatenate((a * [-1.0, 1.0], b * [1.0, -1.0]))

    def walls(self, s, start, goal):
        w, arm = s.corridor_width / 2.0, float(np.abs(start).max()) + 1.0
        if arm <= w:
            raise ValueError("intersection: layout_radius must exceed corridor_width / 2")
        out = []
        for sx in (-1.0, 1.0):
            for sy in (-1.0, 1.0):
                out += [[[sx * w, sy * w], [sx * arm, sy * w]], [[sx * w, sy * w], [sx * w, sy * arm]]]
        return np.array(out)


TRIAL_LAYOUTS = 8
"""Layouts a map drawn at random (the ``walls`` kind; any map with obstacles) draws at construction (seeds 0-7):
if one fails, the scenario is refused."""


WALL_DRAWS = 500
"""Draws of the ``walls`` kind's segments per layout at reset, at most: a dense map may need many (60 walls among 4
robots: about 1 in 30 draws has a place and a route for every robot), and a reset that runs out fails."""
TRIAL_WALL_DRAWS = 100
"""The same for each trial layout at construction: a map whose trial needs more is refused as too dense to draw
reliably (a reset then has five times the draws)."""


def check_trial_layouts(kind: ScenarioKind, s: Scenario, hint: str, generate=None) -> None:
    """Layouts are drawn at reset; a map too dense to draw reliably is refused here (``hint``: what to change),
    not by a reset that fails at random (an autoreset in the middle of training). ``generate(s, rng)`` draws a
    trial layout (default: the kind's)."""
    for seed in range(TRIAL_LAYOUTS):
        try:
            (generate or kind.generate)(s, np.random.default_rng(seed))
        except ValueError as e:
            raise ValueError(
                f"{s.kind}: trial layout {seed} of the {TRIAL_LAYOUTS} trial layouts found no place and route for "
                f"every robot and obstacle, so resets would fail at random; {hint} ({e})"
            ) from None


class Walls(MapKind):
    name = "walls"
    summary = (
        "``n_walls`` random wall segments (length in ``wall_length``) inside a walled square arena of half size "
        "``arena_half_size``; random starts and goals clear of them, each with a route."
    )
    reads = frozenset({"arena_half_size"})

    def n_segments(self, s: Scenario) -> int:
        return 4 + s.n_walls

    def check_layout(self, s: Scenario) -> None:
        check_arena(s)
        if s.wall_length[0] >= 2.0 * s.arena_half_size:
            raise ValueError(f"wall_length={s.wall_length} does not fit an arena of half size {s.arena_half_size:g}")
        hint = "reduce n_robots / n_walls / wall_length or increase arena_half_size"
        check_trial_layouts(self, s, hint, lambda s, rng: self._draw(s, rng, TRIAL_WALL_DRAWS))

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        return self._draw(s, rng, WALL_DRAWS)

    def _draw(self, s: Scenario, rng: np.random.Generator, draws: int) -> Layout:
        """A layout from at most ``draws`` draws of the walls."""
        from .routes import Roadmap

        obs_radius = obstacle_radii(s, rng)
        radii, h, sep = np.full(s.n_robots, s.robot.radius), s.arena_half_size, s.min_separation
        r = s.robot.radius
        last = "no route for every robot"
        for _ in range(draws):
            seg = np.concatenate((box_walls(h), self._segments(s, rng)))
            try:
                start = place_discs(rng, h, radii, sep, "the start of robot {}", segments=seg)
                goal = place_discs(
                    rng, h, radii, sep, "the goal of robot {}", segments=seg, anchor=start, min_anchor=MIN_GOAL_DISTANCE
                )
            except ValueError as e:  # no free place among these walls: draw other walls
                last = str(e)
                continue
            if np.isfinite(Roadmap(seg, r).next_waypoints(start, goal)[1]).all():
                try:
                    placed = place_obstacles(s, rng, start, goal, obs_radius, seg)
                except ValueError as e:  # no room for the obstacles among these walls: draw other walls
                    last = str(e)
                    continue
                lay = finish(s, start, goal, *placed)
                lay.segments = seg
                return lay
            last = "no route for every robot"
        raise ValueError(
            f"walls: no layout with a place and a route for every robot in {draws} draws of the walls "
            f"(last: {last}); reduce n_robots / n_walls / wall_length or increase arena_half_size (now {h:g} m)"
        )

    @staticmethod
    def _segments(s: Scenario, rng: np.random.Generator) -> np.ndarray:
        """``n_walls`` segments with both ends inside the arena."""
        h = s.arena_half_size
        out = np.zeros((s.n_walls, 2, 2))
        for k in range(s.n_walls):
            for _ in range(MAX_TRIES):
                c = rng.uniform(-h, h, size=2)
                ang = rng.uniform(0.0, np.pi)
                half = 0.5 * rng.uniform(*s.wall_length) * np.array([np.cos(ang), np.sin(ang)])
                if np.all(np.abs(c - half) <= h) and np.all(np.abs(c + half) <= h):
                    out[k] = c - half, c + half
                    break
            else:
                raise ValueError(f"walls: could not place wall {k} inside the arena; reduce wall_length")
        return out

    def view_extent(self, s: Scenario) -> float:
        return s.arena_half_size + 0.5
