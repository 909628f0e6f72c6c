"""The TorchRL env (:class:`vcs_env.torchrl.VcsNavEnv`): TorchRL's own spec check, bit-for-bit agreement
with the batched engine, partial resets, robots that finish at different times, seeding, errors, and a
tiny collector run. The ``torchrl`` extra is part of ``.[all]``: these tests run, never skip."""

import inspect
import pathlib
import re

import numpy as np
import pytest
import torch
from tensordict import TensorDict
from torchrl.envs.utils import check_env_specs, step_mdp

from vcs_env.engine import NavEngine
from vcs_env.pedestrians import PedestrianSpec
from vcs_env.scenario import make_scenario
from vcs_env.torchrl import VcsNavEnv

torch.set_num_threads(1)
ROOT = pathlib.Path(__file__).resolve().parents[1]


def replay(actions: np.ndarray):
    """A rollout policy that writes ``actions[t]`` ``(B, n, 2)`` at its ``t``-th call."""
    it = iter(actions)

    def policy(td):
        td.set(("agents", "action"), torch.from_numpy(next(it)))
        return td

    return policy


@pytest.mark.parametrize(
    "scenario, num_envs, kwargs",
    [
        ("circle", 4, {"n_robots": 3}),
        ("corridor", 2, {}),  # a map: static walls
        ("crowd", 3, {"expert": "straight"}),  # moving obstacles, expert action in the specs
        ("crowd", 2, {"obstacle_motion": "pedestrians", "pedestrians": PedestrianSpec()}),  # the keyword + its field
    ],
)
def test_check_env_specs(scenario, num_envs, kwargs):
    env = VcsNavEnv(scenario, num_envs, **kwargs)
    check_env_specs(env, seed=0, break_when_any_done="both")
    td = env.reset()
    n = env.n_robots
    assert td.batch_size == (num_envs,)
    assert td["agents"].batch_size == (num_envs, n)
    assert td["agents", "observation"].shape == (num_envs, n, env.observation_spec["agents", "observation"].shape[-1])
    assert td["agents", "mask"].all()
    assert ("agents", "expert_action") in td.keys(True) if "expert" in kwargs else ("agents", "expert_action") not in td
    assert env.group_map == {"agents": [f"robot_{i}" for i in range(n)]}


@pytest.mark.parametrize("scenario, expert", [("dynamic", None), ("crowd", "straight")])
def test_rollout_matches_the_engine_bit_for_bit(scenario, expert):
    """64 worlds, random actions, episodes ending by crashes, arrivals and time-outs: the TorchRL rollout
    (with its resets through '_reset') equals stepping the engine directly with auto-reset."""
    B, T, seed = 64, 30, 7
    scenario = make_scenario(scenario, max_steps=12)
    n = scenario.n_robots
    actions = np.random.default_rng(0).uniform(-1, 1, (T, B, n, 2)).astype(np.float32)

    env = VcsNavEnv(scenario, B, expert=expert)
    env.set_seed(seed)
    data = env.rollout(T, replay(actions), break_when_any_done=False)

    engine = NavEngine(scenario, B, expert=expert)
    shown = engine.reset([seed + b for b in range(B)])  # what the robots see (zeros once they finished)
    expert_action = engine.expert_action
    live = engine.world.active.copy()
    term = np.zeros((B, n), dtype=bool)
    trunc = np.zeros((B, n), dtype=bool)
    n_ended = 0
    for t in range(T):
        step = data[:, t]
        assert np.array_equal(step["agents", "observation"].numpy(), shown)
        assert np.array_equal(step["agents", "mask"].numpy(), live)
        if expert is not None:
            want = np.where(live[..., None], expert_action, 0.0).astype(np.float32)
            assert np.array_equal(step["agents", "expert_action"].numpy(), want)
        res = engine.step(actions[t].astype(np.float64), autoreset=True)  # finished rows are NOT zeroed here
        last = res.obs if res.final_obs is None else np.where(res.ended[:, None, None], res.final_obs, res.obs)
        term |= live & res.terminated
        trunc |= live & res.truncated
        nxt = step["next"]
        shown = np.where(live[..., None], last, 0.0).astype(np.float32)  # a robot's last step shows where it ended
        assert np.array_equal(nxt["agents", "observation"].numpy(), shown)
        assert np.array_equal(
            nxt["agents", "reward"].numpy()[..., 0], np.where(live, res.reward, 0.0).astype(np.float32)
        )
        assert np.array_equal(nxt["agents", "terminated"].numpy()[..., 0], term)
        assert np.array_equal(nxt["agents", "truncated"].numpy()[..., 0], trunc)
        assert np.array_equal(nxt["agents", "done"].numpy()[..., 0], term | trunc)
        assert np.array_equal(nxt["done"].numpy()[:, 0], res.ended)
        assert np.array_equal(nxt["truncated"].numpy()[:, 0], res.ended & trunc.any(axis=1))
        assert np.array_equal(nxt["terminated"].numpy()[:, 0], res.ended & ~trunc.any(axis=1))
        live = live & ~(res.terminated | res.truncated)
        live[res.ended] = engine.world.active[res.ended]
        term[res.ended] = trunc[res.ended] = False
        shown[res.ended] = res.obs[res.ended]  # the first observation of the new episode
        expert_action = res.expert_action
        n_ended += int(res.ended.sum())
    assert n_ended >= B  # every world went through at least one reset
    if scenario.n_robots > 1:  # and some robots ended before their world (crashes / arrivals)
        assert (data["next", "agents", "terminated"].any(-2) & ~data["next", "done"]).any()


def test_partial_reset_resets_only_the_masked_worlds():
    B = 4
    env = VcsNavEnv("dynamic", B)
    env.set_seed(3)
    td = env.reset()
    for _ in range(3):
        td = step_mdp(env.step(env.rand_action(td)))
    pos = env.engine.world.pos.copy()
    worlds = torch.tensor([True, False, True, False])
    td.set("_reset", worlds[:, None])
    env.set_seed(3)  # worlds 0 and 2 restart from seeds 3 and 5 (world b: seed + b)
    out = env.reset(td)
    assert env.engine.world.steps.tolist() == [0, 3, 0, 3]
    kept = ~worlds.numpy()
    assert np.array_equal(env.engine.world.pos[kept], pos[kept])
    assert not np.array_equal(env.engine.world.pos[~kept], pos[~kept])
    assert (out["agents", "observation"][kept] == td["agents", "observation"][kept]).all()
    # The reset worlds start as those of a fresh env with the same seed start.
    fresh = VcsNavEnv("dynamic", B)
    fresh.set_seed(3)
    first = fresh.reset()
    assert (out["agents", "observation"][~kept] == first["agents", "observation"][~kept]).all()
    # Given only the per-robot "_reset", a world resets when all its robots ask.
    per_robot = torch.zeros(B, env.n_robots, 1, dtype=torch.bool)
    per_robot[1] = True
    per_robot[3, 0] = True
    env.reset(TensorDict({"agents": TensorDict({"_reset": per_robot}, (B, env.n_robots))}, (B,)))
    assert env.engine.world.steps.tolist() == [0, 0, 0, 3]
    # A mask of another shape is named (a per-robot mask at the root failed in a reshape: "shape '[4]' is invalid").
    n = env.n_robots
    with pytest.raises(ValueError, match=rf'reset mask "_reset" must have shape \(4,\) or \(4, 1\), got \(4, {n}\)'):
        env.reset(TensorDict({"_reset": per_robot[..., 0]}, (B,)))
    with pytest.raises(ValueError, match=rf'reset mask \("agents", "_reset"\) must have shape \(4, {n}\)'):
        env.reset(TensorDict({"agents": TensorDict({"_reset": per_robot[:, :2]}, (B, 2))}, (B,)))
    assert env.engine.world.steps.tolist() == [0, 0, 0, 3]


def test_robots_finishing_at_different_times_keep_their_world_running():
    """Robot 0 drives to its goal; robots 1 and 2 brake and wait, so they time out at max_steps."""
    B, T, limit = 2, 64, 60
    env = VcsNavEnv("circle", B, expert="straight", n_robots=3, layout_radius=1.5, max_steps=limit)
    env.set_seed(0)

    def policy(td):
        action = torch.zeros(B, 3, 2)
        action[:, 1:, 0] = -1.0  # brake: stay at rest
        action[:, 0] = td["agents", "expert_action"][:, 0]
        td.set(("agents", "action"), action)
        return td

    data = env.rollout(T, policy, break_when_any_done=False)
    nxt = data["next"]
    done0 = nxt["agents", "terminated"][:, :, 0, 0]
    arrival = int(done0[0].nonzero()[0])  # the step robot 0 reached its goal
    assert 0 < arrival < limit - 2
    assert nxt["agents", "info", "reached_goal"][:, arrival, 0].all()
    after = slice(arrival + 1, limit)
    assert not data["agents", "mask"][:, after, 0].any() and data["agents", "mask"][:, after, 1:].all()
    assert (nxt["agents", "observation"][:, after, 0] == 0).all()  # finished: zeros, no reward
    assert (nxt["agents", "reward"][:, after, 0] == 0).all()
    assert nxt["agents", "done"][:, arrival:limit, 0].all()  # sticky until the world resets
    assert not nxt["done"][:, : limit - 1].any()  # the world runs on while robots 1, 2 wait
    assert nxt["done"][:, limit - 1].all() and nxt["truncated"][:, limit - 1].all()
    assert not nxt["terminated"][:, limit - 1].any()
    assert nxt["agents", "truncated"][:, limit - 1, 1:].all() and not nxt["agents", "truncated"][:, limit - 1, 0].any()
    assert data["agents", "mask"][:, limit].all() and not data["agents", "done"][:, limit].any()  # reset
    # TorchRL's rollout stops at the first done world (the env-level flags prevail), not at robot 0's arrival.
    env.set_seed(0)
    assert env.rollout(T, policy).batch_size == (B, limit)


def test_returned_tensordicts_do_not_change_afterwards():
    """The env hands out views of its arrays, so it must never write into one it handed out."""
    env = VcsNavEnv("dynamic", 4, max_steps=3)
    env.set_seed(0)
    first = env.reset()
    kept = first.clone()
    td = first
    for _ in range(4):  # through a time-out and the resets that follow it
        td = env.rand_action(td)
        out, td = env.step_and_maybe_reset(td)
        kept_out = out.clone()
    env.reset()
    for td, copy in ((first, kept), (out, kept_out)):  # TorchRL adds entries to them ("next"): not ours
        assert (td.select(*copy.keys(True, True)) == copy).all()


def test_per_robot_returns_with_reward_sum():
    """TorchRL's RewardSum on ('agents', 'reward') sums each robot's episode and restarts with its world."""
    from torchrl.envs import RewardSum, TransformedEnv

    env = VcsNavEnv("dynamic", 4, max_steps=10)
    tenv = TransformedEnv(env, RewardSum(in_keys=[env.reward_key], out_keys=[("agents", "episode_reward")]))
    check_env_specs(tenv, seed=0)
    tenv.set_seed(0)
    data = tenv.rollout(25, break_when_any_done=False)
    reward, total = data["next", "agents", "reward"], data["next", "agents", "episode_reward"]
    for episode in (slice(0, 10), slice(10, 20)):
        torch.testing.assert_close(total[:, episode], reward[:, episode].cumsum(1))


def test_same_seed_same_rollout():
    B, T = 8, 20
    actions = np.random.default_rng(1).uniform(-1, 1, (T, B, 6, 2)).astype(np.float32)
    runs = []
    for seed in (5, 5, 6):
        env = VcsNavEnv("random", B, max_steps=10)
        env.set_seed(seed)
        runs.append(env.rollout(T, replay(actions), break_when_any_done=False))
    a, b, c = (r["next", "agents", "observation"] for r in runs)
    assert torch.equal(a, b) and torch.equal(runs[0]["next", "agents", "reward"], runs[1]["next", "agents", "reward"])
    assert not torch.equal(a, c)
    # reset(seed=s) is set_seed(s) then reset() (the seed was ignored: fresh entropy every time).
    first = runs[0]["agents", "observation"][:, 0]
    for seed in (5, torch.tensor(5)):
        assert torch.equal(VcsNavEnv("random", B, max_steps=10).reset(seed=seed)["agents", "observation"], first)


@pytest.mark.parametrize("scenario, expert", [("crossing", "straight"), ("swap", "vcs")])
def test_expert_action_is_the_engine_expert_for_the_observation(scenario, expert):
    env = VcsNavEnv(scenario, 3, expert=expert)
    env.set_seed(0)
    td = env.reset()
    assert torch.equal(td["agents", "expert_action"], torch.tensor(env.engine.expert_action, dtype=torch.float32))
    td = env.step(td.set(("agents", "action"), td["agents", "expert_action"]))
    want = np.where(env._live[..., None], env.engine.expert_action, 0.0).astype(np.float32)
    assert np.array_equal(td["next", "agents", "expert_action"].numpy(), want)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"num_envs": 0}, "num_envs must be an integer >= 1"),
        ({"num_envs": -2}, "num_envs must be an integer >= 1"),
        ({"num_envs": 2.5}, "num_envs must be an integer >= 1"),
        ({"num_envs": True}, "num_envs must be an integer >= 1"),
        ({"scenario": "nope"}, "unknown scenario 'nope'"),
        ({"scenario": 3}, "scenario must be a preset name or a vcs_env.Scenario"),
        ({"n_robotz": 3}, "unknown Scenario fields"),
        ({"n_robots": 0}, "n_robots"),
        ({"action_mode": "fast"}, "action_mode must be one of"),
        ({"expert": "nope"}, "unknown planner 'nope'"),
        ({"max_steps": 0}, r"max_steps must be an integer in \[1, 10000000\]"),
        ({"device": "warp-drive"}, "device must be a torch device"),
        ({"device": "meta"}, "the meta device holds no data"),
    ],
)
def test_bad_arguments_raise_one_line_value_errors(kwargs, match):
    with pytest.raises(ValueError, match=match) as err:
        VcsNavEnv(**kwargs)
    assert "\n" not in str(err.value)


def test_the_time_limit_warning_reads_the_envs_own_max_steps():
    """It warned "every episode will be truncated" from the scenario's 600 steps after max_steps=20000 was given."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert VcsNavEnv("circle", n_robots=200, max_steps=20000).engine.max_steps == 20000
    with pytest.warns(UserWarning, match="leaves no robot the time to arrive") as caught:
        VcsNavEnv("circle", n_robots=200)
    assert caught[0].filename == __file__  # the user's line, not TorchRL's env metaclass


def test_bad_seed_and_actions_raise_value_errors():
    env = VcsNavEnv("swap", 2)
    with pytest.raises(ValueError, match="seed must be a non-negative integer"):
        env.set_seed(-1)
    env.set_seed(0)
    td = env.reset()
    td.set(("agents", "action"), torch.full((2, 2, 2), float("nan")))
    with pytest.raises(ValueError, match="must be finite"):
        env.step(td)


@pytest.mark.filterwarnings("ignore:Creating .*WeightUpdater:DeprecationWarning")  # torchrl.collectors' import
def test_a_collector_with_a_multi_agent_policy_collects_frames_for_gae():
    from tensordict.nn import NormalParamExtractor, TensorDictModule
    from torch import nn
    from torchrl.collectors import Collector
    from torchrl.modules import MultiAgentMLP, ProbabilisticActor, TanhNormal
    from torchrl.objectives.value import GAE

    torch.manual_seed(0)
    env = VcsNavEnv("swap", 4)
    env.set_seed(0)
    n, obs_dim = env.n_robots, env.observation_spec["agents", "observation"].shape[-1]
    net = nn.Sequential(
        MultiAgentMLP(obs_dim, 4, n_agents=n, centralized=False, share_params=True, depth=1, num_cells=16),
        NormalParamExtractor(),
    )
    module = TensorDictModule(
        net, in_keys=[("agents", "observation")], out_keys=[("agents", "loc"), ("agents", "scale")]
    )
    actor = ProbabilisticActor(
        module,
        spec=env.full_action_spec["agents", "action"],
        in_keys=[("agents", "loc"), ("agents", "scale")],
        out_keys=[("agents", "action")],
        distribution_class=TanhNormal,
        distribution_kwargs={"low": -1.0, "high": 1.0},
        return_log_prob=True,
    )
    # torchrl 0.14 registers a policy's transforms unless told not to; 0.11 has no such argument
    quiet = {"auto_register_policy_transforms": False}
    if "auto_register_policy_transforms" not in inspect.signature(Collector.__init__).parameters:
        quiet = {}
    collector = Collector(env, actor, frames_per_batch=32, total_frames=64, **quiet)
    batches = list(collector)
    collector.shutdown()
    assert len(batches) == 2
    batch = batches[0]
    assert batch.batch_size == (4, 8)
    assert batch["next", "agents", "reward"].shape == (4, 8, n, 1)
    assert batch["agents", "action"].abs().max() <= 1.0
    # The per-robot keys plug into TorchRL's GAE as in its multi-agent PPO tutorial.
    critic = TensorDictModule(
        MultiAgentMLP(obs_dim, 1, n_agents=n, centralized=True, share_params=True, depth=1, num_cells=16),
        in_keys=[("agents", "observation")],
        out_keys=[("agents", "state_value")],
    )
    gae = GAE(gamma=0.99, lmbda=0.95, value_network=critic)
    gae.set_keys(
        reward=("agents", "reward"),
        done=("agents", "done"),
        terminated=("agents", "terminated"),
        value=("agents", "state_value"),
        advantage=("agents", "advantage"),
        value_target=("agents", "value_target"),
    )
    with torch.no_grad():
        gae(batch)
    assert batch["agents", "advantage"].shape == (4, 8, n, 1) and torch.isfinite(batch["agents", "advantage"]).all()


def test_the_docs_examples_run():
    text = (ROOT / "docs" / "torchrl.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.DOTALL)
    assert len(blocks) == 1  # the quick start (README's example runs in tests/test_readme.py)
    for code in blocks:
        exec(compile(code, "docs/torchrl.md", "exec"), {})


def test_the_benchmark_contestants_step():
    from benchmarks.torchrl_bench import builders

    for name, build in builders(n=2, B=3).items():
        step = build()
        assert [step(), step()] == [3, 3], name
