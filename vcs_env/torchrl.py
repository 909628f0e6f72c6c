"""TorchRL ``EnvBase`` adapter over :class:`~vcs_env.engine.NavEngine`: ``num_envs`` worlds, one engine call.

The only module of ``vcs_env`` that imports ``torch``, ``tensordict`` and ``torchrl`` (the ``torchrl``
extra: ``pip install -e ".[torchrl]"``); ``import vcs_env`` does not load it. Usage and the
masking semantics in ``docs/torchrl.md``.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .checks import missing_extra

try:
    import torch
    from tensordict import TensorDict, TensorDictBase
    from torchrl.data import Bounded, Categorical, Composite, Unbounded
    from torchrl.envs import EnvBase
except ImportError as e:  # a bare "No module named 'torch'" named no extra
    raise ImportError(missing_extra(e, "torchrl")) from e

from .engine import NavEngine, RewardFn, check_max_steps, env_scenario
from .observations import observation_bounds
from .planning import Planner
from .scenario import Scenario

GROUP = "agents"
"""The one agent group: every robot shares the specs (TorchRL's ``MarlGroupMapType.ALL_IN_ONE_GROUP``)."""


def _check_seed(seed) -> int | None:
    if seed is None:
        return None
    if isinstance(seed, torch.Tensor) and seed.numel() == 1 and not seed.is_floating_point():
        seed = seed.item()  # a one-element integer tensor, as TorchRL code passes seeds around
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer or None, got {seed!r}")
    return int(seed)


def _mask(value: torch.Tensor, shape: tuple[int, ...], key: str) -> torch.Tensor:
    """A reset mask of ``shape`` (or with TorchRL's trailing 1), or a ``ValueError`` naming its key."""
    if tuple(value.shape) not in (shape, (*shape, 1)):
        raise ValueError(f"the reset mask {key} must have shape {shape} or {(*shape, 1)}, got {tuple(value.shape)}")
    return value.reshape(shape)


def _replaced(a: np.ndarray, rows: np.ndarray, value) -> np.ndarray:
    """A copy of ``a`` with ``a[rows] = value`` (``a`` itself untouched)."""
    out = a.copy()
    out[rows] = value
    return out


class VcsNavEnv(EnvBase):
    """Multi-robot navigation among moving obstacles as a batched TorchRL env (``vcs_nav_v2``).

    ## Description
    ``num_envs`` independent worlds of one :class:`~vcs_env.scenario.Scenario`, each with ``n`` robots
    (``robot_0`` ... ``robot_{n-1}``) driving to their goals among obstacles; one ``step`` advances every
    world with ONE call of the batched engine (the engine, observations and rewards of the PettingZoo env
    ``vcs_nav_v2``). Batch size ``(num_envs,)``; the robots are the agent dimension of the group
    ``"agents"``, laid out as TorchRL's multi-agent envs (``VmasEnv``, ``PettingZooWrapper``) lay them out.

    ## Action Space
    ``("agents", "action")``: ``Bounded(-1, 1)``, shape ``(num_envs, n, 2)`` float32. ``action_mode="delta"``
    (default): a point of the one-step velocity change window, for a unicycle robot (speed change, heading
    change) as fractions of ``a_max dt`` [m/s] and ``omega_max dt`` [rad]; ``"absolute"``: a velocity command
    tracked within the limits, for a unicycle target speed ``(a_0 + 1) / 2 v_max`` [m/s] and heading
    ``a_1 pi`` [rad] (holonomic robots: :mod:`vcs_env.dynamics`). Values outside [-1, 1] are clipped; a
    non-finite action of a driving robot raises ``ValueError``. Actions of finished robots (``mask`` False)
    are ignored.

    ## Observation Space
    ======================================  ======================  =============================================
    key                                     shape                   meaning
    ======================================  ======================  =============================================
    ``("agents", "observation")``           ``(B, n, D)`` float32   the robot's observation, ``D = 11 + 9 K`` (+
                                                                    lidar / wall points), in [-1, 1], fixed
                                                                    physical scales (:mod:`vcs_env.observations`);
                                                                    all zeros once the robot has finished
    ``("agents", "mask")``                  ``(B, n)`` bool         the robot is still in its episode: its action
                                                                    drives it
    ``("agents", "expert_action")``         ``(B, n, 2)`` float32   the expert's action for this observation
                                                                    (only with ``expert=``; zeros when masked)
    ``("agents", "info", "reached_goal")``  ``(B, n)`` bool         arrived during the last step
    ``("agents", "info", "collided")``      ``(B, n)`` bool         touched something during the last step
    ``("agents", "info", TERM)``            ``(B, n)`` float32      unweighted reward term ``TERM`` of the last
                                                                    step (``progress``, ``arrival``, ...)
    ======================================  ======================  =============================================

    ## Rewards
    ``("agents", "reward")`` ``(B, n, 1)`` float32: the weighted sum of the scenario's named terms
    (``scenario.rewards``), as in the PettingZoo env; 0 for robots that had finished before the step.

    ## Starting State
    Drawn from the scenario by each world's ``np.random.Generator``. ``set_seed(s)`` seeds world ``b`` with
    ``s + b`` at its next reset (the PettingZoo env's ``reset(seed=s + b)``); worlds reset without a pending
    seed continue their random streams, so a rollout is a pure function of the seed and the actions.

    ## Episode End
    Per robot (``("agents", "done" | "terminated" | "truncated")``, ``(B, n, 1)`` bool): a robot terminates
    when it reaches its goal or, with ``on_collision="terminate"`` (default), when it touches anything; robots
    still driving after ``max_steps`` steps are truncated. These flags stay True until the world resets, and
    a finished robot stays in the world parked as an obstacle (``park_finished``). A world is done when all
    its robots are done (``done``, ``(B, 1)``); it is ``truncated`` when it hit ``max_steps``, ``terminated``
    when every robot terminated. Only done worlds are reset (TorchRL's ``"_reset"`` mask): a world keeps
    running while some of its robots drive.

    ## Arguments
    ``scenario`` (preset name or :class:`~vcs_env.scenario.Scenario`), ``num_envs`` (worlds B, >= 1),
    ``action_mode`` (``"delta"`` / ``"absolute"``), ``expert`` (a planner or a registered planner name such as
    ``"vcs"``: adds ``("agents", "expert_action")``), ``reward_terms`` (``{name: (weight, fn)}``),
    ``obstacle_motion``, ``gamma`` (discount of the ``vcs_potential`` shaping), ``max_steps`` (default
    ``scenario.max_steps``), ``device`` (where the tensors go; the engine runs on the CPU in numpy) and any
    Scenario field as a keyword override (``n_robots=16``), as :func:`vcs_env.parallel_env` takes them.

    ## Version History
    * v2, fix (same id, 2026-12-07, evening): the stall clock counts a robot stalled after two states at rest at
      least, as in the PettingZoo ``vcs_nav_v2`` (its version history).
    * v2, fix (same id, 2026-12-07): simulated time is the step count times ``dt``, as in the PettingZoo
      ``vcs_nav_v2`` (its version history).
    * v2, fix (same id, 2026-12-05): a step through the goal disc and out again ends at its point nearest the
      goal, as in the PettingZoo ``vcs_nav_v2`` (its version history).
    * v2: observation version 2, as the PettingZoo ``vcs_nav_v2`` (a parked flag per neighbour slot).
    * v1: first TorchRL env, same dynamics, observations and rewards as the PettingZoo ``vcs_nav_v1``.
    """

    metadata = {"name": "vcs_nav_v2"}
    batch_locked = True

    def __init__(
        self,
        scenario: str | Scenario = "circle",
        num_envs: int = 1,
        *,
        action_mode: str = "delta",
        expert: str | Planner | None = None,
        reward_terms: Mapping[str, tuple[float, RewardFn]] | None = None,
        obstacle_motion=None,
        gamma: float = 0.99,
        max_steps: int | None = None,
        device: str | torch.device = "cpu",
        **scenario_overrides,
    ):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if not isinstance(scenario, (str, Scenario)):
            raise ValueError(f"scenario must be a preset name or a vcs_env.Scenario, got {type(scenario).__name__}")
        try:
            device = torch.device(device)
            if device.type == "meta":
                raise RuntimeError("the meta device holds no data")
            torch.empty(1, device=device)  # an accelerator this torch was not built for, or that is absent
        except (RuntimeError, TypeError, AssertionError) as e:
            raise ValueError(f"device must be a torch device such as 'cpu', got {device!r} ({e})") from None
        if max_steps is not None:
            max_steps = check_max_steps(max_steps)
        scen, obstacle_motion = env_scenario(scenario, obstacle_motion, scenario_overrides, max_steps)
        engine = NavEngine(scen, int(num_envs), action_mode, expert, reward_terms, obstacle_motion, gamma, max_steps)
        super().__init__(device=device, batch_size=torch.Size([int(num_envs)]))
        self.engine = engine
        self.scenario = scen
        self.num_envs = int(num_envs)
        self.n_robots = self.scenario.n_robots
        self.agent_names = [f"robot_{i}" for i in range(self.n_robots)]
        self.group_map = {GROUP: list(self.agent_names)}
        B, n = self.num_envs, self.n_robots
        low, high = observation_bounds(self.scenario)
        self._obs_dim = low.shape[0]
        self._term_names = list(engine.terms)
        self._live = np.zeros((B, n), dtype=bool)  # robot still in its episode (the mask)
        self._terminated = np.zeros((B, n), dtype=bool)  # sticky until the world resets
        self._truncated = np.zeros((B, n), dtype=bool)
        self._obs = np.zeros((B, n, self._obs_dim), dtype=np.float32)  # masked observations
        self._reached = np.zeros((B, n), dtype=bool)
        self._collided = np.zeros((B, n), dtype=bool)
        self._terms = {name: np.zeros((B, n), dtype=np.float32) for name in self._term_names}
        self._pending_seeds: list[int | None] = [None] * B
        self._make_specs(low, high)

    # ------------------------------------------------------------------ specs
    def _make_specs(self, low: np.ndarray, high: np.ndarray) -> None:
        B, n, D, dev = self.num_envs, self.n_robots, self._obs_dim, self.device

        def flag(*shape):
            return Categorical(n=2, shape=torch.Size(shape), dtype=torch.bool, device=dev)

        info = Composite(
            {"reached_goal": flag(B, n), "collided": flag(B, n)},
            **{name: Unbounded(shape=(B, n), dtype=torch.float32, device=dev) for name in self._term_names},
            shape=(B, n),
        )
        agents_obs = {
            "observation": Bounded(
                low=torch.as_tensor(low).expand(B, n, D).clone(),
                high=torch.as_tensor(high).expand(B, n, D).clone(),
                shape=(B, n, D),
                dtype=torch.float32,
                device=dev,
            ),
            "mask": flag(B, n),
            "info": info,
        }
        if self.engine.expert is not None:
            agents_obs["expert_action"] = Bounded(-1.0, 1.0, shape=(B, n, 2), dtype=torch.float32, device=dev)

        def group(specs: dict) -> Composite:  # one spec per robot of every world, under "agents"
            return Composite({GROUP: Composite(specs, shape=(B, n))}, shape=(B,))

        self.observation_spec = group(agents_obs)
        self.action_spec = group({"action": Bounded(-1.0, 1.0, shape=(B, n, 2), dtype=torch.float32, device=dev)})
        self.reward_spec = group({"reward": Unbounded(shape=(B, n, 1), dtype=torch.float32, device=dev)})
        ends = ("done", "terminated", "truncated")
        done_spec = group({key: flag(B, n, 1) for key in ends})
        for key in ends:  # the world's: all its robots are done
            done_spec[key] = flag(B, 1)
        self.done_spec = done_spec

    # ------------------------------------------------------------------ API
    def _set_seed(self, seed: int | None) -> None:
        """World ``b`` is seeded with ``seed + b`` at its next reset; ``None`` cancels pending seeds."""
        seed = _check_seed(seed)
        self._pending_seeds = [None if seed is None else seed + b for b in range(self.num_envs)]

    def _reset_worlds(self, tensordict: TensorDictBase | None) -> np.ndarray:
        """``(B,)`` bool: the worlds a reset call resets. The env-level ``"_reset"`` decides; given only the
        per-robot ``("agents", "_reset")``, a world resets when all its robots ask; without either, all do."""
        B, n = self.num_envs, self.n_robots
        if tensordict is not None:
            root = tensordict.get("_reset", None)
            if root is not None:
                return _mask(root, (B,), '"_reset"').cpu().numpy().astype(bool)
            per_robot = tensordict.get((GROUP, "_reset"), None)
            if per_robot is not None:
                return _mask(per_robot, (B, n), f'("{GROUP}", "_reset")').all(dim=1).cpu().numpy()
        return np.ones(B, dtype=bool)

    def _reset(self, tensordict: TensorDictBase | None = None, seed=None, **kwargs) -> TensorDictBase:
        """``reset(seed=s)`` is ``set_seed(s)`` then ``reset()``: world ``b`` starts from seed ``s + b``."""
        if kwargs:
            raise ValueError(f"reset takes a tensordict and seed=..., got {sorted(kwargs)}")
        if seed is not None:
            self._set_seed(seed)
        worlds = np.flatnonzero(self._reset_worlds(tensordict))
        if worlds.size:
            seeds = [self._pending_seeds[b] for b in worlds]
            for b in worlds:
                self._pending_seeds[b] = None
            obs = self.engine.reset(seeds, worlds.tolist())
            active = self.engine.world.active
            # New arrays, never writes into old ones: the tensors handed out are views of them (_tensor).
            self._live = _replaced(self._live, worlds, active[worlds])
            self._terminated = _replaced(self._terminated, worlds, False)
            self._truncated = _replaced(self._truncated, worlds, False)
            self._reached = _replaced(self._reached, worlds, False)
            self._collided = _replaced(self._collided, worlds, False)
            self._terms = {name: _replaced(v, worlds, 0.0) for name, v in self._terms.items()}
            self._obs = _replaced(self._obs, worlds, np.where(active[worlds, :, None], obs[worlds], 0.0))
        return self._output(reward=None)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get((GROUP, "action"))
        if action is None:
            raise ValueError(
                "the step's tensordict has no ('agents', 'action'): set one of shape "
                f"({self.num_envs}, {self.n_robots}, 2)"
            )
        if tuple(action.shape) != (self.num_envs, self.n_robots, 2):
            raise ValueError(
                f"('agents', 'action') must have shape ({self.num_envs}, {self.n_robots}, 2), got {tuple(action.shape)}"
            )
        live = self._live.copy()
        # Finished robots' rows are ignored by the engine; a NaN from a policy there must not reach it.
        actions = np.where(live[..., None], action.detach().cpu().numpy().astype(np.float64), 0.0)
        res = self.engine.step(actions)
        ended = live & (res.terminated | res.truncated)
        self._terminated = self._terminated | (live & res.terminated)
        self._truncated = self._truncated | (live & res.truncated & ~res.terminated)
        self._live = live & ~ended
        # The robots that drove this step see where they ended up (their last observation when they finished).
        self._obs = np.where(live[..., None], res.obs, 0.0).astype(np.float32)
        self._reached = res.events.reached & live
        self._collided = res.events.collided & live
        self._terms = {name: np.where(live, v, 0.0).astype(np.float32) for name, v in res.terms.items()}
        reward = np.where(live, res.reward, 0.0).astype(np.float32)
        return self._output(reward)

    # -------------------------------------------------------------- helpers
    def _tensor(self, x: np.ndarray) -> torch.Tensor:
        """``x`` as a tensor on the env's device: a view on the CPU (the env never writes into an array it
        handed out: :meth:`_step` and :meth:`_reset` make new ones)."""
        return torch.from_numpy(np.ascontiguousarray(x)).to(self.device)

    def _output(self, reward: np.ndarray | None) -> TensorDict:
        """The env's tensordict from the current arrays (``reward`` ``(B, n)`` after a step, None after reset)."""
        B, n = self.num_envs, self.n_robots
        done = self._terminated | self._truncated
        world_done = done.all(axis=1)
        world_trunc = world_done & self._truncated.any(axis=1)
        info = {"reached_goal": self._tensor(self._reached), "collided": self._tensor(self._collided)}
        info.update({name: self._tensor(v) for name, v in self._terms.items()})
        agents = {
            "observation": self._tensor(self._obs),
            "mask": self._tensor(self._live),
            "done": self._tensor(done[..., None]),
            "terminated": self._tensor(self._terminated[..., None]),
            "truncated": self._tensor(self._truncated[..., None]),
            "info": TensorDict(info, batch_size=(B, n), device=self.device),
        }
        if self.engine.expert is not None:
            expert = np.where(self._live[..., None], self.engine.expert_action, 0.0).astype(np.float32)
            agents["expert_action"] = self._tensor(expert)
        if reward is not None:
            agents["reward"] = self._tensor(reward[..., None])
        return TensorDict(
            {
                GROUP: TensorDict(agents, batch_size=(B, n), device=self.device),
                "done": self._tensor(world_done[:, None]),
                "terminated": self._tensor((world_done & ~world_trunc)[:, None]),
                "truncated": self._tensor(world_trunc[:, None]),
            },
            batch_size=(B,),
            device=self.device,
        )
