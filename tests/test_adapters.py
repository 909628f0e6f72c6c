"""The trimmed PettingZoo step returns what the plain per-agent loop over the engine returns."""

import numpy as np

import vcs_env


def reference_info(res, i):
    """StepResult.info as it was: one robot at a time, straight from the arrays."""
    ev = res.events
    hits = [f"robot_{j}" for j in np.flatnonzero(ev.robot_hits[0, i])]
    hits += [f"obstacle_{k}" for k in np.flatnonzero(ev.obstacle_hits[0, i])]
    out = {
        "reward_terms": {name: float(v[0, i]) for name, v in res.terms.items()},
        "reached_goal": bool(ev.reached[0, i]),
        "collided_with": hits,
        "min_separation": float(ev.min_separation[0, i]),
    }
    if res.expert_action is not None:
        out["expert_action"] = res.expert_action[0, i]
    return out


def test_parallel_step_equals_the_per_agent_loop():
    kw = dict(
        scenario="dynamic", n_robots=5, n_obstacles=6, expert="vcs", on_collision="terminate", arena_half_size=3.0
    )
    env, ref = vcs_env.parallel_env(**kw), vcs_env.parallel_env(**kw)
    env.reset(seed=4)
    ref.reset(seed=4)
    rng = np.random.default_rng(0)
    collisions = 0
    for t in range(80):
        if not env.agents:
            break
        a = rng.uniform(-1, 1, (5, 2)).astype(np.float32)
        actions = {agent: a[env.agent_index[agent]] for agent in env.agents}
        if t % 3 == 0 and len(env.agents) < 5:  # a finished robot's action: ignored (slow path)
            gone = next(x for x in env.possible_agents if x not in env.agents)
            actions[gone] = np.array([np.nan, 0.0])
        obs, rew, term, trunc, infos = env.step(actions)
        live = list(ref.agents)
        batch = np.zeros((1, 5, 2))
        for agent in live:
            batch[0, ref.agent_index[agent]] = a[ref.agent_index[agent]]
        res = ref.engine.step(batch)
        ref.agents = [
            x for x in live if not (res.terminated[0, ref.agent_index[x]] or res.truncated[0, ref.agent_index[x]])
        ]
        assert list(obs) == list(rew) == list(term) == list(trunc) == list(infos) == live
        for agent in live:
            i = ref.agent_index[agent]
            np.testing.assert_array_equal(obs[agent], res.obs[0, i])
            assert type(rew[agent]) is float and rew[agent] == float(res.reward[0, i])
            assert type(term[agent]) is bool and term[agent] == bool(res.terminated[0, i])
            assert type(trunc[agent]) is bool and trunc[agent] == bool(res.truncated[0, i])
            want = reference_info(res, i)
            got = infos[agent]
            np.testing.assert_array_equal(got.pop("expert_action"), want.pop("expert_action"))
            assert got == want
            assert all(type(v) is float for v in got["reward_terms"].values())
            collisions += len(got["collided_with"])
        assert env.agents == ref.agents
    assert collisions > 0
