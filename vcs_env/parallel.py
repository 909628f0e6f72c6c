"""PettingZoo ``ParallelEnv`` adapter over :class:`~vcs_env.engine.NavEngine` (one world)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from . import spaces as nav_spaces
from .checks import check_reset_options
from .dynamics import check_actions
from .engine import NavEngine, RewardFn, check_max_steps, env_scenario
from .observations import state_vector
from .planning import Planner
from .render import Renderer, RenderMixin
from .scenario import Scenario


class VcsNavParallelEnv(RenderMixin, ParallelEnv):
    """Multi-robot navigation among moving obstacles (``vcs_nav_v2``).

    ## Description
    ``n`` circular wheeled robots (``robot_0`` ... ``robot_{n-1}``) drive to their goals among
    passive obstacles. Every robot acts at every step of ``dt`` seconds; all robots move at
    once. The layout comes from a :class:`~vcs_env.scenario.Scenario` (presets ``circle``,
    ``swap``, ``crossing``, ``random``, ``crowd``, ``dynamic``, ``custom``).

    ## Action Space
    ``Box(-1, 1, (2,), float32)`` per robot. ``action_mode="delta"`` (default): (speed change,
    heading change) as fractions of the one-step limits ``a_max dt`` and ``omega_max dt``, i.e.
    a point of the one-step velocity change window. ``action_mode="absolute"``: (speed,
    heading) commands tracked within the limits (a holonomic robot: a world-frame velocity in units of ``v_max``).
    Values outside [-1, 1] are clipped, and the new speed to
    [0, v_max]; a holonomic robot's action (a velocity change, or command) is cut to the unit disc. NaN, inf
    and wrong shapes raise ``ValueError``. Details: :mod:`vcs_env.dynamics`.

    ## Observation Space
    ``Box(-1, 1, (11 + 9 K,), float32)`` per robot (observation v2; v1: ``11 + 8 K``), in the
    robot's frame and fixed physical scales: own speed, goal distance and bearing (along the route
    among walls), own limits and radius, the scenario's sensing and arrival radii and step, then
    the ``K = n_neighbors`` nearest objects within ``r_ca`` (mask, relative position and velocity,
    radius, gap, robot flag, parked flag), then the optional lidar and wall-point blocks. Blocks and tables in
    :mod:`vcs_env.observations`. ``state()`` is the global state (SI units).

    ## Rewards
    Weighted sum of named terms (``progress``, ``arrival``, ``collision``, ``time``; optional ``vcs_imitation`` /
    ``vcs_potential`` shaping, ``danger``, ``arrival_speed``, ``stuck`` (with the stall clock); custom
    ``reward_terms``), weights in ``scenario.rewards`` (:data:`vcs_env.rewards.TERMS`). ``info[agent]["reward_terms"]``
    has each term in use, unweighted (the optional ones only when weighted).

    ## Starting State
    Drawn from the scenario with the generator seeded by ``reset(seed=...)``.

    ## Episode End
    A robot terminates when its centre passes within ``r_goal`` of its goal (it stops there: a step
    through the goal disc ends at its point nearest the goal) or, with
    ``on_collision="terminate"`` (default), when it touches a robot, obstacle or wall (swept
    check); it then stops where it first touched.
    Robots still driving after ``max_cycles`` steps are truncated. Finished robots stay in the
    world, parked, as obstacles (``park_finished``).

    ## Info
    ``reward_terms``, ``reached_goal`` (bool), ``collided_with`` (list of ``robot_i`` /
    ``obstacle_k`` / ``wall_k``), ``min_separation`` (smallest swept gap this step [m]) and, with an expert,
    ``expert_action`` (the expert's action for the returned observation).

    ## Arguments
    ``scenario`` (name or Scenario), ``render_mode`` (``human``, ``rgb_array``, ``ansi``),
    ``max_cycles`` (default ``scenario.max_steps``), ``action_mode``, ``expert`` (planner or
    name, e.g. ``"vcs"``; an instance is copied, so that envs never share a planner's memory: read the env's
    at ``env.engine.expert``), ``reward_terms`` (``{name: (weight, fn)}``), ``obstacle_motion`` (an
    ``ObstacleMotion`` model, or a model's name as for the Scenario field),
    ``gamma`` (discount of the ``vcs_potential`` shaping; the learner's), and any Scenario
    field as a keyword override (``n_robots=16``).

    ## Version History
    * v2, fix (same id, 2026-12-07, 21:00 UTC): among walls the ``progress`` reward of the step on which a robot ends
      (a crash under ``terminate``, an arrival) is its route's decrease where it stands, not the straight distance's:
      a crash into a wall between a robot and its goal was paid the step's whole motion; other steps' progress is
      unchanged. The ``danger`` term (weight 0 by default) counts a gap within 1e-9 m as touching, on any step (a
      robot stopped at its contact read touching or not by the rounding of its gap).
    * v2, planner fix (same id, 2026-12-07, night): the VCS expert counts its search in periods of several world steps
      where a robot would need more than 1024 steps to reach its top speed or turn half round (vcs-method §2.10): a
      step far finer than the robots' limits made one decision take seconds to minutes. Every suite plans as before.
    * v2, planner default (same id, 2026-12-07, evening): the VCS expert (the others, the expert labels, the shaping)
      keeps each first step within its share of the gap to every active robot (``VCSParams.step_split``):
      the same plans bit for bit on every suite (steps of 0.1 and 0.25 s; hashed on one machine); at coarser steps
      far fewer contacts.
    * v2, fix (same id, 2026-12-07, evening): the stall clock (``stall_clock``, the ``clock`` block) counts a robot
      stalled after two states at rest at least: at ``dt >= 1`` s (the stall time) every robot at rest at its reset
      read stalled, and the VCS expert detoured it; at any smaller ``dt`` nothing changes.
    * v2, fix (same id, 2026-12-07, later): simulated time is the step count times ``dt`` (a sum of ``dt`` drifted:
      an ``arbitrary`` obstacle's turn period came a step early or late from step 34,040 at dt 0.1); six suites x 20
      episodes hash the same, and episodes shorter than some 30,000 steps are unchanged but for float rounding.
    * v2, fix (same id, 2026-12-07): with ``wall_segments``, a wall square to the robot's heading reads the same
      at every heading (the rounding of ``cos(pi / 2)`` flipped its direction and swapped its extents at headings
      ``pi`` and ``pi / 2``).
    * v2, fix (same id, 2026-12-07): the ``vcs_imitation`` term (weight 0 by default) with
      ``action_mode="absolute"`` and unicycles compares headings wrapped (commands of heading pi and -pi, one
      motion, read 2 apart). Every other reward, and this one in ``delta`` mode, unchanged.
    * v2, addition (same id, 2026-12-06): with ``n_wall_points``, the optional segment fields of the wall points
      (``wall_segments=True``, off by default): each point's wall segment, its direction and extent either side of
      the point (``tx, ty, back, ahead``). Without it every observation is as before, bit for bit.
    * v2, fix (same id, 2026-12-05): a robot whose step passes through its goal disc and out again (a fast
      robot, a long ``dt``) stops at the step's point nearest its goal, where it arrived, instead of driving
      on to the step's end (up to ``v_max dt`` past its goal, its progress reward negative, a contact beyond
      the goal counted as a collision of an arrived robot). Steps that end inside the disc are unchanged.
    * v2, planner default (same id, 2026-12-01): the VCS expert behind the expert labels and the VCS
      shaping terms fits its buffers to the gate between two parked robots or standing obstacles it
      heads through (``VCSParams.fit_discs``); dynamics and the other rewards unchanged.
    * v2, addition (same id): an optional reward term ``stuck`` (weight 0 by default; with the stall
      clock): -dt per step while the expert's stall rule counts the robot as stuck. Rewards unchanged
      unless weighted.
    * v2, addition (same id): an optional ``clock`` block (``stall_clock=True``, off by default): each
      robot's stall clock (:mod:`vcs_env.stall`, the memory the VCS expert frees deadlocks with), 5 floats
      after the neighbour slots. Without it every observation, and with it every episode, is as before.
    * v2: observation version 2 (:mod:`vcs_env.observations`): every neighbour slot gains a parked
      flag (a robot that has finished and stays where it is), ``11 + 9 K`` floats, built from named
      blocks; among walls the goal distance and bearing follow the route (remaining route length,
      bearing of the next waypoint), and so does the ``progress`` reward (the decrease of the
      remaining route length, not of the straight goal distance); dynamics unchanged, and rewards
      on open floor. The v1 ids remain: the same env (these rewards too) with ``observation=1``.
    * v1, fix (same id): with ``on_collision="terminate"`` a robot that touches anything stops
      at the point of first contact on its swept motion, instead of where its step would have
      ended (which could be on or beyond a thin wall, or inside the body it hit). Only steps
      with a contact under ``terminate`` change; the suites (``continue``) do not.
    * v1: observations in fixed physical units (goal distance / 20 m, relative positions and
      gaps / 10 m instead of scales built from the world size and ``r_ca``) plus the sensing
      radius, arrival radius and step as features (``11 + 8 K`` floats); policies trained on v0
      do not carry over. Dynamics and rewards unchanged. The v0 ids are removed.
    * v0: initial release.
    """

    metadata = {
        "name": "vcs_nav_v2",
        "render_modes": ["human", "rgb_array", "ansi"],
        "render_fps": 10,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        scenario: str | Scenario = "circle",
        render_mode: str | None = None,
        max_cycles: int | None = None,
        action_mode: str = "delta",
        expert: str | Planner | None = None,
        reward_terms: Mapping[str, tuple[float, RewardFn]] | None = None,
        obstacle_motion=None,
        gamma: float = 0.99,
        **scenario_overrides,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        if max_cycles is not None:
            max_cycles = check_max_steps(max_cycles, "max_cycles")
        overrides = scenario_overrides
        self.scenario, obstacle_motion = env_scenario(scenario, obstacle_motion, overrides, max_cycles, "max_cycles")
        self.engine = NavEngine(self.scenario, 1, action_mode, expert, reward_terms, obstacle_motion, gamma, max_cycles)
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.scenario.dt}  # one step per frame: real time
        self.render_mode = render_mode
        self.possible_agents = [f"robot_{i}" for i in range(self.scenario.n_robots)]
        self.agent_index = {a: i for i, a in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self._started = False  # reset() called once
        self._obs_space = nav_spaces.observation_space(self.scenario)
        self._act_space = nav_spaces.action_space()
        self.state_space = nav_spaces.state_space(self.scenario)
        self._renderer: Renderer | None = None

    # PettingZoo's tests set env.max_cycles directly.
    @property
    def max_cycles(self) -> int:
        return self.engine.max_steps

    @max_cycles.setter
    def max_cycles(self, value: int) -> None:
        self.engine.max_steps = check_max_steps(value, "max_cycles")

    def observation_space(self, agent: str) -> spaces.Box:
        self._check_agent(agent)
        return self._obs_space  # the identical object for every agent and call (PettingZoo API)

    def action_space(self, agent: str) -> spaces.Box:
        self._check_agent(agent)
        return self._act_space

    def _check_agent(self, agent: str) -> int:
        if agent not in self.agent_index:
            raise ValueError(f"unknown agent {agent!r}; agents are robot_0 .. robot_{len(self.possible_agents) - 1}")
        return self.agent_index[agent]

    @property
    def world(self):
        """The simulator state (privileged; planners read it)."""
        return self.engine.world

    def reset(self, seed: int | None = None, options: dict | None = None):
        check_reset_options(options, warn=True, made="parallel_env(scenario=name, n_robots=4)")
        obs = self.engine.reset(None if seed is None else [seed])
        self.agents, self._started = list(self.possible_agents), True
        if self._renderer is not None:
            self._renderer.reset()
        expert = self.engine.expert_action
        infos = {
            a: ({} if expert is None else {"expert_action": expert[0, i].copy()}) for i, a in enumerate(self.agents)
        }
        if self.render_mode == "human":
            self.render()
        return {a: obs[0, i] for i, a in enumerate(self.agents)}, infos

    def step(self, actions: Mapping[str, np.ndarray]):
        if not self.agents:
            said = "on a finished episode" if self._started else "before the first reset()"
            raise RuntimeError(f"step() called {said}; call reset() first")
        if not isinstance(actions, Mapping):
            raise ValueError(f"actions must be a dict {{agent: action}}, got {type(actions).__name__}")
        live = self.agents
        idx = [self.agent_index[a] for a in live]
        batch = np.zeros((1, len(self.possible_agents), 2))
        rows = self._live_rows(actions)
        if rows is not None:  # one conversion for the usual call: one valid action per live agent
            batch[0, idx] = rows
        else:
            self._parse_actions(actions, batch)
        res = self.engine.step(batch)
        rew = dict(zip(live, res.reward[0, idx].tolist()))
        term = dict(zip(live, res.terminated[0, idx].tolist()))
        trunc = dict(zip(live, res.truncated[0, idx].tolist()))
        obs = dict(zip(live, res.obs[0, idx]))
        infos = dict(zip(live, res.infos(idx)))
        self.agents = [a for a in live if not (term[a] or trunc[a])]
        if self.render_mode == "human":
            self.render()
        return obs, rew, term, trunc, infos

    def _live_rows(self, actions: Mapping[str, np.ndarray]) -> np.ndarray | None:
        """The live agents' actions ``(len(agents), 2)`` float64 when ``actions`` has exactly
        one finite real action of shape (2,) per live agent; None otherwise (then
        :meth:`_parse_actions` names the problem)."""
        if len(actions) != len(self.agents):
            return None
        try:
            rows = np.array([actions[a] for a in self.agents])
        except (KeyError, TypeError, ValueError):
            return None
        if rows.dtype.kind not in "biuf":  # complex, strings, objects: named by the slow path
            return None
        rows = rows.astype(np.float64, copy=False)
        if rows.shape != (len(self.agents), 2) or not np.isfinite(rows).all():
            return None
        return rows

    def _parse_actions(self, actions: Mapping[str, np.ndarray], batch: np.ndarray) -> None:
        """Check ``actions`` agent by agent into ``batch`` ``(1, n, 2)``, raising ``ValueError``
        that names the agent; actions of finished agents are ignored."""
        for agent, act in actions.items():
            i = self._check_agent(agent)
            if agent not in self.agents:
                continue  # a finished robot's action is ignored
            batch[0, i] = check_actions(act, (2,), f"action of {agent}")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"missing actions for live agents {missing}")

    def state(self) -> np.ndarray:
        """The global state ``(S,)`` float32 (PettingZoo's ``state()``, ``state_space``):
        :func:`vcs_env.observations.state_vector` of the world."""
        if not self._started:
            raise RuntimeError("state() called before the first reset(); call reset() first")
        return state_vector(self.engine.world)[0]


def parallel_env(**kwargs) -> VcsNavParallelEnv:
    """The PettingZoo parallel env; keyword arguments as :class:`VcsNavParallelEnv`."""
    return VcsNavParallelEnv(**kwargs)


def raw_env(**kwargs):
    """The AEC version (via ``parallel_to_aec``)."""
    return parallel_to_aec(VcsNavParallelEnv(**kwargs))


env = raw_env
