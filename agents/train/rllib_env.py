"""RLlib ``MultiAgentEnv`` adapters of the navigation env (imported by RLlib's env runners).

Two adapters, both built by :func:`make_env` from RLlib's ``env_config``:

* ``batched`` (:class:`NavMultiAgentEnv`): ``B`` worlds of one :class:`~vcs_env.engine.NavEngine`
  stepped in ONE numpy call; every robot of every world is an agent (id ``b * n + i``). One
  RLlib episode is one episode of every world: a world whose robots all finished waits (its
  robots inactive, no agent steps) until the last world ends, then all ``B`` restart together.
* ``pettingzoo``: RLlib's ``ParallelPettingZooEnv`` over :func:`vcs_env.parallel_env` (one world
  per env; RLlib vectorizes ``n_worlds`` of them per runner), with its end-of-episode flag fixed:
  an episode is over when no robot is left (the wrapper alone ends it only when the last step's
  robots were all terminated or all truncated, so a time-out where one robot arrives and another
  is cut off left it running).

Seeding: RLlib resets a runner's envs once with ``seed + worker_index (+ vector index)``, values
that overlap between runners; the worlds are seeded from the pair ``(that seed, worker_index)``
instead, through ``np.random.SeedSequence``, so no two worlds of a run share a start, and a run
is a function of ``seed`` and the number of runners. Later episodes continue each world's stream.
Agent ids are integers in both adapters: RLlib iterates over sets of agent ids, and the order of
a set of strings changes with every process's hash seed (then runs do not repeat).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from ray.rllib.env.multi_agent_env import MultiAgentEnv
from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

from vcs_env.engine import NavEngine
from vcs_env.scenario import Scenario
from vcs_env.spaces import action_space, observation_space

from ..config import build_scenario, config_from_dict
from ..runs import ADAPTERS, RLlibConfig


def world_seeds(seed: int, worker_index: int, n_worlds: int) -> list[int]:
    """Distinct reset seeds of ``n_worlds`` worlds from RLlib's runner seed and ``worker_index``."""
    return [int(s) for s in np.random.SeedSequence([int(seed), int(worker_index)]).generate_state(n_worlds)]


class NavMultiAgentEnv(MultiAgentEnv):
    """``n_worlds`` worlds x ``n`` robots as one RLlib multi-agent episode (module docstring).

    Args:
        scenario: the episode family (its ``rewards`` are the training reward).
        n_worlds: worlds ``B`` stepped together.
        gamma: discount of ``vcs_potential`` shaping (the learner's).
        worker_index: RLlib env runner index (seeding).
    """

    def __init__(self, scenario: Scenario, n_worlds: int, gamma: float = 0.99, worker_index: int = 0):
        super().__init__()
        if n_worlds < 1:
            raise ValueError(f"n_worlds must be >= 1, got {n_worlds}")
        self.engine = NavEngine(scenario, n_worlds, gamma=gamma)
        self.n_worlds, self.n_robots = n_worlds, scenario.n_robots
        self.worker_index = worker_index
        # Integer ids (slot b * n + i): RLlib iterates over sets of agent ids, and the order of a
        # set of strings changes with every process's hash seed (then runs do not repeat).
        self.possible_agents = list(range(n_worlds * scenario.n_robots))
        self.agents = list(self.possible_agents)
        obs_space = observation_space(scenario)
        act_space = action_space()
        self.observation_spaces = {a: obs_space for a in self.possible_agents}
        self.action_spaces = {a: act_space for a in self.possible_agents}
        self._live = np.zeros((n_worlds, scenario.n_robots), dtype=bool)
        self._ids = np.arange(n_worlds * scenario.n_robots).reshape(n_worlds, scenario.n_robots)

    def _obs(self, obs: np.ndarray, mask: np.ndarray) -> dict[int, np.ndarray]:
        return dict(zip(self._ids[mask].tolist(), obs[mask].astype(np.float32)))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        seeds = None if seed is None else world_seeds(seed, self.worker_index, self.n_worlds)
        obs = self.engine.reset(seeds)
        self._live[:] = True
        self.agents = list(self.possible_agents)
        return self._obs(obs, self._live), {}

    def step(self, action_dict: dict[int, Any]):
        actions = np.zeros((self.n_worlds * self.n_robots, 2))
        for agent, act in action_dict.items():
            actions[agent] = act
        actions = actions.reshape(self.n_worlds, self.n_robots, 2)
        live = self._live.copy()
        res = self.engine.step(actions)
        done = live & (res.terminated | res.truncated)
        self._live &= ~done
        ids = self._ids[live].tolist()
        obs = self._obs(res.obs, live)
        rewards = dict(zip(ids, res.reward[live].tolist()))
        terminated = dict(zip(ids, (live & res.terminated)[live].tolist()))
        truncated = dict(zip(ids, (live & res.truncated & ~res.terminated)[live].tolist()))
        over = not self._live.any()
        timed_out = bool(res.truncated[live].any())
        terminated["__all__"] = over and not timed_out
        truncated["__all__"] = over and timed_out
        self.agents = self._ids[self._live].tolist()
        return obs, rewards, terminated, truncated, {}


class PettingZooNavEnv(ParallelPettingZooEnv):
    """RLlib's PettingZoo wrapper over one :class:`~vcs_env.parallel.VcsNavParallelEnv` with the
    episode ending when no robot is left, runner-aware seeding, and integer agent ids (robot
    ``i`` is agent ``i``, for repeatable runs as in :class:`NavMultiAgentEnv`)."""

    def __init__(self, scenario: Scenario, gamma: float = 0.99, worker_index: int = 0):
        from vcs_env.parallel import parallel_env

        super().__init__(parallel_env(scenario=scenario, gamma=gamma))
        self.worker_index = worker_index
        self.possible_agents = list(range(scenario.n_robots))
        self.agents = list(self.possible_agents)
        self.observation_spaces = {i: self.par_env.observation_space(f"robot_{i}") for i in self.possible_agents}
        self.action_spaces = {i: self.par_env.action_space(f"robot_{i}") for i in self.possible_agents}
        # The base class keyed these by the PettingZoo names ("robot_3"); the agents here are ints.
        self._agent_ids = set(self.possible_agents)
        self.observation_space = gym.spaces.Dict(self.observation_spaces)
        self.action_space = gym.spaces.Dict(self.action_spaces)

    @staticmethod
    def _ints(d: dict) -> dict:
        return {int(k[6:]): v for k, v in d.items()}  # "robot_3" -> 3

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            seed = world_seeds(seed, self.worker_index, 1)[0]
        obs, infos = self.par_env.reset(seed=seed, options=options)
        self.agents = list(self.possible_agents)
        return self._ints(obs), {}

    def step(self, action_dict):
        obs, rewards, terminated, truncated, _ = self.par_env.step({f"robot_{i}": a for i, a in action_dict.items()})
        over = not self.par_env.agents
        terminated, truncated = self._ints(terminated), self._ints(truncated)
        timed_out = any(truncated.values())
        terminated["__all__"] = over and not timed_out
        truncated["__all__"] = over and timed_out
        self.agents = [int(a[6:]) for a in self.par_env.agents]
        return self._ints(obs), self._ints(rewards), terminated, truncated, {}


def make_env(env_config) -> MultiAgentEnv:
    """The env of one RLlib runner from ``env_config = {"config": <RLlibConfig as dict>}``."""
    cfg = config_from_dict(RLlibConfig, env_config["config"])
    worker = int(getattr(env_config, "worker_index", 0))
    scenario = build_scenario(cfg)
    if cfg.env_adapter == "batched":
        return NavMultiAgentEnv(scenario, cfg.n_worlds, cfg.gamma, worker)
    if cfg.env_adapter == "pettingzoo":
        return PettingZooNavEnv(scenario, cfg.gamma, worker)
    raise ValueError(f"env_adapter must be one of {list(ADAPTERS)}, got {cfg.env_adapter!r}")
