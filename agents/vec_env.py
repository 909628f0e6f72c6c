"""SB3 ``VecEnv`` over one batched :class:`~vcs_env.engine.NavEngine`: one slot per (world, robot).

(:class:`MixtureVecEnv` puts several of them side by side, one per scenario of a training mixture.)

Parameter sharing: one SB3 policy acts for every robot. ``B`` worlds of ``n`` robots give
``num_envs = B * n`` slots; slot ``j = b * n + i`` is robot ``i`` of world ``b``. A ``step``
is ONE batched engine call for all worlds (no loop over envs).

Semantics of a slot (a robot's episode inside its world's episode):

* **live**: while the robot is active, the slot sees the robot's observation ``(D,)`` and its
  reward, and its action drives the robot.
* **end**: on the step the robot terminates (goal, or a crash under
  ``on_collision="terminate"``) or is truncated (the world reached ``max_steps``), the slot
  returns ``done=True`` with ``info["terminal_observation"]`` (the robot's last observation),
  ``info["TimeLimit.truncated"]`` (True only for a time-out, so SB3 bootstraps the value of
  the terminal observation), ``info["episode"] = {"r", "l", "t", "success", "collision",
  "reached", "time_to_goal"}`` and ``info["is_success"]`` (SB3's ``ep_info_buffer`` and
  ``ep_success_buffer`` then work without a ``VecMonitor``). Do not add one: it counts every ``done``
  as an episode, and padding segments (below) end with ``done=True`` too, and it overwrites
  ``info["episode"]`` (SB3 warns that it overwrites Monitor statistics: the slots say they are
  Monitor-wrapped). SB3's ``evaluate_policy`` counts robot episodes by ``info["episode"]`` for
  that reason; score policies with :mod:`agents.evaluate` (success, collisions, time to goal).
  ``VecNormalize`` would count the padding slots' zero observations in its statistics, and
  :mod:`agents.evaluate` feeds policies raw observations (the observations are already scaled to
  [-1, 1], :mod:`vcs_env.observations`): train without it.
* **padding**: after its robot ended and until its world resets (other robots still drive), and
  from the start for a robot that had already finished in a saved state the world starts from,
  the slot returns an all-zero observation, zero reward, ``done=False`` and
  ``info["padding"] = True``; its actions are ignored (the engine ignores inactive robots).
  Real observations are never all-zero (index 4 holds ``v_max / V_REF > 0``), so the policy
  can tell padding apart.
* **world reset**: when no robot of a world is active any more (or ``max_steps`` is reached)
  the world auto-resets in the same call. Padding slots of that world then return ``done=True``
  (closing the padding segment without bootstrapping: ``TimeLimit.truncated=False``,
  ``terminal_observation`` = zeros, no ``episode`` info), and every slot of the world returns
  the first observation of the new episode.

Seeding: ``seed(s)`` (what ``PPO(seed=s)`` calls) makes the next ``reset()`` seed world ``b``
with ``s + b``; later auto-resets continue each world's random stream, so a run is a pure
function of the seed. ``reset()`` without a pending seed reseeds nothing (continuing
streams, or fresh entropy on the very first reset).

Rewards are the scenario's weighted terms (``scenario.rewards``); ``vcs_imitation`` /
``vcs_potential`` shaping switches on through those weights (the engine then attaches the VCS
expert). :meth:`expert_actions` gives the expert's action for the current observation of every
slot when an expert is attached (DAgger).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

from vcs_env.checks import check_reset_options
from vcs_env.engine import NavEngine
from vcs_env.metrics import robots_succeeded
from vcs_env.observations import observation_config
from vcs_env.scenario import Scenario
from vcs_env.spaces import action_space, observation_space
from vcs_env.start_states import StartStates

from .residual import Residual


class SharedSlots(VecEnv):
    """SB3 ``VecEnv`` plumbing for a VecEnv whose slots are all one object: attribute access and
    method calls go to that object (a method runs once, its result stands for every slot asked
    for; an attribute is set for all slots or none), there are no per-slot images and no wrappers."""

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        if len(list(self._get_indices(indices))) != self.num_envs:
            raise ValueError(
                f"the slots of {type(self).__name__} are one object: set_attr sets all of them (indices=None)"
            )
        setattr(self, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs) -> list[Any]:
        result = getattr(self, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices: VecEnvIndices = None) -> list[bool]:
        """True for SB3's ``Monitor`` alone: each slot reports its robot's episode as ``Monitor`` does
        (``info["episode"]`` with ``r``, ``l`` and ``t`` at a robot's end; none where a padding segment ends), so
        SB3's ``evaluate_policy`` counts robot episodes by it instead of every ``done``."""
        return [wrapper_class is Monitor for _ in self._get_indices(indices)]

    def set_options(self, options: list[dict] | dict | None = None) -> None:
        """SB3's options of the next reset: none is read, so any is refused (``ValueError``) here, not at the reset."""
        for one in options if isinstance(options, list) else [options]:
            check_reset_options(one, made=f"{type(self).__name__}(make_scenario(name, n_robots=4), ...)")
        super().set_options(options)


def _robot_actions(actions, num_envs: int) -> np.ndarray:
    """``actions`` as ``(num_envs, 2)`` float64, one row per robot slot; ``ValueError`` on another size."""
    out = np.asarray(actions, dtype=np.float64)
    if out.size != 2 * num_envs:
        raise ValueError(f"actions must have shape ({num_envs}, 2), one row per robot slot, got {out.shape}")
    return out.reshape(num_envs, 2)


class NavVecEnv(SharedSlots):
    """``B`` worlds x ``n`` robots as ``B * n`` SB3 slots sharing one policy (module docstring).

    Args:
        scenario: the episode family (its ``rewards`` are the training reward).
        n_worlds: number of worlds ``B`` stepped together.
        action_mode: ``"delta"`` or ``"absolute"`` (:mod:`vcs_env.dynamics`).
        expert: planner (or name) whose actions :meth:`expert_actions` reports; needed by, and
            defaulting to ``"vcs"`` for, the ``vcs_*`` shaping weights.
        gamma: discount of the ``vcs_potential`` shaping term (use the learner's gamma, see
            :func:`vcs_env.rewards.potential_term`).
        max_steps: overrides ``scenario.max_steps``.
        start_states: pools of saved states; a world of a scenario with a pool starts, with the
            pools' probability, from one of them (:mod:`vcs_env.start_states`).
        residual: the slots' actions correct the actions of ``residual.planner`` (then the expert,
            which ``expert`` may only name again); delta mode only.
    """

    def __init__(
        self,
        scenario: Scenario,
        n_worlds: int = 8,
        action_mode: str = "delta",
        expert=None,
        gamma: float = 0.99,
        max_steps: int | None = None,
        start_states: StartStates | None = None,
        residual: Residual | None = None,
    ):
        if isinstance(n_worlds, bool) or not isinstance(n_worlds, (int, np.integer)) or n_worlds < 1:
            raise ValueError(f"n_worlds must be an integer >= 1, got {n_worlds!r}")
        if residual is not None:
            if action_mode != "delta":
                raise ValueError(f"a residual policy corrects delta-mode actions, not action_mode={action_mode!r}")
            named = getattr(expert, "name", expert)
            if named not in (None, residual.planner):
                raise ValueError(f"the expert of a residual policy is its planner {residual.planner!r}, not {named!r}")
            expert = expert or residual.planner
        self.residual = residual
        self.jump_share = 0.0
        """Share of half the step limit the expert may drive at the start of an episode (jump-start;
        set between rollouts, it applies to episodes that start later)."""
        self.scenario = scenario
        self.engine = NavEngine(
            scenario, int(n_worlds), action_mode, expert, gamma=gamma, max_steps=max_steps, start_states=start_states
        )
        self.n_worlds = int(n_worlds)
        self.n_robots = scenario.n_robots
        self.render_mode = None
        obs_space = observation_space(scenario)
        act_space = action_space()
        super().__init__(self.n_worlds * self.n_robots, obs_space, act_space)
        B, n = self.n_worlds, self.n_robots
        self._obs = np.zeros((B, n, obs_space.shape[0]), dtype=np.float32)
        self._live = np.zeros((B, n), dtype=bool)  # slot's robot still in its episode
        self._ep_return = np.zeros((B, n))
        self._ep_len = np.zeros((B, n), dtype=np.int64)
        self._collided = np.zeros((B, n), dtype=bool)
        self._guided = np.zeros(B, dtype=np.int64)  # steps the expert still drives, per world
        self._jump_rng = np.random.default_rng()
        self._actions: np.ndarray | None = None
        self._t0 = time.time()

    # ---------------------------------------------------------------- helpers
    @property
    def dt(self) -> float:
        return self.scenario.dt

    @property
    def groups(self) -> list[NavVecEnv]:
        """The batched envs this VecEnv steps: itself (a :class:`MixtureVecEnv` has one per scenario)."""
        return [self]

    def _slot_view(self, x: np.ndarray) -> np.ndarray:
        """``(B, n, ...)`` -> ``(B * n, ...)``."""
        return x.reshape(self.num_envs, *x.shape[2:])

    def expert_actions(self) -> np.ndarray:
        """Expert actions ``(num_envs, 2)`` for the current observations (zeros on padding)."""
        expert = self.engine.expert_action
        if expert is None:
            raise ValueError("this NavVecEnv has no expert; pass expert='vcs' (or use vcs_* shaping weights)")
        return self._slot_view(np.where(self._live[..., None], expert, 0.0)).astype(np.float32)

    def live_mask(self) -> np.ndarray:
        """``(num_envs,)`` bool: slots whose current observation is a real robot (not padding)."""
        return self._slot_view(self._live).copy()

    def _start_episodes(self, worlds: np.ndarray) -> None:
        """New episodes in ``worlds``: their driving robots' slots are live, the rest padding (a world
        started from a saved state, :mod:`vcs_env.start_states`, may hold robots that already finished);
        with jump-start, every slot of a world the expert drives first is padding until the hand-over."""
        if self.jump_share > 0:
            if self.engine.expert is None:
                raise ValueError("jump-start needs an expert; pass expert='vcs'")
            top = round(self.jump_share * self.engine.max_steps / 2)
            self._guided[worlds] = self._jump_rng.integers(0, top + 1, size=len(worlds))
        else:
            self._guided[worlds] = 0
        self._live[worlds] = False
        self._hand_over(worlds)

    def _hand_over(self, worlds: np.ndarray) -> None:
        """Slots of ``worlds`` the expert no longer drives start their episodes: live for driving robots."""
        worlds = np.asarray(worlds)[self._guided[worlds] == 0]
        self._live[worlds] = self.engine.world.active[worlds]
        self._ep_return[worlds] = 0.0
        self._ep_len[worlds] = 0
        self._collided[worlds] = False

    # ------------------------------------------------------------------- API
    def reset(self) -> np.ndarray:
        """Reset every world; returns observations ``(B * n, D)`` float32."""
        base = self._seeds[0]
        seeds = None if base is None else [int(base) + b for b in range(self.n_worlds)]
        obs = self.engine.reset(seeds)
        if base is not None:
            self._jump_rng = np.random.default_rng([int(base), self.n_worlds])
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._begin(obs)

    def reset_worlds(self, seeds: Sequence[int]) -> np.ndarray:
        """Reset world ``b`` with ``seeds[b]`` (a fixed evaluation list); returns ``(B * n, D)``."""
        if len(seeds) != self.n_worlds:
            raise ValueError(f"need one seed per world ({self.n_worlds}), got {len(seeds)}")
        self._reset_seeds()
        return self._begin(self.engine.reset([int(s) for s in seeds]))

    def _begin(self, obs: np.ndarray) -> np.ndarray:
        """Every world's first observations ``obs`` ``(B, n, D)``: new episodes, padding slots zeroed;
        returns them as ``(B * n, D)``."""
        self._start_episodes(np.arange(self.n_worlds))
        self._obs[:] = np.where(self._live[..., None], obs, 0.0)
        return self._slot_view(self._obs).copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = _robot_actions(actions, self.num_envs).reshape(self.n_worlds, self.n_robots, 2)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        n = self.n_robots
        live_before = self._live.copy()
        # Padding rows: the engine ignores inactive robots, but NaN from a policy must not reach it.
        actions = np.where(live_before[..., None], self._actions, 0.0)
        if self.residual is not None:
            actions = self.residual.actions(self.engine.expert_action, actions, self.residual.held(self.engine.expert))
        driven = self._guided > 0  # (B,) worlds the expert drives this step (jump-start)
        if driven.any():
            actions = np.where(driven[:, None, None], self.engine.expert_action, actions)
        self._actions = None
        res = self.engine.step(actions, autoreset=True)
        ended = res.ended  # (B,) worlds reset this step
        self._guided -= driven
        robot_done = live_before & (res.terminated | res.truncated)
        reward = np.where(live_before, res.reward, 0.0)
        self._ep_return += reward
        self._ep_len += live_before
        self._collided |= res.events.collided
        # Observation each slot ended on (before an auto-reset of its world).
        last_obs = res.obs if res.final_obs is None else np.where(ended[:, None, None], res.final_obs, res.obs)
        handed = driven & (self._guided == 0) & ~ended  # (B,) the expert hands these worlds over
        padding_end = (ended | handed)[:, None] & ~live_before
        dones = robot_done | padding_end

        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        now = round(time.time() - self._t0, 6)
        for b, i in zip(*np.nonzero(robot_done)):
            reached = bool(res.events.reached[b, i])
            collided = bool(self._collided[b, i])
            truncated = bool(res.truncated[b, i] and not res.terminated[b, i])
            length = int(self._ep_len[b, i])
            success = bool(robots_succeeded(reached, collided))
            infos[b * n + i] = {
                "terminal_observation": last_obs[b, i].copy(),
                "TimeLimit.truncated": truncated,
                "is_success": success,
                "episode": {
                    "r": float(self._ep_return[b, i]),
                    "l": length,
                    "t": now,
                    "success": float(success),
                    "collision": float(collided),
                    "reached": float(reached),
                    "time_to_goal": length * self.dt if reached else float("nan"),
                },
            }
        zero = np.zeros(self.observation_space.shape, dtype=np.float32)
        for b, i in zip(*np.nonzero(~live_before)):
            info = infos[b * n + i]
            info["padding"] = True
            if padding_end[b, i]:
                info["terminal_observation"] = zero.copy()
                info["TimeLimit.truncated"] = False

        self._live &= ~robot_done
        if handed.any():
            self._hand_over(np.flatnonzero(handed))
        if ended.any():
            self._start_episodes(np.flatnonzero(ended))
        obs = np.where(self._live[..., None], res.obs, 0.0).astype(np.float32)
        self._obs[:] = obs
        return (
            self._slot_view(obs).copy(),
            self._slot_view(reward).astype(np.float32),
            self._slot_view(dones).copy(),
            infos,
        )

    def close(self) -> None:
        pass


def mixture_world_counts(n_robots: Sequence[int], n_worlds: int, balance: str = "worlds") -> list[int]:
    """Worlds of each mixture scenario, at least one each, ``n_worlds`` in all.

    ``balance="worlds"``: ``n_worlds`` dealt round robin (scenario ``g`` gets
    ``len(range(g, n_worlds, S))``). ``balance="robots"``: one world each, then every further world
    to the scenario with the fewest robots so far (the first on ties), so each scenario steps about
    the same number of robots (a difference of at most one world's robots, beyond the floor of one).

    Example: ``mixture_world_counts([1, 1, 4, 24], 100, "robots")`` -> ``[44, 43, 11, 2]`` (robots
    44, 43, 44, 48).
    """
    n_scen = len(n_robots)
    if isinstance(n_worlds, bool) or not isinstance(n_worlds, (int, np.integer)) or n_worlds < n_scen:
        raise ValueError(f"n_worlds must be an integer >= the number of mixture scenarios ({n_scen}), got {n_worlds!r}")
    n_worlds = int(n_worlds)
    if balance == "worlds":
        return [len(range(g, n_worlds, n_scen)) for g in range(n_scen)]
    if balance != "robots":
        raise ValueError(f"mixture balance must be 'worlds' or 'robots', got {balance!r}")
    counts = [1] * n_scen
    for _ in range(n_worlds - n_scen):
        g = min(range(n_scen), key=lambda k: counts[k] * n_robots[k])
        counts[g] += 1
    return counts


class MixtureVecEnv(SharedSlots):
    """Worlds of several scenarios (other kinds, robot and obstacle counts) as one SB3 ``VecEnv``.

    Worlds are split into **groups**, one :class:`NavVecEnv` (one batched engine) per scenario;
    the slots are the groups' slots one after the other, with the same per-slot semantics
    (live / end / padding / world reset). Every scenario has a fixed number of worlds
    (:func:`mixture_world_counts`: an equal share of the worlds, or of the robots with
    ``balance="robots"``), so every rollout holds all of them. Groups rather than padding to the largest robot
    count: no slot is spent on robots that do not exist, and each group keeps the one-call step
    of its engine; the cost is one engine call per group and step (measured in
    ``docs/training.md``, "Mixtures").

    Seeding: ``seed(s)`` then ``reset()`` seeds world ``b`` of the mixture with ``s + b``, like
    :class:`NavVecEnv`.

    Args:
        scenarios: the scenarios (all with one observation config).
        n_worlds: total worlds B, at least ``len(scenarios)``.
        balance: ``"worlds"`` (each scenario the same number of worlds, up to one) or ``"robots"``
            (each about the same number of robots, so a one-robot crowd world is not outweighed
            24 to 1 by a 24-robot circle in every rollout).
        action_mode, expert, gamma, max_steps, start_states, residual: as :class:`NavVecEnv`.
    """

    def __init__(
        self,
        scenarios: Sequence[Scenario],
        n_worlds: int,
        action_mode: str = "delta",
        expert=None,
        gamma: float = 0.99,
        max_steps: int | None = None,
        balance: str = "worlds",
        start_states: StartStates | None = None,
        residual: Residual | None = None,
    ):
        scenarios = list(scenarios)
        if not scenarios:
            raise ValueError("MixtureVecEnv needs at least one scenario")
        counts = mixture_world_counts([s.n_robots for s in scenarios], n_worlds, balance)
        self.scenarios = scenarios
        self.groups = [
            NavVecEnv(s, c, action_mode, expert, gamma, max_steps, start_states, residual)
            for s, c in zip(scenarios, counts)
        ]
        configs = [observation_config(g.engine.scenario) for g in self.groups]
        if any(c != configs[0] for c in configs):
            other = next(c for c in configs if c != configs[0])
            raise ValueError(
                "mixture scenarios must share one observation config (the same numbers mean the same thing), "
                f"got {configs[0]} and {other}"
            )
        self.n_worlds = int(n_worlds)
        self.render_mode = None
        self._world_offsets = np.cumsum([0] + counts[:-1]).tolist()
        self._slot_bounds = np.cumsum([g.num_envs for g in self.groups])[:-1].tolist()
        first = self.groups[0]
        super().__init__(sum(g.num_envs for g in self.groups), first.observation_space, first.action_space)

    def _concat(self, parts: Sequence[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts, axis=0)

    def reset(self) -> np.ndarray:
        """Reset every world of every group; returns observations ``(num_envs, D)``."""
        base = self._seeds[0]
        if base is not None:
            for g, off in zip(self.groups, self._world_offsets):
                g.seed(int(base) + off)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._concat([g.reset() for g in self.groups])

    def step_async(self, actions: np.ndarray) -> None:
        parts = np.split(_robot_actions(actions, self.num_envs), self._slot_bounds)
        for g, a in zip(self.groups, parts):
            g.step_async(a)

    def step_wait(self) -> VecEnvStepReturn:
        results = [g.step_wait() for g in self.groups]
        infos: list[dict[str, Any]] = []
        for r in results:
            infos.extend(r[3])
        return (
            self._concat([r[0] for r in results]),
            self._concat([r[1] for r in results]),
            self._concat([r[2] for r in results]),
            infos,
        )

    def expert_actions(self) -> np.ndarray:
        """Expert actions ``(num_envs, 2)`` of every group (:meth:`NavVecEnv.expert_actions`)."""
        return self._concat([g.expert_actions() for g in self.groups])

    def live_mask(self) -> np.ndarray:
        """``(num_envs,)`` bool: slots whose current observation is a real robot (not padding)."""
        return self._concat([g.live_mask() for g in self.groups])

    def close(self) -> None:
        for g in self.groups:
            g.close()
