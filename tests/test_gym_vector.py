"""The Gymnasium vector entry point (VcsNavVectorEnv) and its SB3 adapter.

The oracle is Gymnasium's own SyncVectorEnv over the single env: same seeds and actions must give
the same observations, rewards, flags and infos, bit for bit, across autoresets.
"""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import vcs_env
from vcs_env.gym_env import VcsNavVectorEnv

SMALL = dict(n_robots=3, n_obstacles=2, max_steps=40)  # short episodes: many autoresets


def make(mode, num_envs=3, env_id="vcs_env/Dynamic-v2", **kw):
    return gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=mode, **{**SMALL, **kw})


def assert_same(a, b, path="info"):
    """Exact equality of nested dicts / arrays (object arrays element by element)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            assert_same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{path}[{i}]")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, path
        if a.dtype == object:
            assert list(a) == list(b), path
        else:
            np.testing.assert_array_equal(a, b, err_msg=path)
    else:
        assert a == b, path


@pytest.mark.parametrize(
    "env_id, kw",
    [
        ("vcs_env/Dynamic-v2", {}),
        ("vcs_env/Crowd-v2", {"expert": "vcs", "on_collision": "continue"}),
        ("vcs_env/Circle-v2", {"n_robots": 1, "n_obstacles": 0}),
        ("vcs_env/Dynamic-v2", {"max_episode_steps": 7}),  # a TimeLimit in sync mode
        ("vcs_env/Navigation-v2", {"scenario": "corridor", "action_mode": "absolute", "on_collision": "continue"}),
    ],
)
def test_vector_entry_point_equals_sync_bit_for_bit(env_id, kw):
    fast, slow = make("vector_entry_point", env_id=env_id, **kw), make("sync", env_id=env_id, **kw)
    assert isinstance(fast.unwrapped, VcsNavVectorEnv)
    assert fast.observation_space == slow.observation_space and fast.action_space == slow.action_space
    assert_same(fast.reset(seed=7), slow.reset(seed=7), "reset")
    rng = np.random.default_rng(0)
    ends = walls = 0
    pending = np.zeros(3, dtype=bool)  # worlds whose episode ended: the next step resets them, ignoring their action
    for t in range(120):
        actions = rng.uniform(-1.2, 1.2, (3, 2)).astype(np.float32)
        actions[pending] = np.nan  # ignored, so not refused (a policy's output for a finished episode)
        a, b = fast.step(actions), slow.step(actions)
        pending = a[2] | a[3]
        for x, y, name in zip(a, b, ("obs", "reward", "terminated", "truncated", "info")):
            assert_same(x, y, f"step {t} {name}")
        assert fast.observation_space.contains(a[0])
        ends += int((a[2] | a[3]).sum())
        walls += sum(name.startswith("wall_") for hits in a[4].get("collided_with", []) if hits for name in hits)
        if t == 60:  # reset a subset, mid-episode
            mask = np.array([True, False, True])
            assert_same(fast.reset(options={"reset_mask": mask}), slow.reset(options={"reset_mask": mask.copy()}))
            pending &= ~mask
    assert ends >= 3  # autoresets were exercised
    assert walls > 0 or kw.get("scenario") != "corridor"  # wall contacts were named


def test_one_engine_call_steps_every_world(monkeypatch):
    env = make("vector_entry_point", num_envs=5)
    engine = env.unwrapped.engine
    assert engine.batch_size == 5
    calls = []
    real = engine.step
    monkeypatch.setattr(engine, "step", lambda *a, **k: calls.append(1) or real(*a, **k))
    env.reset(seed=0)
    for _ in range(4):
        env.step(np.zeros((5, 2), dtype=np.float32))
    assert len(calls) == 4


def test_metadata_and_gymnasium_vector_wrappers():
    env = make("vector_entry_point", num_envs=4)
    assert env.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    # Vector wrappers read the autoreset mode; observation wrappers accept only NEXT_STEP / DISABLED.
    env = gym.wrappers.vector.NormalizeObservation(gym.wrappers.vector.RecordEpisodeStatistics(env))
    env.reset(seed=1)
    episodes = 0
    for _ in range(100):
        _, _, _, _, info = env.step(env.action_space.sample())
        if "episode" in info:
            episodes += int(info["_episode"].sum())
            assert np.all(info["episode"]["l"][info["_episode"]] > 0)
    assert episodes >= 4


def test_bad_input_raises_clear_errors():
    env = make("vector_entry_point", num_envs=2)
    with pytest.raises(RuntimeError, match=r"before the first reset\(\); call reset\(\) first"):
        env.step(np.zeros((2, 2)))
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(2, 2\)"):
        env.step(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([[0.0, np.nan], [0.0, 0.0]]))
    with pytest.raises(ValueError, match="reset_mask"):
        env.reset(options={"reset_mask": np.zeros(2, dtype=bool)})
    with pytest.raises(ValueError, match="num_envs"):
        VcsNavVectorEnv(num_envs=0)
    with pytest.raises(ValueError, match="max_episode_steps"):
        VcsNavVectorEnv(num_envs=2, max_episode_steps=0)
    with pytest.raises(ValueError, match="seeds"):
        env.reset(seed=[1, 2, 3])


def test_every_registered_id_has_the_vector_entry_point():
    for env_id in vcs_env.GYM_IDS:
        for v in (1, 2):
            vid = env_id.replace("-v2", f"-v{v}")
            assert gym.spec(vid).vector_entry_point == f"vcs_env.registry:vector_v{v}"
            env = gym.make_vec(vid, 2, vectorization_mode="vector_entry_point")
            assert isinstance(env, VcsNavVectorEnv) and env.scenario.observation == v
            env.close()


def test_sb3_adapter_equals_dummy_vec_env():
    """GymVectorToSB3 over the vector entry point gives what SB3's DummyVecEnv over the single env
    gives: same observations, rewards, dones and terminal observations."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.gym_vec import GymVectorToSB3

    fast = GymVectorToSB3(make("vector_entry_point"))
    slow = DummyVecEnv([lambda: gym.make("vcs_env/Dynamic-v2", **SMALL) for _ in range(3)])
    fast.seed(11)
    slow.seed(11)
    np.testing.assert_array_equal(fast.reset(), slow.reset())
    rng = np.random.default_rng(1)
    dones = 0
    for _ in range(100):
        actions = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        obs_a, rew_a, done_a, info_a = fast.step(actions)
        obs_b, rew_b, done_b, info_b = slow.step(actions)
        np.testing.assert_array_equal(obs_a, obs_b)
        np.testing.assert_array_equal(rew_a, rew_b)
        np.testing.assert_array_equal(done_a, done_b)
        for i in np.flatnonzero(done_a):
            np.testing.assert_array_equal(info_a[i]["terminal_observation"], info_b[i]["terminal_observation"])
            assert info_a[i]["TimeLimit.truncated"] == info_b[i]["TimeLimit.truncated"]
        dones += int(done_a.sum())
    assert dones >= 3
    # set_options reaches the vector env's reset (here a mask that selects nothing: its error).
    fast.set_options({"reset_mask": np.zeros(3, dtype=bool)})
    with pytest.raises(ValueError, match="reset_mask"):
        fast.reset()


def test_sb3_ppo_learns_through_the_adapter():
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    from agents.gym_vec import GymVectorToSB3

    torch.set_num_threads(1)
    venv = VecMonitor(GymVectorToSB3(make("vector_entry_point", num_envs=4)))
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(256)
    assert model.num_timesteps >= 256 and len(model.ep_info_buffer) > 0
    with pytest.raises(ValueError, match="NEXT_STEP"):
        GymVectorToSB3(make("sync", vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}))


@pytest.mark.parametrize("vector", [False, True])
def test_one_planner_instance_as_others_and_expert_gives_the_same_episode(vector):
    """``others=p, expert=p``: the env must not plan the state a second time with the planner's
    memory already advanced (the expert labels then drifted from step 7 on); the episode equals
    the one with two separate instances."""
    from baselines.vcs.planner import VCSPlanner
    from vcs_env.gym_env import VcsNavEnv, VcsNavVectorEnv

    def run(shared):
        p = VCSPlanner()
        kw = dict(others=p, expert=p if shared else VCSPlanner(), n_robots=4)
        env = VcsNavVectorEnv(2, "circle", **kw) if vector else VcsNavEnv("circle", **kw)
        obs, info = env.reset(seed=3)
        out = [np.asarray(info["expert_action"], dtype=np.float64).copy()]
        for _ in range(40):
            obs, *_, info = env.step(out[-1])  # follow the expert
            out.append(np.asarray(info["expert_action"], dtype=np.float64).copy())
        return np.array(out)

    np.testing.assert_array_equal(run(True), run(False))


def test_a_robot_arriving_on_the_time_limits_step_is_truncated_too_as_in_sync():
    """gym.make's TimeLimit marks its last step truncated also when the robot terminates on it; the vector entry
    point said terminated only. The expert's robot arrives on step 138 of seed 0 here."""
    kw = dict(scenario="crowd", n_obstacles=3, expert="vcs", max_episode_steps=138)
    flags = {}
    for mode in ("vector_entry_point", "sync"):
        env = gym.make_vec("vcs_env/Navigation-v2", num_envs=1, vectorization_mode=mode, **kw)
        info = env.reset(seed=0)[1]
        flags[mode] = []
        for _ in range(139):
            _, _, terminated, truncated, info = env.step(np.asarray(info["expert_action"], np.float32).reshape(1, 2))
            flags[mode].append((bool(terminated[0]), bool(truncated[0])))
    assert flags["sync"][137] == (True, True)
    assert flags["vector_entry_point"] == flags["sync"]
