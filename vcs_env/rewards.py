"""Named reward terms. The reward is ``sum(weight[name] * term[name])``; every term is reported.

Each term is one :class:`RewardTerm` object: a name, the term ``(B, n)`` of a step from a
:class:`StepInput`, and optional hooks when episodes start. :data:`TERMS` lists the built-in
terms, whose weights are the fields of :class:`~vcs_env.scenario.RewardWeights` (definitions
there); a term of your own is passed to the env as ``reward_terms={name: (weight, term)}``
(``docs/extending.md``).
"""

from __future__ import annotations

import dataclasses
import functools
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from . import routes
from .dynamics import check_actions
from .geometry import time_to_collision
from .planning import Planner, env_copy
from .sim import StepEvents
from .stall import CLOCK_FIELDS
from .state import WorldState

STALL_TRIES = CLOCK_FIELDS.index("tries")
"""The stall clock's detours begun since the robot last made progress (:mod:`vcs_env.stall`)."""
RewardFn = Callable[[WorldState, StepEvents, np.ndarray], np.ndarray]
"""A custom reward term as a function: ``fn(world_after, events, actions (B, n, 2)) -> (B, n)``."""


@dataclass
class StepInput:
    """What a reward term sees after one step of ``B`` worlds."""

    world: WorldState  # state after the step
    events: StepEvents
    actions: np.ndarray  # (B, n, 2) the actions as given to the step
    crashed: np.ndarray  # (B, n) bool: collisions that end the robot's episode
    dt: float  # step [s]
    gamma: float  # discount of potential-based shaping
    expert: Planner | None
    expert_action: np.ndarray | None  # (B, n, 2) the expert's action for the state before the step
    action_mode: str = "delta"  # how the actions command the robots (vcs_env.dynamics.ACTION_MODES)


class RewardTerm:
    """One named reward term. Subclasses set :attr:`name` and implement :meth:`__call__`."""

    name: str = ""
    needs_expert: bool = False
    """Terms that need an expert are also :attr:`only_when_weighted`, and their weight attaches the
    VCS expert unless the env is given another."""
    only_when_weighted: bool = False
    """Computed (and reported in ``info["reward_terms"]``) only when weighted: the expert's terms
    and those that cost a pass over every pair of objects."""

    def check(self, expert: Planner | None) -> None:
        """Raise ``ValueError`` if the term cannot work with this expert (called once)."""

    def start(self, world: WorldState, expert: Planner | None, worlds: Sequence[int] | np.ndarray) -> None:
        """Episodes of ``worlds`` (indices) have just started (reset or auto-reset)."""

    def __call__(self, x: StepInput) -> np.ndarray:
        """The term ``(B, n)`` of the step; zero for robots that did not act."""
        raise NotImplementedError(
            f"reward term {type(self).__name__} ({self.name!r}) must define __call__(self, x) -> (B, n) array "
            "(docs/extending.md)"
        )


class Progress(RewardTerm):
    """Decrease of the remaining route length [m]: of the goal distance on open floor; among walls,
    of the length of the shortest route around them (:func:`vcs_env.routes.waypoints`, the route
    the planners follow; a robot that ends its episode on the step is routed where it stands), so that pressing into
    a wall between a robot and its goal earns nothing, also on the step it crashes.
    A step's route progress is bounded by the distance the robot moved (the roadmap's routes are
    approximate: where the shortest one switches, or none is found, the length may jump)."""

    name = "progress"

    def __init__(self) -> None:
        self.length: np.ndarray | None = None  # (B, n) remaining route length of the current state [m]
        self.pos: np.ndarray | None = None  # (B, n, 2) positions of the current state [m]

    def start(self, world: WorldState, expert: Planner | None, worlds: Sequence[int] | np.ndarray) -> None:
        if not routes.walled(world):
            return
        length = routes.waypoints(world)[1]
        if self.length is None or self.length.shape != length.shape:
            self.length, self.pos = length, world.pos.copy()
        else:
            self.length[worlds], self.pos[worlds] = length[worlds], world.pos[worlds]

    def __call__(self, x: StepInput) -> np.ndarray:
        ev = x.events
        if not routes.walled(x.world) or self.length is None:
            return np.where(ev.acted, ev.goal_dist_before - ev.goal_dist_after, 0.0)
        ended = ev.acted & ~x.world.active  # arrived or stopped by a crash: routed where they stand, not straight
        ended_length = routes.waypoints(dataclasses.replace(x.world, active=ended))[1] if ended.any() else None
        length = routes.waypoints(x.world)[1]  # last: the planners ask for this state next (waypoints' cache)
        if ended_length is not None:
            length = np.where(ended, ended_length, length)
        moved = np.linalg.norm(x.world.pos - self.pos, axis=-1)
        progress = np.clip(self.length - length, -moved, moved)
        self.length, self.pos = length, x.world.pos.copy()
        return np.where(ev.acted, progress, 0.0)


class Arrival(RewardTerm):
    """1 on the step the goal is reached."""

    name = "arrival"

    def __call__(self, x: StepInput) -> np.ndarray:
        return x.events.reached.astype(np.float64)


class Collision(RewardTerm):
    """-1 on every step the robot touches something."""

    name = "collision"

    def __call__(self, x: StepInput) -> np.ndarray:
        return -x.events.collided.astype(np.float64)


class Time(RewardTerm):
    """-dt [s] per step driven."""

    name = "time"

    def __call__(self, x: StepInput) -> np.ndarray:
        return np.where(x.events.acted, -x.dt, 0.0)


class VcsImitation(RewardTerm):
    """``-|a - a_expert| / (2 sqrt 2)`` in [-1, 0]: distance of the taken and the expert action
    in the one-step velocity change window (both in action units, clipped to [-1, 1]); a unicycle's
    absolute heading component differs by its wrapped angle (headings pi and -pi are one command)."""

    name = "vcs_imitation"
    needs_expert = True
    only_when_weighted = True

    def __call__(self, x: StepInput) -> np.ndarray:
        diff = np.clip(np.asarray(x.actions, dtype=np.float64), -1.0, 1.0) - x.expert_action
        if x.action_mode == "absolute" and not x.world.holonomic:  # a_1 pi is a heading [rad]: wrap the difference
            diff[..., 1] = (diff[..., 1] + 1.0) % 2.0 - 1.0
        return np.where(x.events.acted, -np.sqrt(np.einsum("...i,...i->...", diff, diff)) / (2.0 * np.sqrt(2.0)), 0.0)


class VcsPotential(RewardTerm):
    """Potential-based shaping with phi = minus the expert's optimal cost (:func:`potential_term`)."""

    name = "vcs_potential"
    needs_expert = True
    only_when_weighted = True

    def __init__(self) -> None:
        self.phi: np.ndarray | None = None  # (B, n) potential of the current state

    def check(self, expert: Planner | None) -> None:
        if not (hasattr(expert, "potential") and hasattr(expert, "potential_floor")):
            raise ValueError(
                f"vcs_potential shaping needs an expert with potential() and potential_floor (the VCS planner); "
                f"{getattr(expert, 'name', type(expert).__name__)!r} has none"
            )

    def start(self, world: WorldState, expert: Planner | None, worlds: Sequence[int] | np.ndarray) -> None:
        phi = expert.potential(world)
        if self.phi is None:
            self.phi = phi
        else:
            self.phi[worlds] = phi[worlds]

    def __call__(self, x: StepInput) -> np.ndarray:
        # Goal: phi = 0 (best); terminating collision: the floor (worst); truncation keeps phi(s').
        phi_next = x.expert.potential(x.world)
        out = potential_term(
            self.phi, phi_next, x.events.reached, x.crashed, x.events.acted, x.gamma, x.expert.potential_floor
        )
        self.phi = phi_next
        return out


DANGER_TIME = 1.0
"""Time scale of the ``danger`` term [s]: a contact ``DANGER_TIME`` ahead weighs ``1/e`` of one now."""


TOUCH_GAP = 1e-9
"""[m] gap :func:`contact_times` counts as touching."""


def contact_times(world: WorldState) -> np.ndarray:
    """``(B, n, n + m)`` time [s] until robot ``i`` touches robot ``j`` (columns ``:n``) or obstacle
    ``k`` (columns ``n:``) if both keep their current velocities: 0 when they touch now (within
    :data:`TOUCH_GAP`: a robot stopped at its point of contact, whose gap is 0 up to rounding), ``inf``
    when they never will, for itself and for robots no longer present."""
    vel = world.vel
    pos = np.concatenate((world.pos, world.obs_pos), axis=1)  # (B, n + m, 2)
    other_vel = np.concatenate((vel, world.obs_vel), axis=1)
    radius = np.concatenate((world.radius, world.obs_radius), axis=1)
    p = pos[:, None, :, :] - world.pos[:, :, None, :]  # (B, n, n + m, 2), from robot i to object j
    own_rel_vel = vel[:, :, None, :] - other_vel[:, None, :, :]  # robot i relative to object j
    reach = radius[:, None, :] + world.radius[:, :, None]
    t = time_to_collision(p, own_rel_vel, reach)
    t = np.where(np.einsum("...i,...i->...", p, p) <= (reach + TOUCH_GAP) ** 2, 0.0, t)
    n = world.pos.shape[1]
    gone = np.concatenate((~world.present, np.zeros(world.obs_pos.shape[:2], dtype=bool)), axis=1)
    t = np.where(gone[:, None, :], np.inf, t)
    t[:, np.arange(n), np.arange(n)] = np.inf
    return t


class Danger(RewardTerm):
    """``-dt * max_j exp(-t_j / DANGER_TIME)`` [s]: how soon the robot would touch another robot or an
    obstacle if everything kept its velocity (:func:`contact_times`; walls are not counted). A dense
    signal of the contacts the ``collision`` term sees only when they happen."""

    name = "danger"
    only_when_weighted = True

    def __call__(self, x: StepInput) -> np.ndarray:
        t = contact_times(x.world)
        worst = np.exp(-t.min(axis=-1, initial=np.inf) / DANGER_TIME)
        return np.where(x.events.acted, -x.dt * worst, 0.0)


class ArrivalSpeed(RewardTerm):
    """``-v / v_max`` on the step the goal is reached, ``v`` the robot's speed [m/s] when that step
    began (0 on other steps). An arriving robot stops dead (``kernels.commit``); this term asks it
    to arrive slowly, so robots behind and beside it are not surprised by the stop."""

    name = "arrival_speed"
    only_when_weighted = True

    def __init__(self) -> None:
        self.speed: np.ndarray | None = None  # (B, n) [m/s] at the start of the coming step

    def start(self, world: WorldState, expert: Planner | None, worlds: Sequence[int] | np.ndarray) -> None:
        if self.speed is None or self.speed.shape != world.speed.shape:
            self.speed = world.speed.copy()
        else:
            self.speed[worlds] = world.speed[worlds]

    def __call__(self, x: StepInput) -> np.ndarray:
        out = np.where(x.events.reached, -self.speed / x.world.v_max, 0.0)
        self.speed = x.world.speed.copy()
        return out


class Stuck(RewardTerm):
    """``-dt`` [s] per step while the robot is stuck by the VCS expert's stall rule (:mod:`vcs_env.stall`):
    since it last gained ground on its goal (along its route among walls) it has been slow or
    without progress long enough to begin a detour (the stall clock's detour count is at least
    one). Waiting in front of a door, or circling in a deadlock, costs it until it makes progress
    again, which the ``time`` term alone barely does. Needs the stall clock (``Scenario.stall_clock``)."""

    name = "stuck"
    only_when_weighted = True

    def __call__(self, x: StepInput) -> np.ndarray:
        if x.world.clock is None:
            raise ValueError(
                "the stuck reward term needs each robot's stall clock: make the scenario with stall_clock=True "
                "(--stall-clock)"
            )
        stuck = x.world.clock[..., STALL_TRIES] >= 1.0
        return np.where(x.events.acted & stuck, -x.dt, 0.0)


class FunctionTerm(RewardTerm):
    """A term from a :data:`RewardFn`, zero for robots that did not act."""

    def __init__(self, name: str, fn: RewardFn) -> None:
        self.name, self.fn = name, fn

    def __call__(self, x: StepInput) -> np.ndarray:
        value = checked_term(self.name, self.fn(x.world, x.events, x.actions), x.events.acted.shape)
        return np.where(x.events.acted, value, 0.0)


TERMS: tuple[type[RewardTerm], ...] = (
    Progress, Arrival, Collision, Time, VcsImitation, VcsPotential, Danger, ArrivalSpeed, Stuck,
)  # fmt: skip
"""The built-in terms, in the order they are summed; each has a weight in ``RewardWeights``."""


def potential_term(
    phi_before: np.ndarray,
    phi_after: np.ndarray,
    reached: np.ndarray,
    crashed: np.ndarray,
    acted: np.ndarray,
    gamma: float,
    floor: float,
):
    """``gamma * phi(s') - phi(s)`` per robot ``(B, n)``: potential-based shaping (Ng et al. 1999), with the
    learner's ``gamma``. At the end of a robot's episode ``phi(s')`` is replaced by the best potential, 0, on
    reaching the goal (``reached``) and by the worst, ``floor`` (< 0), on a collision that ends it (``crashed``); a
    truncated robot keeps ``phi(s')`` (its value is bootstrapped). Ng et al.'s guarantee (the optimal policy
    unchanged) holds for one terminal potential; these two differ by outcome, so the term also adds ``gamma *
    floor`` to a crash against an arrival: a crash penalty, by design. A crash step earns ``gamma * floor -
    phi(s)``, no more than staying one step in a state at the floor does.

    With ``gamma = 1`` an episode's terms sum to ``phi(s_T) - phi(s_0)``; with ``gamma < 1`` a robot earns
    ``(1 - gamma) |phi|`` per step for staying where it is, most in crowded states (with weight 10, PPO learned
    to stand still on ``circle``; measured).
    """
    end = np.where(crashed, floor, np.where(reached, 0.0, phi_after))
    return np.where(acted, gamma * end - phi_before, 0.0)


def build_terms(
    weights: Mapping[str, float], extra: Mapping[str, tuple[float, RewardTerm | RewardFn]] | None = None
) -> tuple[dict[str, RewardTerm], dict[str, float]]:
    """The terms an env computes (name -> term, in summing order) and every term's weight.

    Built-in terms are computed unless they are :attr:`RewardTerm.only_when_weighted` and weigh 0;
    ``extra`` adds ``{name: (weight, term or function)}`` after them.

    Raises:
        ValueError: for ``extra`` not a mapping, an extra name that exists, or a spec that is not a (finite weight,
            term) pair.
    """
    weights = dict(weights)
    terms = {cls.name: cls() for cls in TERMS if not cls.only_when_weighted or weights[cls.name] != 0.0}
    if extra is not None and not isinstance(extra, Mapping):
        raise ValueError(f"reward_terms must be a dict {{name: (weight, fn)}}, got a {type(extra).__name__}")
    for name, spec in (extra or {}).items():
        if name in weights:
            raise ValueError(f"reward term {name!r} already exists; pick another name")
        try:
            w, fn = spec
        except (TypeError, ValueError):
            raise ValueError(f"reward_terms[{name!r}] must be a (weight, fn) pair") from None
        if isinstance(fn, type) and issubclass(fn, RewardTerm):
            raise ValueError(f"reward_terms[{name!r}]: give an instance, {fn.__name__}(), not the class")
        if not callable(fn):
            raise ValueError(f"reward_terms[{name!r}] function is not callable")
        try:
            weights[name] = float(w)
            if isinstance(w, (bool, str, bytes)) or not np.isfinite(weights[name]):
                raise ValueError
        except (TypeError, ValueError):
            raise ValueError(f"reward_terms[{name!r}]: the weight must be a finite number, got {w!r}") from None
        own = env_copy(fn, f"reward term {name!r}") if not isinstance(fn, PLAIN_FUNCTIONS) else fn
        terms[name] = own if isinstance(fn, RewardTerm) else FunctionTerm(name, own)
    return terms, weights


PLAIN_FUNCTIONS = (types.FunctionType, types.BuiltinFunctionType, types.MethodType, functools.partial)
"""Reward callables an env uses as given: functions (a closure's state is the caller's), bound methods (their object
is the caller's) and partials. Any other callable object is copied per env, as a :class:`RewardTerm` is, so two envs
given one object do not mix its state."""


def checked_term(name: str, value, shape: tuple[int, int]) -> np.ndarray:
    """A term's value as a ``(B, n)`` float64 array of finite numbers, or a ``ValueError`` naming the term (a custom
    term that returned another shape was broadcast into the reward, or failed far from its cause)."""
    return check_actions(value, shape, f"reward term {name!r} (one number per robot)")


def weighted_sum(terms: Mapping[str, np.ndarray], weights: Mapping[str, float]) -> np.ndarray:
    """``sum(weights[name] * terms[name])`` ``(B, n)`` in the order of ``terms``, skipping zero weights."""
    total = None
    for name, value in terms.items():
        w = weights.get(name, 0.0)
        if w:
            total = w * value if total is None else total + w * value
    if total is None:
        total = np.zeros_like(next(iter(terms.values())))
    return total
