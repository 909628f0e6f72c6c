"""Scenario kinds: how each kind places one world's starts, goals and obstacles, checks that
its layout fits, and sizes it.

Every kind is one :class:`ScenarioKind` object in :data:`KINDS`; :class:`~vcs_env.scenario.Scenario`
delegates to it (``kind="circle"`` is ``KINDS["circle"]``). Adding a kind is one new subclass
here, listed in :data:`KINDS`, plus its test (``docs/extending.md``).

Except ``crowd`` and ``custom``, kinds place the ``n_obstacles`` obstacles at random in the arena,
clear of every start and goal (:func:`place_obstacles`). :meth:`ScenarioKind.check_layout`
rejects, at scenario construction, deterministic layouts that cannot be placed without
overlap; random layouts that cannot be sampled raise at reset. Both raise ``ValueError``
saying which fields to change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .walls import box_segments as box_walls
from .walls import clearance

if TYPE_CHECKING:  # scenario.py looks kinds up here when it validates
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
    segments: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))  # (s, 2, 2) walls [m]


class ScenarioKind:
    """One kind of layout. Subclasses set :attr:`name` and :attr:`summary` and implement
    :meth:`generate`; the other methods have defaults shared by most kinds."""

    name: str = ""
    summary: str = ""
    """One line for the docs and the command-line help (which fields it reads)."""

    def default_radius(self, s: Scenario) -> float:
        """``layout_radius`` when the scenario leaves it None [m]."""
        return 5.0

    def n_segments(self, s: Scenario) -> int:
        """Most wall segments a layout of ``s`` has (the size of the world's segment arrays)."""
        return 0

    def validate(self, s: Scenario) -> None:
        """Kind-specific field rules (``ValueError`` naming the field)."""
        if s.custom is not None:
            raise ValueError(f"custom is only allowed with kind='custom', got kind={s.kind!r}")

    def check_layout(self, s: Scenario) -> None:
        """Raise ``ValueError`` if the layout cannot be placed without overlap."""
        if s.n_obstacles:
            check_arena(s)

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        """Draw one world's initial state for ``s`` from ``rng``."""
        raise NotImplementedError

    def world_extent(self, s: Scenario) -> float:
        """A generous half size of the area of an episode [m] (see ``Scenario.world_extent``)."""
        reach = s.circle_radius + s.jitter + s.lane_spacing * s.n_robots / 2
        return max(s.arena_half_size, reach)

    def view_extent(self, s: Scenario) -> float:
        """Half size of the square drawn by the renderers [m]: the starts, goals and spawn area."""
        return _view(s, s.circle_radius + s.jitter)


# ------------------------------------------------------------------------------ the kinds
class Circle(ScenarioKind):
    name = "circle"
    summary = "``n_robots`` on a circle of radius ``layout_radius``, each driving to the antipodal point."

    def default_radius(self, s: Scenario) -> float:
        return max(5.0, 0.3 * s.n_robots)

    def check_layout(self, s: Scenario) -> None:
        check_ring(s)
        super().check_layout(s)

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        start = jittered(rng, circle_points(s.n_robots, s.circle_radius, 0.0), s.jitter)
        return finish(s, start, -start, *place_obstacles(s, rng, start, -start, obs_radius))


class Swap(ScenarioKind):
    name = "swap"
    summary = (
        "``n_robots / 2`` head-on pairs on parallel lanes ``lane_spacing`` apart, ``2 layout_radius`` long "
        "(``n_robots`` even)."
    )

    def validate(self, s: Scenario) -> None:
        super().validate(s)
        if s.n_robots % 2:
            raise ValueError(f"n_robots must be even for kind='swap', got {s.n_robots}")

    def check_layout(self, s: Scenario) -> None:
        need = check_lanes(s)
        if 2.0 * s.circle_radius < need:
            raise ValueError(f"layout_radius={s.circle_radius:g} m is too short for a swap: need >= {need / 2:.3f} m")
        super().check_layout(s)

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
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
        start = jittered(rng, start, s.jitter)
        return finish(s, start, goal, *place_obstacles(s, rng, start, goal, obs_radius))

    def view_extent(self, s: Scenario) -> float:
        spread = s.n_robots / 2 * s.lane_spacing / 2
        return _view(s, max(s.circle_radius + s.jitter, spread))


class Crossing(ScenarioKind):
    name = "crossing"
    summary = "two groups at 90 degrees: half drive along +x, half along +y, crossing near the origin."

    def validate(self, s: Scenario) -> None:
        super().validate(s)
        if s.n_robots < 2:
            raise ValueError(f"n_robots must be >= 2 for kind='crossing', got {s.n_robots}")

    def check_layout(self, s: Scenario) -> None:
        check_lanes(s)
        r = s.robot.radius
        spread = (math.ceil(s.n_robots / 2) - 1) / 2.0 * s.lane_spacing + r + s.jitter + s.min_separation
        if spread >= s.circle_radius:
            raise ValueError(
                f"crossing groups overlap: layout_radius={s.circle_radius:g} m must exceed the half group "
                f"width {spread:.3f} m; increase layout_radius or reduce n_robots / lane_spacing"
            )
        super().check_layout(s)

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        n1 = (s.n_robots + 1) // 2
        n2 = s.n_robots - n1
        r = s.circle_radius
        off1 = (np.arange(n1) - (n1 - 1) / 2.0) * s.lane_spacing
        off2 = (np.arange(n2) - (n2 - 1) / 2.0) * s.lane_spacing
        # Group 1 drives along +x, group 2 along +y; both paths cross near the origin.
        start = np.concatenate((np.stack((np.full(n1, -r), off1), -1), np.stack((off2, np.full(n2, -r)), -1)))
        goal = np.concatenate((np.stack((np.full(n1, r), off1), -1), np.stack((off2, np.full(n2, r)), -1)))
        start = jittered(rng, start, s.jitter)
        return finish(s, start, goal, *place_obstacles(s, rng, start, goal, obs_radius))

    def view_extent(self, s: Scenario) -> float:
        spread = math.ceil(s.n_robots / 2) * s.lane_spacing / 2
        return _view(s, max(s.circle_radius + s.jitter, spread))


class Random(ScenarioKind):
    name = "random"
    summary = "random starts and goals in the square arena ``[-arena_half_size, arena_half_size]^2``."

    def check_layout(self, s: Scenario) -> None:
        check_arena(s)
        if 2 * (s.arena_half_size - s.robot.radius) < MIN_GOAL_DISTANCE:
            raise ValueError(f"arena_half_size={s.arena_half_size:g} m leaves no room for goals >= 1 m away")

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        n, r, half = s.n_robots, s.robot.radius, s.arena_half_size
        starts = Sampler(rng, half, s.min_separation)
        goals = Sampler(rng, half, s.min_separation)
        start = np.array([starts.sample(r, f"the start of robot {i}") for i in range(n)]).reshape(n, 2)
        goal = np.array(
            [
                goals.sample(
                    r, f"the goal of robot {i}", lambda p, i=i: np.linalg.norm(p - start[i]) >= MIN_GOAL_DISTANCE
                )
                for i in range(n)
            ]
        ).reshape(n, 2)
        return finish(s, start, goal, *place_obstacles(s, rng, start, goal, obs_radius))

    def view_extent(self, s: Scenario) -> float:
        return s.arena_half_size + 0.5


class Dynamic(Random):
    name = "dynamic"
    summary = "random starts and goals among obstacles on arbitrary trajectories bouncing in the arena."


class Crowd(ScenarioKind):
    name = "crowd"
    summary = (
        "robots on a circle (robot_0 from (0, -R) to (0, R)) among ``n_obstacles`` passive obstacles "
        "that cross the same circle and ignore the robots (CrowdNav style)."
    )

    def check_layout(self, s: Scenario) -> None:
        check_ring(s)
        r, r_obs = s.robot.radius, s.obstacle_radius[1]
        ring = 2.0 * math.pi * s.circle_radius
        used = s.n_robots * (2 * r + s.min_separation) + s.n_obstacles * (2 * r_obs + s.min_separation)
        if used > ring:
            raise ValueError(
                f"cannot place {s.n_robots} robots and {s.n_obstacles} obstacles on a crowd circle of radius "
                f"{s.circle_radius:g} m: they need {used:.1f} m of its {ring:.1f} m; increase layout_radius"
            )

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        start = circle_points(s.n_robots, s.circle_radius, -np.pi / 2)
        goal = -start
        obs_pos, obs_target = self._obstacles(rng, s, start, goal, obs_radius)
        return finish(s, start, goal, obs_pos, obs_target, obs_radius)

    @staticmethod
    def _obstacles(
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
                ok = all(
                    np.linalg.norm(q - c) - rad - radius[k] >= s.min_separation for c, rad in bodies for q in (p, g)
                )
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

    def view_extent(self, s: Scenario) -> float:
        return s.circle_radius + s.jitter + 0.5 + s.robot.radius + 0.5


class Custom(ScenarioKind):
    name = "custom"
    summary = "explicit arrays (:class:`~vcs_env.scenario.CustomLayout`), e.g. to reproduce a layout from a paper."

    def validate(self, s: Scenario) -> None:
        from .scenario import CustomLayout

        if not isinstance(s.custom, CustomLayout):
            raise ValueError("kind='custom' needs custom=CustomLayout(...)")
        if s.n_robots != len(s.custom.start):
            raise ValueError(
                f"n_robots must equal the number of custom starts ({len(s.custom.start)}), got {s.n_robots}"
            )
        if s.n_obstacles != len(s.custom.obstacles):
            raise ValueError(
                f"n_obstacles must equal the number of custom obstacles ({len(s.custom.obstacles)}), "
                f"got {s.n_obstacles}"
            )
        if s.custom.speed is not None and max(s.custom.speed) > s.robot.v_max:
            raise ValueError(f"custom.speed must be <= robot.v_max = {s.robot.v_max}, got {max(s.custom.speed)}")

    def n_segments(self, s: Scenario) -> int:
        return len(s.custom.walls)

    def check_layout(self, s: Scenario) -> None:
        lay = self.generate(s, np.random.default_rng(0))
        check_walls(s, lay)
        pos = np.concatenate((lay.start, lay.obs_pos))
        radius = np.concatenate((np.full(s.n_robots, s.robot.radius), lay.obs_radius))
        d = np.linalg.norm(pos[:, None] - pos[None], axis=-1) - radius[:, None] - radius[None]
        np.fill_diagonal(d, np.inf)
        if np.any(d < 0):
            i, j = np.unravel_index(np.argmin(d), d.shape)
            raise ValueError(
                f"custom layout overlaps at t=0: bodies {min(i, j)} and {max(i, j)} (robots first, then obstacles)"
            )

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        c, n, m = s.custom, s.n_robots, s.n_obstacles
        obs_pos = np.array([o.positions[0] for o in c.obstacles], dtype=np.float64).reshape(m, 2)
        lay = finish(
            s,
            np.asarray(c.start, dtype=np.float64).reshape(n, 2),
            np.asarray(c.goal, dtype=np.float64).reshape(n, 2),
            obs_pos,
            obs_pos.copy(),
            np.array([o.radius for o in c.obstacles], dtype=np.float64),
            heading=c.heading,
            speed=c.speed,
        )
        lay.segments = np.array(c.walls, dtype=np.float64).reshape(-1, 2, 2)
        return lay

    def world_extent(self, s: Scenario) -> float:
        return self._extent(s)

    def view_extent(self, s: Scenario) -> float:
        return self._extent(s)

    @staticmethod
    def _extent(s: Scenario) -> float:
        from .scenario import R_REF

        pts = [c for p in s.custom.start + s.custom.goal for c in p]
        pts += [c for o in s.custom.obstacles for p in o.positions for c in p]
        pts += [c for w in s.custom.walls for p in w for c in p]
        return max(1.0, max(abs(c) for c in pts) + R_REF)


# ------------------------------------------------------------------------------ maps
class MapKind(ScenarioKind):
    """A kind with static walls (:mod:`vcs_env.walls`). Its obstacles are placed at random in
    the arena, clear of the walls; :meth:`check_layout` requires starts, goals and obstacles
    clear of the walls and a route for every robot (:func:`check_walls`)."""

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
    ``lane_spacing`` apart in the direction ``away`` (+1 or -1)."""
    r, sp = s.robot.radius, s.lane_spacing
    room = width - 2.0 * (r + s.min_separation)
    if room < 0.0:
        raise ValueError(
            f"{s.kind}: a passage of {width:g} m does not fit a robot of radius {r:g} m with min_separation "
            f"{s.min_separation:g} m on both sides; widen it (corridor_width / arena_half_size)"
        )
    lanes = max(1, min(count, 1 + int(room // sp)))
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

    def places(self, s, rng):
        return _two_way(s, 2.0 * s.arena_half_size)

    def walls(self, s, start, goal):
        h, d = s.arena_half_size, s.door_width / 2.0
        if d >= h:
            raise ValueError(f"door_width={s.door_width:g} m must be below the arena side 2 arena_half_size")
        return np.concatenate((box_walls(h), [[[0.0, -h], [0.0, -d]], [[0.0, d], [0.0, h]]]))


class Room(MapKind):
    name = "room"
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


class Walls(MapKind):
    name = "walls"
    summary = (
        "``n_walls`` random wall segments (length in ``wall_length``) inside a walled square arena of half size "
        "``arena_half_size``; random starts and goals clear of them, each with a route."
    )

    def n_segments(self, s: Scenario) -> int:
        return 4 + s.n_walls

    def check_layout(self, s: Scenario) -> None:
        check_arena(s)
        if s.wall_length[0] >= 2.0 * s.arena_half_size:
            raise ValueError(f"wall_length={s.wall_length} does not fit an arena of half size {s.arena_half_size:g}")

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        from .routes import Roadmap

        obs_radius = obstacle_radii(s, rng)
        n, r, h = s.n_robots, s.robot.radius, s.arena_half_size
        for _ in range(50):
            seg = np.concatenate((box_walls(h), self._segments(s, rng)))

            def clear(p, seg=seg):
                return clearance(p, seg) - r >= s.min_separation

            starts, goals = Sampler(rng, h, s.min_separation), Sampler(rng, h, s.min_separation)
            start = np.array([starts.sample(r, f"the start of robot {i}", clear) for i in range(n)]).reshape(n, 2)
            goal = np.array(
                [
                    goals.sample(
                        r,
                        f"the goal of robot {i}",
                        lambda p, q=start[i]: clear(p) and np.linalg.norm(p - q) >= MIN_GOAL_DISTANCE,
                    )
                    for i in range(n)
                ]
            ).reshape(n, 2)
            roadmap = Roadmap(seg, r)
            if all(np.isfinite(roadmap.route_length(start[i], goal[i])) for i in range(n)):
                lay = finish(s, start, goal, *place_obstacles(s, rng, start, goal, obs_radius, seg))
                lay.segments = seg
                return lay
        raise ValueError(
            f"walls: no layout with a route for every robot in 50 draws; reduce n_walls / wall_length or "
            f"increase arena_half_size (now {h:g} m)"
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


KINDS: dict[str, ScenarioKind] = {
    k.name: k
    for k in (
        Circle(),
        Swap(),
        Crossing(),
        Random(),
        Crowd(),
        Dynamic(),
        Custom(),
        Corridor(),
        Doorway(),
        Room(),
        Intersection(),
        Walls(),
    )
}
"""Every scenario kind by name (the values ``Scenario.kind`` accepts)."""


def kinds_help(width: int = 10) -> str:
    """One line per kind, ``name  summary`` (for docstrings and command-line help)."""
    return "\n".join(f"{name:<{width}} {kind.summary}" for name, kind in KINDS.items())


def generate(s: Scenario, rng: np.random.Generator) -> Layout:
    """Draw one world's initial state for scenario ``s`` from ``rng``."""
    return KINDS[s.kind].generate(s, rng)


def segment_capacity(s: Scenario) -> int:
    """Most wall segments a layout of scenario ``s`` has."""
    return KINDS[s.kind].n_segments(s)


def check_layout(s: Scenario) -> None:
    """Raise ``ValueError`` if the layout of ``s`` cannot be placed without overlap."""
    KINDS[s.kind].check_layout(s)


# ------------------------------------------------------------------ shared building blocks
def _view(s: Scenario, half: float) -> float:
    """Drawn half size [m] around robots reaching ``half`` [m], widened to the arena if it holds obstacles."""
    if s.n_obstacles:
        half = max(half, s.arena_half_size)
    return half + s.robot.radius + 0.5


def check_ring(s: Scenario) -> None:
    """Neighbours on the layout circle must not overlap."""
    need = 2.0 * s.robot.radius + s.min_separation + 2.0 * s.jitter
    if s.n_robots >= 2:
        chord = 2.0 * s.circle_radius * math.sin(math.pi / s.n_robots)
        if chord < need:
            raise ValueError(
                f"cannot place {s.n_robots} robots on a circle of radius {s.circle_radius:g} m without overlap: "
                f"neighbours are {chord:.3f} m apart, need {need:.3f} m (2 radius + min_separation + 2 jitter); "
                "increase layout_radius or reduce n_robots"
            )


def check_lanes(s: Scenario) -> float:
    """Neighbouring lanes must not overlap; returns the body spacing needed [m]."""
    r = s.robot.radius
    need = 2.0 * r + s.min_separation + 2.0 * s.jitter
    if s.lane_spacing < need:
        raise ValueError(
            f"lane_spacing={s.lane_spacing:g} m is too small for robots of radius {r:g} m: need >= {need:.3f} m"
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
            f"{s.arena_half_size:g} m without overlap; increase arena_half_size or reduce the counts"
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
        if np.any(gap < s.min_separation + more):
            i = int(np.argmin(gap))
            raise ValueError(
                f"{s.kind} layout: {what} {i} at {np.round(pts[i], 3).tolist()} is {gap[i]:.3f} m from a wall, "
                f"need >= min_separation = {s.min_separation} m" + (f" + jitter = {more} m" if more else "")
            )
    from .routes import Roadmap

    roadmap = Roadmap(seg, r)
    for i in range(s.n_robots):
        if not np.isfinite(roadmap.route_length(lay.start[i], lay.goal[i])):
            raise ValueError(
                f"{s.kind} layout: no route for robot {i} from {np.round(lay.start[i], 3).tolist()} to "
                f"{np.round(lay.goal[i], 3).tolist()} between the walls (robot radius {r} m)"
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
        sampler = Sampler(rng, s.arena_half_size, s.min_separation)
        for p in np.concatenate((start, goal)):
            sampler.add(p, s.robot.radius)
        for k in range(m):
            if segments is None or len(segments) == 0:
                obs_pos[k] = sampler.sample(radius[k], f"obstacle {k}")
            else:
                clear = lambda p, k=k: clearance(p, segments) - radius[k] >= s.min_separation  # noqa: E731
                obs_pos[k] = sampler.sample(radius[k], f"obstacle {k}", clear)
        lim = s.arena_half_size - radius[:, None]
        obs_target = rng.uniform(-lim, lim, size=(m, 2))
    return obs_pos, obs_target, radius


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
    """The :class:`Layout`; robots face their goal at ``initial_speed`` unless given."""
    if heading is None:
        d = goal - start
        heading = np.arctan2(d[:, 1], d[:, 0])
    if speed is None:
        speed = np.full(s.n_robots, float(s.initial_speed))
    return Layout(
        start=np.ascontiguousarray(start, dtype=np.float64),
        goal=np.ascontiguousarray(goal, dtype=np.float64),
        heading=np.asarray(heading, dtype=np.float64),
        speed=np.asarray(speed, dtype=np.float64),
        obs_pos=obs_pos,
        obs_target=obs_target,
        obs_radius=np.asarray(obs_radius, dtype=np.float64),
    )


class Sampler:
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
