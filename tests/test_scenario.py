"""Scenario validation, presets, layouts, and property tests over random parameters."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vcs_env
from vcs_env import layouts
from vcs_env.engine import NavEngine
from vcs_env.layouts import generate
from vcs_env.scenario import SCENARIOS, CustomLayout, ObstacleTrajectory, Scenario, make_scenario
from vcs_env.sim import Simulator
from vcs_env.spaces import observation_space
from vcs_env.suites import SUITES


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_every_preset_generates_a_valid_layout(name):
    s = SCENARIOS[name]
    for seed in range(5):
        lay = generate(s, np.random.default_rng(seed))
        assert lay.start.shape == (s.n_robots, 2) and lay.goal.shape == (s.n_robots, 2)
        assert lay.obs_pos.shape == (s.n_obstacles, 2)
        pos = np.concatenate((lay.start, lay.obs_pos))
        rad = np.concatenate((np.full(s.n_robots, s.robot.radius), lay.obs_radius))
        gap = np.linalg.norm(pos[:, None] - pos[None], axis=-1) - rad[:, None] - rad[None]
        np.fill_diagonal(gap, np.inf)
        assert gap.min() >= (s.min_separation if name != "custom" else 0.0) - 1e-9


def test_circle_is_antipodal_and_symmetric():
    s = make_scenario("circle", n_robots=6)
    lay = generate(s, np.random.default_rng(0))
    np.testing.assert_allclose(lay.goal, -lay.start)
    np.testing.assert_allclose(np.linalg.norm(lay.start, axis=1), s.circle_radius)
    # Perfectly symmetric (no jitter): independent of the seed.
    np.testing.assert_array_equal(lay.start, generate(s, np.random.default_rng(99)).start)


def test_make_scenario_overrides_and_nested_dicts():
    s = make_scenario("circle", n_robots=12, robot={"v_max": 2.0}, rewards={"arrival": 3.0})
    assert s.n_robots == 12 and s.robot.v_max == 2.0 and s.robot.a_max == 0.5 and s.rewards.arrival == 3.0
    assert make_scenario(s) is s
    with pytest.raises(ValueError, match="unknown Scenario fields"):
        make_scenario("circle", n_robot=3)
    with pytest.raises(ValueError, match="unknown scenario"):
        make_scenario("nope")
    # A typo inside the nested dicts names the field and the valid ones (not Python's TypeError).
    with pytest.raises(ValueError, match=r"unknown rewards fields \['colision'\].*'collision'"):
        make_scenario("circle", rewards={"colision": 30.0})
    with pytest.raises(ValueError, match=r"unknown robot fields \['vmax'\].*'v_max'"):
        make_scenario("circle", robot={"vmax": 2.0})


def test_least_time_to_goal_bounds_every_robots_trip():
    # The bound holds on every layout: no robot starts within v_max * least_time_to_goal + r_goal of its goal.
    for name, over in [("circle", {"jitter": 0.3}), ("swap", {"jitter": 0.2}), ("crossing", {}), ("crowd", {})]:
        s = make_scenario(name, **over)
        assert s.least_time_to_goal > 0
        for seed in range(20):
            lay = generate(s, np.random.default_rng(seed))
            trip = np.linalg.norm(lay.goal - lay.start, axis=-1) - s.r_goal
            assert trip.min() >= s.least_time_to_goal * s.robot.v_max - 1e-9, (name, seed)
    assert make_scenario("random").least_time_to_goal == 0.0  # no bound from the kind
    # A circle of 256 robots has a 76.8 m radius: nobody can arrive within the preset's 60 s.
    big = make_scenario("circle", n_robots=256)
    assert big.least_time_to_goal > big.max_time


@pytest.mark.parametrize(
    "field, value, match",
    [
        ("kind", "maze", "kind"),
        ("n_robots", 0, "n_robots"),
        ("n_robots", 2.5, "n_robots"),
        ("n_obstacles", -1, "n_obstacles"),
        ("dt", 0.0, "dt"),
        ("dt", float("nan"), "dt"),
        ("dt", 1e-4, r"dt \[s\] must be a finite number in \[0.001, 1.0\]"),  # the expert took 0.4 s a decision at 1e-6
        ("r_goal", -0.1, "r_goal"),
        ("r_ca", 0.0, "r_ca"),
        ("n_neighbors", 0, "n_neighbors"),
        ("max_steps", 0, "max_steps"),
        ("on_collision", "explode", "on_collision"),
        ("obstacle_motion", "teleport", "obstacle_motion"),
        ("obstacle_radius", (0.5, 0.1), "obstacle_radius"),
        ("obstacle_speed", (0.1, 99.0), "obstacle_speed"),
        ("initial_speed", 5.0, "initial_speed"),
        ("jitter", -1.0, "jitter"),
    ],
)
def test_invalid_fields_raise_value_error_naming_the_field(field, value, match):
    with pytest.raises(ValueError, match=match):
        dataclasses.replace(SCENARIOS["circle"], **{field: value})


def test_impossible_layouts_say_so():
    with pytest.raises(ValueError, match="without overlap"):
        make_scenario("circle", n_robots=40, layout_radius=2.0)
    with pytest.raises(ValueError, match="even"):
        make_scenario("swap", n_robots=3)
    with pytest.raises(ValueError, match="lane_spacing"):
        make_scenario("swap", n_robots=4, lane_spacing=0.3)
    # exactly the spacing needed (0.5 + 0.3 + 2 * 0.2 = 1.2000000000000002 in floats) is allowed
    make_scenario("crossing", n_robots=8, lane_spacing=1.2, jitter=0.2)
    with pytest.raises(ValueError, match="without overlap"):
        make_scenario("random", n_robots=60, arena_half_size=2.0)
    with pytest.raises(ValueError, match="overlaps"):
        CustomLayout(start=((0, 0), (0.1, 0)), goal=((1, 0), (2, 0)))
        make_scenario(
            "custom", n_robots=2, n_obstacles=0, custom=CustomLayout(start=((0, 0), (0.1, 0)), goal=((1, 0), (2, 0)))
        )


def test_custom_validation():
    with pytest.raises(ValueError, match="n_robots"):
        make_scenario("custom", n_robots=3)
    # A layout given without counts sets them: one robot, no obstacle (the preset has 2 and 1).
    one = make_scenario("custom", custom=CustomLayout(start=((0.0, 0.0),), goal=((5.0, 0.0),)))
    assert (one.n_robots, one.n_obstacles) == (1, 0) and (
        SCENARIOS["custom"].n_robots,
        SCENARIOS["custom"].n_obstacles,
    ) == (2, 1)
    assert vcs_env.parallel_env(scenario="custom", custom=one.custom).possible_agents == ["robot_0"]
    with pytest.raises(ValueError, match="custom"):
        dataclasses.replace(SCENARIOS["circle"], custom=SCENARIOS["custom"].custom)
    with pytest.raises(ValueError, match="increase strictly"):
        ObstacleTrajectory(times=(0.0, 1.0, 1.0), positions=((0, 0), (1, 0), (2, 0)))
    with pytest.raises(ValueError, match="speed"):
        ObstacleTrajectory(times=(0.0, 0.1), positions=((0, 0), (10, 0)))
    with pytest.raises(ValueError, match=r"start must be an \(n, 2\) array \[m\], got shape \(1, 3\)"):
        CustomLayout(start=((0, 0, 0),), goal=((1, 0),))
    # A non-finite value is named as such, with its index (not reported as a shape problem).
    with pytest.raises(ValueError, match=r"start\[1\] is not finite: \(nan, 0.0\)"):
        CustomLayout(start=((0, 0), (float("nan"), 0)), goal=((1, 0), (2, 0)))
    with pytest.raises(ValueError, match=r"speed\[0\] is not finite"):
        CustomLayout(start=((0, 0),), goal=((1, 0),), speed=(float("inf"),))
    with pytest.raises(ValueError, match="heading"):
        CustomLayout(start=((0, 0),), goal=((1, 0),), heading=(0.0, 1.0))


@pytest.mark.slow
def test_crowd_layouts_are_refused_when_built_or_placed_on_every_seed():
    # 20 obstacles whose starts AND antipodal goals must keep clear of each other do not fit on a
    # 5 m circle: refused when the scenario is built, not at some reset of a long run.
    for kw in ({"n_obstacles": 20, "layout_radius": 5.0}, {"layout_radius": 1.0}, {"obstacle_radius": (2.0, 2.0)}):
        with pytest.raises(ValueError, match="starts and goals need .* increase layout_radius"):
            make_scenario("crowd", **kw)
    # Near that bound (13 obstacles on the preset's 4 m circle), the random draws sometimes find no
    # room (one of these 200 seeds; the env's seed 154 gave up after 2000 draws): the search over
    # every place then finds one, clear of every start and goal.
    s = make_scenario("crowd", n_obstacles=13)
    for seed in range(200):
        lay = generate(s, np.random.default_rng(seed))
        centres = np.concatenate((lay.start, lay.goal, lay.obs_pos, lay.obs_target))
        radii = np.concatenate((2 * [s.robot.radius] * len(lay.start), lay.obs_radius, lay.obs_radius))
        gap = np.linalg.norm(centres[:, None] - centres[None], axis=-1) - radii[:, None] - radii[None]
        np.fill_diagonal(gap, np.inf)
        assert gap.min() >= s.min_separation - 1e-9, seed
    # Obstacles placed first can leave no room for the next even where the search looks: the
    # layout then places them all again (these seeds gave up at reset, aborting an evaluation).
    big = make_scenario(SUITES["crowd-10-v0"].scenario, obstacle_radius=(0.6, 0.8), layout_radius=7.0)
    for seed in (20051, 20092, 20125):
        Simulator(big).reset(seed)


# ------------------------------------------------------------------ properties
KINDS = ("circle", "swap", "crossing", "random", "crowd", "dynamic")


@st.composite
def scenarios(draw):
    kind = draw(st.sampled_from(KINDS))
    n = draw(st.integers(1, 8))
    if kind == "swap":
        n = 2 * max(1, n // 2)
    if kind == "crossing":
        n = max(2, n)
    robot = vcs_env.RobotSpec(
        radius=draw(st.floats(0.1, 0.4)),
        v_max=draw(st.floats(0.3, 2.0)),
        a_max=draw(st.floats(0.2, 3.0)),
        omega_max=draw(st.floats(0.3, 2 * math.pi)),
        holonomic=draw(st.booleans()),
    )
    fields = dict(
        kind=kind,
        n_robots=n,
        n_obstacles=draw(st.integers(0, 6)),
        robot=robot,
        obstacle_motion=draw(st.sampled_from(("static", "constant", "patrol", "arbitrary", "stop_and_go"))),
        bounce=draw(st.booleans()),
        dt=draw(st.sampled_from((0.05, 0.1, 0.2))),
        n_neighbors=draw(st.integers(1, 6)),
        r_ca=draw(st.floats(1.0, 10.0)),
        max_steps=30,
        on_collision=draw(st.sampled_from(("terminate", "continue"))),
        park_finished=draw(st.booleans()),
        arena_half_size=8.0,
        layout_radius=draw(st.floats(3.0, 8.0)),
        jitter=draw(st.floats(0.0, 0.2)),
    )
    try:
        return Scenario(**fields)
    except ValueError:
        return None  # an impossible combination: rejected with ValueError, which is the contract


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenario=scenarios(), seed=st.integers(0, 2**31 - 1), action_mode=st.sampled_from(("delta", "absolute")))
def test_random_scenarios_and_actions_never_nan_and_stay_in_the_space(scenario, seed, action_mode):
    if scenario is None:
        return
    eng = NavEngine(scenario, batch_size=2, action_mode=action_mode)
    try:
        obs = eng.reset([seed, seed + 1])
    except ValueError as e:  # an unsampleable random layout says so
        assert "could not place" in str(e)
        return
    space = observation_space(scenario)
    rng = np.random.default_rng(seed)
    for _ in range(scenario.max_steps):
        assert obs.dtype == np.float32 and np.all(np.isfinite(obs))
        assert all(space.contains(o) for o in obs.reshape(-1, obs.shape[-1]))
        res = eng.step(rng.uniform(-3, 3, size=(2, scenario.n_robots, 2)))
        obs = res.obs
        assert np.all(np.isfinite(res.reward))
        w = eng.world
        assert np.all(np.isfinite(w.pos)) and np.all(np.isfinite(w.obs_pos))
        assert np.all((w.speed >= 0) & (w.speed <= w.v_max + 1e-12))


@settings(max_examples=60, deadline=None)
@given(
    field=st.sampled_from(("dt", "r_goal", "r_ca", "arena_half_size", "lane_spacing", "turn_period")),
    value=st.one_of(st.floats(max_value=0.0), st.just(float("nan")), st.just(float("inf"))),
)
def test_invalid_parameters_always_raise_value_error(field, value):
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(SCENARIOS["circle"], **{field: value})


class Line(layouts.ScenarioKind):
    """A test kind: robots in a row on y = 0, each driving to the mirror point on y = 2."""

    name = "line"
    summary = "robots in a row on y = 0, driving to y = 2."

    def check_layout(self, s):
        if s.lane_spacing < 2 * s.robot.radius + s.min_separation:
            raise ValueError("lane_spacing too small for a line")

    def generate(self, s, rng):
        x = (np.arange(s.n_robots) - (s.n_robots - 1) / 2) * s.lane_spacing
        start = np.stack((x, np.zeros_like(x)), -1)
        goal = start + [0.0, 2.0]
        return layouts.finish(s, start, goal, *layouts.place_obstacles(s, rng, start, goal, np.zeros(0)))


def test_a_new_kind_is_one_object(monkeypatch):
    monkeypatch.setitem(layouts.KINDS, "line", Line())
    s = Scenario(kind="line", n_robots=3)
    assert s.circle_radius == 5.0 and s.world_extent == max(s.arena_half_size, 5.0 + 1.2 * 3 / 2)
    lay = generate(s, np.random.default_rng(0))
    np.testing.assert_allclose(lay.start[:, 0], [-1.2, 0.0, 1.2])
    np.testing.assert_allclose(lay.heading, np.pi / 2)
    env = vcs_env.parallel_env(scenario=s)
    obs, _ = env.reset(seed=0)
    assert len(obs) == 3
    with pytest.raises(ValueError, match="too small for a line"):
        Scenario(kind="line", lane_spacing=0.1)
    assert "line       robots in a row" in layouts.kinds_help()


def test_kinds_of_ones_own_are_held_to_their_registry(monkeypatch):
    """A built-in kind is not replaced (its suites ran another layout under their names and fingerprints); a layout
    given as lists of numbers works (it failed deep in the library); a scenario of a kind no longer registered names
    it (a bare KeyError); a kind of one's own with walls has walls (the blind-policy warning never fired)."""
    with pytest.raises(ValueError, match="KINDS\\['swap'\\] is the built-in swap kind"):
        layouts.KINDS["swap"] = Line()
    assert type(layouts.KINDS["swap"]).__name__ == "Swap"

    class Listed(Line):
        name = "listed"

        def generate(self, s, rng):
            start = [[float(k), 0.0] for k in range(s.n_robots)]
            return layouts.finish(s, start, [[x, 2.0] for x, _ in start], [], [], [])

        def n_segments(self, s):
            return 1

    monkeypatch.setitem(layouts.KINDS, "listed", Listed())
    s = Scenario(kind="listed", n_robots=2, lane_spacing=1.0)
    assert s.has_walls  # it says it has a wall segment (this one draws none)
    env = vcs_env.parallel_env(scenario=s)
    env.reset(seed=0)
    np.testing.assert_array_equal(env.engine.world.pos[0], [[0.0, 0.0], [1.0, 0.0]])
    del layouts.KINDS["listed"]
    with pytest.raises(ValueError, match="no scenario kind 'listed' is registered: register it"):
        generate(s, np.random.default_rng(0))


def test_every_kind_documents_itself_and_unknown_kinds_list_them():
    text = layouts.kinds_help()
    assert [line.split()[0] for line in text.splitlines()] == list(layouts.KINDS)
    assert all(k.summary and k.name == name for name, k in layouts.KINDS.items())
    with pytest.raises(ValueError, match=r"kind must be one of \['circle', 'swap', 'crossing'"):
        Scenario(kind="maze")


class _Column(layouts.ScenarioKind):
    """A kind of one's own (docs/extending.md), whose generate returns ``self.bend(layout)``."""

    name = "column-test"
    summary = "robots in a column"
    reads = frozenset({"layout_radius"})

    def __init__(self, bend=lambda lay: lay):
        self.bend = bend

    def generate(self, s, rng):
        y = (np.arange(s.n_robots) - (s.n_robots - 1) / 2) * s.lane_spacing
        start = np.stack((np.full(s.n_robots, -s.circle_radius), y), axis=-1)
        goal = start * [-1.0, 1.0]
        lay = layouts.finish(
            s, start, goal, *layouts.place_obstacles(s, rng, start, goal, layouts.obstacle_radii(s, rng))
        )
        return self.bend(lay)


def test_a_kind_of_ones_own_is_checked_where_it_goes_wrong(monkeypatch):
    """A custom kind's layouts of the wrong sizes or types failed deep in the simulator, NaN starts were blamed on the
    actions, overlapping starts began every episode in collision, and a class registered for an instance failed with a
    missing argument."""
    kinds = dict(layouts.KINDS)
    monkeypatch.setattr(layouts, "KINDS", kinds)
    kinds["column-test"] = _Column()
    s = vcs_env.Scenario(kind="column-test", n_robots=3, n_obstacles=2)
    env = vcs_env.parallel_env(scenario=s)
    env.reset(seed=0)  # fine as it is
    bad = {
        "generated a tuple, not a Layout": lambda lay: (lay.start, lay.goal),
        r"generated start \(2, 2\) float64: it must be finite numbers of shape \(3, 2\)": lambda lay: (
            dataclasses.replace(lay, start=lay.start[:2])
        ),
        r"generated goal \(3, 2\) float64: it must be finite": lambda lay: dataclasses.replace(
            lay, goal=np.full((3, 2), np.nan)
        ),
        r"generated robot 0 starting 0\.380 m into robot 1": lambda lay: dataclasses.replace(
            lay, start=lay.start * [1.0, 0.1]
        ),
        "generated robot 2 starting .* into obstacle 0": lambda lay: dataclasses.replace(
            lay, obs_pos=np.concatenate((lay.start[2:], lay.obs_pos[1:]))
        ),
    }
    for said, bend in bad.items():
        kinds["column-test"] = _Column(bend)
        with pytest.raises(ValueError, match="kind 'column-test' " + said):
            vcs_env.parallel_env(scenario=s).reset(seed=0)
    with pytest.raises(ValueError, match=r"'column-test' is a kind without a preset: Scenario\(kind='column-test'\)"):
        vcs_env.parallel_env(scenario="column-test")
    kinds["column-test"] = _Column
    with pytest.raises(ValueError, match=r"KINDS\['column-test'\] must be a ScenarioKind instance.* _Column\(\)"):
        vcs_env.Scenario(kind="column-test", n_robots=3)


def test_bad_custom_obstacles_and_fields_are_value_errors_naming_them():
    """A NaN waypoint time made the obstacle's position and every observation NaN; other bad values were TypeErrors or
    IndexErrors from inside the conversion, or silently cut (a third coordinate)."""
    from vcs_env.scenario import CustomLayout, ObstacleTrajectory

    for times, positions, said in [
        ((0.0, float("nan")), ((0, 3), (0, -3)), "times must be finite"),
        ((None,), ((0, 0),), "times must be finite"),
        (("a",), ((0, 0),), "times .* of numbers"),
        (0.0, ((0, 0),), r"times of shape \(k,\) and positions of shape \(k, 2\)"),
        ((0.0,), ((0,),), r"got \(1,\) and \(1, 1\)"),
        ((0.0,), ((0, 0, 7),), r"got \(1,\) and \(1, 3\)"),
    ]:
        with pytest.raises(ValueError, match="ObstacleTrajectory.*" + said):
            ObstacleTrajectory(times=times, positions=positions)
    one = ObstacleTrajectory(times=(0.0,), positions=((1, 1),))
    for obstacles in (None, one):
        with pytest.raises(ValueError, match="CustomLayout.obstacles must be a tuple of ObstacleTrajectory"):
            CustomLayout(start=((0, 0),), goal=((1, 0),), obstacles=obstacles)
    with pytest.raises(ValueError, match=r"obstacle_radius must be a \(low, high\) pair"):
        vcs_env.make_scenario("dynamic", obstacle_radius=np.array(0.3))
    with pytest.raises(ValueError, match="unknown scenario"):
        vcs_env.make_scenario(["circle"])


def test_a_run_records_scenario_makes_the_scenario_again():
    """A record's scenario is JSON: lidar, pedestrians and custom layouts came back as dicts (refused), intervals as
    lists."""
    import json

    from agents.runs import jsonable
    from vcs_env.lidar import LidarSpec
    from vcs_env.pedestrians import PedestrianSpec
    from vcs_env.scenario import CustomLayout, ObstacleTrajectory

    custom = CustomLayout(
        start=((-2, 0),), goal=((3, 0),), obstacles=(ObstacleTrajectory(times=(0, 1), positions=((1, 1), (2, 2))),),
        walls=(((0, -3), (0, -2)),),
    )  # fmt: skip
    for s in (
        vcs_env.make_scenario("corridor", lidar=LidarSpec(n_beams=16), n_wall_points=3, stall_clock=True),
        vcs_env.make_scenario("crowd", obstacle_motion="pedestrians", pedestrians=PedestrianSpec(model="social_force")),
        vcs_env.Scenario(kind="custom", n_robots=1, n_obstacles=1, custom=custom),
    ):
        d = json.loads(json.dumps(jsonable(s)))
        assert vcs_env.make_scenario(d["kind"], **d) == s
    with pytest.raises(ValueError, match=r"unknown lidar fields \['beams'\]"):
        vcs_env.make_scenario("corridor", lidar={"beams": 3})


def test_a_layout_its_kind_accepts_resets():
    """Robots exactly touching (a ring at the spacing check_ring allows, to 1e-9 m) were refused at every reset by
    the generated-layout check, blamed on the built-in kind; that check is for kinds from outside the package."""
    from vcs_env.sim import Simulator

    ring = 0.25 / math.sin(math.pi / 7)  # neighbours' centres 0.5 m apart: touching
    robot = vcs_env.RobotSpec(radius=0.25)
    s = vcs_env.Scenario(kind="circle", n_robots=7, min_separation=0.0, jitter=0.0, robot=robot, layout_radius=ring)
    Simulator(s, 1).reset(0)
