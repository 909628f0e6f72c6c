"""Single-robot Gymnasium adapter: ``robot_0`` learns, the other robots follow a planner."""

from __future__ import annotations

from collections.abc import Mapping

import gymnasium as gym
import numpy as np

from .engine import NavEngine, RewardFn
from .planning import Planner, make_planner
from .render import Renderer, RenderMixin
from .scenario import Scenario, make_scenario
from .spaces import action_space, observation_space


class VcsNavEnv(RenderMixin, gym.Env):
    """One learning robot among planner-driven robots and passive obstacles
    (``vcs_env/Navigation-v0``).

    ## Description
    The scenario's ``robot_0`` is controlled by the agent; every other robot is driven by
    ``others`` (a planner or planner name; default the VCS expert), which sees the learner as
    one more robot. Obstacles move as the scenario says.

    ## Action Space / Observation Space / Rewards
    As one robot of the PettingZoo env :class:`~vcs_env.parallel.VcsNavParallelEnv`:
    ``Box(-1, 1, (2,))`` actions, ``Box(-1, 1, (8 + 8 K,))`` observations, weighted named
    reward terms (``info["reward_terms"]``).

    ## Episode End
    Terminated when ``robot_0`` reaches its goal or (``on_collision="terminate"``) touches
    anything; truncated after ``scenario.max_steps`` steps (or the ``max_episode_steps`` of
    ``gym.make``).

    ## Arguments
    ``scenario`` (name or Scenario), ``others`` (planner for the other robots), ``render_mode``
    (``human``, ``rgb_array``, ``ansi``), ``action_mode``, ``expert``, ``reward_terms``,
    ``obstacle_motion``, ``gamma``, and Scenario fields as keyword overrides.

    ## Version History
    * v0: initial release.
    """

    metadata = {"render_modes": ["human", "rgb_array", "ansi"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Scenario = "circle",
        others: str | Planner = "vcs",
        render_mode: str | None = None,
        action_mode: str = "delta",
        expert: str | Planner | None = None,
        reward_terms: Mapping[str, tuple[float, RewardFn]] | None = None,
        obstacle_motion=None,
        gamma: float = 0.99,
        **scenario_overrides,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.scenario = make_scenario(scenario, **scenario_overrides)
        self.engine = NavEngine(self.scenario, 1, action_mode, expert, reward_terms, obstacle_motion, gamma)
        n = self.scenario.n_robots
        self.others = make_planner(others) if n > 1 else None
        self.render_mode = render_mode
        self.observation_space = observation_space(self.scenario)
        self.action_space = action_space()
        self._renderer: Renderer | None = None

    @property
    def world(self):
        return self.engine.world

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        # The world generator is seeded from Gymnasium's np_random so reset() without a seed
        # continues one reproducible stream.
        world_seed = int(self.np_random.integers(0, 2**63 - 1))
        obs = self.engine.reset([world_seed])
        if self._renderer is not None:
            self._renderer.reset()
        info = {} if self.engine.expert_action is None else {"expert_action": self.engine.expert_action[0, 0]}
        if self.render_mode == "human":
            self.render()
        return obs[0, 0], info

    def step(self, action):
        try:
            arr = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"action must be numeric with shape (2,), got {action!r}") from None
        if arr.shape != (2,):
            raise ValueError(f"action must have shape (2,), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"action must be finite, got {arr}")
        world = self.engine.world
        if self.others is not None:
            actions = self.others.act(world, self.engine.action_mode).astype(np.float64)
        else:
            actions = np.zeros((1, 1, 2))
        actions[0, 0] = arr
        res = self.engine.step(actions)
        info = res.info(0)
        if self.render_mode == "human":
            self.render()
        return res.obs[0, 0], float(res.reward[0, 0]), bool(res.terminated[0, 0]), bool(res.truncated[0, 0]), info
