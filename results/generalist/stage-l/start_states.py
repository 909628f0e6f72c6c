"""Stage L prototype: PPO episodes that start from the policy's own pre-contact states.

``collect``: play the training mixture's scenarios that have obstacles with a policy (deterministic)
and keep world states (robot and obstacle arrays and the obstacle motion model's state) 0.5, 1, 1.5, 2
and 2.5 s before each episode's first contact, and as many states again (at least 20) drawn from the
steps where an obstacle would touch an active robot within 1.5 s at current velocities
(``vcs_env.rewards.contact_times``). One pool per scenario, pickled.

``train``: run ``vcs-env train`` with ``Simulator.reset`` patched so that a reset world of a scenario
with a pool starts, with probability ``--p``, from a state of the pool drawn with the world's own
generator (the rest of the world's episode runs as usual). The training's own periodic evaluation
then also starts from pool states: judge the run on validation seeds outside it.

    PYTHONPATH=. python results/generalist/stage-l/start_states.py collect POLICY pools.pkl 400
    PYTHONPATH=. python results/generalist/stage-l/start_states.py train --pools pools.pkl --p 0.5 -- <train args>

A prototype for the issue's record, not part of the package: it patches a private method.
"""

from __future__ import annotations

import argparse
import dataclasses
import pickle
import sys
import time

import numpy as np

import vcs_env.sim as simmod
from vcs_env.rewards import contact_times

MIX = (  # policies/generalist.sh, with the jittered circle-24 entry of its last step
    "circle-8-v0:n_robots=4-12/4,jitter=0.1-0.5/0.2",
    "circle-16-v0:jitter=0.1-0.3/0.2",
    "circle-24-v0",
    "swap-v0:n_robots=6-10/4",
    "crossing-v0:n_robots=8-12/2,jitter=0.1-0.2/0.1",
    "crowd-5-v0:n_obstacles=3-8",
    "crowd-5-v0:obstacle_speed=1.0-1.5",
    "crowd-10-v0:n_obstacles=9-12",
    "crowd-20-v0:n_obstacles=14-22/2",
    "dynamic-v0:n_robots=2-6/2",
    "dynamic-v0:n_obstacles=4-8/2",
    "dynamic-v0:obstacle_speed=0.6-1.2",
    "circle-24-v0:jitter=0.1-0.2/0.1",
)
OFFSETS = (5, 10, 15, 20, 25)
"""Steps before the first contact whose states are kept (dt = 0.1 s)."""
DANGER_TIME = 1.5
"""A state is a danger state when an obstacle would touch an active robot within this [s]."""


def key(scenario) -> str:
    """A scenario's pool key: everything but its reward weights."""
    return repr(dataclasses.replace(scenario, rewards=type(scenario.rewards)()))


def obstacle_contact_time(world) -> np.ndarray:
    """``(B, n)`` time [s] until each robot touches an obstacle at current velocities (inf: never)."""
    return contact_times(world)[:, :, world.n_robots :].min(axis=-1, initial=np.inf)


def snapshot(engine) -> tuple:
    """The engine's world state and obstacle motion state, copied."""
    return engine.world.copy(), {k: v.copy() for k, v in engine.sim.motion_params.items()}


def collect(policy_path: str, out: str, episodes: int) -> None:
    import torch as th

    th.set_num_threads(1)
    from agents.checkpoint import load_model
    from agents.config import ScenarioConfig, mixture_scenarios
    from agents.policies import predictor_controller
    from vcs_env.rollout import Hook
    from vcs_env.rollout import play as play_episodes

    class Recorder(Hook):
        def begin(self, engine, seeds, first):
            self.engine, self.hist = engine, [snapshot(engine)]
            self.first_contact = np.full(engine.batch_size, -1)
            self.danger: list[tuple[int, int]] = []  # (world, state index)

        def step(self, s):
            w = self.engine.world
            new = (s.result.events.collided & s.acting).any(axis=1) & (self.first_contact < 0)
            self.first_contact[new] = s.steps[new]
            danger = ((obstacle_contact_time(w) < DANGER_TIME) & w.active).any(axis=1) & s.running & ~s.finished
            self.hist.append(snapshot(self.engine))
            self.danger += [(b, len(self.hist) - 1) for b in np.flatnonzero(danger & (self.first_contact < 0))]

    scenarios = mixture_scenarios(ScenarioConfig(on_collision="terminate"), MIX)
    control = predictor_controller(load_model(policy_path, scenarios[0]).policy)

    def state(rec, b, i):
        """World ``b`` of state ``i``: its arrays and its obstacle motion state."""
        world, params = rec.hist[i]
        arrays = {f: v[b] for f, v in vars(world).items() if isinstance(v, np.ndarray)}
        return arrays, {f: v[b] for f, v in params.items()}

    pools: dict[str, list] = {}
    rng = np.random.default_rng(0)
    t0 = time.time()
    for g, sc in enumerate(scenarios):
        if sc.n_obstacles == 0:
            continue
        contact, danger = [], []
        for c0 in range(0, episodes, 50):
            first = 80_000 + g * 10_000 + c0
            rec = Recorder()
            play_episodes(sc, control, list(range(first, first + min(50, episodes - c0))), [rec])
            for b in np.flatnonzero(rec.first_contact >= 0):
                T = rec.first_contact[b]  # contact during step T: state T is the one before it
                contact += [state(rec, b, T - k) for k in OFFSETS if T - k >= 1]
            picks = rng.permutation(len(rec.danger))[: max(1, len(rec.danger) // 20)]
            danger += [state(rec, *rec.danger[p]) for p in picks]
        danger = [danger[i] for i in rng.permutation(len(danger))[: max(len(contact), 20)]]
        pools.setdefault(key(sc), []).extend(contact + danger)
        print(
            f"{g} {sc.kind} n={sc.n_robots} m={sc.n_obstacles}: {len(contact)} pre-contact, {len(danger)} danger "
            f"states ({time.time() - t0:.0f} s)",
            flush=True,
        )
    with open(out, "wb") as f:
        pickle.dump(pools, f)


def train(pools_path: str, p: float, args: list[str]) -> int:
    with open(pools_path, "rb") as f:
        pools = pickle.load(f)
    original = simmod.Simulator.reset
    stats = {"fresh": 0, "pool": 0}

    def reset(self, seeds=None, worlds=None):
        w = original(self, seeds, worlds)
        pool = pools.get(key(self.scenario))
        if not pool:
            return w
        for b in range(self.batch_size) if worlds is None else [int(x) for x in worlds]:
            rng = self.rngs[b]
            if rng.random() >= p:
                stats["fresh"] += 1
                continue
            stats["pool"] += 1
            arrays, params = pool[int(rng.integers(len(pool)))]
            for f, v in arrays.items():
                getattr(w, f)[b] = v
            for k, v in params.items():
                self.motion_params[k][b] = v
        return w

    simmod.Simulator.reset = reset
    from vcs_cli import main

    try:
        return main(["train", *args])
    finally:
        print("start states:", stats, flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect")
    c.add_argument("policy")
    c.add_argument("out")
    c.add_argument("episodes", type=int)
    t = sub.add_parser("train")
    t.add_argument("--pools", required=True)
    t.add_argument("--p", type=float, default=0.5)
    t.add_argument("rest", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    if a.cmd == "collect":
        collect(a.policy, a.out, a.episodes)
    else:
        sys.exit(train(a.pools, a.p, [x for x in a.rest if x != "--"]))
