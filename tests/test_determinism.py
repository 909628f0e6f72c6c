"""One seed, one trajectory, bit for bit; B worlds stepped together equal B worlds one by one, for planners and
for learned policies."""

import numpy as np
import pytest

import vcs_env
from vcs_env.engine import NavEngine
from vcs_env.rollout import planner_controller, run_episodes
from vcs_env.sim import Simulator


def pz_rollout(seed, steps=40, **kw):
    env = vcs_env.parallel_env(**kw)
    obs, infos = env.reset(seed=seed)
    rng = np.random.default_rng(1000 + seed)  # the same action stream for both runs
    trace = [(obs, infos)]
    for _ in range(steps):
        if not env.agents:
            break
        acts = {a: rng.uniform(-1, 1, size=2).astype(np.float32) for a in env.agents}
        trace.append(env.step(acts))
    return trace


def assert_same(a, b):
    """Exact equality of nested dicts / lists / arrays / scalars."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            assert_same(a[k], b[k])
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_same(x, y)
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    else:
        assert a == b or (a != a and b != b)


@pytest.mark.parametrize("scenario", ["circle", "dynamic", "crowd", "random"])
def test_same_seed_same_actions_identical_rollout(scenario):
    kw = dict(scenario=scenario, expert="vcs", rewards={"vcs_imitation": 0.5, "vcs_potential": 0.5})
    assert_same(pz_rollout(3, **kw), pz_rollout(3, **kw))


def test_different_seeds_differ():
    a = pz_rollout(1, scenario="random", steps=1)
    b = pz_rollout(2, scenario="random", steps=1)
    assert not np.array_equal(a[0][0]["robot_0"], b[0][0]["robot_0"])


@pytest.mark.parametrize("scenario", ["dynamic", "crowd"])
def test_batched_worlds_equal_worlds_one_by_one(scenario):
    s = vcs_env.make_scenario(scenario)
    seeds = [11, 12, 13]
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(60, 3, s.n_robots, 2))
    batched = NavEngine(s, batch_size=3, expert="vcs", reward_terms=None)
    obs_b = [batched.reset(seeds)]
    rew_b, exp_b = [], [batched.expert_action.copy()]
    for t in range(60):
        res = batched.step(actions[t], autoreset=True)
        obs_b.append(res.obs)
        rew_b.append(res.reward)
        exp_b.append(res.expert_action.copy())
    for b, seed in enumerate(seeds):
        single = NavEngine(s, batch_size=1, expert="vcs")
        obs = single.reset([seed])
        np.testing.assert_array_equal(obs[0], obs_b[0][b])
        np.testing.assert_array_equal(single.expert_action[0], exp_b[0][b])
        for t in range(60):
            res = single.step(actions[t, b : b + 1], autoreset=True)
            np.testing.assert_array_equal(res.obs[0], obs_b[t + 1][b])
            np.testing.assert_array_equal(res.reward[0], rew_b[t][b])
            np.testing.assert_array_equal(res.expert_action[0], exp_b[t + 1][b])


def test_expert_rollouts_batched_equal_one_by_one():
    s = vcs_env.make_scenario("circle", n_robots=6, on_collision="continue", max_steps=200)
    planner = vcs_env.make_planner("vcs")
    together = run_episodes(s, planner_controller(planner), [5, 6, 7])
    for ep in together:
        alone = run_episodes(s, planner_controller(vcs_env.make_planner("vcs")), [ep.seed])[0]
        np.testing.assert_array_equal(alone.pos, ep.pos)
        np.testing.assert_array_equal(alone.actions, ep.actions)


def test_a_learned_policys_episode_does_not_depend_on_the_worlds_beside_it():
    """The released v2 network on intersections: a seed run alone (8 rows of observations a step) plays the episode
    it plays among others and in batches of one (torch's products round otherwise for a handful of rows; padded to
    agents.policies.MIN_ROWS they do not): seed 2 took 413 steps alone and 426 beside seeds 0 and 1 before."""
    from agents.config import ScenarioConfig, probe_scenario
    from agents.evaluate import evaluate
    from vcs_env.suites import Suite

    scenario = probe_scenario(ScenarioConfig(scenario="intersection"))
    policy = "policies/generalist-v2/model.zip"
    runs = [
        evaluate(policy, Suite("alone", scenario, (2,)), progress=False, keep_episodes=[0]).episodes[0],
        evaluate(policy, Suite("three", scenario, (0, 1, 2)), progress=False, keep_episodes=[2]).episodes[2],
        evaluate(policy, Suite("one", scenario, (0, 1, 2)), progress=False, batch_size=1, keep_episodes=[2]).episodes[
            2
        ],
    ]
    for ep in runs[1:]:
        np.testing.assert_array_equal(ep.pos, runs[0].pos)
        np.testing.assert_array_equal(ep.actions, runs[0].actions)


def test_planner_output_depends_only_on_the_state():
    """Planning twice on one state gives the same targets (the plan is idempotent)."""
    s = vcs_env.make_scenario("circle", n_robots=8)
    eng = NavEngine(s)
    eng.reset([2])
    p = vcs_env.make_planner("vcs")
    for _ in range(30):
        eng.step(p.act(eng.world))
    first = p.plan(eng.world)
    p._cache_key = None  # force a recomputation on the same state
    np.testing.assert_array_equal(p.plan(eng.world), first)


def test_a_planner_never_reuses_a_plan_made_for_another_world():
    """Two worlds alike in positions, speeds and episode key but not in goals (or headings): each gets its own
    plan, as from a fresh planner (the plan of the first was returned for the second)."""
    import dataclasses

    def world(goal, heading=0.0):
        custom = vcs_env.CustomLayout(start=[(0.0, 0.0)], goal=[goal], heading=[heading])
        eng = NavEngine(vcs_env.Scenario(kind="custom", n_robots=1, custom=custom))
        eng.reset([0])
        return eng.world

    shared = vcs_env.make_planner("vcs")
    for w in (world((5.0, 0.0)), world((0.0, 5.0)), world((0.0, 5.0), heading=1.0)):
        np.testing.assert_array_equal(shared.plan(w), vcs_env.make_planner("vcs").plan(w))
    w = world((5.0, 0.0))
    assert dataclasses.replace(w, goal=w.goal + 1.0).key.tobytes() == w.key.tobytes()  # the same episode key


def test_one_planner_instance_given_to_several_envs_drives_each_as_its_own():
    """An env copies a planner instance it is given: envs stepped in turn with one instance have the episodes of
    envs with one planner each (they cleared each other's memory across periods)."""
    from baselines.vcs import VCSPlanner

    def run(planners):
        envs = [vcs_env.parallel_env(scenario="random", n_robots=8, expert=p) for p in planners]
        out = [[] for _ in envs]
        for k, env in enumerate(envs):
            env.reset(seed=k)
        for _ in range(60):
            for k, env in enumerate(envs):
                if env.agents:
                    infos = env.step({a: np.zeros(2, np.float32) for a in env.agents})[-1]
                    out[k].append(np.array([infos[a]["expert_action"] for a in sorted(infos)]))
        return [np.concatenate(o) for o in out]

    shared = VCSPlanner()
    for a, b in zip(run([shared, shared]), run([VCSPlanner(), VCSPlanner()]), strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_masked_plan_of_a_state_already_planned_leaves_the_experts_memory():
    """A label asked for some robots (``act(world, robots=mask)``) of a state the expert has planned: the robots left
    out keep the residual its full plan gave them (they lost it, and the expert's episode turned from the next step on,
    by up to a full action)."""
    scenario = vcs_env.make_scenario("crowd", n_robots=4, n_obstacles=4)

    def run(query: bool) -> np.ndarray:
        engine = NavEngine(scenario, 1, expert="vcs")
        engine.reset([1])
        out = []
        for t in range(30):
            if query and t == 5:
                engine.expert.act(engine.world, robots=np.array([True, False, False, False]))
            out.append(engine.expert_action.copy())
            engine.step(engine.expert_action)
        return np.array(out)

    np.testing.assert_array_equal(run(True), run(False))


def test_the_others_of_a_gym_env_follow_robots_moved_by_hand():
    """One planner instance as both the others and the expert of a Gymnasium env: after a robot is moved by hand the
    others act on the state as it is (they took the expert's plan of the state before the move), as with two
    instances."""
    import gymnasium as gym

    from baselines.vcs import VCSPlanner

    def run(shared: bool) -> np.ndarray:
        p = VCSPlanner()
        kw = dict(others=p, expert=p) if shared else dict(others=VCSPlanner(), expert=VCSPlanner())
        env = gym.make("vcs_env/Navigation-v2", scenario="crowd", n_robots=4, n_obstacles=4, **kw)
        env.reset(seed=7)
        world = env.unwrapped.world
        out = []
        for t in range(10):
            if t in (0, 4):
                world.heading[0, 2] += 1.5
                world.pos[0, 3] += 0.2
            env.step(np.zeros(2))
            out.append(np.concatenate([world.pos[0].ravel(), world.heading[0]]))
        return np.array(out)

    np.testing.assert_array_equal(run(True), run(False))


def test_time_is_the_step_count_times_dt_not_a_drifting_sum():
    """Time summed step by step drifted (-7e-10 s after 20k steps of 0.1 s, 7e-6 s after 2M): the turn periods of
    arbitrary obstacles changed a step early or late from step 34,040 on, and scripted waypoints were met a step off."""
    sim = Simulator(vcs_env.make_scenario("dynamic", n_robots=2, n_obstacles=2, dt=0.1, max_steps=10_000))
    sim.reset(0)
    for _ in range(300):
        sim.step(np.zeros((1, 2, 2)))
        assert sim.world.time[0] == sim.world.steps[0] * 0.1  # bit for bit
