"""Scenarios: frozen, validated descriptions of an episode family, and the named presets.

A :class:`Scenario` says what to place where (``kind`` and its layout fields), how robots move
(:class:`RobotSpec`), how obstacles move, when an episode ends and how it is rewarded
(:class:`RewardWeights`). Invalid values raise :class:`ValueError` naming the field and its
allowed range at construction. Variants come from :func:`dataclasses.replace` or
:func:`make_scenario`::

    >>> from vcs_env import make_scenario
    >>> s = make_scenario("circle", n_robots=16)
    >>> s.n_robots, s.circle_radius
    (16, 5.0)

The kinds of layout are objects in :data:`vcs_env.layouts.KINDS`; each generates, checks and
sizes its layout and documents itself (``print(vcs_env.layouts.kinds_help())``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from .checks import (  # noqa: F401
    A_REF,
    LEAST_LIMIT,
    OMEGA_REF,
    R_REF,
    V_REF,
    check_choice,
    check_flag,
    check_int,
    check_interval,
    check_range,
)
from .custom_layout import CustomLayout, ObstacleTrajectory  # noqa: F401  (re-exported: Scenario's custom layouts)
from .lidar import LidarSpec
from .pedestrians import PedestrianSpec

MOTIONS = ("static", "constant", "patrol", "arbitrary", "stop_and_go", "pedestrians")
COLLISION_MODES = ("terminate", "continue")


def _kinds(checked: bool = False):
    from .layouts import KINDS, check_kinds  # late import: the kinds read this module's dataclasses

    return check_kinds(KINDS) if checked else KINDS


class UnknownFieldError(TypeError, ValueError):
    """Keyword arguments that are no :class:`Scenario` field: a ``ValueError`` as every bad scenario input, and a
    ``TypeError`` as Python's own unexpected keyword argument, which wrappers that retry without an optional keyword
    catch (TorchRL's ``GymEnv`` passes ``frameskip`` and retries without it on a ``TypeError`` in Python's wording)."""


def _suites():
    from .suites import SUITES  # late import: the suites are built from this module's presets

    return SUITES


MAX_STEPS = 10**7
"""The longest step limit of an episode (``Scenario.max_steps``, and the envs' own limits)."""


@dataclass(frozen=True)
class RobotSpec:
    """Body and motion limits of every robot of a scenario."""

    radius: float = 0.25
    """Body radius [m], in (0, 2]."""
    v_max: float = 1.0
    """Top speed [m/s], in (0, 3]. Unicycle robots never reverse: 0 <= speed <= v_max."""
    a_max: float = 0.5
    """Largest speed change per second [m/s^2], in [0.001, 10]; |dv| <= a_max * dt per step."""
    omega_max: float = math.pi / 2
    """Largest turn rate [rad/s], in [0.001, 2 pi]; |dtheta| <= omega_max * dt per step (unicycle)."""
    holonomic: bool = False
    """If True the velocity vector may change in any direction by up to a_max * dt per step and
    the heading is the direction of motion (no turn-rate limit). Default: unicycle."""

    def __post_init__(self) -> None:
        check_range("robot.radius", self.radius, 0.0, R_REF, lo_open=True)
        check_range("robot.v_max", self.v_max, 0.0, V_REF, lo_open=True)
        # Limits below LEAST_LIMIT (a_max, omega_max, dt): the expert counts steps of a_max dt (omega_max dt, dt), and
        # a step of 1e-9 made each decision take seconds (a robot of 1e-3 m/s^2 needs 1000 s to reach 1 m/s).
        check_range("robot.a_max", self.a_max, LEAST_LIMIT, A_REF)
        check_range("robot.omega_max", self.omega_max, LEAST_LIMIT, OMEGA_REF)
        object.__setattr__(self, "holonomic", check_flag("robot.holonomic", self.holonomic))


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the named reward terms; the reward is the weighted sum of the terms.

    Terms (per robot and step; each in use is reported in ``info["reward_terms"]`` before weighting: the first four
    always, the others only when weighted, :attr:`vcs_env.rewards.RewardTerm.only_when_weighted`):
    ``progress`` = decrease of the remaining route length [m] (the goal distance on open floor;
    among walls the route around them, :class:`vcs_env.rewards.Progress`); ``arrival`` = 1 on the step the goal is
    reached; ``collision`` = -1 on every step the robot touches something; ``time`` = -dt [s];
    ``vcs_imitation`` = -distance between the taken and the expert action in the velocity change window, scaled to
    [-1, 0] (needs an expert; both actions clipped to the box [-1, 1]^2: a holonomic robot's action beyond the unit
    disc, which drives as its point on the disc, is scored as given); ``vcs_potential`` = gamma * phi(s') - phi(s) with
    phi = minus the expert's optimal cost of the state, 0 on reaching the goal and its floor on a terminating collision
    (needs an expert; see :func:`vcs_env.rewards.potential_term`);
    ``danger`` = ``-dt * max_j exp(-t_j / DANGER_TIME)`` [s], ``t_j`` the time until the robot
    would touch robot or obstacle ``j`` if both kept their velocities (0 when touching; walls not
    counted; :class:`vcs_env.rewards.Danger`); ``arrival_speed`` = ``-v / v_max`` on the step the
    goal is reached, ``v`` the speed [m/s] when that step began (:class:`vcs_env.rewards.ArrivalSpeed`);
    ``stuck`` = -dt [s] per step while the VCS expert's stall rule counts the robot as stuck (a detour
    begun since it last gained ground on its goal; needs ``stall_clock``, :class:`vcs_env.rewards.Stuck`).
    Each term is an object in :data:`vcs_env.rewards.TERMS`.
    """

    progress: float = 1.0
    arrival: float = 10.0
    collision: float = 10.0
    time: float = 0.5
    vcs_imitation: float = 0.0
    vcs_potential: float = 0.0
    danger: float = 0.0
    arrival_speed: float = 0.0
    stuck: float = 0.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            check_range(f"rewards.{f.name}", getattr(self, f.name), -1e6, 1e6)

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class Scenario:
    """A family of episodes: layout, robots, obstacles, sensing, termination and rewards."""

    kind: str = "circle"
    """The kind of layout, a name in :data:`vcs_env.layouts.KINDS` (what its fields below mean)."""
    n_robots: int = 8
    """Number of robots n, in [1, 256]; even for ``swap``, >= 2 for ``crossing``."""
    n_obstacles: int = 0
    """Number of passive obstacles m, in [0, 256] (custom: the number of trajectories)."""
    layout_radius: float | None = None
    """Circle radius for circle/crowd, half lane length for swap/crossing [m]; None picks
    max(5, 0.3 n) for circle and 5 otherwise."""
    arena_half_size: float = 6.0
    """Half side of the square arena [m] for random placement and obstacle bouncing."""
    lane_spacing: float = 1.2
    """Distance between neighbouring lanes (swap) or robots in a group (crossing) [m]."""
    jitter: float = 0.0
    """Uniform noise on start positions [m] (circle, swap, crossing and the map kinds); 0 = perfectly symmetric."""
    min_separation: float = 0.3
    """Smallest gap between spawned bodies and between starts/goals [m]."""
    initial_speed: float = 0.0
    """Initial robot speed [m/s] (robots start facing their goal)."""
    dt: float = 0.1
    """Sensing-acting period [s], in [0.001, 1] (``LEAST_LIMIT``)."""
    robot: RobotSpec = field(default_factory=RobotSpec)
    """Robot body and limits."""
    obstacle_motion: str = "static"
    """Motion of generated obstacles: static, constant, patrol, arbitrary, stop_and_go, pedestrians."""
    obstacle_radius: tuple[float, float] = (0.2, 0.4)
    """Obstacle radius range [m], drawn uniformly."""
    obstacle_speed: tuple[float, float] = (0.2, 0.7)
    """Obstacle speed range [m/s], drawn uniformly (ignored by static)."""
    turn_rate: float = 0.6
    """``arbitrary``: turn rates are drawn from U(-turn_rate, turn_rate) [rad/s] ..."""
    turn_period: float = 2.0
    """... and redrawn every turn_period [s]."""
    go_time: tuple[float, float] = (2.0, 5.0)
    """``stop_and_go``: duration range of a moving phase [s]."""
    stop_time: tuple[float, float] = (1.0, 3.0)
    """``stop_and_go``: duration range of a stopped phase [s]."""
    bounce: bool = False
    """Obstacles bounce off the arena walls (``arena_half_size``)."""
    r_goal: float = 0.1
    """A robot arrives when its centre passes within r_goal of its goal [m], and stops inside that disc."""
    r_ca: float = 6.0
    """Sensing radius [m]: a robot observes objects whose centres are within r_ca."""
    n_neighbors: int = 8
    """K, the number of nearest objects in each observation, in [1, 64]."""
    max_steps: int = 600
    """Episode length limit in steps (truncation)."""
    on_collision: str = "terminate"
    """``terminate``: a robot that touches anything stops where it first touched (swept) and its
    episode ends; ``continue``: it keeps driving (for evaluating planners), every contact step is
    still reported."""
    park_finished: bool = True
    """Robots that arrived (or crashed) stay in the world as static obstacles; if False they
    leave the world (no collisions, not observed)."""
    rewards: RewardWeights = field(default_factory=RewardWeights)
    """Reward weights."""
    corridor_width: float = 2.0
    """Width between the walls of a corridor (``corridor``, ``intersection``) [m]."""
    door_width: float = 1.2
    """Width of a door (``doorway``, ``room``) [m]."""
    n_walls: int = 8
    """``walls``: number of random wall segments in the arena (besides its four sides), in [0, 256]."""
    wall_length: tuple[float, float] = (1.0, 3.0)
    """``walls``: length range of the random wall segments [m], drawn uniformly."""
    custom: CustomLayout | None = None
    """Explicit layout, required by and only allowed with ``kind="custom"``."""
    lidar: LidarSpec | None = None
    """Optional lidar beams appended to every robot's observation (:mod:`vcs_env.lidar`); None: off."""
    n_wall_points: int = 0
    """Optional block of the ``n_wall_points`` nearest points on walls appended to every robot's
    observation after the lidar (:func:`vcs_env.walls.nearest_wall_points`); 0: off."""
    wall_segments: bool = False
    """With ``n_wall_points``, each nearest point on a wall also gives the wall segment it lies on: its
    direction and how far it runs on either side of the point (four more fields, ``tx, ty, back, ahead``);
    False: three fields, as before."""
    stall_clock: bool = False
    """Keep each robot's stall clock (:mod:`vcs_env.stall`: how long it has been stuck and the detour the
    expert's stall rule gives it) and append it to every robot's observation after the neighbours, before the
    lidar and the wall points (the ``clock`` block, observation v2 only); False: off."""
    observation: int = 2
    """Observation version (:mod:`vcs_env.observations`): 2, the default, or 1 (what v1 checkpoints read)."""
    pedestrians: PedestrianSpec | None = None
    """How the obstacles walk with ``obstacle_motion="pedestrians"`` (:mod:`vcs_env.pedestrians`);
    None: ``PedestrianSpec()``. Only allowed with that motion."""

    def __post_init__(self) -> None:
        check_choice("kind", self.kind, list(_kinds(checked=True)))  # checked here, not at every look-up
        if not isinstance(self.robot, RobotSpec):
            raise ValueError(f"robot must be a RobotSpec, got {type(self.robot).__name__}")
        if not isinstance(self.rewards, RewardWeights):
            raise ValueError(f"rewards must be a RewardWeights, got {type(self.rewards).__name__}")
        check_int("n_robots", self.n_robots, 1, 256)
        check_int("n_obstacles", self.n_obstacles, 0, 256)
        _kinds()[self.kind].validate(self)
        if self.layout_radius is not None:
            check_range("layout_radius", self.layout_radius, 0.0, 1e4, lo_open=True)
        check_range("arena_half_size", self.arena_half_size, 0.0, 1e4, lo_open=True)
        check_range("lane_spacing", self.lane_spacing, 0.0, 1e3, lo_open=True)
        check_range("jitter", self.jitter, 0.0, 1e3)
        check_range("min_separation", self.min_separation, 0.0, 1e3)
        check_range("initial_speed", self.initial_speed, 0.0, self.robot.v_max)
        check_range("dt [s]", self.dt, LEAST_LIMIT, 1.0)
        check_choice("obstacle_motion", self.obstacle_motion, MOTIONS)
        check_interval("obstacle_radius", self.obstacle_radius, 1e-3, R_REF)
        check_interval("obstacle_speed", self.obstacle_speed, 0.0, V_REF)
        check_range("turn_rate", self.turn_rate, 0.0, OMEGA_REF)
        check_range("turn_period", self.turn_period, 0.0, 1e4, lo_open=True)
        check_interval("go_time", self.go_time, 1e-3, 1e4)
        check_interval("stop_time", self.stop_time, 0.0, 1e4)
        if not isinstance(self.bounce, bool) or not isinstance(self.park_finished, bool):
            raise ValueError("bounce and park_finished must be bools")
        check_range("r_goal", self.r_goal, 0.0, 1e3, lo_open=True)
        check_range("r_ca", self.r_ca, 0.0, 1e4, lo_open=True)
        check_int("n_neighbors", self.n_neighbors, 1, 64)
        check_int("max_steps", self.max_steps, 1, MAX_STEPS)
        check_choice("on_collision", self.on_collision, COLLISION_MODES)
        check_range("corridor_width", self.corridor_width, 0.0, 1e3, lo_open=True)
        check_range("door_width", self.door_width, 0.0, 1e3, lo_open=True)
        check_int("n_walls", self.n_walls, 0, 256)
        check_interval("wall_length", self.wall_length, 0.01, 1e3)
        for name in ("obstacle_radius", "obstacle_speed", "go_time", "stop_time", "wall_length"):  # lists from JSON
            object.__setattr__(self, name, tuple(getattr(self, name)))
        check_int("n_wall_points", self.n_wall_points, 0, 64)
        check_int("observation", self.observation, 1, 2)
        object.__setattr__(self, "wall_segments", check_flag("wall_segments", self.wall_segments))
        if self.wall_segments and not self.n_wall_points:
            raise ValueError("wall_segments needs the wall points block: set n_wall_points > 0 (--n-wall-points)")
        if self.wall_segments and self.observation < 2:
            raise ValueError("wall_segments needs observation version 2 (v1's wall points have three fields)")
        object.__setattr__(self, "stall_clock", check_flag("stall_clock", self.stall_clock))
        if self.stall_clock and self.observation < 2:
            raise ValueError("stall_clock needs observation version 2 (the clock block is not part of v1)")
        if self.rewards.stuck != 0.0 and not self.stall_clock:
            raise ValueError(
                "the stuck reward term needs each robot's stall clock: set stall_clock=True (--stall-clock)"
            )
        if self.lidar is not None and not isinstance(self.lidar, LidarSpec):
            raise ValueError(f"lidar must be a vcs_env.lidar.LidarSpec or None, got {type(self.lidar).__name__}")
        if self.pedestrians is not None:
            if not isinstance(self.pedestrians, PedestrianSpec):
                raise ValueError(f"pedestrians must be a PedestrianSpec or None, got {type(self.pedestrians).__name__}")
            if self.obstacle_motion != "pedestrians":
                raise ValueError(
                    f"pedestrians needs obstacle_motion='pedestrians', got {self.obstacle_motion!r} (for another "
                    "motion on a scenario with pedestrians, give pedestrians=None too)"
                )
        if self.bounce and self.n_obstacles:
            walkers = self.obstacle_motion == "pedestrians"
            fastest = (self.pedestrians or PedestrianSpec()).top_speed if walkers else self.obstacle_speed[1]
            room = self.arena_half_size - self.obstacle_radius[1]
            if fastest * self.dt > room:  # a reversed step would carry the disc out through the opposite edge
                raise ValueError(
                    f"bouncing obstacles at up to {fastest:g} m/s move {fastest * self.dt:g} m in a step of "
                    f"dt={self.dt:g} s, more than the {room:g} m from the arena's centre to where their edge meets its "
                    "wall (arena_half_size - the largest obstacle_radius): they would leave the arena; reduce dt or "
                    "the obstacles' speed, or increase arena_half_size"
                )
        _kinds()[self.kind].check_layout(self)
        if (
            self.n_obstacles
            and self.obstacle_motion == "pedestrians"
            and (self.pedestrians or PedestrianSpec()).goal_policy == "square"
        ):
            from .obstacles import check_square_crossing  # late: obstacles imports this module

            check_square_crossing(self)

    # Derived quantities are properties, never defaults computed from other fields.
    @property
    def has_walls(self) -> bool:
        """Whether the worlds have static walls (a map kind, a custom layout with walls, or a kind of one's own that
        places some: ``ScenarioKind.n_segments``)."""
        return self.kind in MAPS or _kinds()[self.kind].n_segments(self) > 0

    @property
    def circle_radius(self) -> float:
        """Layout radius actually used [m] (see ``layout_radius``)."""
        if self.layout_radius is not None:
            return float(self.layout_radius)
        return _kinds()[self.kind].default_radius(self)

    @property
    def max_time(self) -> float:
        """Episode time limit [s]."""
        return self.max_steps * self.dt

    @property
    def least_time_to_goal(self) -> float:
        """A lower bound on the time [s] every robot needs to reach its goal at ``v_max`` from the
        layout's geometry alone (0.0 where the kind gives none). When it exceeds :attr:`max_time`,
        no robot can arrive before the episode is truncated."""
        return _kinds()[self.kind].least_trip(self) / self.robot.v_max

    @property
    def world_extent(self) -> float:
        """A generous half size of the area of an episode [m] (placement bounds; observations do
        not depend on it since observation v1)."""
        return _kinds()[self.kind].world_extent(self)

    @property
    def view_extent(self) -> float:
        """Half size of the square drawn by the renderers [m]: the starts, goals and spawn area."""
        return _kinds()[self.kind].view_extent(self)

    def with_robot(self, **changes) -> Scenario:
        """Copy with some RobotSpec fields replaced (``s.with_robot(v_max=2.0)``)."""
        return dataclasses.replace(self, robot=dataclasses.replace(self.robot, **changes))


SCENARIOS: dict[str, Scenario] = {
    "circle": Scenario(kind="circle", n_robots=8),
    "swap": Scenario(kind="swap", n_robots=2, lane_spacing=1.2),
    "crossing": Scenario(kind="crossing", n_robots=6, layout_radius=5.0),
    "random": Scenario(kind="random", n_robots=6, arena_half_size=5.0),
    "crowd": Scenario(
        kind="crowd",
        n_robots=1,
        n_obstacles=5,
        layout_radius=4.0,
        obstacle_motion="constant",
        obstacle_radius=(0.3, 0.3),
        obstacle_speed=(0.5, 1.0),
        max_steps=300,
    ),
    "dynamic": Scenario(
        kind="dynamic",
        n_robots=4,
        n_obstacles=6,
        arena_half_size=6.0,
        obstacle_motion="arbitrary",
        bounce=True,
        obstacle_speed=(0.2, 0.6),
    ),
    "custom": Scenario(
        kind="custom",
        n_robots=2,
        n_obstacles=1,
        max_steps=300,
        custom=CustomLayout(
            start=((-5.0, 0.0), (5.0, 0.2)),
            goal=((5.0, 0.0), (-5.0, 0.2)),
            obstacles=(ObstacleTrajectory(times=(0.0, 20.0), positions=((0.0, -6.0), (0.0, 6.0)), radius=0.4),),
        ),
    ),
}
"""Named presets; build variants with :func:`make_scenario` or ``dataclasses.replace``."""


MAPS: dict[str, Scenario] = {
    "corridor": Scenario(kind="corridor", n_robots=4, corridor_width=2.5, max_steps=400),
    "doorway": Scenario(kind="doorway", n_robots=4, arena_half_size=4.0, layout_radius=2.5, max_steps=400),
    "room": Scenario(kind="room", n_robots=4, max_steps=400),
    "intersection": Scenario(kind="intersection", n_robots=4, corridor_width=2.5, max_steps=400),
    "walls": Scenario(kind="walls", n_robots=4, n_walls=8, max_steps=600),
}
"""Named presets with static walls (:mod:`vcs_env.walls`), one per map kind; ``make_scenario``
finds them like :data:`SCENARIOS`. They stay out of :data:`SCENARIOS` (which the VCS expert must
solve on every seed) until the VCS planner's kernel sees walls."""


def make_scenario(name_or_scenario: str | Scenario = "circle", **overrides) -> Scenario:
    """A preset by name, a suite's scenario by the suite's name (``"crowd-20-v0"``: :data:`vcs_env.suites.SUITES`,
    with all its conventions), or a given scenario, with fields replaced by ``overrides``.

    ``robot``, ``rewards``, ``lidar``, ``pedestrians`` and ``custom`` may be given as dicts: the fields to change
    (all of them where the base has none), so a run record's scenario (``record["scenario"]``, JSON) makes the
    scenario again: ``make_scenario(s["kind"], **s)``. A ``custom`` layout given for a custom scenario sets
    ``n_robots`` and ``n_obstacles`` to its own counts unless they are given too.
    """
    if isinstance(name_or_scenario, Scenario):
        base = name_or_scenario
    elif isinstance(name_or_scenario, str) and (name_or_scenario in SCENARIOS or name_or_scenario in MAPS):
        base = SCENARIOS.get(name_or_scenario) or MAPS[name_or_scenario]
    elif isinstance(name_or_scenario, str) and name_or_scenario in _suites():
        base = _suites()[name_or_scenario].scenario
    else:
        kind = isinstance(name_or_scenario, str) and name_or_scenario in _kinds()
        hint = (
            f" ({name_or_scenario!r} is a kind without a preset: Scenario(kind={name_or_scenario!r}))" if kind else ""
        )
        raise ValueError(
            f"unknown scenario {name_or_scenario!r}; give a preset ({sorted({**SCENARIOS, **MAPS})}) or a suite name "
            f"(e.g. crowd-20-v0; vcs_env.suites.SUITES lists them){hint}"
        )
    if not overrides:
        return base
    names = {f.name for f in dataclasses.fields(Scenario)}
    unknown = set(overrides) - names
    if unknown:
        python = ", ".join(f"unexpected keyword argument {k!r}" for k in sorted(unknown))  # Python's own wording
        raise UnknownFieldError(
            f"unknown Scenario fields {sorted(unknown)} ({python}); valid fields are {sorted(names)}"
        )
    nested = {"robot": RobotSpec, "rewards": RewardWeights, "lidar": LidarSpec, "pedestrians": PedestrianSpec}
    for key, cls in (nested | {"custom": CustomLayout}).items():
        if isinstance(overrides.get(key), dict):
            current, given = getattr(base, key), dict(overrides[key])
            valid = {f.name for f in dataclasses.fields(cls)}
            wrong = sorted(set(given) - valid)
            if wrong:
                raise ValueError(f"unknown {key} fields {wrong}; valid {key} fields are {sorted(valid)}")
            if key == "custom" and isinstance(given.get("obstacles"), (list, tuple)):  # as JSON holds them
                given["obstacles"] = tuple(
                    ObstacleTrajectory(**o) if isinstance(o, dict) else o for o in given["obstacles"]
                )
            overrides[key] = cls(**given) if current is None else dataclasses.replace(current, **given)
    if base.kind == "custom" and overrides.get("kind", "custom") != "custom":
        overrides.setdefault("custom", None)
    layout = overrides.get("custom")
    if isinstance(layout, CustomLayout) and overrides.get("kind", base.kind) == "custom":  # counts from the layout
        overrides.setdefault("n_robots", len(layout.start))
        overrides.setdefault("n_obstacles", len(layout.obstacles))
    return dataclasses.replace(base, **overrides)


TIME_MARGIN = 2.0
"""A time limit under this many times :attr:`Scenario.least_time_to_goal` is too short for robots
that must also avoid each other (:func:`fit_time_limit`)."""


def short_time_limit(scenario: Scenario, name: str = "max_steps") -> str | None:
    """A note when ``scenario.max_steps`` (given as ``name``) leaves no robot the time to reach its goal even on a
    straight run at top speed (:attr:`Scenario.least_time_to_goal`), with the least limit that would, else None."""
    need = scenario.least_time_to_goal
    if need <= scenario.max_time:
        return None
    return (
        f"{name}={scenario.max_steps} ({scenario.max_time:g} s at dt={scenario.dt:g} s) leaves no robot the time "
        f"to arrive: each must travel at least {need * scenario.robot.v_max:.1f} m ({need:.1f} s at v_max, "
        f"{name} >= {math.ceil(need / scenario.dt - 1e-9)})"
    )


def fit_time_limit(scenario: Scenario, base: Scenario) -> tuple[Scenario, str | None]:
    """``scenario`` with ``max_steps`` grown for a layout that outgrew ``base``'s, and a note saying so.

    Circles, swaps, crossings and crowds grow with ``n_robots`` or ``layout_radius``, while a preset's
    ``max_steps`` is sized for its own layout (``n_robots=256`` makes a 76.8 m circle that nobody
    crosses in the circle preset's 60 s). A limit under :data:`TIME_MARGIN` times the least time to
    the goal grows in proportion to the least trip from ``base`` (the preset or suite the scenario was
    made from, same kind), and to at least :data:`TIME_MARGIN` times that time. Kinds whose layout spans the arena
    (those that read ``arena_half_size``: random, dynamic, doorway and walls layouts) grow it in proportion to an
    arena larger than ``base``'s. Otherwise ``(scenario, None)``.
    """
    if base.kind != scenario.kind:
        return scenario, None
    steps, why = scenario.max_steps, ""
    need, base_need = scenario.least_time_to_goal, base.least_time_to_goal  # [s]
    if TIME_MARGIN * need > scenario.max_time and base_need > 0.0:
        steps = max(math.ceil(base.max_steps * need / base_need), math.ceil(TIME_MARGIN * need / scenario.dt))
        why = f"every robot must travel at least {need * scenario.robot.v_max:.1f} m"
    if "arena_half_size" in _kinds()[scenario.kind].reads and scenario.arena_half_size > base.arena_half_size:
        wide = math.ceil(base.max_steps * scenario.arena_half_size / base.arena_half_size)
        if wide > steps:
            steps, half = wide, scenario.arena_half_size
            why = f"the arena's half size is {half:g} m (the scenario it grew from: {base.arena_half_size:g} m)"
    if steps <= scenario.max_steps:
        return scenario, None
    note = (
        f"max_steps {scenario.max_steps} -> {steps} ({steps * scenario.dt:g} s): on this {scenario.kind} layout "
        f"{why}, and the time limit grows with it"
    )
    return dataclasses.replace(scenario, max_steps=steps), note
