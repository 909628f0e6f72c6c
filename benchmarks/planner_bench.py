"""Planner throughput in robot-decisions per second, every planner on the same world states.

States: a VCS rollout of the scenario (``B_ROLLOUT`` worlds, seeds 0..) recorded at
``n_snapshots`` evenly spaced steps from the start until the robots crowd the centre, so the
states range from sparse to dense. Every contestant plans on exactly these snapshots, cycling
through them (so no planner can answer from a cache of the previous call), and a decision is
one active robot planned once. For ``B = 16`` the rollout's worlds are tiled.

Contestants:

* ``vcs`` - our VCS planner (numba kernel, batched over worlds and robots);
* ``orca`` - ORCA of RVO2 2.0.3 via ``pyrvo`` as our ``orca`` planner drives it (a fresh
  ``RVOSimulator`` per world and step, Python calls per agent);
* ``pyrvo_raw`` - the lower bound of ORCA: the same agents (robots and obstacles, same radius,
  speed, neighbour distance, horizon and preferred velocity) loaded once into one simulator per
  world and snapshot; only ``do_step`` is timed (positions and velocities are restored
  untimed between calls);
* ``vo``, ``hrvo`` - our sampling VO / HRVO planners (numba).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from .peers import require
from .timing import Missing, Step

B_ROLLOUT = 4
"""Worlds in the rollout that produces the snapshots."""
TIME_HORIZON = 5.0
"""ORCA time horizon of the raw pyrvo contestant [s] (the orca planner's default)."""
RADIUS_MARGIN = 0.01
"""ORCA radius margin of planning robots in the raw pyrvo contestant [m] (the orca planner's
default, CrowdNav's)."""


def circle_scenario(n: int):
    """``circle`` with ``n`` robots, 0.1 m start jitter, collisions counted, not ended."""
    from vcs_env.scenario import make_scenario

    return make_scenario("circle", n_robots=n, jitter=0.1, on_collision="continue")


def density_scenario(n: int, r_ca: float = 3.0):
    """``random`` starts and goals at a constant density of one robot per 9 m^2 (arena half size
    ``1.5 sqrt(n)`` [m]) with sensing radius ``r_ca`` [m]: the mean neighbourhood stays the
    same as ``n`` grows."""
    from vcs_env.scenario import make_scenario

    return make_scenario(
        "random", n_robots=n, arena_half_size=1.5 * float(np.sqrt(n)), r_ca=r_ca, on_collision="continue"
    )


def circle_horizon(scenario) -> int:
    """Steps for a robot at full speed to reach the centre of the circle."""
    return int(round(scenario.circle_radius / scenario.robot.v_max / scenario.dt))


def snapshots(scenario, n_snapshots: int, horizon: int, worlds: int = B_ROLLOUT, seed: int = 0) -> list:
    """World states ``(worlds, n)`` of a VCS rollout at ``n_snapshots`` steps in ``[0, horizon]``."""
    from baselines import make_planner
    from vcs_env.engine import NavEngine

    eng = NavEngine(scenario, worlds)
    eng.reset(list(range(seed, seed + worlds)))
    planner = make_planner("vcs")
    keep = set(np.linspace(0, horizon, n_snapshots).round().astype(int).tolist())
    out = []
    for s in range(horizon + 1):
        if s in keep:
            out.append(eng.world.copy())
        if s < horizon:
            eng.step(planner.act(eng.world))
    return out


def tile(world, reps: int):
    """``world`` with its batch repeated ``reps`` times (``B -> reps B``)."""
    arrays = {
        f.name: np.concatenate([getattr(world, f.name)] * reps, axis=0)
        for f in dataclasses.fields(world)
        if isinstance(getattr(world, f.name), np.ndarray)
    }
    return dataclasses.replace(world, **arrays)


def batch(states: Sequence, B: int) -> list:
    """The snapshots as batches of ``B`` worlds (world 0 alone, or tiled rollout worlds)."""
    if B == 1:
        return [w.world(0) for w in states]
    reps = -(-B // states[0].batch_size)
    return [_first(tile(w, reps), B) for w in states]


def _first(world, B: int):
    """The first ``B`` worlds of ``world``."""
    arrays = {
        f.name: getattr(world, f.name)[:B].copy()
        for f in dataclasses.fields(world)
        if isinstance(getattr(world, f.name), np.ndarray)
    }
    return dataclasses.replace(world, **arrays)


def with_r_ca(states: Sequence, r_ca: float) -> list:
    return [dataclasses.replace(w, r_ca=float(r_ca)) for w in states]


def mean_neighbours(states: Sequence) -> float:
    """Mean number of robots and obstacles within ``r_ca`` (centre distance) of an active robot."""
    counts = []
    for w in states:
        d = np.linalg.norm(w.pos[:, :, None] - w.pos[:, None], axis=-1)
        n = w.n_robots
        robots = (d <= w.r_ca) & w.present[:, None, :] & ~np.eye(n, dtype=bool)[None]
        total = robots.sum(-1)
        if w.n_obstacles:
            do = np.linalg.norm(w.pos[:, :, None] - w.obs_pos[:, None], axis=-1)
            total = total + (do <= w.r_ca).sum(-1)
        counts.append(total[w.active])
    c = np.concatenate(counts)
    return float(c.mean()) if c.size else float("nan")


def _cycle(states: Sequence, plan: Callable) -> Step:
    decisions = [int(w.active.sum()) for w in states]
    k = [0]

    def step() -> int:
        k[0] = (k[0] + 1) % len(states)
        plan(states[k[0]])
        return decisions[k[0]]

    return step


def planner_step(name: str, states: Sequence) -> Step:
    """A registered planner (``baselines.PLANNERS``) cycling through ``states``."""
    from baselines import make_planner

    try:
        planner = make_planner(name)
    except ImportError as e:
        raise Missing(str(e)) from None
    return _cycle(states, planner.plan)


def pyrvo_raw_step(states: Sequence) -> Step:
    """Only RVO2's ``do_step`` on the snapshots' agents (module docstring)."""
    rvo = require("pyrvo")
    from baselines.common import preferred_velocity

    loaded = []
    for w in states:
        pref, vel = preferred_velocity(w), w.vel
        n, m = w.n_robots, w.n_obstacles
        sims = []
        for b in range(w.batch_size):
            sim = rvo.RVOSimulator()
            sim.set_time_step(float(w.dt))
            restore = []
            for i in range(n):
                if not w.present[b, i]:
                    continue
                planning = bool(w.active[b, i])
                p = (float(w.pos[b, i, 0]), float(w.pos[b, i, 1]))
                v = (float(vel[b, i, 0]), float(vel[b, i, 1])) if planning else (0.0, 0.0)
                a = sim.add_agent(
                    p,
                    float(w.r_ca) if planning else 0.0,
                    n + m,
                    TIME_HORIZON,
                    TIME_HORIZON,
                    float(w.radius[b, i]) + (RADIUS_MARGIN if planning else 0.0),
                    float(w.v_max[b, i]),
                    v,
                )
                sim.set_agent_pref_velocity(a, (float(pref[b, i, 0]), float(pref[b, i, 1])) if planning else v)
                restore.append((a, p, v))
            for k in range(m):
                p = (float(w.obs_pos[b, k, 0]), float(w.obs_pos[b, k, 1]))
                v = (float(w.obs_vel[b, k, 0]), float(w.obs_vel[b, k, 1]))
                a = sim.add_agent(
                    p, 0.0, n + m, TIME_HORIZON, TIME_HORIZON, float(w.obs_radius[b, k]), float(np.hypot(*v)) + 1e-3, v
                )
                sim.set_agent_pref_velocity(a, v)
                restore.append((a, p, v))
            sims.append((sim, restore))
        loaded.append((sims, int(w.active.sum())))
    k = [0]

    def step() -> tuple[int, float]:
        k[0] = (k[0] + 1) % len(loaded)
        sims, decisions = loaded[k[0]]
        for sim, restore in sims:  # untimed: put everybody back where the snapshot had them
            for a, p, v in restore:
                sim.set_agent_position(a, p)
                sim.set_agent_velocity(a, v)
        # A block of microseconds: perf_counter (cheap; process_time costs ~2 us a call here,
        # as much as a small do_step) rarely includes a preemption over so short a time.
        t0 = time.perf_counter()
        for sim, _ in sims:
            sim.do_step()
        return decisions, time.perf_counter() - t0

    return step


def builders(states: Sequence, names: Sequence[str]) -> dict[str, Callable[[], Step]]:
    out: dict[str, Callable[[], Step]] = {}
    for name in names:
        if name == "pyrvo_raw":
            out[name] = lambda: pyrvo_raw_step(states)
        else:
            out[name] = lambda name=name: planner_step(name, states)
    return out
