"""Start-state pools from a policy's own near misses (``vcs-env collect-states``).

PPO rarely sees the few states from which a policy goes on to touch something, so it learns
little about them. ``collect-states`` plays each scenario of a mixture with a policy
(deterministic actions) and keeps, per scenario (:mod:`vcs_env.start_states`):

* **pre-contact states**: the world ``before`` seconds (default 0.5, 1, ..., 2.5 s) before each
  episode's first contact (states after the first step only);
* **danger states**: a random twentieth of the steps before the first contact at which an
  obstacle would touch an active robot within ``danger_time`` seconds if everything kept its
  velocity (:func:`vcs_env.rewards.contact_times`), capped at the number of pre-contact states
  (at least 20).

``vcs-env train --start-states FILE --start-prob P`` then starts each training world of a scenario
with a pool, with probability P, from one of its states (:class:`vcs_env.start_states.StartStates`).
Scenario ``g`` of the list plays seeds ``seed + 10000 g``, ``seed + 10000 g + 1``, ...

Example (the states before the released generalist's contacts on the dynamic scenarios)::

    vcs-env collect-states --policy policies/generalist --on-collision terminate \\
        --mixture dynamic-v0:n_obstacles=4-8/2 --episodes 400 --out runs/states.npz
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass

import numpy as np

from vcs_env.rewards import contact_times
from vcs_env.rollout import Hook, Step, play
from vcs_env.start_states import StartStates, StatePool, scenario_key

from ..checkpoint import open_checkpoint
from ..config import ScenarioConfig
from ..mixture import scenarios_of
from ..outputs import check_out_file
from ..policies import resolve_policy, sensed_as_trained

DANGER_THIN = 20
"""One in this many danger steps is kept (neighbouring steps are near duplicates)."""
MIN_DANGER = 20
"""Danger states kept per scenario even when the policy made fewer pre-contact states."""
SEED_STRIDE = 10_000
"""Seed distance between the scenarios of a collection (so at most this many episodes each)."""
BATCH = 50
"""Episodes played together."""


@dataclass
class StatesConfig(ScenarioConfig):
    """``vcs-env collect-states``: pools of pre-contact and danger states from a policy."""

    policy: str = "policies/generalist"
    """Checkpoint whose deterministic actions play the episodes (.zip or run directory)."""
    episodes: int = 400
    """Episodes per scenario."""
    seed: int = 80_000
    """First seed; scenario g plays seeds seed + 10000 g on."""
    before: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 2.5)
    """Times before a first contact whose states are kept [s]."""
    danger_time: float = 1.5
    """Keep danger states: an obstacle would touch an active robot within this time [s] (0: none)."""
    mixture: tuple[str, ...] = ()
    """Collect on every scenario of a mixture (the entries of train's --mixture) instead of one."""
    out: str = "runs/start_states.npz"
    """Output file (.npz, vcs_env.start_states)."""


def obstacle_contact_time(world) -> np.ndarray:
    """``(B, n)`` time [s] until each robot touches an obstacle at current velocities (inf: never)."""
    return contact_times(world)[:, :, world.n_robots :].min(axis=-1, initial=np.inf)


class _Recorder(Hook):
    """Keeps every state of a batch, each world's first contact step and its danger steps."""

    def __init__(self, danger_time: float):
        self.danger_time = danger_time

    def begin(self, engine, seeds, first) -> None:
        self.engine = engine
        self.history = [self._snapshot()]  # history[t]: the worlds after t steps
        self.first_contact = np.full(engine.batch_size, -1)  # the step (count before it) of the first contact
        self.danger: list[tuple[int, int]] = []  # (world, history index)

    def _snapshot(self) -> tuple:
        return self.engine.world.copy(), {k: v.copy() for k, v in self.engine.sim.motion_params.items()}

    def step(self, s: Step) -> None:
        w = self.engine.world
        new = (s.result.events.collided & s.acting).any(axis=1) & (self.first_contact < 0)
        self.first_contact[new] = s.steps[new]
        self.history.append(self._snapshot())
        if self.danger_time > 0:
            danger = ((obstacle_contact_time(w) < self.danger_time) & w.active).any(axis=1) & s.running & ~s.finished
            self.danger += [(b, len(self.history) - 1) for b in np.flatnonzero(danger & (self.first_contact < 0))]

    def pool(self, picks: list[tuple[int, int]]) -> list[StatePool]:
        return [StatePool.take(*self.history[i], [b]) for b, i in picks]


def collect_states(cfg: StatesConfig) -> StartStates:
    """Play the scenarios of ``cfg`` with its policy and return their pools (module docstring)."""
    import torch

    torch.set_num_threads(1)
    if not 1 <= cfg.episodes <= SEED_STRIDE:
        raise ValueError(f"episodes must be in [1, {SEED_STRIDE}], got {cfg.episodes}")
    if not cfg.before or not all(math.isfinite(t) and t > 0 for t in cfg.before):
        raise ValueError(f"before must be finite times > 0 [s], got {cfg.before}")
    if not (math.isfinite(cfg.danger_time) and cfg.danger_time >= 0):
        raise ValueError(f"danger_time must be a finite time >= 0 [s], got {cfg.danger_time}")
    check_out_file(cfg.out, "--out", new=True, writable=True)
    scenarios = scenarios_of(cfg, cfg.mixture)
    ckpt = open_checkpoint(cfg.policy)
    sensed = [sensed_as_trained(ckpt, sc, str(cfg.policy)) for sc in scenarios]  # the policy's own sensing
    # As evaluate runs it (any checkpoint format; a residual policy with its planner), without a shield: the states
    # are where the policy itself comes close to a contact.
    with warnings.catch_warnings():  # what the policy cannot sense was said just above
        warnings.simplefilter("ignore")
        control = resolve_policy(ckpt, sensed[0], shield=False).controller
    rng = np.random.default_rng(cfg.seed)
    pools: dict[str, list[StatePool]] = {}
    t0 = time.time()
    for g, sc in enumerate(scenarios):
        offsets = sorted({max(1, round(t / sc.dt)) for t in cfg.before})
        contact: list[StatePool] = []
        danger: list[StatePool] = []
        for c0 in range(0, cfg.episodes, BATCH):
            first = cfg.seed + g * SEED_STRIDE + c0
            rec = _Recorder(cfg.danger_time)
            play(sensed[g], control, list(range(first, first + min(BATCH, cfg.episodes - c0))), [rec])
            hit = np.flatnonzero(rec.first_contact >= 0)
            picks = [(b, int(rec.first_contact[b]) - k) for b in hit for k in offsets]
            contact += rec.pool([(b, i) for b, i in picks if i >= 1])
            keep = rng.permutation(len(rec.danger))[: max(1, len(rec.danger) // DANGER_THIN)] if rec.danger else []
            danger += rec.pool([rec.danger[p] for p in keep])
        danger = [danger[i] for i in rng.permutation(len(danger))[: max(len(contact), MIN_DANGER)]]
        if contact or danger:
            pools.setdefault(scenario_key(sc), []).extend(contact + danger)
        print(
            f"{g} {sc.kind} n={sc.n_robots} m={sc.n_obstacles}: {len(contact)} pre-contact, {len(danger)} danger "
            f"states ({time.time() - t0:.0f} s)",
            flush=True,
        )
    return StartStates({k: StatePool.concat(v) for k, v in pools.items()})
