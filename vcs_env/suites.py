"""Named, versioned evaluation suites: a fixed scenario and a fixed list of seeds.

A number reported for ``circle-16-v0`` can be reproduced by anyone with one command::

    vcs-env evaluate --suite circle-16-v0 --policy vcs

=============================== ======== =============================================================
suite                           episodes content
=============================== ======== =============================================================
``circle-8-v0``                 100      8 robots to the antipodes of a circle of radius 5 m
``circle-16-v0``                100      16 robots, circle radius 6 m
``circle-24-v0``                50       24 robots, circle radius 7 m
``circle-40-v0``                10       40 robots, circle radius 11 m, 90 s
``circle-40-symmetric-v0``      10       the same from perfectly symmetric starts (no jitter)
``random-dense-v0``             100      12 robots, random starts and goals in an 8 m square (robots
                                         park inside the traffic)
``swap-v0``                     100      6 robots = 3 head-on pairs on lanes 1.2 m apart, 10 m long
``crossing-v0``                 100      two groups of 4 crossing at 90 degrees, 10 m long
``crowd-5-v0``                  100      1 robot among 5 non-reactive obstacles (CrowdNav circle
                                         crossing, radius 4 m, constant velocity 0.5-1 m/s)
``crowd-10-v0``                 100      1 robot among 10 non-reactive obstacles, radius 5 m
``crowd-20-v0``                 100      1 robot among 20 non-reactive obstacles, radius 6 m
``dynamic-v0``                  100      4 robots, random starts and goals, among 6 obstacles on
                                         arbitrary (random-turning, wall-bouncing) trajectories
``corridor-v0``                 100      6 robots, two-way traffic in a corridor 2.5 m wide
``doorway-v0``                  100      6 robots, two groups swap sides through a 1.2 m door
``door-headon-v0``              20       2 robots head-on through a door 0.7 m wide (one robot
                                         diameter + 0.2 m), perfectly symmetric
``room-v0``                     100      8 robots leave a 6 m room with a 1.2 m door on each side
``intersection-v0``             100      8 robots, two groups cross where two 2.5 m corridors meet
``walls-v0``                    100      6 robots, random starts and goals among 12 random walls
``corridor-narrow-v0``          100      6 robots, two-way traffic in a corridor 1.7 m wide (two
                                         robot diameters + 0.7 m)
``dynamic-fast-v0``             100      ``dynamic-v0`` with obstacles at 1.2-1.8 m/s, faster than
                                         the robots (1.2-1.8 v_max)
``random-dense-holonomic-v0``   100      ``random-dense-v0`` with holonomic robots
=============================== ======== =============================================================

The map suites (``corridor``, ``doorway``, ``door-headon``, ``room``, ``intersection``, ``walls``,
``corridor-narrow``) have static walls (:mod:`vcs_env.walls`); every planner aims at
the route layer's waypoints (:mod:`vcs_env.routes`).

Every suite has a ``-smoke`` variant (``circle-16-v0-smoke``, ...) for CI: its first 3 seeds,
and fewer robots where the full suite is big (``circle-24-v0-smoke`` has 12, the 40-robot
circles 16). Smoke numbers
are not results; they only show that a policy runs.

Conventions:

* **Collisions are counted, not ended** (``on_collision="continue"``). With ``"terminate"`` a
  robot that touches anything stops and becomes a parked obstacle; the rest of its episode is
  lost (does it still arrive? how often does it touch again?) and the other robots then face
  a different problem, so two planners would no longer be scored on the same situations. An
  episode with any contact still counts as a collision (:mod:`vcs_env.metrics`).
* Circle, swap and crossing starts carry 0.1 m of jitter: without it every seed gives the same
  layout, and a deterministic planner would play one episode 100 times.
* Robots: radius 0.25 m, v_max 1 m/s, a_max 0.5 m/s^2, omega_max pi/2 rad/s (unicycle), dt 0.1 s.
  Time limits: 60 s (600 steps); circle-40 90 s, crowd-5 30 s, crowd-10 35 s, crowd-20 40 s.
  Crowd bodies spawn 0.2 m apart (CrowdNav's discomfort distance), the others 0.3 m.
* Scenarios are written out field by field (not derived from :data:`~vcs_env.scenario.SCENARIOS`,
  whose presets may be retuned).

**The CrowdNav protocol** (Chen et al., ICRA 2019; ``vita-epfl/CrowdNav``
``crowd_nav/configs/env.config``, ``crowd_sim/envs/crowd_sim.py``): ``crowdnav-circle-v0`` and
``crowdnav-square-v0``, 500 episodes each like the paper's test set: one holonomic robot of
radius 0.3 m and preferred speed 1 m/s from (0, -4) to (0, 4) among 5 ORCA pedestrians of radius
0.3 m and preferred speed 1 m/s that do not see it, crossing a circle of radius 4 m or a square
10 m wide; dt 0.25 s, 25 s. ``crowdnav-circle-unicycle-v0`` drives our default unicycle limits
instead; ``crowdnav-circle-10-v0`` and ``crowdnav-circle-20-v0`` are denser. What differs from
CrowdNav is in ``docs/people.md``.

**Versioning.** A suite's content (scenario, seeds) and the simulator semantics it relies on
never change under the same name. Any change that can alter an episode means a new version
(``circle-16-v1``), and the old one stays for old numbers. :attr:`Suite.fingerprint` hashes the
content; ``tests/test_evaluate.py`` pins it so an accidental change fails loudly.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .pedestrians import PedestrianSpec
from .scenario import RobotSpec, Scenario

LATER_FIELDS = {
    f.name: f.default
    for f in dataclasses.fields(Scenario)
    if f.name
    in (
        "corridor_width",
        "door_width",
        "n_walls",
        "wall_length",
        "lidar",
        "n_wall_points",
        "wall_segments",
        "pedestrians",
        "observation",
        "stall_clock",
    )
}
"""Scenario fields (with their defaults) added after the first suites were pinned: the maps, lidar,
pedestrians and the observation version."""
LATER_REWARDS = {"danger": 0.0, "arrival_speed": 0.0, "stuck": 0.0}
"""Reward weights (with their defaults) added after the first suites were pinned."""
SMOKE_SEEDS = 3
"""Episodes in a ``-smoke`` suite."""
SMOKE_SUFFIX = "-smoke"


@dataclass(frozen=True)
class Suite:
    """A fixed set of episodes: one scenario, one seed per episode."""

    name: str
    """Versioned name, e.g. ``circle-16-v0``."""
    scenario: Scenario
    """The episode family; evaluation runs it unchanged."""
    seeds: tuple[int, ...]
    """One reset seed per episode, in report order."""
    description: str = ""
    """One line for humans."""

    def __post_init__(self) -> None:
        given = self.seeds

        def whole(s) -> bool:
            return isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_))

        listed = isinstance(given, (Sequence, np.ndarray)) and not isinstance(given, (str, bytes))
        if not listed or not all(map(whole, given)):
            raise ValueError(f"suite {self.name!r}: seeds must be a sequence of integers, got {given!r}")
        seeds = tuple(int(s) for s in given)
        if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
            raise ValueError(f"suite {self.name!r}: seeds must be distinct non-negative integers, at least one")
        object.__setattr__(self, "seeds", seeds)
        if not isinstance(self.scenario, Scenario):
            raise ValueError(f"suite {self.name!r}: scenario must be a Scenario, got {type(self.scenario).__name__}")

    @property
    def n_episodes(self) -> int:
        return len(self.seeds)

    @property
    def is_smoke(self) -> bool:
        return self.name.endswith(SMOKE_SUFFIX)

    @property
    def fingerprint(self) -> str:
        """First 16 hex digits of the SHA-256 of the suite's content (scenario fields and seeds).

        Scenario fields and reward weights added after suites were first pinned
        (:data:`LATER_FIELDS`, :data:`LATER_REWARDS`) count only when they differ from their
        default, so adding a field with a neutral default leaves every existing fingerprint as it was."""
        scenario = {
            k: v
            for k, v in dataclasses.asdict(self.scenario).items()
            if not (k in LATER_FIELDS and v == LATER_FIELDS[k])
        }
        scenario["rewards"] = {
            k: v for k, v in scenario["rewards"].items() if not (k in LATER_REWARDS and v == LATER_REWARDS[k])
        }
        content = {"scenario": scenario, "seeds": list(self.seeds)}
        blob = json.dumps(content, sort_keys=True, default=repr).encode()
        return hashlib.sha256(blob).hexdigest()[:16]


def _seeds(count: int, base: int = 1000) -> tuple[int, ...]:
    return tuple(range(base, base + count))


_ROBOT = RobotSpec(radius=0.25, v_max=1.0, a_max=0.5, omega_max=math.pi / 2, holonomic=False)
_COMMON = dict(
    robot=_ROBOT,
    dt=0.1,
    r_goal=0.1,
    r_ca=6.0,
    n_neighbors=8,
    min_separation=0.3,
    on_collision="continue",
    park_finished=True,
)


def _circle(n: int, radius: float, jitter: float = 0.1, max_steps: int = 600) -> Scenario:
    return Scenario(kind="circle", n_robots=n, layout_radius=radius, jitter=jitter, max_steps=max_steps, **_COMMON)


def _crowd(m: int, radius: float, max_steps: int) -> Scenario:
    # Bodies spawn 0.2 m apart, CrowdNav's discomfort distance (0.3 m cannot place 20 obstacles
    # on a 6 m circle for every seed).
    common = {**_COMMON, "min_separation": 0.2}
    return Scenario(
        kind="crowd",
        n_robots=1,
        n_obstacles=m,
        layout_radius=radius,
        obstacle_motion="constant",
        obstacle_radius=(0.3, 0.3),
        obstacle_speed=(0.5, 1.0),
        max_steps=max_steps,
        **common,
    )


def _maps() -> list[Suite]:
    def door(n: int, width: float, half: float, radius: float, jitter: float) -> Scenario:
        return Scenario(
            kind="doorway", n_robots=n, door_width=width, arena_half_size=half, layout_radius=radius,
            lane_spacing=1.2, jitter=jitter, max_steps=600, **_COMMON,
        )  # fmt: skip

    def lanes(kind: str, n: int) -> Scenario:
        return Scenario(
            kind=kind, n_robots=n, corridor_width=2.5, layout_radius=4.0, lane_spacing=1.2, jitter=0.1,
            max_steps=600, **_COMMON,
        )  # fmt: skip

    return [
        Suite("corridor-v0", lanes("corridor", 6), _seeds(100), "two-way traffic of 6 robots in a 2.5 m corridor"),
        Suite("doorway-v0", door(6, 1.2, 5.0, 3.0, 0.1), _seeds(100), "two groups of 3 swap sides through a door"),
        Suite(
            "door-headon-v0",
            door(2, 2 * _ROBOT.radius + 0.2, 4.0, 2.5, 0.0),
            _seeds(20),
            "2 robots head-on through a door one robot diameter + 0.2 m wide",
        ),
        Suite(
            "room-v0",
            Scenario(kind="room", n_robots=8, layout_radius=3.0, door_width=1.2, jitter=0.1, max_steps=600, **_COMMON),
            _seeds(100),
            "8 robots leave a room through its 4 doors",
        ),
        Suite("intersection-v0", lanes("intersection", 8), _seeds(100), "two groups of 4 cross at a junction"),
        Suite(
            "walls-v0",
            Scenario(
                kind="walls",
                n_robots=6,
                n_walls=12,
                wall_length=(1.0, 3.0),
                arena_half_size=6.0,
                max_steps=600,
                **_COMMON,
            ),  # fmt: skip
            _seeds(100),
            "6 robots among 12 random walls",
        ),
    ]


def _hard() -> list[Suite]:
    """Tight spaces, fast movers and the holonomic robot kind (issue 42)."""
    narrow = Scenario(
        kind="corridor", n_robots=6, corridor_width=1.7, layout_radius=4.0, lane_spacing=1.2, jitter=0.1,
        max_steps=600, **_COMMON,
    )  # fmt: skip
    fast = Scenario(
        kind="dynamic", n_robots=4, n_obstacles=6, arena_half_size=6.0, obstacle_motion="arbitrary", bounce=True,
        obstacle_radius=(0.2, 0.4), obstacle_speed=(1.2, 1.8), turn_rate=0.6, turn_period=2.0, max_steps=600,
        **_COMMON,
    )  # fmt: skip
    holonomic = Scenario(
        kind="random", n_robots=12, arena_half_size=4.0, max_steps=600,
        **{**_COMMON, "robot": dataclasses.replace(_ROBOT, holonomic=True)},
    )  # fmt: skip
    return [
        Suite("corridor-narrow-v0", narrow, _seeds(100), "two-way traffic of 6 robots in a 1.7 m corridor"),
        Suite("dynamic-fast-v0", fast, _seeds(100), "4 robots among 6 obstacles at 1.2-1.8 m/s (1.2-1.8 v_max)"),
        Suite("random-dense-holonomic-v0", holonomic, _seeds(100), "random-dense-v0 with holonomic robots"),
    ]


CROWDNAV_ROBOT = RobotSpec(radius=0.3, v_max=1.0, a_max=10.0, omega_max=2 * math.pi, holonomic=True)
"""CrowdNav's robot: holonomic, radius 0.3 m, v_pref 1 m/s, any velocity in the disc every step. The
largest a_max allowed, 10 m/s^2, changes the velocity by up to 2.5 m/s in a 0.25 s step: more than
the 2 m/s between any two velocities of the 1 m/s disc, so no step is limited."""


def _crowdnav_scenario(m: int = 5, radius: float = 4.0, goal_policy: str = "circle", robot=CROWDNAV_ROBOT) -> Scenario:
    """CrowdNav's test protocol (module docstring): ``m`` ORCA pedestrians that ignore the robot."""
    return Scenario(
        kind="crowd",
        n_robots=1,
        n_obstacles=m,
        layout_radius=radius,
        arena_half_size=5.0,  # the square crossing's square: 10 m wide
        obstacle_motion="pedestrians",
        pedestrians=PedestrianSpec(model="orca", v_pref=1.0, goal_policy=goal_policy, sees_robots=False),
        obstacle_radius=(0.3, 0.3),
        robot=robot,
        dt=0.25,
        max_steps=100,  # 25 s
        r_goal=0.3,  # CrowdNav: arrived when the centre is within a robot radius of the goal
        r_ca=12.0,  # CrowdNav's robot observes every human
        n_neighbors=8,
        min_separation=0.2,  # CrowdNav's discomfort distance, kept between spawned bodies
        on_collision="continue",
        park_finished=True,
    )


def _crowdnav() -> list[Suite]:
    unicycle = dataclasses.replace(_ROBOT, radius=0.3)
    return [
        Suite("crowdnav-circle-v0", _crowdnav_scenario(), _seeds(500), "CrowdNav circle crossing, 5 ORCA humans"),
        Suite(
            "crowdnav-square-v0",
            _crowdnav_scenario(goal_policy="square"),
            _seeds(500),
            "CrowdNav square crossing, 5 ORCA humans",
        ),
        Suite(
            "crowdnav-circle-unicycle-v0",
            _crowdnav_scenario(robot=unicycle),
            _seeds(500),
            "CrowdNav circle crossing with our default unicycle robot limits",
        ),
        Suite("crowdnav-circle-10-v0", _crowdnav_scenario(10), _seeds(500), "CrowdNav circle crossing, 10 humans"),
        Suite(
            "crowdnav-circle-20-v0",
            _crowdnav_scenario(20, radius=6.0),
            _seeds(500),
            "CrowdNav-style circle crossing, 20 humans on a 6 m circle",
        ),
    ]


def _build() -> dict[str, Suite]:
    full = [
        Suite("circle-8-v0", _circle(8, 5.0), _seeds(100), "8 robots swap to the antipodes of a 5 m circle"),
        Suite("circle-16-v0", _circle(16, 6.0), _seeds(100), "16 robots swap to the antipodes of a 6 m circle"),
        Suite("circle-24-v0", _circle(24, 7.0), _seeds(50), "24 robots swap to the antipodes of a 7 m circle"),
        Suite(
            "swap-v0",
            Scenario(
                kind="swap", n_robots=6, layout_radius=5.0, lane_spacing=1.2, jitter=0.1, max_steps=600, **_COMMON
            ),
            _seeds(100),
            "3 head-on pairs on parallel lanes 1.2 m apart",
        ),
        Suite(
            "crossing-v0",
            Scenario(
                kind="crossing", n_robots=8, layout_radius=5.0, lane_spacing=1.2, jitter=0.1, max_steps=600, **_COMMON
            ),
            _seeds(100),
            "two groups of 4 robots crossing at 90 degrees",
        ),
        Suite(
            "circle-40-v0",
            _circle(40, 11.0, max_steps=900),
            _seeds(10),
            "40 robots swap to the antipodes of an 11 m circle",
        ),
        Suite(
            "circle-40-symmetric-v0",
            _circle(40, 11.0, jitter=0.0, max_steps=900),
            _seeds(10),
            "40 robots, perfectly symmetric starts (seeds change only the planners' noise)",
        ),
        Suite(
            "random-dense-v0",
            Scenario(kind="random", n_robots=12, arena_half_size=4.0, max_steps=600, **_COMMON),
            _seeds(100),
            "12 robots, random starts and goals in an 8 m square: robots park inside the traffic",
        ),
        Suite("crowd-5-v0", _crowd(5, 4.0, 300), _seeds(100), "1 robot among 5 non-reactive obstacles (CrowdNav)"),
        Suite("crowd-10-v0", _crowd(10, 5.0, 350), _seeds(100), "1 robot among 10 non-reactive obstacles"),
        Suite("crowd-20-v0", _crowd(20, 6.0, 400), _seeds(100), "1 robot among 20 non-reactive obstacles"),
        Suite(
            "dynamic-v0",
            Scenario(
                kind="dynamic",
                n_robots=4,
                n_obstacles=6,
                arena_half_size=6.0,
                obstacle_motion="arbitrary",
                bounce=True,
                obstacle_radius=(0.2, 0.4),
                obstacle_speed=(0.2, 0.6),
                turn_rate=0.6,
                turn_period=2.0,
                max_steps=600,
                **_COMMON,
            ),
            _seeds(100),
            "4 robots among 6 obstacles on random-turning, wall-bouncing trajectories",
        ),
    ]
    full += _maps()
    full += _hard()
    full += _crowdnav()
    smoke_robots = {"circle-24-v0": 12, "circle-40-v0": 16, "circle-40-symmetric-v0": 16}
    out: dict[str, Suite] = {}
    for s in full:
        out[s.name] = s
        scenario = s.scenario
        if s.name in smoke_robots:
            scenario = dataclasses.replace(scenario, n_robots=smoke_robots[s.name])
        out[s.name + SMOKE_SUFFIX] = Suite(
            s.name + SMOKE_SUFFIX, scenario, s.seeds[:SMOKE_SEEDS], f"CI smoke variant of {s.name}"
        )
    return out


SUITES: dict[str, Suite] = _build()
"""Every suite by name; built once here and never mutated elsewhere."""


def get_suite(name_or_suite: str | Suite) -> Suite:
    """A suite by name (or the given suite); ``ValueError`` listing the names if unknown."""
    if isinstance(name_or_suite, Suite):
        return name_or_suite
    if not isinstance(name_or_suite, str):
        raise ValueError(
            f"a suite is a name or a Suite, got {type(name_or_suite).__name__} (a Scenario runs on seeds as "
            "Suite(name, scenario, seeds))"
        )
    if name_or_suite not in SUITES:
        raise ValueError(f"unknown suite {name_or_suite!r}; suites are {sorted(SUITES)}")
    return SUITES[name_or_suite]


def suite_names(smoke: bool | None = None) -> list[str]:
    """Suite names in definition order: all, only full (``smoke=False``) or only smoke ones."""
    return [k for k, s in SUITES.items() if smoke is None or s.is_smoke == smoke]
