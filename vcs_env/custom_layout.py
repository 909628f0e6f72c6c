"""Explicit layouts for ``Scenario(kind="custom")``: robots' starts and goals, scripted obstacles and walls.

Both dataclasses check and normalise their fields at construction (``ValueError`` naming the field); they are
re-exported by :mod:`vcs_env.scenario`, where they belong to :class:`~vcs_env.scenario.Scenario`'s ``custom`` field.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import MISSING, dataclass, fields

import numpy as np

from .checks import R_REF, V_REF, check_range, user_stacklevel

COORD_LIMIT = 1e6
"""[m] Largest coordinate of a custom layout: beyond, squared distances lose all precision (a start at 1e155 m made
the progress reward NaN) and a float resolves centimetres no more."""


@dataclass(frozen=True)
class ObstacleTrajectory:
    """A scripted obstacle: piecewise-linear motion through timed waypoints, held after the last.

    A static obstacle is one waypoint; a constant-velocity one is two (start and end).
    """

    times: tuple[float, ...]
    """Strictly increasing waypoint times [s], the first one 0."""
    positions: tuple[tuple[float, float], ...]
    """Waypoints [m], one per time."""
    radius: float = 0.3
    """Body radius [m]."""

    def __post_init__(self) -> None:
        try:
            times = np.asarray(self.times, dtype=np.float64)
            positions = np.asarray(self.positions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"ObstacleTrajectory needs times (k,) [s] and positions (k, 2) [m] of numbers, got {self.times!r} and "
                f"{self.positions!r}"
            ) from None
        k = len(times) if times.ndim == 1 else -1
        if k < 1 or positions.shape != (k, 2):
            raise ValueError(
                "ObstacleTrajectory needs times of shape (k,) and positions of shape (k, 2), k >= 1, got "
                f"{times.shape} and {positions.shape}"
            )
        if not np.isfinite(times).all():
            raise ValueError(f"ObstacleTrajectory.times must be finite, got {tuple(times.tolist())}")
        times, positions = tuple(times.tolist()), tuple(map(tuple, positions.tolist()))
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "positions", positions)
        if times[0] != 0.0 or any(b <= a for a, b in zip(times, times[1:])):
            raise ValueError(f"ObstacleTrajectory.times must start at 0 and increase strictly, got {times}")
        if not all(math.isfinite(c) for p in positions for c in p):
            raise ValueError("ObstacleTrajectory.positions must be finite")
        if max(abs(c) for p in positions for c in p) > COORD_LIMIT:
            raise ValueError(f"ObstacleTrajectory.positions must be within +-{COORD_LIMIT:g} m (COORD_LIMIT)")
        check_range("ObstacleTrajectory.radius", self.radius, 0.0, R_REF, lo_open=True)
        speeds = [math.dist(positions[i + 1], positions[i]) / (times[i + 1] - times[i]) for i in range(len(times) - 1)]
        if speeds and max(speeds) > V_REF:
            raise ValueError(f"ObstacleTrajectory speed must be <= {V_REF} m/s, got {max(speeds):.3f}")


@dataclass(frozen=True)
class CustomLayout:
    """Explicit initial state for ``kind="custom"`` (all robots share the scenario's RobotSpec)."""

    start: tuple[tuple[float, float], ...]
    """Robot start positions [m], shape (n, 2)."""
    goal: tuple[tuple[float, float], ...]
    """Robot goals [m], shape (n, 2)."""
    heading: tuple[float, ...] | None = None
    """Initial headings [rad], shape (n,); default: facing the goal."""
    speed: tuple[float, ...] | None = None
    """Initial speeds [m/s], shape (n,); default 0."""
    obstacles: tuple[ObstacleTrajectory, ...] = ()
    """Scripted obstacles."""
    walls: tuple = ()
    """Static wall segments [m], shape (s, 2, 2): ``((ax, ay), (bx, by))`` each; a polygon is the
    closed chain :func:`vcs_env.walls.polygon_segments` of its vertices."""

    def __post_init__(self) -> None:
        def pts(name, value):
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                raise ValueError(f"CustomLayout.{name} must be an (n, 2) array of numbers [m], got {value!r}") from None
            if arr.ndim != 2 or arr.shape[1] != 2:
                raise ValueError(f"CustomLayout.{name} must be an (n, 2) array [m], got shape {arr.shape}")
            bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
            if bad.size:
                raise ValueError(f"CustomLayout.{name}[{bad[0]}] is not finite: {tuple(arr[bad[0]].tolist())}")
            far = np.flatnonzero(np.any(np.abs(arr) > COORD_LIMIT, axis=1))
            if far.size:
                raise ValueError(
                    f"CustomLayout.{name}[{far[0]}] = {tuple(arr[far[0]].tolist())} is beyond +-{COORD_LIMIT:g} m "
                    "(COORD_LIMIT): shift the layout toward the origin"
                )
            return tuple(map(tuple, arr.tolist()))

        object.__setattr__(self, "start", pts("start", self.start))
        object.__setattr__(self, "goal", pts("goal", self.goal))
        n = len(self.start)
        if n == 0 or len(self.goal) != n:
            raise ValueError(f"CustomLayout needs n >= 1 starts and as many goals, got {n} and {len(self.goal)}")
        for name in ("heading", "speed"):
            value = getattr(self, name)
            if value is not None:
                try:
                    flat = np.asarray(value)
                    if flat.dtype.kind not in "iuf":  # bools, strings, complex numbers: no heading or speed
                        raise TypeError
                    arr = flat.astype(np.float64)
                except (TypeError, ValueError):
                    raise ValueError(f"CustomLayout.{name} must be numbers, one per robot, got {value!r}") from None
                if name == "heading":  # far beyond a turn a float resolves no step's turn: wrapped (in range as given)
                    arr = np.where(np.abs(arr) > math.pi, np.mod(arr + math.pi, 2.0 * math.pi) - math.pi, arr)
                if arr.shape != (n,):
                    raise ValueError(f"CustomLayout.{name} must have shape ({n},) (one per robot), got {arr.shape}")
                if not np.all(np.isfinite(arr)):
                    raise ValueError(f"CustomLayout.{name}[{np.flatnonzero(~np.isfinite(arr))[0]}] is not finite")
                object.__setattr__(self, name, tuple(arr.tolist()))
        if self.speed is not None and min(self.speed) < 0:
            raise ValueError("CustomLayout.speed must be >= 0")
        from .walls import check_segments

        walls = check_segments(self.walls, "CustomLayout.walls")
        far = np.flatnonzero(np.any(np.abs(walls) > COORD_LIMIT, axis=(1, 2)))
        if far.size:  # squared lengths overflow from about 1e154 m: a wall that far is lost to every test
            raise ValueError(
                f"CustomLayout.walls[{far[0]}] = {tuple(map(tuple, walls[far[0]].tolist()))} reaches beyond "
                f"+-{COORD_LIMIT:g} m (COORD_LIMIT): shift the layout toward the origin"
            )
        object.__setattr__(self, "walls", tuple(tuple(map(tuple, w)) for w in walls.tolist()))
        walls.setflags(write=False)
        object.__setattr__(self, "_wall_array", walls)  # the walls as an (s, 2, 2) array, for every reset
        if isinstance(self.obstacles, ObstacleTrajectory) or not isinstance(self.obstacles, (tuple, list)):
            raise ValueError(f"CustomLayout.obstacles must be a tuple of ObstacleTrajectory, got {self.obstacles!r}")
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        for o in self.obstacles:
            if not isinstance(o, ObstacleTrajectory):
                raise ValueError(f"CustomLayout.obstacles must hold ObstacleTrajectory objects, got {type(o)}")


SCRIPTED = ("obstacle_motion", "obstacle_speed", "obstacle_radius", "bounce", "pedestrians", "turn_rate", "turn_period",
            "go_time", "stop_time")  # fmt: skip
"""Scenario fields a custom layout's obstacles ignore: they follow their scripts (``CustomLayout.obstacles``)."""


def check_scripted(s) -> None:
    """A ``ValueError`` for a custom scenario ``s`` whose initial speeds exceed ``v_max``, or that sets a field of
    ``SCRIPTED`` away from its default: it could not change the episodes (``Scenario(kind="custom", bounce=True)``
    would otherwise be accepted and ignored)."""
    if s.custom.speed is not None and max(s.custom.speed) > s.robot.v_max:
        raise ValueError(f"custom.speed must be <= robot.v_max = {s.robot.v_max}, got {max(s.custom.speed)}")
    for f in fields(s):
        default = f.default if f.default_factory is MISSING else f.default_factory()
        value = getattr(s, f.name)
        if f.name in SCRIPTED and (tuple(value) if isinstance(value, list) else value) != default:
            raise ValueError(
                f"{f.name} does not apply to custom scenarios: their obstacles follow their scripts "
                "(CustomLayout.obstacles, ObstacleTrajectory times, positions and radius); leave it out"
            )


def check_goals(s, goal: np.ndarray, obs_radius: np.ndarray) -> None:
    """A ``ValueError`` for a goal of custom scenario ``s`` no robot can arrive at (come within ``r_goal`` of, clear of
    the other bodies): inside an obstacle where it comes to rest (its last waypoint, which it holds for good;
    ``obs_radius`` ``(m,)`` [m]), or, with finished robots parked (``park_finished``), too close to another robot's
    goal for both to park. ``goal`` ``(n, 2)`` [m]."""
    r, reach = s.robot.radius, s.r_goal
    for k, o in enumerate(s.custom.obstacles):  # an obstacle holds its last waypoint for good
        gap = np.linalg.norm(goal - np.asarray(o.positions[-1]), axis=-1) + reach - r - obs_radius[k]
        if np.any(gap < 0):
            still = "still obstacle" if len(o.times) == 1 else "obstacle"
            rest = "" if len(o.times) == 1 else f" where it comes to rest (its last waypoint, from {o.times[-1]:g} s)"
            raise ValueError(
                f"custom layout: the goal of robot {int(np.argmin(gap))} lies inside {still} {k}{rest} (no robot can "
                f"come within r_goal={reach:g} m of it)"
            )
    if s.park_finished and len(goal) > 1:
        gap = np.linalg.norm(goal[:, None] - goal[None], axis=-1) + 2 * reach - 2 * r
        np.fill_diagonal(gap, np.inf)
        if np.any(gap < 0):
            i, j = np.unravel_index(np.argmin(gap), gap.shape)
            raise ValueError(
                f"custom layout: the goals of robots {min(i, j)} and {max(i, j)} are too close for both to park there "
                f"(finished robots stay; their centres {2 * r:g} m apart, each within r_goal={reach:g} m of its goal)"
            )
        if np.any(gap < 4 * reach - 1e-9):  # both fit only if neither parks toward the other within its r_goal
            i, j = np.unravel_index(np.argmin(gap), gap.shape)
            d = float(np.linalg.norm(goal[i] - goal[j]))
            warnings.warn(
                f"custom layout: the goals of robots {min(i, j)} and {max(i, j)} are {d:.3g} m apart, less than two "
                f"radii and twice r_goal ({2 * r + 2 * reach:g} m): a robot parks where it first comes within "
                f"r_goal={reach:g} m of its goal, and one parked toward the other's goal may leave no room there",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
