"""Reward terms as objects: the built-ins match RewardWeights, and a term of one's own is one
object passed to the env."""

import dataclasses
import re

import numpy as np
import pytest

import vcs_env
from vcs_env.engine import NavEngine
from vcs_env.rewards import TERMS, RewardTerm, StepInput, weighted_sum
from vcs_env.scenario import RewardWeights


class Speed(RewardTerm):
    """The speed after the step [m/s], zero for robots that did not act."""

    name = "speed"

    def __call__(self, x: StepInput) -> np.ndarray:
        return np.where(x.events.acted, x.world.speed, 0.0)


def test_every_built_in_term_has_a_weight_and_a_unique_name():
    assert [t.name for t in TERMS] == [f.name for f in dataclasses.fields(RewardWeights)]


def test_a_term_object_is_computed_weighted_and_reported():
    s = vcs_env.make_scenario("swap", rewards={"progress": 0.0, "arrival": 0.0, "collision": 0.0, "time": 0.0})
    eng = NavEngine(s, reward_terms={"speed": (2.0, Speed()), "half_speed": (1.0, lambda w, e, a: 0.5 * w.speed)})
    eng.reset(seeds=[0])
    res = eng.step(np.ones((1, 2, 2)))  # full acceleration: speed a_max dt = 0.05 m/s
    np.testing.assert_allclose(res.terms["speed"], 0.05)
    np.testing.assert_allclose(res.terms["half_speed"], 0.025)
    np.testing.assert_allclose(res.reward, 2.0 * 0.05 + 0.025)
    assert list(res.terms) == ["progress", "arrival", "collision", "time", "speed", "half_speed"]
    assert res.info(0)["reward_terms"]["speed"] == pytest.approx(0.05)


def test_a_term_object_that_forgets_the_mask_pays_no_robot_that_ended():
    """The engine promises no reward after a robot ends; a RewardTerm of the user's that returns a value for every
    robot paid parked robots through NavEngine (only FunctionTerm masked)."""

    class One(RewardTerm):
        name = "one"

        def __call__(self, x):
            return np.ones(x.events.acted.shape)

    layout = vcs_env.CustomLayout(start=((0, 0), (0, 3)), goal=((0.35, 0), (3, 3)), heading=(0, 0), speed=(1, 0))
    eng = NavEngine(vcs_env.Scenario(kind="custom", n_robots=2, custom=layout), reward_terms={"one": (1.0, One())})
    eng.reset(seeds=[0])
    for _ in range(5):
        res = eng.step(np.zeros((1, 2, 2)))
    assert list(eng.world.active[0]) == [False, True] and list(res.terms["one"][0]) == [0.0, 1.0]


def test_a_crash_into_a_wall_earns_no_progress():
    """Among walls progress is the route's decrease; on the step a robot crashed (terminate) it was read from the
    straight distance, as for robots no longer active, and paid the step's whole motion."""
    wall = (((1, -1), (1, 1)),)
    layout = vcs_env.CustomLayout(start=((0, 0),), goal=((2, 0),), heading=(0,), speed=(1,), walls=wall)
    eng = NavEngine(vcs_env.Scenario(kind="custom", n_robots=1, custom=layout, on_collision="terminate"))
    eng.reset(seeds=[0])
    while eng.world.active[0, 0]:
        res = eng.step(np.zeros((1, 1, 2)))
    assert res.events.collided[0, 0] and res.terms["progress"][0, 0] <= 0.0


def test_built_in_terms_by_hand():
    s = vcs_env.make_scenario("swap", rewards={"vcs_imitation": 1.0})
    eng = NavEngine(s)
    eng.reset(seeds=[0])
    expert = eng.expert_action.copy()
    res = eng.step(np.stack((np.zeros(2), expert[0, 1]))[None])  # robot 0 stands, robot 1 follows
    ev = res.events
    np.testing.assert_array_equal(res.terms["progress"], ev.goal_dist_before - ev.goal_dist_after)
    np.testing.assert_array_equal(res.terms["time"], -s.dt)
    np.testing.assert_array_equal(res.terms["arrival"], 0.0)
    assert np.hypot(*expert[0, 0]) > 0.1
    np.testing.assert_allclose(res.terms["vcs_imitation"], [[-np.hypot(*expert[0, 0]) / (2 * np.sqrt(2)), 0.0]])
    assert "vcs_potential" not in res.terms  # expert terms are computed only when weighted
    w = s.rewards
    expected = w.progress * res.terms["progress"] + w.time * res.terms["time"] + res.terms["vcs_imitation"]
    np.testing.assert_allclose(res.reward, expected, rtol=1e-12)


def test_weighted_sum_skips_zero_weights_and_keeps_the_shape():
    terms = {"a": np.ones((2, 3)), "b": np.full((2, 3), 2.0)}
    np.testing.assert_array_equal(weighted_sum(terms, {"a": 0.0, "b": 0.5}), 1.0)
    np.testing.assert_array_equal(weighted_sum(terms, {}), np.zeros((2, 3)))


@pytest.mark.parametrize(
    "terms, match",
    [
        ({"time": (1.0, Speed())}, "'time' already exists"),
        ({"x": 1.0}, r"must be a \(weight, fn\) pair"),
        ({"x": (1.0, "no")}, "not callable"),
    ],
)
def test_bad_reward_terms_raise(terms, match):
    with pytest.raises(ValueError, match=match):
        NavEngine(vcs_env.make_scenario("swap"), reward_terms=terms)


def test_reward_term_specs_are_checked_by_name():
    """A NaN weight made every reward NaN, a string one failed in float() without the term named, a RewardTerm class
    given for an instance failed when called."""
    scenario = vcs_env.make_scenario("swap", n_robots=2)
    term = lambda w, e, a: w.speed  # noqa: E731
    for weight in (float("nan"), "abc", None, True, float("inf")):
        with pytest.raises(ValueError, match=r"reward_terms\['x'\]: the weight must be a finite number"):
            NavEngine(scenario, reward_terms={"x": (weight, term)})
    with pytest.raises(ValueError, match=r"reward_terms\['x'\]: give an instance, Moved\(\), not the class"):
        NavEngine(scenario, reward_terms={"x": (1.0, Moved)})
    eng = NavEngine(scenario, reward_terms={"x": (np.float32(0.5), term), "y": (2, term)})  # numbers of any kind
    eng.reset([0])
    res = eng.step(np.ones((1, 2, 2)))
    np.testing.assert_allclose(res.terms["x"], eng.world.speed)


def test_a_term_that_gives_other_than_one_number_per_robot_is_named():
    """A custom term's value must be (B, n) finite numbers: other shapes were broadcast into the reward (or failed in
    the adapter, far from the term), None became NaN."""
    for fn, said in (
        (lambda w, e, a: np.ones((1, 2, 2)), r"'x' \(one number per robot\) must have shape \(1, 2\), got \(1, 2, 2\)"),
        (lambda w, e, a: np.ones(3), r"'x' \(one number per robot\) must have shape \(1, 2\), got \(3,\)"),
        (lambda w, e, a: None, r"'x' \(one number per robot\) must be real numbers of shape \(1, 2\), got None"),
        (lambda w, e, a: np.full((1, 2), np.nan), r"'x' \(one number per robot\) must be finite"),
        (lambda w, e, a: "many", r"'x' \(one number per robot\) must be real numbers of shape \(1, 2\), got 'many'"),
    ):
        eng = NavEngine(vcs_env.make_scenario("swap", n_robots=2), reward_terms={"x": (1.0, fn)})
        eng.reset([0])
        with pytest.raises(ValueError, match=said):
            eng.step(np.zeros((1, 2, 2)))


def test_a_term_object_without_call_is_named():
    class Half(RewardTerm):  # forgot __call__: NotImplementedError with no message
        name = "half"

    eng = NavEngine(vcs_env.make_scenario("swap", n_robots=2), reward_terms={"half": (1.0, Half())})
    eng.reset([0])
    with pytest.raises(NotImplementedError, match=r"reward term Half \('half'\) must define __call__"):
        eng.step(np.zeros((1, 2, 2)))


class Moved(RewardTerm):
    """Distance each robot moved in the step [m], from positions it keeps across steps (state, as in
    docs/extending.md)."""

    name = "moved"

    def __init__(self):
        self.prev = None

    def start(self, world, expert, worlds):
        if self.prev is None or self.prev.shape != world.pos.shape:
            self.prev = world.pos.copy()
        else:
            self.prev[worlds] = world.pos[worlds]

    def __call__(self, x: StepInput) -> np.ndarray:
        d = np.linalg.norm(x.world.pos - self.prev, axis=-1)
        self.prev = x.world.pos.copy()
        return np.where(x.events.acted, d, 0.0)


def test_one_term_object_given_to_several_envs_keeps_a_state_per_env():
    """An env copies a reward term object it is given: two envs stepped in turn with one object get the rewards of
    envs with one each (they measured against each other's positions)."""

    def run(terms):
        envs = [vcs_env.parallel_env(scenario="random", n_robots=4, reward_terms={"moved": (1.0, t)}) for t in terms]
        for k, env in enumerate(envs):
            env.reset(seed=k)
        out = []
        for _ in range(20):
            for env in envs:
                rewards = env.step({a: np.ones(2, np.float32) for a in env.agents})[1]
                out.append(sorted(rewards.items()))
        return out

    shared = Moved()
    assert run([shared, shared]) == run([Moved(), Moved()])

    class MovedFn:  # the function form as a callable object with state: copied per env too
        def __init__(self):
            self.prev = None

        def __call__(self, world, events, actions):
            d = np.zeros(world.pos.shape[:2]) if self.prev is None else np.linalg.norm(world.pos - self.prev, axis=-1)
            self.prev = world.pos.copy()
            return d

    shared = MovedFn()
    assert run([shared, shared]) == run([MovedFn(), MovedFn()])
    calls = []  # a plain function is used as it is: its closure is the caller's
    assert run([lambda w, e, a: calls.append(1) or np.zeros(w.pos.shape[:2])] * 2) and len(calls) == 40


def test_potential_shaping_needs_a_planner_with_a_potential():
    with pytest.raises(ValueError, match="'straight' has none"):
        NavEngine(vcs_env.make_scenario("swap", rewards={"vcs_potential": 1.0}), expert="straight")


def _contact_time_oracle(world, b: int, i: int, j: int, horizon: float = 8.0, step: float = 1e-4) -> float:
    """First t in [0, horizon] [s] at which robot i and object j (robots, then obstacles) touch if both
    keep their velocities, found by scanning t; inf if they do not within the horizon."""
    n = world.pos.shape[1]
    vel_i = world.speed[b, i] * np.array([np.cos(world.heading[b, i]), np.sin(world.heading[b, i])])
    if j < n:
        pos_j, r_j = world.pos[b, j], world.radius[b, j]
        vel_j = world.speed[b, j] * np.array([np.cos(world.heading[b, j]), np.sin(world.heading[b, j])])
    else:
        pos_j, vel_j, r_j = world.obs_pos[b, j - n], world.obs_vel[b, j - n], world.obs_radius[b, j - n]
    t = np.arange(0.0, horizon, step)
    d = np.linalg.norm(pos_j + t[:, None] * vel_j - world.pos[b, i] - t[:, None] * vel_i, axis=-1)
    hit = np.flatnonzero(d <= r_j + world.radius[b, i])
    return float(t[hit[0]]) if hit.size else np.inf


def test_contact_times_match_a_scan_and_the_danger_term_uses_the_soonest():
    from vcs_env.rewards import DANGER_TIME, contact_times

    s = vcs_env.make_scenario("dynamic", n_robots=4, n_obstacles=6, rewards={"danger": 1.0})
    eng = NavEngine(s, batch_size=2)
    eng.reset(seeds=[3, 4])
    rng = np.random.default_rng(0)
    for _ in range(25):  # let robots and obstacles get moving
        res = eng.step(rng.uniform(-0.2, 1.0, (2, 4, 2)))
    world = eng.world
    t = contact_times(world)
    assert t.shape == (2, 4, 10)
    for b in range(2):
        for i in range(4):
            assert t[b, i, i] == np.inf
            for j in range(10):
                if j == i:
                    continue
                expected = _contact_time_oracle(world, b, i, j)
                got = t[b, i, j] if t[b, i, j] < 8.0 - 1e-3 else np.inf
                assert got == pytest.approx(expected, abs=2e-4), (b, i, j)
    assert np.isfinite(t).any()  # the check above saw some contacts ahead, not only inf
    acted = res.events.acted
    worst = np.exp(-t.min(axis=-1) / DANGER_TIME)
    np.testing.assert_allclose(res.terms["danger"], np.where(acted, -s.dt * worst, 0.0))


def test_danger_is_computed_only_when_weighted_and_counts_touching_as_now():
    eng = NavEngine(vcs_env.make_scenario("swap"))
    eng.reset(seeds=[0])
    assert "danger" not in eng.step(np.zeros((1, 2, 2))).terms
    from vcs_env.rewards import contact_times

    world = eng.world
    world.pos[0, 1] = world.pos[0, 0] + [0.3, 0.0]  # closer than the two radii: touching now
    assert contact_times(world)[0, 0, 1] == 0.0
    # A robot stopped at its point of contact (terminate) touches, whatever the rounding of its gap (1e-16 m either
    # side read 0 or inf, so danger on a crash step depended on dt).
    reach = world.radius[0, 0] + world.radius[0, 1]
    for gap in (-1e-16, 1e-16, 1e-10):
        world.pos[0, 1] = world.pos[0, 0] + [reach + gap, 0.0]
        world.speed[0] = 0.0
        assert contact_times(world)[0, 0, 1] == 0.0
    world.present[0, 1] = False  # a robot taken out of the world is no danger
    assert contact_times(world)[0, 0, 1] == np.inf


def test_the_danger_weight_enters_a_suite_fingerprint_only_when_set():
    from vcs_env.suites import get_suite

    suite = get_suite("dynamic-v0")

    def with_danger(w):
        rewards = dataclasses.replace(suite.scenario.rewards, danger=w)
        return dataclasses.replace(suite, scenario=dataclasses.replace(suite.scenario, rewards=rewards))

    assert with_danger(0.0).fingerprint == suite.fingerprint
    assert with_danger(1.0).fingerprint != suite.fingerprint


def test_arrival_speed_is_minus_the_speed_the_arriving_step_began_with():
    """Only the arriving step carries the term, at -v / v_max with v the speed before that step."""
    s = vcs_env.make_scenario("circle", n_robots=1, jitter=0.3, rewards={"arrival_speed": 1.0})  # a free run
    totals = {}
    for name in ("vcs", "straight"):
        eng = NavEngine(s, batch_size=2, expert=name)
        eng.reset(seeds=[0, 1])
        seen, total = 0, np.zeros((2, 1))
        for _ in range(s.max_steps):
            before = eng.world.speed.copy()
            res = eng.step(eng.expert_action.copy())
            term = res.terms["arrival_speed"]
            np.testing.assert_allclose(term, np.where(res.events.reached, -before / eng.world.v_max, 0.0))
            seen += int(res.events.reached.sum())
            total += term
            if not eng.world.active.any():
                break
        assert seen == 2  # the robot of each world arrived once
        totals[name] = total.mean()
    assert all(-1.0 <= t < 0.0 for t in totals.values()), totals
    eng = NavEngine(vcs_env.make_scenario("swap"))
    eng.reset(seeds=[0])
    assert "arrival_speed" not in eng.step(np.zeros((1, 2, 2))).terms  # computed only when weighted


def test_stuck_costs_dt_while_the_stall_rule_counts_a_detour_without_progress():
    """Two robots head-on in a door (``door-headon-v0``'s scenario), both standing still (zero
    actions): after the stall rule's second at rest each begins a detour and from then on each step
    costs it dt, the stall clock's detour count at one or more. Computed only when weighted, and
    only with the stall clock."""
    from vcs_env.suites import get_suite

    base = dataclasses.replace(get_suite("door-headon-v0").scenario, stall_clock=True)
    s = dataclasses.replace(base, rewards=dataclasses.replace(base.rewards, stuck=1.0))
    eng = NavEngine(s)
    eng.reset(seeds=[0])
    terms = []
    for _ in range(30):
        res = eng.step(np.zeros((1, 2, 2)))
        terms.append(res.terms["stuck"][0].copy())
        tries = eng.world.clock[0, :, 4]
        np.testing.assert_array_equal(res.terms["stuck"][0], np.where(tries >= 1, -s.dt, 0.0))
    terms = np.array(terms)
    assert (terms[:5] == 0.0).all() and (terms[-5:] == -s.dt).all()
    eng = NavEngine(base)
    eng.reset(seeds=[0])
    assert "stuck" not in eng.step(np.zeros((1, 2, 2))).terms
    with pytest.raises(ValueError, match="stuck reward term needs each robot's stall clock"):
        dataclasses.replace(s, stall_clock=False)


def test_rewards_flag_help_names_every_term():
    # --rewards takes any term of TERMS; its help (the ScenarioConfig field's docstring) lists them.
    from agents.config import ScenarioConfig, field_docs

    listed = set(re.findall(r"\w+", field_docs(ScenarioConfig)["rewards"].split("names:")[1]))
    assert {t.name for t in TERMS} <= listed


def test_among_walls_progress_is_the_decrease_of_the_route_length():
    """A wall with a door between a robot and its goal: driving the route (the straight planner
    follows it), the progress terms add up to the route's length minus what is left, not to the
    straight distance's decrease; a step pressed into the wall toward the goal earns less than its
    straight progress, and no step earns more than the distance moved."""
    from vcs_env.routes import waypoints
    from vcs_env.scenario import CustomLayout, Scenario

    walls = (((0.0, -4.0), (0.0, 1.5)), ((0.0, 2.5), (0.0, 4.0)))  # the door 1.5 m above the straight line
    s = Scenario(kind="custom", n_robots=1, custom=CustomLayout(start=((-2.0, 0.0),), goal=((2.0, 0.0),), walls=walls))
    engine = NavEngine(s)
    engine.reset(0)
    route = float(waypoints(engine.world)[1][0, 0])
    planner = vcs_env.make_planner("straight")
    total, first = 0.0, None
    for _ in range(s.max_steps):
        before = engine.world.pos.copy()
        res = engine.step(planner.act(engine.world))
        step = float(res.terms["progress"][0, 0])
        assert step <= np.linalg.norm(engine.world.pos - before) + 1e-12
        first = step if first is None else first
        total += step
        if not engine.world.active.any():
            break
    assert engine.world.reached.all()
    left = float(np.linalg.norm(engine.world.goal[0, 0] - engine.world.pos[0, 0]))
    np.testing.assert_allclose(
        total, route - left, atol=0.1
    )  # the roadmap route is approximate: small jumps are clipped
    assert total > 4.0 - left + 1.0  # the route is longer than the straight line
    engine.reset(0)
    route_gain = straight_gain = 0.0
    for _ in range(10):  # speed up dead ahead: toward the wall, not the door
        res = engine.step(np.array([[[1.0, 0.0]]]))
        route_gain += res.terms["progress"][0, 0]
        straight_gain += (res.events.goal_dist_before - res.events.goal_dist_after)[0, 0]
    assert 0.0 < route_gain < 0.75 * straight_gain


def test_imitation_in_absolute_mode_wraps_the_heading_and_planners_refuse_an_unknown_mode():
    """Headings pi and -pi are one absolute command (the robot ends the step in the same place) but the imitation
    term read them 2 apart (-0.71 for the one, -0.0007 for the other); act(world, "Delta") was taken as absolute."""
    terms, places = [], []
    for h in (1.0, -1.0):
        env = vcs_env.parallel_env(
            scenario="swap", n_robots=2, action_mode="absolute", rewards=RewardWeights(vcs_imitation=1.0)
        )
        _, infos = env.reset(seed=0)
        actions = {a: infos[a]["expert_action"] for a in env.agents}
        assert abs(abs(actions["robot_1"][1]) - 1.0) < 0.01  # the expert heads (nearly) west: pi or -pi
        actions["robot_1"] = np.array([actions["robot_1"][0], h], np.float32)
        _, _, _, _, infos = env.step(actions)
        terms.append(infos["robot_1"]["reward_terms"]["vcs_imitation"])
        places.append(env.world.pos[0, 1].copy())
    np.testing.assert_allclose(places[0], places[1], atol=1e-12)
    assert abs(terms[0] - terms[1]) < 1e-9 and terms[0] > -0.01
    with pytest.raises(ValueError, match="action_mode must be one of"):
        vcs_env.make_planner("vcs").act(env.world, "Delta")
