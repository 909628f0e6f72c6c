"""Env throughput with random actions and no planner, in robot-steps per second.

Contestants (same agent count ``n``, same batch size ``B``):

* ``pettingzoo`` - our PettingZoo parallel env (``B = 1``): dict in, dicts out, per step.
* ``mpe`` - PettingZoo MPE ``simple_spread`` (``mpe2``), parallel API, continuous actions,
  ``N = n`` agents (and ``n`` landmarks).
* ``engine`` - :class:`~vcs_env.engine.NavEngine` stepping ``B`` worlds in one numpy call,
  with auto-reset.
* ``vecenv`` - the SB3 ``VecEnv`` of ``agents/vec_env.py`` (``B * n`` slots), if present.
* ``gym_vector`` / ``gym_sync`` - ``gym.make_vec("vcs_env/Navigation-v2", num_envs=B,
  vectorization_mode=...)`` with ``"vector_entry_point"`` (:class:`~vcs_env.gym_env.VcsNavVectorEnv`,
  one engine call for all worlds) and with ``"sync"`` (Gymnasium's ``SyncVectorEnv``, a Python
  loop over ``B`` single envs), on our worlds with ``n`` robots: the learner is ``robot_0``, the
  others follow a planner, ``vcs`` (the default) or ``straight`` (to time the env without the
  VCS planner's cost). Rates count learner steps (one per env and step).
* ``vmas`` - VMAS ``navigation`` on CPU with ``B`` = ``num_envs``, ``n_agents = n``, torch on
  one thread. Its spawning square is scaled as ``sqrt(n / 4)`` so the agent density stays that
  of the default 4-agent scenario (the default 2 m x 2 m square cannot hold 32 agents and
  their goals at VMAS's minimum spacing: its rejection sampler never ends).

Our worlds: the ``dynamic`` preset with ``n`` robots and 10 obstacles on arbitrary
(random-turning, wall-bouncing) trajectories, ``on_collision="continue"`` (random actions crash
all the time; with ``terminate`` episodes would be a few steps long and we would mostly
measure resets). Every contestant runs episodes of :data:`EPISODE_STEPS` steps and resets
when they end, so reset cost is included at the same rate. Actions come from a pool drawn
before timing, so no contestant pays for sampling. A robot-step is one acting robot advanced
by one step (our counts exclude robots that arrived and are parked, the peers count all).

Walls (issue 16): ``engine_walls`` against ``engine_open`` steps the same worlds with and without
a map of :data:`MAP_SEGMENTS` wall segments (:func:`map_scenarios`), one world and batched.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from .peers import require
from .timing import Step

EPISODE_STEPS = 200
"""Episode length of every contestant [steps]; all reset when it ends."""
N_OBSTACLES = 10
"""Moving obstacles in our worlds (MPE and VMAS navigation have none that move)."""
POOL = 16
"""Pre-drawn action sets cycled through."""
MAP_SEGMENTS = 50
"""Wall segments of the map of the walls comparison (the arena's 4 sides and 46 random walls)."""


def our_scenario(n: int, n_obstacles: int = N_OBSTACLES):
    """``dynamic`` preset with ``n`` robots and ``n_obstacles`` moving obstacles; its 6 m arena
    half size grows as ``6 sqrt(n / 32)`` [m] beyond 32 robots, which it cannot hold."""
    from vcs_env.scenario import make_scenario

    return make_scenario(
        "dynamic",
        n_robots=n,
        n_obstacles=n_obstacles,
        arena_half_size=6.0 * max(1.0, math.sqrt(n / 32.0)),
        on_collision="continue",
        max_steps=EPISODE_STEPS,
    )


def parallel_stepper(env, pool: np.ndarray, index: dict) -> Step:
    """One PettingZoo ``ParallelEnv`` step per call with the next action row of ``pool`` (POOL, n, ...), agent
    ``a`` taking row ``index[a]``; resets when every agent is done. Returns the agents that acted."""
    k = [0]

    def step() -> int:
        if not env.agents:
            env.reset()
        k[0] = (k[0] + 1) % POOL
        a = pool[k[0]]
        actions = {agent: a[index[agent]] for agent in env.agents}
        env.step(actions)
        return len(actions)

    return step


def pettingzoo_env(n: int, seed: int = 0) -> Step:
    from vcs_env.parallel import VcsNavParallelEnv

    env = VcsNavParallelEnv(our_scenario(n))
    env.reset(seed=seed)
    pool = np.random.default_rng(seed).uniform(-1.0, 1.0, (POOL, n, 2)).astype(np.float32)
    index = env.agent_index
    return parallel_stepper(env, pool, index)


def mpe_env(n: int, seed: int = 0) -> Step:
    require("mpe2")
    from mpe2 import simple_spread_v3

    env = simple_spread_v3.parallel_env(N=n, max_cycles=EPISODE_STEPS, continuous_actions=True)
    env.reset(seed=seed)
    space = env.action_space(env.possible_agents[0])
    pool = np.random.default_rng(seed).uniform(space.low, space.high, (POOL, n, *space.shape)).astype(space.dtype)
    index = {a: i for i, a in enumerate(env.possible_agents)}
    return parallel_stepper(env, pool, index)


def map_scenarios(n: int, segments: int = MAP_SEGMENTS):
    """One fixed map for ``n`` robots: the first layout of the ``walls`` kind with ``segments``
    segments (arena half size as in :func:`our_scenario`) as a custom scenario, and the same
    custom scenario without its walls: ``(with_walls, without)``. Custom maps are validated
    once, at construction, so resets cost the same in both."""
    import dataclasses

    from vcs_env.layouts import generate
    from vcs_env.scenario import CustomLayout, Scenario, make_scenario

    half = 6.0 * max(1.0, math.sqrt(n / 32.0))
    base = make_scenario("walls", n_robots=n, n_walls=segments - 4, arena_half_size=half)
    lay = generate(base, np.random.default_rng(0))
    custom = CustomLayout(start=lay.start, goal=lay.goal, walls=lay.segments)
    walls = Scenario(kind="custom", n_robots=n, custom=custom, on_collision="continue", max_steps=EPISODE_STEPS)
    return walls, dataclasses.replace(walls, custom=dataclasses.replace(custom, walls=()))


def engine_env(n: int, B: int, seed: int = 0, scenario=None, split: dict | None = None) -> Step:
    """The engine stepping ``B`` worlds with random actions (auto-reset on). ``split``: a dict whose
    ``units`` and ``seconds`` add up the robot-steps and wall seconds of the steps in which no world
    ended (no reset ran), for the rate between resets."""
    import time

    from vcs_env.engine import NavEngine

    eng = NavEngine(our_scenario(n) if scenario is None else scenario, B)
    eng.reset(list(range(seed, seed + B)))
    pool = np.random.default_rng(seed).uniform(-1.0, 1.0, (POOL, B, n, 2))
    k = [0]

    def step() -> int:
        k[0] = (k[0] + 1) % POOL
        acting = int(eng.world.active.sum())
        if split is None:  # the plain benchmark: nothing timed inside the step
            eng.step(pool[k[0]], autoreset=True)
            return acting
        t0 = time.perf_counter()
        res = eng.step(pool[k[0]], autoreset=True)
        if not res.ended.any():
            split["units"] += acting
            split["seconds"] += time.perf_counter() - t0
        return acting

    return step


def vecenv_env(n: int, B: int, seed: int = 0) -> Step:
    try:
        from agents.vec_env import NavVecEnv
    except ImportError as e:
        from .timing import Missing

        raise Missing(f"agents.vec_env not importable ({e})") from None
    venv = NavVecEnv(our_scenario(n), B)
    venv.seed(seed)
    venv.reset()
    pool = np.random.default_rng(seed).uniform(-1.0, 1.0, (POOL, B * n, 2)).astype(np.float32)
    k = [0]

    def step() -> int:
        k[0] = (k[0] + 1) % POOL
        acting = int(venv.live_mask().sum())
        venv.step(pool[k[0]])
        return acting

    return step


def gym_vector_env(n: int, B: int, mode: str, others: str = "vcs", seed: int = 0) -> Step:
    import gymnasium as gym

    import vcs_env  # noqa: F401  (registers the ids)

    env = gym.make_vec(
        "vcs_env/Navigation-v2", num_envs=B, vectorization_mode=mode, scenario=our_scenario(n), others=others
    )
    env.reset(seed=seed)
    pool = np.random.default_rng(seed).uniform(-1.0, 1.0, (POOL, B, 2)).astype(np.float32)
    k = [0]

    def step() -> int:
        k[0] = (k[0] + 1) % POOL
        env.step(pool[k[0]])  # NEXT_STEP autoreset: ended envs restart on the next call
        return B

    return step


def vmas_spawn_half_size(n: int) -> float:
    """VMAS navigation spawning half-size [VMAS length units] at the default 4-agent density."""
    return math.sqrt(max(n, 4) / 4.0)


def vmas_env(n: int, B: int, seed: int = 0, **scenario_kwargs) -> Step:
    """VMAS ``navigation`` (its defaults: agent collisions and a 12-ray lidar that senses the other agents;
    ``scenario_kwargs`` such as ``n_lidar_rays`` go to ``vmas.make_env``), ``B`` worlds stepped with random
    actions; returns agent-steps."""
    torch = require("torch")
    vmas = require("vmas")
    s = vmas_spawn_half_size(n)
    env = vmas.make_env(
        "navigation",
        num_envs=B,
        device="cpu",
        continuous_actions=True,
        seed=seed,
        max_steps=EPISODE_STEPS,
        n_agents=n,
        world_spawning_x=s,
        world_spawning_y=s,
        **scenario_kwargs,
    )
    env.reset()
    gen = torch.Generator().manual_seed(seed)
    pool = [[torch.rand(B, 2, generator=gen) * 2.0 - 1.0 for _ in range(n)] for _ in range(POOL)]
    k = [0]

    def step() -> int:
        k[0] = (k[0] + 1) % POOL
        _, _, dones, _ = env.step(pool[k[0]])
        if dones.all():
            env.reset()
        elif dones.any():
            for i in torch.nonzero(dones).flatten().tolist():
                env.reset_at(i)
        return B * n

    return step


def single_builders(n: int) -> dict[str, Callable[[], Step]]:
    """``B = 1`` PettingZoo contestants."""
    return {"pettingzoo": lambda: pettingzoo_env(n), "mpe": lambda: mpe_env(n)}


def batched_builders(n: int, B: int) -> dict[str, Callable[[], Step]]:
    """Batched contestants at batch size ``B``."""
    return {
        "engine": lambda: engine_env(n, B),
        "vecenv": lambda: vecenv_env(n, B),
        "vmas": lambda: vmas_env(n, B),
    }


def walls_builders(n: int, B: int) -> dict[str, Callable[[], Step]]:
    """The engine on one map of :data:`MAP_SEGMENTS` walls and on the same worlds without them."""
    walls, open_ = map_scenarios(n)
    return {
        "engine_walls": lambda: engine_env(n, B, scenario=walls),
        "engine_open": lambda: engine_env(n, B, scenario=open_),
    }


def gym_vector_builders(n: int, B: int, others: str) -> dict[str, Callable[[], Step]]:
    """``gym.make_vec`` with the vector entry point against ``SyncVectorEnv``, ``B`` envs."""
    return {
        "gym_vector": lambda: gym_vector_env(n, B, "vector_entry_point", others),
        "gym_sync": lambda: gym_vector_env(n, B, "sync", others),
    }
