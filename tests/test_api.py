"""Conformance with the PettingZoo, Gymnasium and SB3 APIs, through their own checkers and tools."""

import json
import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, max_cycles_test, parallel_api_test, parallel_seed_test, render_test
from pettingzoo.utils.conversions import parallel_to_aec

import vcs_env
from vcs_env.scenario import SCENARIOS


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_parallel_api(name):
    parallel_api_test(vcs_env.parallel_env(scenario=name, max_cycles=60), num_cycles=200)


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_parallel_seed(name):
    parallel_seed_test(lambda: vcs_env.parallel_env(scenario=name), num_cycles=60)


def test_aec_api():
    api_test(vcs_env.env(scenario="crowd", max_cycles=50), num_cycles=100)


def test_max_cycles():
    max_cycles_test(vcs_env)


def test_render_modes():
    render_test(lambda render_mode=None: vcs_env.env(scenario="dynamic", render_mode=render_mode))
    env = vcs_env.parallel_env(scenario="circle", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 5  # something is drawn
    # Bodies far outside the view (here an obstacle 10 km away) are off the picture, not an error.
    far = vcs_env.parallel_env(scenario="crowd", render_mode="rgb_array")
    far.reset(seed=0)
    far.engine.world.obs_pos[0, 0] = (1e4, -1e4)
    assert far.render().shape == frame.shape
    env.close()


def test_off_screen_frames_print_nothing_on_a_machine_without_display_or_audio():
    """rgb_array frames need no pygame.init(), whose audio and video probes printed "XDG_RUNTIME_DIR is invalid or not
    set" on a headless machine (the README's first command, Gymnasium's check_env)."""
    import os
    import subprocess
    import sys

    pytest.importorskip("pygame")
    env = {k: v for k, v in os.environ.items() if k not in ("SDL_VIDEODRIVER", "SDL_AUDIODRIVER", "XDG_RUNTIME_DIR")}
    code = "import vcs_env; e = vcs_env.parallel_env(render_mode='rgb_array'); e.reset(seed=0); print(e.render().shape)"
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and proc.stdout.strip() == "(600, 600, 3)", proc.stderr
    assert "error" not in proc.stderr.lower(), proc.stderr


def test_closing_one_human_window_leaves_the_others_drawing(monkeypatch):
    """pygame has one display per process: closing one env quit it under another env's renderer, whose next
    frame failed ("display Surface quit"); the display closes with the last human renderer."""
    pygame = pytest.importorskip("pygame")
    from vcs_env.render import Renderer

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    before = Renderer.windows  # human renderers another test left open (none when each closes its env)
    a = vcs_env.parallel_env(scenario="circle", n_robots=2, render_mode="human")
    b = vcs_env.parallel_env(scenario="swap", render_mode="human")
    a.reset(seed=0)
    b.reset(seed=0)
    a.close()
    b.step({x: np.zeros(2, np.float32) for x in b.agents})
    assert pygame.display.get_init()
    b.close()
    assert Renderer.windows == before and pygame.display.get_init() == (before > 0)
    b.close()  # twice is harmless
    assert Renderer.windows == before


def test_spaces_are_identical_objects_and_unknown_agents_raise():
    env = vcs_env.parallel_env(scenario="circle", n_robots=3)
    assert env.observation_space("robot_0") is env.observation_space("robot_2")
    assert env.action_space("robot_1") is env.action_space("robot_1")
    with pytest.raises(ValueError, match="unknown agent"):
        env.action_space("robot_7")


def test_bad_actions_raise_clear_errors():
    env = vcs_env.parallel_env(scenario="swap")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="robot_0.*finite"):
        env.step({"robot_0": np.array([np.nan, 0.0]), "robot_1": np.zeros(2)})
    with pytest.raises(ValueError, match="robot_1.*shape"):
        env.step({"robot_0": np.zeros(2), "robot_1": np.zeros(3)})
    with pytest.raises(ValueError, match="missing actions"):
        env.step({"robot_0": np.zeros(2)})
    with pytest.raises(ValueError, match="unknown agent"):
        env.step({"robot_0": np.zeros(2), "robot_1": np.zeros(2), "robot_9": np.zeros(2)})
    with pytest.raises(ValueError, match="dict"):
        env.step([np.zeros(2), np.zeros(2)])
    # Anything but real numbers is refused by name in every adapter (complex parts were dropped
    # with a ComplexWarning, strings were parsed as numbers).
    for bad in (np.array([1j, 0.0]), ["0.5", "0"], [0.5, "x"]):
        with pytest.raises(ValueError, match="robot_0 must be real numbers"):
            env.step({"robot_0": bad, "robot_1": np.zeros(2)})
    single = gym.make("vcs_env/Swap-v2").unwrapped
    single.reset(seed=0)
    with pytest.raises(ValueError, match="action must be real numbers"):
        single.step(np.array([0.5 + 1j, 0.0]))
    vec = gym.make_vec("vcs_env/Swap-v2", num_envs=2, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="actions must be real numbers"):
        vec.step(np.zeros((2, 2), dtype=complex))
    # An unknown planner for the other robots is named even when there are none to drive.
    with pytest.raises(ValueError, match="unknown planner 'nope'"):
        gym.make("vcs_env/Circle-v2", n_robots=1, others="nope")


def test_render_fps_is_real_time_for_the_scenario_step():
    for dt in (0.1, 0.05):
        par = vcs_env.parallel_env(scenario="circle", dt=dt)
        aec = vcs_env.env(scenario="circle", dt=dt)
        single = gym.make("vcs_env/Circle-v2", dt=dt)
        for e in (par, aec, single):
            assert e.metadata["render_fps"] == pytest.approx(1.0 / dt)
    assert vcs_env.parallel_env(scenario="circle").metadata["render_modes"] == ["human", "rgb_array", "ansi"]


def test_info_events_and_state():
    env = vcs_env.parallel_env(scenario="swap", expert="straight")
    obs, infos = env.reset(seed=3)
    assert infos["robot_0"]["expert_action"].shape == (2,)
    assert env.state_space.contains(env.state())
    _, rew, _, _, infos = env.step({a: np.zeros(2) for a in env.agents})
    info = infos["robot_0"]
    assert set(info) >= {"reward_terms", "reached_goal", "collided_with", "min_separation", "expert_action"}
    terms = info["reward_terms"]
    w = env.scenario.rewards.as_dict()
    assert rew["robot_0"] == pytest.approx(sum(w[k] * v for k, v in terms.items()))


def test_expert_actions_handed_out_are_the_callers_own():
    # Stored expert labels must not change when the env resets, and editing one in place must not
    # change what the env compares against (vcs_imitation).
    env = vcs_env.parallel_env(scenario="circle", n_robots=4, jitter=0.2, expert="vcs")
    _, infos = env.reset(seed=0)
    for _ in range(3):
        _, _, _, _, infos = env.step({a: infos[a]["expert_action"] for a in env.agents})
    kept = infos["robot_1"]["expert_action"]
    snapshot = kept.copy()
    engine_before = env.engine.expert_action.copy()
    kept += 0.5
    np.testing.assert_array_equal(env.engine.expert_action, engine_before)
    env.reset(seed=1)
    np.testing.assert_array_equal(kept, snapshot + 0.5)
    single = gym.make("vcs_env/Circle-v2", expert="vcs")
    _, info = single.reset(seed=0)
    held = info["expert_action"].copy()
    info["expert_action"] += 0.5
    np.testing.assert_array_equal(single.unwrapped.engine.expert_action[0, 0], held)


def test_obstacle_motion_keyword_is_the_scenario_field_in_every_adapter():
    pz = vcs_env.parallel_env(scenario="dynamic", obstacle_motion="constant")
    single = gym.make("vcs_env/Dynamic-v2", obstacle_motion="constant")
    vec = gym.make_vec("vcs_env/Dynamic-v2", num_envs=2, obstacle_motion="constant")
    for env in (pz, single.unwrapped, vec.unwrapped):
        assert env.scenario.obstacle_motion == "constant"
    pz.reset(seed=0)
    single.reset(seed=0)
    vec.reset(seed=0)
    v0 = pz.engine.world.obs_vel.copy()
    for _ in range(5):  # constant velocity: no turns (the dynamic preset's obstacles turn)
        pz.step({a: np.zeros(2) for a in pz.agents})
    far = np.abs(pz.engine.world.obs_pos).max(axis=-1) < pz.scenario.arena_half_size - 0.5  # no wall bounce
    np.testing.assert_allclose(pz.engine.world.obs_vel[far], v0[far])
    with pytest.raises(ValueError, match="obstacle_motion must be one of"):
        vcs_env.parallel_env(scenario="dynamic", obstacle_motion="teleport")
    with pytest.raises(ValueError, match="ObstacleMotion"):
        vcs_env.parallel_env(scenario="dynamic", obstacle_motion=3)


def test_obstacle_motion_keyword_takes_the_fields_that_need_it():
    """``obstacle_motion="pedestrians"`` and ``pedestrians=...`` given together to an env are one scenario (the
    spec was checked against the preset's motion before the keyword was applied, and refused)."""
    from vcs_env.pedestrians import PedestrianSpec

    spec = PedestrianSpec(model="social_force")
    kw = {"obstacle_motion": "pedestrians", "pedestrians": spec}
    pz = vcs_env.parallel_env(scenario="crowd", **kw)
    single = gym.make("vcs_env/Crowd-v2", **kw)
    vec = gym.make_vec("vcs_env/Crowd-v2", num_envs=2, vectorization_mode="vector_entry_point", **kw)
    for env in (pz, single.unwrapped, vec.unwrapped):
        assert env.scenario.obstacle_motion == "pedestrians" and env.scenario.pedestrians == spec
        assert env.engine.scenario == env.scenario
    with pytest.raises(ValueError, match="pedestrians needs obstacle_motion='pedestrians'"):
        vcs_env.parallel_env(scenario="crowd", pedestrians=spec)


def test_engine_arguments_are_checked_by_name():
    from vcs_env.engine import NavEngine

    s = vcs_env.make_scenario("circle", n_robots=2)
    for kw, message in (({"gamma": "x"}, "gamma must be a number"), ({"max_steps": 0}, "max_steps must be"),
                        ({"max_steps": 2.5}, "max_steps must be")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            NavEngine(s, **kw)


def test_bad_seeds_and_limits_are_named(tmp_path, capsys):
    import vcs_cli as cli
    from agents.vec_env import NavVecEnv

    env = vcs_env.parallel_env(max_cycles=np.int64(5))  # numpy integers are integers
    for seed in (1.5, -3, "abc"):
        with pytest.raises(ValueError, match="seeds must be non-negative integers"):
            env.reset(seed=seed)
    with pytest.raises(ValueError, match="max_cycles must be"):
        env.max_cycles = 0
    with pytest.raises(ValueError, match=r"max_cycles must be an integer in \[1, 10000000\], got 100000000"):
        vcs_env.parallel_env(max_cycles=10**8)  # named max_steps, the scenario's field it sets, not the one given
    with pytest.raises(ValueError, match=r"obstacle_speed must be a \(low, high\) pair"):
        vcs_env.make_scenario("crowd", obstacle_speed=1.0)
    vec = gym.make_vec("vcs_env/Circle-v2", num_envs=2)
    with pytest.raises(ValueError, match="seed must be an integer, None or one seed per world"):
        vec.reset(seed="ab")
    slots = NavVecEnv(vcs_env.make_scenario("circle", n_robots=4), n_worlds=2)
    slots.reset()
    with pytest.raises(ValueError, match=r"actions must have shape \(8, 2\)"):
        slots.step(np.zeros((5, 2)))
    # The CLI: a negative seed is named; output files may go to directories that do not exist yet.
    assert cli.main(["rollout", "--seed", "-5"]) == 2
    assert "--seed must be >= 0" in capsys.readouterr().err
    out = tmp_path / "new" / "dir" / "metrics.json"
    assert cli.main(["rollout", "--episodes", "1", "--n-robots", "2", "--max-steps", "5", "--json", str(out)]) == 0
    rows = json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"{c} is not JSON"))
    assert rows[0]["time_to_goal"] is None  # no robot arrived in 5 steps: no value, null (it was a bare NaN)
    # Outputs that cannot be written are refused before the episodes, not after them (a later output lost).
    capsys.readouterr()
    bad = (("--json", "/proc/x/m.json", "cannot be written"), ("--plot", "p.xyz", "must end in .png"))
    for flag, path, said in bad:
        assert cli.main(["rollout", "--episodes", "1", "--max-steps", "5", flag, path]) == 2
        assert said in capsys.readouterr().err


def test_pickle_round_trip():
    env = vcs_env.parallel_env(scenario="crowd", n_obstacles=3)
    clone = pickle.loads(pickle.dumps(env))
    a, _ = env.reset(seed=5)
    b, _ = clone.reset(seed=5)
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])


def test_a_copy_taken_mid_episode_continues_as_the_env_would():
    """EzPickle rebuilt the PettingZoo env from its arguments: a deepcopy or pickle taken mid-episode was an env never
    reset (its step raised), and the AEC wrapper's copy listed live agents over an empty inner env."""
    import copy

    env = vcs_env.parallel_env(scenario="dynamic", n_robots=3, expert="vcs", render_mode="rgb_array")
    _, infos = env.reset(seed=3)
    for _ in range(15):
        _, _, _, _, infos = env.step({a: infos[a]["expert_action"] for a in env.agents})
    env.render()  # a renderer (pygame) stays behind; the copies open their own
    copies = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    runs = []
    for e in [env, *copies]:
        i, steps = infos, []
        for _ in range(10):
            obs, rew, _, _, i = e.step({a: i[a]["expert_action"] for a in e.agents})
            steps.append((np.concatenate([obs[a] for a in sorted(obs)]), sorted(rew.items())))
        runs.append(steps)
        assert e.render().shape[-1] == 3
    for other in runs[1:]:
        assert all(np.array_equal(x[0], y[0]) and x[1] == y[1] for x, y in zip(runs[0], other))
    aec = vcs_env.env(scenario="circle", n_robots=2)
    aec.reset(seed=0)
    for _ in range(6):
        aec.step(np.zeros(2, np.float32))
    twin = copy.deepcopy(aec)
    for e in (aec, twin):
        e.step(np.full(2, 0.5, np.float32))
    np.testing.assert_array_equal(aec.observe(aec.agent_selection), twin.observe(twin.agent_selection))


@pytest.mark.parametrize("env_id", sorted(vcs_env.GYM_IDS))
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped)
    env.close()


@pytest.mark.slow
def test_gym_make_overrides_and_vector_envs():
    env = gym.make("vcs_env/Navigation-v2", scenario="crowd", n_obstacles=2, others="straight")
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    obs, reward, term, trunc, info = env.step(env.action_space.sample())
    assert "reward_terms" in info
    env.close()
    vec = gym.make_vec(
        "vcs_env/Swap-v2", num_envs=2, vectorization_mode="async", vector_kwargs={"context": "spawn"}, others="straight"
    )
    obs, _ = vec.reset(seed=1)
    assert obs.shape == (2, vec.single_observation_space.shape[0])
    vec.step(np.zeros((2, 2), dtype=np.float32))
    vec.close()


def test_gym_env_seeding_is_reproducible():
    def rollout(seed):
        env = gym.make("vcs_env/Crossing-v2", others="vcs")
        obs, _ = env.reset(seed=seed)
        out = [obs]
        for _ in range(20):
            obs, *_ = env.step(np.array([0.5, 0.1], dtype=np.float32))
            out.append(obs)
        return np.array(out)

    np.testing.assert_array_equal(rollout(7), rollout(7))


def test_aec_env_via_parallel_to_aec_matches_the_parallel_env():
    acts = {"robot_0": np.array([1.0, 0.2], np.float32), "robot_1": np.array([0.5, -0.3], np.float32)}
    par = vcs_env.parallel_env(scenario="swap")
    par.reset(seed=0)
    aec = parallel_to_aec(vcs_env.parallel_env(scenario="swap"))
    aec.reset(seed=0)
    for _ in range(10):
        obs, rew, *_ = par.step(acts)
        for agent in ("robot_0", "robot_1"):  # one AEC cycle steps the parallel env once
            assert aec.agent_selection == agent
            aec.step(acts[agent])
        for agent in par.agents:
            np.testing.assert_array_equal(aec.observe(agent), obs[agent])
            assert aec.rewards[agent] == rew[agent] != 0.0


def test_registered_ids_fix_their_observation_version():
    """An id's observation version holds: the keyword asking for the other one is refused by name (the registries
    merge a user's keywords into the registered ones, so it replaced the version and built a -v2 env under a -v1
    id); the same version given again is accepted."""
    import pettingzoo

    assert gym.make("vcs_env/Navigation-v1", observation=1).unwrapped.scenario.observation == 1
    assert gym.make("vcs_env/Crowd-v2", observation=2).observation_space.shape == (11 + 9 * 8,)
    for make in (
        lambda: gym.make("vcs_env/Navigation-v1", observation=2),
        lambda: gym.make("vcs_env/Swap-v2", observation=1),
        lambda: gym.make_vec("vcs_env/Crowd-v1", 2, vectorization_mode="vector_entry_point", observation=2),
        lambda: gym.make_vec("vcs_env/Crowd-v1", 2, vectorization_mode="sync", observation=2),
        lambda: pettingzoo.make("parallel", "vcs_env/VcsNav-v1", observation=2),
        lambda: pettingzoo.make("aec", vcs_env.PZ_ID, observation=1),
    ):
        with pytest.raises(ValueError, match=r"was given to a -v\d id, which fixes observation version \d: use the"):
            make()
    with pytest.raises(ValueError, match=r"use the -v2 id of the same name \(vcs_env/<Name>-v2"):
        gym.make("vcs_env/Swap-v1", observation=2)  # the twin of the id used, not Navigation (another preset)
    for bad in (3, 0, None, "2", 2.0, True):  # no version at all: the scenario's own check names it, as before
        with pytest.raises(ValueError, match=r"observation must be an integer in \[1, 2\]"):
            gym.make("vcs_env/Navigation-v2", observation=bad)
    # gym.make still reads the entry point's render modes (the rgb_array_list collection wrapper)
    assert type(gym.make("vcs_env/Navigation-v2", render_mode="rgb_array_list")).__name__ == "RenderCollection"


def test_pettingzoo_registry():
    import pettingzoo

    env = pettingzoo.make("parallel", vcs_env.PZ_ID, scenario="swap", max_cycles=5)
    assert env.metadata["name"] == "vcs_nav_v2" and env.max_cycles == 5
    assert env.observation_space("robot_0").shape == (11 + 9 * 8,)
    v1 = pettingzoo.make("parallel", "vcs_env/VcsNav-v1", scenario="swap")  # observation v1 stays available
    assert v1.observation_space("robot_0").shape == (11 + 8 * 8,) and v1.scenario.observation == 1
    # A scenario of one version given to the other version's id: refused by name (the id's version replaced it).
    with pytest.raises(ValueError, match="the scenario given has observation=1, and observation=2 is given too"):
        pettingzoo.make("parallel", vcs_env.PZ_ID, scenario=v1.scenario)
    with pytest.raises(ValueError, match="use the id of the scenario's version"):
        gym.make("vcs_env/Navigation-v2", scenario=v1.scenario)
    assert gym.make("vcs_env/Navigation-v1", scenario=v1.scenario).observation_space.shape == (11 + 8 * 8,)
    env.reset(seed=0)
    aec = pettingzoo.make("aec", vcs_env.PZ_ID, scenario="swap")
    aec.reset(seed=0)
    assert aec.agent_selection == "robot_0"


def test_sb3_evaluate_policy_counts_robot_episodes_not_padding():
    """A slot reports its robot's episode as SB3's Monitor does, and says so (``env_is_wrapped(Monitor)``):
    ``evaluate_policy`` then counts episodes by ``info["episode"]``, not by every ``done`` (a padding segment
    ends with done=True too, with no reward: it was counted as an episode of return 0)."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.monitor import Monitor

    from agents.vec_env import NavVecEnv

    full_throttle = np.array([1.0, 0.0], dtype=np.float32)

    class Throttle:
        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.tile(full_throttle, (len(obs), 1)), None

    # robot_0 starts 0.3 m from its goal (arrives after 9 full-throttle steps), robot_1 5 m (times out at 15)
    layout = vcs_env.CustomLayout(start=((0.0, 0.0), (0.0, 3.0)), goal=((0.3, 0.0), (5.0, 3.0)))
    venv = NavVecEnv(vcs_env.make_scenario("custom", custom=layout, n_robots=2, max_steps=15), n_worlds=2)
    assert venv.env_is_wrapped(Monitor) == [True] * 4 and venv.env_is_wrapped(NavVecEnv) == [False] * 4
    returns, lengths = evaluate_policy(Throttle(), venv, n_eval_episodes=8, return_episode_rewards=True)
    assert sorted(lengths) == [9] * 4 + [15] * 4  # robot_0 arrives after 9 steps, robot_1 times out at 15
    assert 0.0 not in returns


def test_a_gymnasium_seed_names_its_world_for_the_other_doors():
    """The Gymnasium envs draw the world's seed from Gymnasium's np_random; gym_world_seed gives it, so the PettingZoo
    env (which uses its seed as the world's) can start the same world (the same seed started another one)."""
    from vcs_env.gym_env import gym_world_seed

    kw = dict(scenario="random", n_robots=4, arena_half_size=3.0)
    for seed in (0, 7):
        g = gym.make("vcs_env/Navigation-v2", **kw)
        obs, _ = g.reset(seed=seed)
        p = vcs_env.parallel_env(**kw)
        pobs, _ = p.reset(seed=gym_world_seed(seed))
        np.testing.assert_array_equal(obs, pobs["robot_0"])
        for field in ("pos", "goal", "heading", "obs_pos"):
            np.testing.assert_array_equal(getattr(g.unwrapped.world, field), getattr(p.engine.world, field))


def test_numpy_integer_seeds_work_on_every_gymnasium_door():
    """np.int64 seeds (as ``np.arange`` hands them out) start the same worlds as Python ints on ``gym.make``, and per
    env on ``gym.make_vec`` in ``sync`` mode (Gymnasium's seeding takes Python ints only; the other doors take both)."""
    kw = dict(scenario="random", n_robots=3, arena_half_size=3.0)
    ints = [gym.make("vcs_env/Navigation-v2", **kw).reset(seed=5)[0]]
    nps = [gym.make("vcs_env/Navigation-v2", **kw).reset(seed=np.int64(5))[0]]
    for out, seeds in ((ints, [5, 6]), (nps, list(np.arange(5, 7)))):
        v = gym.make_vec("vcs_env/Navigation-v2", num_envs=2, vectorization_mode="sync", **kw)
        out.append(v.reset(seed=seeds)[0])
        v.close()
    for a, b in zip(ints, nps):
        np.testing.assert_array_equal(a, b)
