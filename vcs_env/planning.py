"""The planner protocol the env understands, and the registry of planners by name.

A planner sees the privileged :class:`~vcs_env.state.WorldState` of ``B`` worlds and returns a
*target* per robot: a desired velocity in polar form ``(speed [m/s], heading [rad])``. Every
consumer (expert actions, rollouts, evaluation) turns targets into actions through the same
:func:`~vcs_env.dynamics.target_to_action`, so planners differ by method only.

``vcs_env`` owns the registry but imports no planner: installed packages offer planners through
the entry-point group ``vcs_env.planners`` (``name = "module:factory"`` in their
``pyproject.toml``; this project's ``baselines`` registers ``vcs``, ``vo``, ``rvo``, ``hrvo``,
``orca`` and ``straight`` that way), and code that is not packaged calls
:func:`register_planner`. A factory's module is imported when the planner is first made, so
``expert="vcs"`` costs nothing until it is used.
"""

from __future__ import annotations

import copy
import functools
import warnings
from collections.abc import Callable, Iterator, Mapping
from importlib.metadata import EntryPoint, entry_points

import numpy as np

from .checks import user_stacklevel
from .dynamics import check_actions, target_to_action
from .state import WorldState

ENTRY_POINT_GROUP = "vcs_env.planners"
"""Entry-point group that installed packages fill with planner factories."""


class Planner:
    """Base class of scripted planners (decentralised: each robot plans for itself, but all
    robots of all worlds are planned in one call).

    A plan must depend only on the world state (randomness comes from :mod:`vcs_env.noise`
    keyed by ``world.key`` and ``world.steps``). A planner with memory across steps (e.g.
    hysteresis) must clear it for worlds whose ``steps`` is 0 and give the same answer when
    called twice on the same state.
    """

    name: str = "planner"

    def plan(self, world: WorldState) -> np.ndarray:
        """Targets ``(B, n, 2)`` = (speed [m/s], heading [rad]) for every robot."""
        raise NotImplementedError(f"planner {type(self).__name__} must define plan(world) -> targets (B, n, 2)")

    def plan_for(self, world: WorldState, robots: np.ndarray) -> np.ndarray:
        """Targets ``(B, n, 2)`` as :meth:`plan` gives them, of which the caller reads only the
        rows of ``robots`` ``(n,)`` bool (e.g. not the learner's); a planner may skip the other
        robots (their rows are then unspecified). The plans of the robots read are those of
        :meth:`plan` with the same mask every step (a planner with memory across periods, as the VCS expert, keeps
        none for a robot it did not plan in a period). The default plans every robot."""
        robots_mask(world, robots)
        return self.plan(world)

    def act(self, world: WorldState, action_mode: str = "delta", robots: np.ndarray | None = None) -> np.ndarray:
        """Actions ``(B, n, 2)`` for the env, from :meth:`plan`, or from :meth:`plan_for` when
        only the actions of ``robots`` ``(n,)`` bool are needed. Targets that are not numbers of shape ``(B, n, 2)``,
        or not finite in a row that is read (an active robot's, of ``robots``), are a ``ValueError`` naming the
        planner; rows nobody reads may hold anything (:meth:`plan_for`)."""
        targets = self.plan(world) if robots is None else self.plan_for(world, robots)
        ok = isinstance(targets, np.ndarray) and targets.dtype == np.float64 and targets.shape == world.pos.shape
        if ok and np.isfinite(targets).all():  # what every planner gives: no more to check
            return target_to_action(world, targets, action_mode)
        try:
            arr = np.asarray(targets, dtype=np.float64) if isinstance(targets, (np.ndarray, list, tuple)) else None
        except (TypeError, ValueError):
            arr = None  # not numbers: check_actions names it
        if arr is not None and arr.shape == world.pos.shape:
            read = world.active if robots is None else world.active & robots_mask(world, robots)
            targets = np.where(read[..., None] | np.isfinite(arr), arr, 0.0)
        what = f"the targets of planner {self.name!r} ({type(self).__name__})"
        return target_to_action(world, check_actions(targets, world.pos.shape, what), action_mode)

    def potential(self, world: WorldState) -> np.ndarray:
        """Optional state value estimate ``(B, n)`` used by potential-based shaping."""
        raise NotImplementedError(f"planner {self.name!r} does not provide a potential")


PlannerFactory = Callable[..., Planner]
"""Makes a planner; keyword arguments configure it (``factory(**kwargs) -> Planner``)."""

_REGISTERED: dict[str, PlannerFactory] = {}
"""Planners registered in this process with :func:`register_planner`."""


@functools.cache
def _entry_points() -> dict[str, EntryPoint]:
    """The installed ``vcs_env.planners`` entry points by name, read once per process."""
    found: dict[str, EntryPoint] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in found and found[ep.name].value != ep.value:
            raise ValueError(
                f"planner {ep.name!r} is offered by two installed packages ({found[ep.name].value} and {ep.value}); "
                "uninstall one of them"
            )
        found[ep.name] = ep
    return found


def register_planner(name: str, factory: PlannerFactory) -> PlannerFactory:
    """Register ``factory`` under ``name`` for this process (for code that is not an installed
    package; packages use the ``vcs_env.planners`` entry points). Returns ``factory``, so it
    also works as a class decorator: ``@functools.partial(register_planner, "mine")``.

    Raises:
        ValueError: if ``name`` is not a non-empty string, ``factory`` is not callable, or the
            name is taken.
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"a planner name must be a non-empty string, got {name!r}")
    if not callable(factory):
        raise ValueError(f"the factory of planner {name!r} must be callable, got {type(factory).__name__}")
    if name in PLANNERS:
        raise ValueError(f"planner {name!r} is already registered; pick another name")
    _REGISTERED[name] = factory
    return factory


class _Registry(Mapping[str, PlannerFactory]):
    """Read-only view ``name -> factory`` of the installed and the registered planners."""

    def __getitem__(self, name: str) -> PlannerFactory:
        if name in _REGISTERED:
            return _REGISTERED[name]
        return _entry_points()[name].load()

    def __contains__(self, name: object) -> bool:
        return name in _REGISTERED or name in _entry_points()

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(set(_entry_points()) | set(_REGISTERED)))

    def __len__(self) -> int:
        return len(set(_entry_points()) | set(_REGISTERED))

    def __repr__(self) -> str:
        return f"PLANNERS({', '.join(self)})"


PLANNERS: Mapping[str, PlannerFactory] = _Registry()
"""The one planner registry: name -> factory (keyword arguments go to the planner)."""


def robots_mask(world: WorldState, robots) -> np.ndarray:
    """``robots`` as the ``(n,)`` bool mask of :meth:`Planner.plan_for`, or a ``ValueError`` naming its shape."""
    mask = np.asarray(robots, dtype=bool)
    if mask.shape != (world.n_robots,):
        raise ValueError(f"robots must be a bool mask of shape ({world.n_robots},), got shape {mask.shape}")
    return mask


def make_planner(spec: str | Planner, **kwargs) -> Planner:
    """A planner instance from a registered name (see :data:`PLANNERS`) or as given."""
    if isinstance(spec, Planner):
        if kwargs:
            raise ValueError("planner keyword arguments can only be given with a planner name")
        return spec
    if not isinstance(spec, str):
        raise ValueError(f"a planner must be a name or a vcs_env.planning.Planner, got {type(spec).__name__}")
    if spec not in PLANNERS:
        hint = "" if len(PLANNERS) else " (none: is vcs-env installed, e.g. `pip install -e .`?)"
        raise ValueError(f"unknown planner {spec!r}; registered planners are {list(PLANNERS)}{hint}")
    try:
        planner = PLANNERS[spec](**kwargs)
    except TypeError as e:  # an option the planner does not take: said as bad input, not as a crash
        if not kwargs:
            raise
        raise ValueError(f"planner {spec!r} does not take the options {sorted(kwargs)} ({e})") from None
    if not isinstance(planner, Planner):
        raise ValueError(f"the factory of planner {spec!r} returned a {type(planner).__name__}, not a Planner")
    return planner


def own_planner(spec: str | Planner) -> Planner:
    """:func:`make_planner` for an env: a planner instance given is copied, so that envs never share one (a
    planner keeps memory across periods, per batch of worlds: two envs planning in turn with one instance
    would clear each other's, or mix it at the same seeds, and their episodes would differ from those with a
    planner each)."""
    return env_copy(spec, f"planner {type(spec).__name__}") if isinstance(spec, Planner) else make_planner(spec)


def env_copy(obj, what: str):
    """The env's own copy of ``obj``, a planner or a reward term that may keep state across steps (two envs given one
    object would mix their states); one that cannot be copied (holding a file or a lock, say) is used as it is,
    with a warning naming ``what``."""
    try:
        return copy.deepcopy(obj)
    except Exception as e:  # deepcopy raises what the object's own parts raise (TypeError, PicklingError, ...)
        said = f"{what} cannot be copied ({e}); this env uses the object itself: give every env its own"
        warnings.warn(said, stacklevel=user_stacklevel())
        return obj
