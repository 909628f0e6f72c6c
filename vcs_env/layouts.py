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
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # scenario.py looks kinds up here when it validates
    from .scenario import Scenario

from .custom_layout import check_goals, check_scripted
from .placement import (  # noqa: F401  (re-exported: the building blocks of every kind)
    CROWD_REDRAWS,
    MAX_TRIES,
    MIN_GOAL_DISTANCE,
    RING_NOISE,
    Ahead,
    Layout,
    _view,
    check_arena,
    check_lanes,
    check_ring,
    check_walls,
    circle_points,
    crowd_ring,
    crowd_view,
    finish,
    jittered,
    obstacle_radii,
    on_ring,
    place_discs,
    place_obstacles,
    ring_crossers,
    walks_square,
)


class ScenarioKind:
    """One kind of layout. Subclasses set :attr:`name` and :attr:`summary` and implement
    :meth:`generate`; the other methods have defaults shared by most kinds."""

    name: str = ""
    summary: str = ""
    """One line for the docs and the command-line help (which fields it reads)."""
    reads: frozenset[str] = frozenset({"jitter", "layout_radius"})
    """The optional layout fields (of ``jitter``, ``layout_radius``, ``arena_half_size``) that change this kind's
    worlds; setting another one explicitly is an error in the command line and mixtures
    (:func:`agents.config.build_scenario`; ``arena_half_size`` also applies where obstacles bounce off the arena's
    edges or walk as pedestrians in it)."""

    def default_radius(self, s: Scenario) -> float:
        """``layout_radius`` when the scenario leaves it None [m]."""
        return 5.0

    def least_trip(self, s: Scenario) -> float:
        """A lower bound on the straight distance [m] from start to goal (within ``r_goal``) that
        every robot of every layout of ``s`` must cover; 0.0 where the kind gives none."""
        return 0.0

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

    def least_trip(self, s: Scenario) -> float:
        # The goal is the antipode of the jittered start, which lies within jitter of the circle.
        return max(0.0, 2.0 * (s.circle_radius - s.jitter) - s.r_goal)


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

    def least_trip(self, s: Scenario) -> float:
        # Starts (jittered) and goals lie 2 layout_radius apart along a lane.
        return max(0.0, 2.0 * s.circle_radius - s.jitter - s.r_goal)

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

    least_trip = Swap.least_trip

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
    reads = frozenset({"arena_half_size"})

    def check_layout(self, s: Scenario) -> None:
        check_arena(s)
        if 2 * (s.arena_half_size - s.robot.radius) < MIN_GOAL_DISTANCE:
            raise ValueError(f"arena_half_size={s.arena_half_size:g} m leaves no room for goals >= 1 m away")

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        radii, half, sep = np.full(s.n_robots, s.robot.radius), s.arena_half_size, s.min_separation
        start = place_discs(rng, half, radii, sep, "the start of robot {}")
        goal = place_discs(rng, half, radii, sep, "the goal of robot {}", anchor=start, min_anchor=MIN_GOAL_DISTANCE)
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
    reads = frozenset({"layout_radius"})

    def check_layout(self, s: Scenario) -> None:
        check_ring(s)
        r, r_obs = s.robot.radius, s.obstacle_radius[1]
        m = 0 if walks_square(s) else s.n_obstacles  # pedestrians crossing the square need no place on the ring
        if m and s.bounce and s.circle_radius + RING_NOISE + r_obs > s.arena_half_size:
            raise ValueError(
                f"crowd obstacles start on the ring of radius {s.circle_radius:g} m (+-{RING_NOISE:g} m), and their "
                f"discs (radius up to {r_obs:g} m) reach beyond the arena they bounce in (arena_half_size="
                f"{s.arena_half_size:g} m); increase arena_half_size or reduce layout_radius"
            )
        used, ring = crowd_ring(s, m)
        if used > ring:
            raise ValueError(
                f"cannot place {s.n_robots} robots and {s.n_obstacles} obstacles on a crowd circle of radius "
                f"{s.circle_radius:g} m: their starts and goals need {used:.1f} m of its {ring:.1f} m; "
                "increase layout_radius"
            )
        if m:  # the length of the ring is not the room between the robots: the first obstacle must fit
            start = circle_points(s.n_robots, s.circle_radius, -np.pi / 2)
            bodies = [(p, r) for p in np.concatenate((start, -start))]
            try:
                Crowd._search(np.random.default_rng(0), s, bodies, r_obs, 0)
            except ValueError:
                raise ValueError(
                    f"no crowd obstacle of radius {r_obs:g} m fits, start and antipodal goal, between {s.n_robots} "
                    f"robots of radius {r:g} m on a circle of radius {s.circle_radius:g} m; increase layout_radius or "
                    "reduce n_robots / robot radius / obstacle_radius / min_separation"
                ) from None

    def least_trip(self, s: Scenario) -> float:
        return max(0.0, 2.0 * s.circle_radius - s.r_goal)  # start and goal are antipodes of the ring

    def generate(self, s: Scenario, rng: np.random.Generator) -> Layout:
        obs_radius = obstacle_radii(s, rng)
        start = circle_points(s.n_robots, s.circle_radius, -np.pi / 2)
        goal = -start
        obs_pos, obs_target = np.zeros((2, s.n_obstacles, 2))  # square walkers without room on the ring: placed later
        for attempt in range(CROWD_REDRAWS if on_ring(s) else 0):
            try:
                obs_pos, obs_target = self._obstacles(rng, s, start, goal, obs_radius)
                break
            except ValueError:  # the obstacles placed first left no room for one: place them all again
                if attempt == CROWD_REDRAWS - 1 and not walks_square(s):
                    raise
        return finish(s, start, goal, obs_pos, obs_target, obs_radius)

    @staticmethod
    def _obstacles(
        rng: np.random.Generator, s: Scenario, start: np.ndarray, goal: np.ndarray, radius: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """CrowdNav circle crossing: obstacles start on the circle (with +-0.5 m noise) and head for
        the antipodal point; starts and goals keep clear of the robots' and of each other's."""
        m, R = len(radius), s.circle_radius
        if not np.array_equal(goal, -start):  # ring_crossers checks a start only: the goals of the bodies mirror it
            raise ValueError("crowd layout: the robots' goals must be their starts mirrored through the centre")
        pos = np.zeros((m, 2))
        centre = np.zeros((2 * s.n_robots + 2 * m, 2))
        centre[: 2 * s.n_robots] = np.concatenate((start, goal))
        rad = np.full(len(centre), float(s.robot.radius))
        k = tries = 0
        chunk, sep = 8 * m, s.min_separation
        while k < m:
            # Each try draws an angle on the circle and a +-0.5 m noise per axis (rng.uniform(0, 2 pi), then
            # rng.uniform(-0.5, 0.5, size=2)); drawn ahead in chunks, the loop compiled (ring_crossers).
            ahead = Ahead(rng, 3 * chunk)
            u = ahead.u.reshape(-1, 3)
            ang = (2.0 * np.pi) * u[:, 0]
            px = R * np.cos(ang) + (-RING_NOISE + 2.0 * RING_NOISE * u[:, 1])
            py = R * np.sin(ang) + (-RING_NOISE + 2.0 * RING_NOISE * u[:, 2])
            k, used, tries, status = ring_crossers(px, py, centre, rad, radius, k, tries, sep, MAX_TRIES, pos)
            ahead.settle(3 * used)
            if status == 2:  # the random draws found no room: search every place, in an order drawn from rng
                bodies = [(centre[b], rad[b]) for b in range(2 * s.n_robots + 2 * k)]
                p = Crowd._search(rng, s, bodies, radius[k], k)
                pos[k] = p
                j = 2 * s.n_robots + 2 * k
                centre[j], centre[j + 1], rad[j : j + 2] = p, -p, radius[k]
                k, tries = k + 1, 0
            chunk *= 2
        return pos, -pos

    @staticmethod
    def _search(rng: np.random.Generator, s: Scenario, bodies: list, r: float, k: int) -> np.ndarray:
        """The first of :meth:`_spots`, in an order drawn from ``rng``, whose start and antipodal goal keep
        clear of ``bodies`` (the random draws' test); ``ValueError`` if none does."""
        spots = Crowd._spots(s)
        spots = spots[rng.permutation(len(spots))]
        centre = np.array([c for c, _ in bodies])
        rad = np.array([rad for _, rad in bodies])
        fits = np.ones(len(spots), dtype=bool)
        for q in (spots, -spots):
            fits &= (np.linalg.norm(q[:, None] - centre[None], axis=-1) - rad - r >= s.min_separation).all(axis=1)
        if not fits.any():
            raise ValueError(
                f"could not place crowd obstacle {k} without overlap; "
                "increase layout_radius or reduce n_obstacles / min_separation"
            )
        return spots[np.argmax(fits)]

    @staticmethod
    def _spots(s: Scenario) -> np.ndarray:
        """Every start the random draw can give, on a grid ``(720 * 25, 2)`` [m]: 720 angles on the
        circle, each with a 5 x 5 grid of the +-0.5 m noise."""
        ang = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
        ring = s.circle_radius * np.stack((np.cos(ang), np.sin(ang)), axis=-1)
        off = np.stack(np.meshgrid(*2 * (np.linspace(-RING_NOISE, RING_NOISE, 5),)), axis=-1).reshape(-1, 2)
        return (ring[:, None] + off[None]).reshape(-1, 2)

    def view_extent(self, s: Scenario) -> float:
        return crowd_view(s)


class Custom(ScenarioKind):
    name = "custom"
    summary = "explicit arrays (:class:`~vcs_env.scenario.CustomLayout`), e.g. to reproduce a layout from a paper."
    reads = frozenset()

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
        check_scripted(s)

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
        check_goals(s, lay.goal, lay.obs_pos, lay.obs_radius)

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
        lay.segments = c._wall_array.copy()  # = np.array(c.walls), converted once
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


def kinds_help(width: int = 10) -> str:
    """One line per kind, ``name  summary`` (for docstrings and command-line help)."""
    return "\n".join(f"{name:<{width}} {kind.summary}" for name, kind in KINDS.items())


def generate(s: Scenario, rng: np.random.Generator) -> Layout:
    """Draw one world's initial state for scenario ``s`` from ``rng``; a kind from outside this package is checked
    (:func:`check_generated`; the built-in ones are held to their layouts by the tests, and a reset pays no check)."""
    kind = KINDS[s.kind]
    lay = kind.generate(s, rng)
    return lay if type(kind).__module__.startswith("vcs_env.") else check_generated(s, lay)


def check_generated(s: Scenario, lay) -> Layout:
    """``lay`` if it is a :class:`Layout` of ``s``: arrays of finite numbers of the scenario's sizes, no robot
    overlapping another or an obstacle at its start; else a ``ValueError`` naming the kind (a kind of one's own that
    gets these wrong failed deep in the simulator, or started its episodes in collision)."""
    said = f"kind {s.kind!r} generated"
    if not isinstance(lay, Layout):
        raise ValueError(f"{said} a {type(lay).__name__}, not a Layout (layouts.finish builds one)")
    n, m = s.n_robots, s.n_obstacles
    k = len(lay.segments) if np.ndim(lay.segments) == 3 else -1
    sizes = {"start": (n, 2), "goal": (n, 2), "heading": (n,), "speed": (n,), "obs_pos": (m, 2)}
    sizes |= {"obs_target": (m, 2), "obs_radius": (m,), "segments": (k, 2, 2)}
    for name, shape in sizes.items():
        value = np.asarray(getattr(lay, name))
        if value.shape != shape or value.dtype.kind not in "biuf" or not np.isfinite(value).all():
            raise ValueError(f"{said} {name} {value.shape} {value.dtype}: it must be finite numbers of shape {shape}")
    if k > segment_capacity(s):
        raise ValueError(f"{said} {k} wall segments, more than its n_segments(s) = {segment_capacity(s)}")
    r = s.robot.radius
    gap = np.linalg.norm(lay.start[:, None] - lay.start[None], axis=-1) - 2.0 * r + np.diag(np.full(n, np.inf))
    gap_obs = np.linalg.norm(lay.start[:, None] - lay.obs_pos[None], axis=-1) - r - lay.obs_radius[None]
    for what, g in (("robot", gap), ("obstacle", gap_obs)):
        if g.size and g.min() < -1e-9:  # placement's tolerance (check_ring, check_lanes)
            i, j = np.unravel_index(np.argmin(g), g.shape)
            raise ValueError(
                f"{said} robot {i} starting {-g[i, j]:.3f} m into {what} {j}: its check_layout should refuse this "
                "scenario (docs/extending.md)"
            )
    return lay


def check_kinds(kinds: dict[str, ScenarioKind]) -> dict[str, ScenarioKind]:
    """``kinds`` if every value is a :class:`ScenarioKind` instance, else a ``ValueError`` naming the entry."""
    for name, kind in kinds.items():
        if not isinstance(kind, ScenarioKind):
            hint = f": register an instance, {kind.__name__}()" if isinstance(kind, type) else ""
            raise ValueError(f"KINDS[{name!r}] must be a ScenarioKind instance, got {kind!r}{hint}")
    return kinds


def segment_capacity(s: Scenario) -> int:
    """Most wall segments a layout of scenario ``s`` has."""
    return KINDS[s.kind].n_segments(s)


def check_layout(s: Scenario) -> None:
    """Raise ``ValueError`` if the layout of ``s`` cannot be placed without overlap."""
    KINDS[s.kind].check_layout(s)


# Map kinds live in map_kinds.py, which builds on the blocks above (hence the import here).
from .map_kinds import Corridor, Doorway, Intersection, Room, Walls  # noqa: E402

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
