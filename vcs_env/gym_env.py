"""Single-robot Gymnasium adapter: ``robot_0`` learns, the other robots follow a planner."""

from __future__ import annotations

from collections.abc import Mapping

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .checks import check_reset_options
from .dynamics import check_actions
from .engine import NavEngine, RewardFn, check_max_steps, env_scenario
from .planning import Planner, own_planner
from .render import Renderer, RenderMixin
from .scenario import Scenario
from .spaces import action_space, observation_space


def _others_actions(others: Planner, engine: NavEngine, mask: np.ndarray) -> np.ndarray:
    """Actions ``(B, n, 2)`` of the planner driving the robots in ``mask`` ``(n,)``, planned from the state as it is
    (robots may have been moved by hand since the engine's expert labelled it). The engine's expert instance plans
    every robot, as for its labels: the state unchanged, its plan is the one it made (the planner's cache)."""
    robots = None if others is engine.expert else mask
    return others.act(engine.world, engine.action_mode, robots).astype(np.float64)


class VcsNavEnv(RenderMixin, gym.Env):
    """One learning robot among planner-driven robots and passive obstacles
    (``vcs_env/Navigation-v2``).

    ## Description
    The scenario's ``robot_0`` is controlled by the agent; every other robot is driven by
    ``others`` (a planner or planner name; default the VCS expert), which sees the learner as
    one more robot. Obstacles move as the scenario says.

    ## Action Space / Observation Space / Rewards
    As one robot of the PettingZoo env :class:`~vcs_env.parallel.VcsNavParallelEnv`:
    ``Box(-1, 1, (2,))`` actions, ``Box(-1, 1, (11 + 9 K,))`` observations (v2), weighted named
    reward terms (``info["reward_terms"]``).

    ## Episode End
    Terminated when ``robot_0`` reaches its goal or (``on_collision="terminate"``) touches
    anything (it stops where it first touched); truncated after ``scenario.max_steps`` steps
    (or the ``max_episode_steps`` of ``gym.make``). A step after the end raises ``RuntimeError``: call ``reset()``.

    ## Arguments
    ``scenario`` (name or Scenario), ``others`` (planner for the other robots; a planner instance given as
    ``others`` or ``expert`` is copied, so that envs never share a planner's memory), ``render_mode``
    (``human``, ``rgb_array``, ``ansi``), ``action_mode``, ``expert``, ``reward_terms``,
    ``obstacle_motion`` (an ``ObstacleMotion`` model, or a model's name as for the Scenario field),
    ``gamma``, and Scenario fields as keyword overrides.

    ## Vectorized
    ``gym.make_vec(id, num_envs, vectorization_mode="vector_entry_point")`` gives
    :class:`VcsNavVectorEnv`: the same numbers as ``"sync"``, all worlds in one engine call.

    ## Version History
    The PettingZoo env's (``vcs_nav_v2``, :class:`~vcs_env.parallel.VcsNavParallelEnv`), entry by entry: the same
    dynamics, observations and rewards for ``robot_0``. What that history says of the VCS expert (the
    ``fit_discs`` default of 2026-12-01) holds here for ``others`` too, which it drives by default
    (``others=VCSPlanner(fit_discs=False)`` drives them as before).
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
        self.scenario, obstacle_motion = env_scenario(scenario, obstacle_motion, scenario_overrides)
        self.engine = NavEngine(self.scenario, 1, action_mode, expert, reward_terms, obstacle_motion, gamma)
        n = self.scenario.n_robots
        # Checked even when no other robot needs it; an instance is the env's own copy (own_planner), the expert's
        # copy when the same instance drives the others and labels (it then plans every robot, _others_actions).
        others = self.engine.expert if others is expert and isinstance(others, Planner) else own_planner(others)
        self.others = others if n > 1 else None
        self._others_mask = np.arange(n) > 0  # robots the `others` planner drives (not robot_0)
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.scenario.dt}  # one step per frame: real time
        self.render_mode = render_mode
        self.observation_space = observation_space(self.scenario)
        self.action_space = action_space()
        self._renderer: Renderer | None = None
        self._started = self._running = False  # reset() called once; the episode has not ended

    @property
    def world(self):
        return self.engine.world

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        check_reset_options(options)
        if isinstance(seed, np.integer):  # as the other doors take them (Gymnasium's seeding takes Python ints only)
            seed = int(seed)
        super().reset(seed=seed)
        # The world generator is seeded from Gymnasium's np_random so reset() without a seed
        # continues one reproducible stream (gym_world_seed: the first world's seed).
        world_seed = _next_world_seed(self.np_random)
        obs = self.engine.reset([world_seed])
        self._started = self._running = True
        if self._renderer is not None:
            self._renderer.reset()
        info = {} if self.engine.expert_action is None else {"expert_action": self.engine.expert_action[0, 0].copy()}
        if self.render_mode == "human":
            self.render()
        return obs[0, 0], info

    def step(self, action):
        if not self._running:  # as the PettingZoo env: an ended episode would go on with stale flags
            said = "on a finished episode" if self._started else "before the first reset()"
            raise RuntimeError(f"step() called {said}; call reset() first")
        arr = check_actions(action, (2,), "action")
        if self.others is not None:
            actions = _others_actions(self.others, self.engine, self._others_mask)
        else:
            actions = np.zeros((1, 1, 2))
        actions[0, 0] = arr
        res = self.engine.step(actions)
        info = res.info(0)
        terminated, truncated = bool(res.terminated[0, 0]), bool(res.truncated[0, 0])
        self._running = not (terminated or truncated)
        if self.render_mode == "human":
            self.render()
        return res.obs[0, 0], float(res.reward[0, 0]), terminated, truncated, info


def gym_world_seed(seed: int) -> int:
    """The seed of the world a Gymnasium env's ``reset(seed=seed)`` starts (drawn from Gymnasium's ``np_random``, so
    that resets without a seed continue one stream): ``parallel_env(...).reset(seed=gym_world_seed(s))``, the SB3
    and TorchRL envs seeded so, start the world that ``gym.make(...).reset(seed=s)`` starts, with the same
    scenario. The other front doors use their seed as the world's seed."""
    return _next_world_seed(seeding.np_random(seed)[0])


def _next_world_seed(rng: np.random.Generator) -> int:
    return int(rng.integers(0, 2**63 - 1))


class VcsNavVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`VcsNavEnv` stepped in one engine call: the
    ``vector_entry_point`` of the Gymnasium ids, so
    ``gym.make_vec("vcs_env/Navigation-v2", num_envs=64, vectorization_mode="vector_entry_point")``
    steps every world (and plans every other robot) at once.

    It returns what ``vectorization_mode="sync"`` returns for the same seeds and actions,
    bit for bit: observations ``(num_envs, D)`` float32 (D: :func:`vcs_env.observations.observation_dim`),
    rewards ``(num_envs,)`` float64,
    terminated / truncated ``(num_envs,)`` bool, and the single env's ``info`` batched the
    Gymnasium way (each key an array with a ``_key`` mask; ``reward_terms`` nested;
    ``collided_with`` an object array of lists). ``reset(seed=s)`` seeds world ``i`` as
    ``VcsNavEnv.reset(seed=s + i)`` does; ``seed`` may also be a list, one per world.

    Autoreset: ``AutoresetMode.NEXT_STEP`` (``metadata["autoreset_mode"]``), as
    ``SyncVectorEnv``: the step after a world's episode ended returns that world's first
    observation of a new episode with reward 0, and its action is ignored (not checked: it may be NaN).
    ``reset(options={"reset_mask": mask})`` resets only the worlds in ``mask`` ``(num_envs,)``
    bool. SB3 drives it through :class:`agents.gym_vec.GymVectorToSB3`.

    Arguments: ``num_envs`` and those of :class:`VcsNavEnv` (no rendering), and
    ``max_episode_steps``, which ``gym.make`` turns into a ``TimeLimit`` in the other modes: every
    world's episode is then truncated after that many steps (or the scenario's ``max_steps``, if
    fewer), as there.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        scenario: str | Scenario = "circle",
        others: str | Planner = "vcs",
        render_mode: str | None = None,
        action_mode: str = "delta",
        expert: str | Planner | None = None,
        reward_terms: Mapping[str, tuple[float, RewardFn]] | None = None,
        obstacle_motion=None,
        gamma: float = 0.99,
        max_episode_steps: int | None = None,
        **scenario_overrides,
    ):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError(f"VcsNavVectorEnv does not render; render_mode must be None, got {render_mode!r}")
        self.num_envs = int(num_envs)
        self.render_mode = None
        self.scenario, obstacle_motion = env_scenario(scenario, obstacle_motion, scenario_overrides)
        limit = self.scenario.max_steps
        self._time_limit = None  # gym.make's TimeLimit in the other modes: truncated at it, also when terminated
        if max_episode_steps is not None:
            self._time_limit = check_max_steps(max_episode_steps, "max_episode_steps")
            limit = min(limit, self._time_limit)
        self.engine = NavEngine(
            self.scenario, self.num_envs, action_mode, expert, reward_terms, obstacle_motion, gamma, max_steps=limit
        )
        # Checked even when no other robot needs it; an instance is the env's own copy (own_planner), the expert's
        # copy when the same instance drives the others and labels (it then plans every robot, _others_actions).
        others = self.engine.expert if others is expert and isinstance(others, Planner) else own_planner(others)
        self.others = others if self.scenario.n_robots > 1 else None
        self._others_mask = np.arange(self.scenario.n_robots) > 0  # robots `others` drives (not robot_0)
        self.single_observation_space = observation_space(self.scenario)
        self.single_action_space = action_space()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._world_rngs: list[np.random.Generator | None] = [None] * self.num_envs  # VcsNavEnv.np_random
        self._obs = np.zeros((self.num_envs, *self.single_observation_space.shape), dtype=np.float32)
        self._autoreset = np.zeros(self.num_envs, dtype=bool)

    @property
    def world(self):
        return self.engine.world

    def _start(self, worlds: np.ndarray, seeds: list[int | None]) -> None:
        """New episodes in ``worlds``, each world seeded from its own generator as VcsNavEnv.reset."""
        world_seeds = []
        for b, seed in zip(worlds, seeds):
            if seed is not None or self._world_rngs[b] is None:
                self._world_rngs[b] = seeding.np_random(seed)[0]
            world_seeds.append(_next_world_seed(self._world_rngs[b]))
        obs = self.engine.reset(world_seeds, worlds.tolist())
        self._obs[worlds] = obs[worlds, 0]
        self._autoreset[worlds] = False

    def _reset_info(self, worlds: np.ndarray) -> dict:
        expert = self.engine.expert_action
        if expert is None:
            return {}
        return {"expert_action": np.where(worlds[:, None], expert[:, 0], np.float32(0.0)), "_expert_action": worlds}

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            super().reset(seed=int(seed))
            seeds = [int(seed) + i for i in range(self.num_envs)]
        elif seed is None:
            seeds = [None] * self.num_envs
        else:
            if isinstance(seed, (str, bytes, bool)) or not hasattr(seed, "__len__"):
                raise ValueError(f"seed must be an integer, None or one seed per world, got {seed!r}")
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"got {len(seeds)} seeds for num_envs={self.num_envs}")
        options = check_reset_options(options, ("reset_mask",), made="gym.make_vec(id, num_envs, n_robots=4)")
        mask = np.ones(self.num_envs, dtype=bool)
        if "reset_mask" in options:
            mask = options["reset_mask"]
            if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
                raise ValueError(
                    f"options['reset_mask'] must be a bool array of shape ({self.num_envs},), got {mask!r}"
                )
            if not mask.any():
                raise ValueError("options['reset_mask'] must select at least one world")
        worlds = np.flatnonzero(mask)
        self._start(worlds, [seeds[b] for b in worlds])
        info = self._reset_info(mask)
        return self._obs.copy(), info

    def step(self, actions):
        never = [b for b, rng in enumerate(self._world_rngs) if rng is None]
        if never:
            said = "the first reset()" if len(never) == self.num_envs else f"worlds {never} were ever reset"
            raise RuntimeError(f"step() called before {said}; call reset() first")
        # A world that auto-resets in this call does not step with its action (as in SyncVectorEnv): not checked.
        arr = check_actions(actions, (self.num_envs, 2), ignored=self._autoreset)
        eng = self.engine
        if self.others is not None:
            batch = _others_actions(self.others, eng, self._others_mask)
        else:
            batch = np.zeros((self.num_envs, 1, 2))
        batch[:, 0] = arr
        # Every world steps; those whose episode ended last step are then started afresh
        # (stepping an ended world draws no randomness, so the restart is what VcsNavEnv.reset gives).
        res = eng.step(batch)
        restart = self._autoreset.copy()
        stepped = ~restart
        self._obs[:] = res.obs[:, 0]
        reward = np.where(stepped, res.reward[:, 0], 0.0)
        terminated = res.terminated[:, 0] & stepped
        truncated = res.truncated[:, 0] & stepped
        if self._time_limit is not None:  # as TimeLimit: its last step is truncated, whatever else it is
            truncated |= stepped & (eng.world.steps >= self._time_limit)
        info = self._step_info(res, stepped) if stepped.any() else {}
        if restart.any():
            self._start(np.flatnonzero(restart), [None] * int(restart.sum()))
        info.update(self._reset_info(np.ones(self.num_envs, dtype=bool)))
        self._autoreset = terminated | truncated
        return self._obs.copy(), reward, terminated, truncated, info

    def _step_info(self, res, stepped: np.ndarray) -> dict:
        """VcsNavEnv's step info of the ``stepped`` worlds, batched as SyncVectorEnv batches it."""
        ev = res.events
        terms = {}
        for name, value in res.terms.items():
            terms[name] = np.where(stepped, value[:, 0], 0.0)
            terms[f"_{name}"] = stepped
        collided_with = np.full(self.num_envs, None, dtype=object)
        collided = ev.collided[:, 0].tolist()
        for b in np.flatnonzero(stepped).tolist():
            collided_with[b] = res.collided_with(0, b) if collided[b] else []
        return {
            "reward_terms": terms,
            "_reward_terms": stepped,
            "reached_goal": ev.reached[:, 0] & stepped,
            "_reached_goal": stepped,
            "collided_with": collided_with,
            "_collided_with": stepped,
            "min_separation": np.where(stepped, ev.min_separation[:, 0], 0.0),
            "_min_separation": stepped,
        }
