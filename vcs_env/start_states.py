"""Start-state pools: episodes that begin from saved world states instead of fresh layouts.

A :class:`StatePool` holds K snapshots of single worlds of one scenario: every per-world array of
:class:`~vcs_env.state.WorldState` (time, step count and random key included; not the stall clock) and the
obstacle motion model's per-world state. A :class:`~vcs_env.sim.Simulator` given :class:`StartStates` starts
each world it resets, with probability ``prob``, from a state of its scenario's pool drawn with that
world's own generator (after the fresh layout was drawn, so the world's random stream does not
depend on the pool's contents); the episode then runs as usual from there: a restored world's bodies,
obstacles and random draws continue exactly as those of the world it was taken from, and its time and step
count go on from the snapshot, so it ends at the original time limit. What remembers the past starts afresh,
as at a reset: the stall clock (:mod:`vcs_env.stall`: its observation block and the ``stuck`` reward) and an
expert's own memory (the VCS planner's last periods and movers), so these, and the expert's actions, may differ
from the original world's after the restore.

Training uses this to make rare situations frequent, e.g. the moments before a policy's contacts
(:mod:`agents.train.collect_states`, ``vcs-env collect-states`` and ``vcs-env train --start-states``).
Evaluation never does.

Pools are keyed by :func:`scenario_key` (the scenario without its reward weights), so one file can
serve a whole training mixture; scenarios without a pool start fresh every time.

File format (``.npz``, loadable without pickle): ``scenarios`` ``(S,)`` str, the keys; for pool
``s``, ``{s}/world/{field}`` ``(K, ...)`` the world arrays and ``{s}/motion/{name}`` ``(K, ...)``
the motion state; ``command`` (a str, optional) the command that made it (:attr:`StartStates.command`).
"""

from __future__ import annotations

import dataclasses
import re
import zipfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .files import replacing
from .observations import SENSOR_FIELDS
from .scenario import RewardWeights, Scenario
from .state import WorldState

_REWARDS = re.compile(r", rewards=RewardWeights\([^)]*\)")
"""The reward weights in a scenario's repr (keys of files written before they were left out)."""
_SENSORS = re.compile(rf", (?:{'|'.join(SENSOR_FIELDS)})=[^,()]*")
"""The sensing fields at their defaults in a scenario's repr: left out of the keys, so that a sensing field added
later (``wall_segments``) leaves the keys of files written before it as they were."""


def scenario_key(scenario: Scenario) -> str:
    """The key of a scenario's pool: its repr without the reward weights and with the default sensing
    (a pool serves any reward, reward terms added later and any observation, not another layout,
    robot, obstacle or episode setting)."""
    defaults = {f.name: f.default for f in dataclasses.fields(Scenario) if f.name in SENSOR_FIELDS}
    # Default rewards too: a term that needs a sensor (stuck: the stall clock) must not outlive it.
    return _key(repr(dataclasses.replace(scenario, rewards=RewardWeights(), **defaults)))


def _key(text: str) -> str:
    """A scenario's repr without its reward weights and its sensing fields (:func:`scenario_key`)."""
    return _SENSORS.sub("", _REWARDS.sub("", text))


@dataclass
class StatePool:
    """K saved single-world states of one scenario.

    Attributes:
        world: ``{field: (K, ...)}`` the per-world arrays of :class:`~vcs_env.state.WorldState`.
        motion: ``{name: (K, ...)}`` the obstacle motion model's per-world state
            (``Simulator.motion_params``).
    """

    world: dict[str, np.ndarray]
    motion: dict[str, np.ndarray]

    def __post_init__(self) -> None:
        sizes = {len(v) for v in (*self.world.values(), *self.motion.values())}
        if len(sizes) > 1:
            raise ValueError(f"a state pool's arrays must all hold the same number of states, got {sorted(sizes)}")

    def __len__(self) -> int:
        return len(next(iter(self.world.values()))) if self.world else 0

    @classmethod
    def take(cls, world: WorldState, motion: Mapping[str, np.ndarray], worlds: Iterable[int]) -> StatePool:
        """The current states of ``worlds`` (indices into the batch) of a batched world state and
        its motion state, copied."""
        idx = np.asarray(list(worlds), dtype=np.int64)
        return cls(
            {f: v[idx].copy() for f, v in world.saved_arrays().items()},
            {k: np.asarray(v)[idx].copy() for k, v in motion.items()},
        )

    @classmethod
    def concat(cls, pools: Iterable[StatePool]) -> StatePool:
        """One pool with the states of ``pools`` in order (all of one scenario)."""
        pools = [p for p in pools if len(p)]
        if not pools:
            raise ValueError("nothing to concatenate: every pool is empty")
        return cls(
            {f: np.concatenate([p.world[f] for p in pools]) for f in pools[0].world},
            {k: np.concatenate([p.motion[k] for p in pools]) for k in pools[0].motion},
        )

    def check(self, world: WorldState, name: str) -> None:
        """A ``ValueError`` naming ``name`` unless the pool's world arrays fit a world state of
        that scenario (``world``, batch first)."""
        arrays = world.saved_arrays()
        if set(self.world) != set(arrays):
            raise ValueError(
                f"the start-state pool of {name} has world fields {sorted(self.world)}, expected {sorted(arrays)}"
            )
        for f, v in self.world.items():
            if v.shape[1:] != arrays[f].shape[1:] or v.dtype != arrays[f].dtype:
                raise ValueError(
                    f"the start-state pool of {name} has {f} of shape {v.shape[1:]} ({v.dtype}) per state, the "
                    f"scenario needs {arrays[f].shape[1:]} ({arrays[f].dtype}) (a pool of another robot, obstacle "
                    "or wall count?)"
                )


def npz_path(path: str | Path) -> Path:
    """``path`` with ``.npz`` added unless it ends so: the file numpy's ``savez`` writes for it."""
    path = Path(path)
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def saved_npz(path: str | Path) -> Path:
    """The file a ``.npz`` written as ``path`` is in: ``path`` itself if it is a file, else :func:`npz_path` of it if
    that one is (a name given without ``.npz``), else ``path`` (for the caller's missing-file message)."""
    path = Path(path)
    return npz_path(path) if not path.is_file() and npz_path(path).is_file() else path


@dataclass
class StartStates:
    """Pools per scenario and the probability that a reset world starts from one.

    Attributes:
        pools: ``{scenario_key(scenario): pool}``.
        prob: probability in [0, 1] that a reset world of a scenario with a pool starts from a
            state of it.
        command: the command that made the pools (``vcs-env collect-states ...``), kept in the file; None: not
            known.
    """

    pools: dict[str, StatePool]
    prob: float = 0.5
    command: str | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= float(self.prob) <= 1.0:
            raise ValueError(f"the start-state probability must be in [0, 1], got {self.prob}")
        self.prob = float(self.prob)

    def pool(self, scenario: Scenario) -> StatePool | None:
        """The pool of ``scenario`` (None: it starts fresh)."""
        return self.pools.get(scenario_key(scenario))

    def matching(self, scenarios: Iterable[Scenario]) -> list[Scenario]:
        """The scenarios of ``scenarios`` that have a non-empty pool."""
        return [s for s in scenarios if self.pool(s) is not None and len(self.pool(s)) > 0]

    def save(self, path: str | Path) -> Path:
        """Write the pools as ``.npz`` (module docstring); returns the path written: ``.npz`` is added to a name
        without it, as numpy and the datasets of ``vcs-env collect`` do (:meth:`load` finds it either way)."""
        keys = list(self.pools)
        arrays = {"scenarios": np.array(keys, dtype=str)}
        if self.command is not None:
            arrays["command"] = np.array(self.command, dtype=str)
        for s, k in enumerate(keys):
            arrays |= {f"{s}/world/{f}": v for f, v in self.pools[k].world.items()}
            arrays |= {f"{s}/motion/{f}": v for f, v in self.pools[k].motion.items()}
        path = npz_path(path)
        with replacing(path) as part, open(part, "wb") as f:
            np.savez_compressed(f, **arrays)
        return path

    @classmethod
    def load(cls, path: str | Path, prob: float = 0.5) -> StartStates:
        """Read pools written by :meth:`save` (``path``, or ``path`` with ``.npz`` added, as :meth:`save` writes a name
        without it).

        Raises:
            ValueError: no such file, or a file that is not a readable start-state ``.npz``
                (both named).
        """
        path = saved_npz(path)
        if not path.is_file():
            raise ValueError(f"no start-state file {str(path)!r} (make one with vcs-env collect-states)")
        if not zipfile.is_zipfile(path):  # numpy would try it as a pickle and say how to load that unsafely
            raise ValueError(
                f"{str(path)!r} is not a .npz start-state file (no zip archive; make one with vcs-env collect-states)"
            )
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
        except Exception as e:  # empty, truncated, pickled or not an npz at all
            raise ValueError(
                f"{str(path)!r} is not a readable .npz start-state file: {type(e).__name__}: {e}"
            ) from None
        if "scenarios" not in arrays:
            raise ValueError(f"{str(path)!r} is not a start-state file (no 'scenarios' entry)")
        pools = {}
        for s, key in enumerate(_key(k) for k in arrays["scenarios"].tolist()):
            parts = {"world": {}, "motion": {}}
            for name, value in arrays.items():
                head, _, rest = name.partition("/")
                if head == str(s):
                    kind, _, field = rest.partition("/")
                    parts[kind][field] = value
            pools[key] = StatePool(parts["world"], parts["motion"])
        return cls(pools, prob, str(arrays["command"]) if "command" in arrays else None)
