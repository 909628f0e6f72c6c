"""Episode logic shared by every API adapter: simulator + observations + rewards + expert.

:class:`NavEngine` is batched and array-only (no Gymnasium or PettingZoo types). The PettingZoo
env (B = 1), the single-robot Gymnasium env and the SB3 VecEnv of ``agents`` are thin
adapters over it, so episode semantics are defined once:

* a robot *terminates* on the step it reaches its goal, or touches anything when
  ``scenario.on_collision == "terminate"``;
* robots still driving when a world has taken ``max_steps`` steps are *truncated*;
* robots that ended get no more reward, and stay in the world parked (``park_finished``).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .applies import check_applies
from .checks import check_flag, check_int, user_stacklevel
from .observations import observe
from .obstacles import Pedestrians
from .planning import Planner, own_planner
from .rewards import (
    TERMS,
    FunctionTerm,
    RewardFn,
    RewardTerm,
    StepInput,
    build_terms,
    checked_term,
    weighted_sum,
)
from .scenario import MAX_STEPS, Scenario, make_scenario, short_time_limit
from .sim import Simulator, StepEvents
from .start_states import StartStates
from .state import WorldState


@dataclass
class StepResult:
    """Outcome of one batched step."""

    obs: np.ndarray  # (B, n, D) float32, observation after the step
    reward: np.ndarray  # (B, n) weighted sum of the terms
    terms: dict[str, np.ndarray]  # name -> (B, n), unweighted
    terminated: np.ndarray  # (B, n) bool
    truncated: np.ndarray  # (B, n) bool
    events: StepEvents
    expert_action: np.ndarray | None  # (B, n, 2) expert's action for the new state, if attached
    final_obs: np.ndarray | None = None  # (B, n, D) last obs of the worlds auto-reset this step
    ended: np.ndarray | None = None  # (B,) bool, worlds auto-reset this step

    def info(self, i: int, b: int = 0) -> dict:
        """The API ``info`` of robot ``i`` in world ``b``: unweighted ``reward_terms``,
        ``reached_goal``, ``collided_with`` (``robot_j`` / ``obstacle_k`` / ``wall_k`` names),
        ``min_separation`` [m] and, with an expert, ``expert_action``."""
        return self.infos((i,), b)[0]

    def collided_with(self, i: int, b: int = 0) -> list[str]:
        """Names of what robot ``i`` of world ``b`` touched this step: ``robot_j``, then
        ``obstacle_k``, then ``wall_k``."""
        ev = self.events
        hits = [f"robot_{j}" for j in np.flatnonzero(ev.robot_hits[b, i])]
        hits += [f"obstacle_{k}" for k in np.flatnonzero(ev.obstacle_hits[b, i])]
        return hits + [f"wall_{k}" for k in np.flatnonzero(ev.wall_hits[b, i])]

    def infos(self, robots: Sequence[int], b: int = 0) -> list[dict]:
        """:meth:`info` of each robot in ``robots`` of world ``b`` (one array-to-list conversion
        per field, not per robot)."""
        ev = self.events
        terms = {name: v[b].tolist() for name, v in self.terms.items()}
        reached, collided, sep = ev.reached[b].tolist(), ev.collided[b].tolist(), ev.min_separation[b].tolist()
        out = []
        for i in robots:
            info = {
                "reward_terms": {name: v[i] for name, v in terms.items()},
                "reached_goal": reached[i],
                "collided_with": self.collided_with(i, b) if collided[i] else [],
                "min_separation": sep[i],
            }
            if self.expert_action is not None:
                info["expert_action"] = self.expert_action[b, i].copy()
            out.append(info)
        return out


def check_max_steps(value, name: str = "max_steps") -> int:
    """``value`` as an int if it is an integer in [1, :data:`~vcs_env.scenario.MAX_STEPS`]; ``ValueError`` naming
    ``name`` otherwise (the scenario's own check named ``max_steps`` for an env's ``max_cycles``)."""
    check_int(name, value, 1, MAX_STEPS)
    return int(value)


def env_scenario(
    scenario: str | Scenario, obstacle_motion: Any, overrides: dict, max_steps: int | None = None, limit="max_steps"
) -> tuple[Scenario, Any]:
    """The scenario an env runs, and the obstacle motion left for its engine: an env's ``obstacle_motion``
    given as a model's name is the Scenario field, set together with ``overrides`` (so that
    ``obstacle_motion="pedestrians", pedestrians=PedestrianSpec(...)`` is checked as one scenario), and so is a
    ``Pedestrians(spec)`` object; another ``ObstacleMotion`` object (or None) goes to the engine as it is. A keyword
    that cannot change the episodes (a layout field the kind does not read, an obstacle setting without obstacles:
    :func:`vcs_env.applies.check_applies`, as on the command line) is a ``ValueError``; a ``UserWarning`` when the
    time limit leaves no robot the time to arrive (:func:`~vcs_env.scenario.short_time_limit`; the command line grows
    or notes it) in ``max_steps``, the env's own limit where it has one (PettingZoo's ``max_cycles``, TorchRL's
    ``max_steps``; ``limit`` names it), else the scenario's."""
    version = overrides.get("observation")
    if isinstance(scenario, Scenario) and version is not None and version != scenario.observation:
        raise ValueError(  # the registered ids give observation=2 (-v2) or 1 (-v1); it replaced the scenario's own
            f"the scenario given has observation={scenario.observation}, and observation={version} is given too (the "
            f"registered -v{version} ids give it): use the id of the scenario's version (e.g. "
            f"vcs_env/Navigation-v{scenario.observation}, vcs_env/VcsNav-v{scenario.observation}), or give one of "
            "the two only"
        )
    if type(obstacle_motion) is Pedestrians:  # the Scenario's fields, so that the scenario says so and its checks apply
        given = overrides.get("pedestrians")
        if given is not None and given != obstacle_motion.spec:
            raise ValueError("pedestrians= and the Pedestrians object given as obstacle_motion differ: give one")
        obstacle_motion, overrides = obstacle_motion.name, {**overrides, "pedestrians": obstacle_motion.spec}
    if isinstance(obstacle_motion, str):
        out = make_scenario(scenario, **overrides, obstacle_motion=obstacle_motion), None
    else:
        out = make_scenario(scenario, **overrides), obstacle_motion
    named = ["obstacle_motion"] if isinstance(obstacle_motion, str) else []
    check_applies(out[0], {*overrides, *named}, own_motion=out[1] is not None)
    limited = out[0] if max_steps is None else dataclasses.replace(out[0], max_steps=max_steps)
    note = short_time_limit(limited, "max_steps" if max_steps is None else limit)
    if note:
        warnings.warn(f"{note}: every episode will be truncated", UserWarning, stacklevel=user_stacklevel())
    return out


MOVED_BY_HAND = ("pos", "heading", "speed", "active", "present", "goal", "obs_pos", "obs_vel")
"""The :class:`~vcs_env.state.WorldState` fields whose change by hand makes :attr:`NavEngine.expert_action` plan
again."""


class NavEngine:
    """Batched episodes of one scenario.

    Args:
        scenario: the episode family.
        batch_size: number of worlds B stepped together.
        action_mode: ``"delta"`` or ``"absolute"`` (:mod:`vcs_env.dynamics`).
        expert: a planner or planner name whose action is reported for every state
            (``expert_action``); needed by, and defaulting to ``"vcs"`` for, the ``vcs_*``
            shaping terms.
        reward_terms: extra named terms ``{name: (weight, term)}``, a term being a
            :class:`~vcs_env.rewards.RewardTerm` or a function (:data:`~vcs_env.rewards.RewardFn`).
        obstacle_motion: an :class:`~vcs_env.obstacles.ObstacleMotion` that overrides the
            scenario's obstacle motion model, or the name of a model (``"constant"``, ...), which
            sets the Scenario field ``obstacle_motion`` (so the envs' keyword of that name works
            like every other Scenario field).
        gamma: discount of the ``vcs_potential`` shaping term ``gamma * phi(s') - phi(s)``; use
            the learner's (see :func:`vcs_env.rewards.potential_term`).
        max_steps: overrides ``scenario.max_steps``.
        start_states: pools of saved states that reset worlds may start from
            (:mod:`vcs_env.start_states`; training only).
    """

    def __init__(
        self,
        scenario: Scenario,
        batch_size: int = 1,
        action_mode: str = "delta",
        expert: str | Planner | None = None,
        reward_terms: Mapping[str, tuple[float, RewardTerm | RewardFn]] | None = None,
        obstacle_motion=None,
        gamma: float = 0.99,
        max_steps: int | None = None,
        start_states: StartStates | None = None,
    ):
        if isinstance(obstacle_motion, str):
            scenario, obstacle_motion = dataclasses.replace(scenario, obstacle_motion=obstacle_motion), None
        self.sim = Simulator(scenario, batch_size, action_mode, obstacle_motion, start_states)
        self.scenario = scenario
        self.action_mode = action_mode
        self.terms, self.weights = build_terms(scenario.rewards.as_dict(), reward_terms)
        # Terms of the user's own classes (a FunctionTerm checks its function's value itself).
        self._custom = [name for name, term in self.terms.items() if type(term) not in (*TERMS, FunctionTerm)]
        if expert is None and any(t.needs_expert for t in self.terms.values()):
            expert = "vcs"
        self.expert: Planner | None = None if expert is None else own_planner(expert)
        for term in self.terms.values():
            term.check(self.expert)
        if isinstance(gamma, bool) or not isinstance(gamma, (int, float, np.integer, np.floating)):
            raise ValueError(f"gamma must be a number in [0, 1], got {gamma!r}")
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {gamma}")
        self.gamma = float(gamma)
        self.max_steps = scenario.max_steps if max_steps is None else check_max_steps(max_steps)
        self._expert_action: np.ndarray | None = None
        self._expert_state: tuple[np.ndarray, ...] = ()  # the fields of MOVED_BY_HAND it was planned with

    @property
    def world(self) -> WorldState:
        """The state of every world (the simulator's, updated in place)."""
        return self.sim.world

    @property
    def batch_size(self) -> int:
        """The number of worlds ``B``."""
        return self.sim.batch_size

    def observe(self) -> np.ndarray:
        """Every robot's observation now, ``(B, n, D)`` float32 (:mod:`vcs_env.observations`)."""
        return observe(self.sim.world, self.scenario)

    def reset(self, seeds=None, worlds: Sequence[int] | None = None) -> np.ndarray:
        """Reset ``worlds`` (default all) with ``seeds`` (see :meth:`Simulator.reset`); returns every robot's
        observation, ``(B, n, D)`` float32 (the worlds not reset as they are)."""
        idx = list(range(self.batch_size)) if worlds is None else list(worlds)
        self.sim.reset(seeds, idx)
        if self.expert is not None:
            self._refresh_expert(idx)
        for term in self.terms.values():
            term.start(self.sim.world, self.expert, idx)
        return self.observe()

    def _refresh_expert(self, idx: Sequence[int] | None = None) -> None:
        """Expert action for the current state of every world (``idx``: of those worlds and of any moved by hand since
        its last plan; the others' are kept)."""
        world = self.sim.world
        action = self.expert.act(world, self.action_mode)
        if idx is None or self._expert_action is None:
            self._expert_action = action
        else:  # a new array: the old one may be held by a caller (infos, StepResult)
            take = np.zeros(self.batch_size, dtype=bool)
            for field, was in zip(MOVED_BY_HAND, self._expert_state):
                now = getattr(world, field)
                take |= (now != was).reshape(self.batch_size, -1).any(axis=1)
            take[idx] = True
            self._expert_action = self._expert_action.copy()
            self._expert_action[take] = action[take]
        self._expert_state = tuple(getattr(world, field).copy() for field in MOVED_BY_HAND)

    @property
    def expert_action(self) -> np.ndarray | None:
        """Expert actions ``(B, n, 2)`` for the current state (None without an expert): planned again when robots,
        their goals or obstacles were changed by hand since the last plan (:data:`MOVED_BY_HAND`)."""
        if self._expert_action is not None:
            world = self.sim.world
            now = (getattr(world, field).tobytes() for field in MOVED_BY_HAND)  # bytes: the quickest comparison
            if not all(a == was.tobytes() for a, was in zip(now, self._expert_state)):
                self._refresh_expert()
        return self._expert_action

    def step(self, actions: np.ndarray, autoreset: bool = False) -> StepResult:
        """Step all worlds with ``actions`` ``(B, n, 2)``.

        With ``autoreset``, worlds whose episode ended (no robot active, or ``max_steps``
        reached) start a new episode (continuing their random streams): ``obs`` is then the
        first observation of the new episode and ``final_obs`` the last one of the old. Without it a world whose
        robots were truncated (``max_steps``) keeps stepping if asked (its robots stay active: the envs stop there).
        """
        autoreset = check_flag("autoreset", autoreset)
        prev_expert = self.expert_action  # of the state acted in, also after a move by hand
        events = self.sim.step(actions)
        world = self.sim.world
        crashed = events.collided & (self.scenario.on_collision == "terminate")
        terminated = events.reached | crashed
        truncated = world.active & (world.steps >= self.max_steps)[:, None]
        x = StepInput(
            world, events, actions, crashed, self.scenario.dt, self.gamma, self.expert, prev_expert, self.action_mode
        )
        terms = {name: term(x) for name, term in self.terms.items()}
        for name in self._custom:  # the built-in terms are trusted (and checking costs a few % at large B)
            terms[name] = np.where(events.acted, checked_term(name, terms[name], world.active.shape), 0.0)  # ended: 0
        obs = self.observe()
        final_obs, ended = None, np.zeros(self.batch_size, dtype=bool)
        if autoreset:
            ended = ~(world.active & ~truncated).any(axis=1)
            if ended.any():
                final_obs = obs.copy()
                self.sim.reset(None, np.flatnonzero(ended))
                obs = self.observe()
                for term in self.terms.values():
                    term.start(world, self.expert, np.flatnonzero(ended))
        if self.expert is not None:
            self._refresh_expert()
        return StepResult(
            obs=obs,
            reward=weighted_sum(terms, self.weights),
            terms=terms,
            terminated=terminated,
            truncated=truncated,
            events=events,
            expert_action=self._expert_action,
            final_obs=final_obs,
            ended=ended,
        )
