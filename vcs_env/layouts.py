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
    (:func:`agents.config.build_scenario`; ``arena_half_size`` also applies where obstacles are placed in the arena,
    :attr:`obstacles_in_arena`, bounce off its edges or walk as pedestrians in it)."""
    obstacles_in_arena: bool = True
    """Whether its obstacles (``n_obstacles`` > 0) are placed at random in the arena (:func:`place_obstacles`, as the
    kinds here but the crowd's ring and the custom scripts), so that ``arena_half_size`` shapes them."""

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


class Custom(ScenarioKind):
    name = "custom"
    obstacles_in_arena = False  # they follow their scripts
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
        check_goals(s, lay.goal, lay.obs_radius)

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
    kind = kind_of(s)
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
        setattr(lay, name, value.astype(np.float64))  # lists of numbers, or integers, as the simulator reads them
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
    return kind_of(s).n_segments(s)


def kind_of(s: Scenario) -> ScenarioKind:
    """The registered kind of ``s``; a ``ValueError`` naming it if none is (a scenario of a kind of one's own, e.g.
    unpickled where the kind was never registered)."""
    try:
        return KINDS[s.kind]
    except KeyError:
        raise ValueError(
            f"no scenario kind {s.kind!r} is registered: register it (vcs_env.layouts.KINDS[{s.kind!r}] = ...) "
            "before using its scenarios"
        ) from None


def check_layout(s: Scenario) -> None:
    """Raise ``ValueError`` if the layout of ``s`` cannot be placed without overlap."""
    kind_of(s).check_layout(s)


# The crowd and map kinds live in crowd_kind.py and map_kinds.py, which build on the blocks above (hence the
# imports here).
from .crowd_kind import Crowd  # noqa: E402
from .map_kinds import Corridor, Doorway, Intersection, Room, Walls  # noqa: E402


class KindRegistry(dict):
    """The kinds by name: a dict that refuses to replace a built-in kind (its presets and suites would run another
    layout under their names and fingerprints) and takes only :class:`ScenarioKind` instances."""

    def __setitem__(self, name: str, kind: ScenarioKind) -> None:
        if name in BUILT_IN and type(kind) is not BUILT_IN[name]:
            raise ValueError(
                f"KINDS[{name!r}] is the built-in {name} kind: its presets and suites would run your layout under "
                "their names; register yours under another name"
            )
        check_kinds({name: kind})
        super().__setitem__(name, kind)


BUILT_IN: dict[str, type] = {
    k.name: k
    for k in (Circle, Swap, Crossing, Random, Crowd, Dynamic, Custom, Corridor, Doorway, Room, Intersection, Walls)
}
KINDS: dict[str, ScenarioKind] = KindRegistry({name: kind() for name, kind in BUILT_IN.items()})
"""Every scenario kind by name (the values ``Scenario.kind`` accepts); a kind of one's own is registered with
``KINDS["name"] = Kind()`` (docs/extending.md), a built-in one is not replaced."""
