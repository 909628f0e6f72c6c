"""The stall clock: how long each robot has been stuck, and the detour the stall rule gives it.

The VCS expert frees deadlocks with a rule that needs memory (vcs-method §2.13): a robot slower than
``STALL_SPEED v_max`` for ``STALL_TIME`` [s] away from its goal, or one that has not come
``STALL_SPEED v_max PROGRESS_WINDOW`` [m] closer to its goal (along its route among walls) over
``PROGRESS_WINDOW`` [s], detours for ``DETOUR_TIME`` [s] (among walls times a factor in
``[1 - DETOUR_JITTER, 1 + DETOUR_JITTER]`` from the world's counter-based noise). Without that memory
the expert deadlocks where the maps need it (every episode of ``door-headon-v0`` and
``intersection-v0``, ``docs/training.md``), and so does a policy that sees one observation.

:func:`stall_rules` is that rule, one implementation: the expert runs it on its own memory every
period (:mod:`baselines.vcs.kernel.period`), and the simulator runs it on each robot's own motion
when a scenario keeps the clock (``Scenario.stall_clock``, a sensing field: it changes what robots
observe, never the episode), so the observation's ``clock`` block (:mod:`vcs_env.observations`) tells
a policy what the expert's memory tells the expert. The clock ``(B, n, CLOCK_DIM)`` of a world
state (:attr:`vcs_env.state.WorldState.clock`) holds, per robot, after the rule has run on the
current state: the time stalled [s], the detour time left [s], the goal (route) distance at the last
progress mark [m] (0: unset), the time since that mark [s], the detours begun since the robot last
made progress, and whether it detours in this state (0 or 1).
"""

from __future__ import annotations

import dataclasses
import math
from collections import namedtuple

import numpy as np
from numba import njit

STALL_SPEED = 0.05
"""A robot slower than this fraction of its v_max is at rest."""
STALL_TIME = 1.0
"""At rest this long [s], away from its goal, a robot is stalled."""
PROGRESS_WINDOW = 5.0
"""Not ``STALL_SPEED v_max PROGRESS_WINDOW`` [m] closer to its goal over this long [s]: stalled too."""
DETOUR_TIME = 2.0
"""A stall starts a detour of this long [s]."""
DETOUR_JITTER = 0.5
"""Among walls a detour lasts ``DETOUR_TIME`` times a factor in ``[1 - DETOUR_JITTER, 1 + DETOUR_JITTER]``."""
CLOCK_FIELDS = ("stall", "detour", "ref", "wait", "tries", "detouring")
"""The fields of a robot's clock (module docstring)."""
CLOCK_DIM = len(CLOCK_FIELDS)

Rules = namedtuple(
    "Rules",
    "dt r_goal stall_goal_margin stall_speed stall_time progress_window detour_time detour_jitter jitter_walls",
)
"""The stall and detour rules (:func:`stall_rules`): period [s], arrival radius [m], the margin beyond it
[m], the fractions and times above, and whether detours are jittered (walls, ``detour_jitter > 0``)."""
Memory = namedtuple("Memory", "stall detour ref wait tries")
"""What the rule remembers per robot ``(B, n)`` (the clock's first five fields)."""

CLOCK_BLOCK_FIELDS = ("detouring", "detour_left", "stalled", "no_progress", "tries")
"""Fields of the ``clock`` block (:func:`clock_block`)."""
CLOCK_REF = 5.0
"""Time that reads 1 in the ``clock`` block [s] (the expert's progress window, twice its detour)."""
TRIES_REF = 4.0
"""Detours without progress that read 1 in the ``clock`` block."""

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
TWO_PI = 2.0 * math.pi


@njit(cache=True)
def uniform(key, step, i, stream):
    """:func:`vcs_env.noise.uniform` of world key ``key``, step ``step``, robot ``i`` and
    ``stream``, one number in [0, 1) (the same splitmix64 bits)."""
    counter = np.uint64(step) * np.uint64(1 << 20) + np.uint64(i) * np.uint64(64) + np.uint64(stream)
    z = key + (counter + np.uint64(1)) * _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    z = z ^ (z >> np.uint64(31))
    return np.float64(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def stall_rules(key, steps, speed, v_max, active, rules, d_goal, inp, out, psi, detour):
    """The stall and detour rules of every robot (vcs-method §2.13) into ``out`` (the memory for
    the next period), ``detour`` ``(B, n)`` (the robot detours this period) and ``psi`` ``(B, n)``
    [rad] (the direction of the expert's symmetry-breaking push, vcs-method §2.5).

    After ``stall_time`` [s] slow and away from the goal, or after ``progress_window`` [s] without
    gaining ``stall_speed v_max progress_window`` [m] on the goal (whatever the speed), a robot
    detours for ``detour_time`` [s] (times a factor in [1 - jitter, 1 + jitter] among walls, so
    that a head-on pair in a door comes back one after the other). ``rules`` is a :data:`Rules`,
    ``key``, ``steps`` ``(B,)`` the worlds' noise keys and step counts, ``speed`` [m/s], ``v_max``
    [m/s], ``active`` and ``d_goal`` (the goal or route distance [m]) ``(B, n)``; ``inp`` and
    ``out`` have the fields of :data:`Memory` ``(B, n)``."""
    rl = rules
    B, n = d_goal.shape
    dt = rl.dt
    for b in range(B):
        for i in range(n):
            psi[b, i] = TWO_PI * uniform(key[b], steps[b], i, 1)
            dg = d_goal[b, i]
            away = dg > rl.r_goal + rl.stall_goal_margin and active[b, i]
            stalled = speed[b, i] < rl.stall_speed * v_max[b, i] and away
            ref = inp.ref[b, i] if inp.ref[b, i] > 0 else dg
            progressed = ref - dg >= rl.stall_speed * v_max[b, i] * rl.progress_window
            wait = 0.0 if progressed else inp.wait[b, i] + dt
            no_progress = away and rl.progress_window > 0 and wait >= rl.progress_window - 1e-9
            # Slow over this period and the ones before for stall_time; at least two states at rest (a robot at rest
            # in its first state has not stalled yet: a step of dt >= stall_time detoured every robot at its reset).
            slow = stalled and inp.stall[b, i] > 0.0 and inp.stall[b, i] + dt >= rl.stall_time - 1e-9
            start = inp.detour[b, i] <= 0 and (slow or no_progress)
            detour[b, i] = inp.detour[b, i] > 0 or start
            if start:
                length = rl.detour_time
                if rl.jitter_walls:
                    length = rl.detour_time * (1.0 + rl.detour_jitter * (2.0 * uniform(key[b], steps[b], i, 2) - 1.0))
                out.detour[b, i] = length - dt
            else:
                out.detour[b, i] = inp.detour[b, i] - dt if detour[b, i] else 0.0
            out.stall[b, i] = inp.stall[b, i] + dt if stalled and not detour[b, i] else 0.0
            mark = progressed or start  # a new progress mark: progress made, or a detour begins
            out.ref[b, i] = dg if mark else ref
            out.wait[b, i] = 0.0 if mark else wait
            out.tries[b, i] = 0.0 if progressed else inp.tries[b, i] + (1.0 if start else 0.0)


def goal_distances(world) -> np.ndarray:
    """Each robot's distance to its goal ``(B, n)`` [m]: along its route among walls
    (:func:`vcs_env.routes.route_direction`), straight without (as the expert measures progress)."""
    if world.n_segments:
        from .routes import route_direction

        return route_direction(world)[1]
    e = world.goal - world.pos
    return np.sqrt(e[..., 0] * e[..., 0] + e[..., 1] * e[..., 1])


def tick(world, worlds=None) -> None:
    """Run the stall rule (the default constants above) on the current state of ``worlds`` (default
    all) of ``world``: their clocks become the memory after this state (module docstring). The
    simulator calls it after every reset (on cleared clocks) and step; ``world.clock`` must be set."""
    idx = slice(None) if worlds is None else np.asarray(worlds, dtype=np.int64)
    clock = world.clock
    sub = clock[idx]
    B, n = sub.shape[:2]
    if B == 0:
        return
    # Route distances of the ticked worlds only (a reset of a few worlds must not route them all).
    ticked = world if worlds is None else dataclasses.replace(world, **{f: v[idx] for f, v in world.arrays().items()})
    d_goal = np.ascontiguousarray(goal_distances(ticked))
    rules = Rules(
        float(world.dt), float(world.r_goal), 0.0, STALL_SPEED, STALL_TIME, PROGRESS_WINDOW, DETOUR_TIME,
        DETOUR_JITTER, bool(world.n_segments),
    )  # fmt: skip
    out = np.zeros((B, n, CLOCK_DIM))
    detour = np.empty((B, n), dtype=bool)
    stall_rules(
        world.key[idx], world.steps[idx], world.speed[idx], world.v_max[idx], world.active[idx], rules, d_goal,
        Memory(*(sub[..., k] for k in range(5))), Memory(*(out[..., k] for k in range(5))), np.empty((B, n)), detour,
    )  # fmt: skip
    out[..., 5] = detour
    clock[idx] = out


def clock_block(world) -> np.ndarray:
    """The ``clock`` block ``(B, n, 5)`` float32 of :data:`CLOCK_BLOCK_FIELDS` from the world's stall clock
    (:mod:`vcs_env.stall`): detouring (0 or 1), the detour time left, the time stalled and the time
    since the last progress mark, each / ``CLOCK_REF`` [s] and clipped to [0, 1], and the detours
    begun since the robot last made progress / ``TRIES_REF``, clipped to [0, 1]."""
    if world.clock is None:
        raise ValueError(
            "the scenario observes the stall clock (stall_clock=True) but this world state keeps none: make it "
            "with a Simulator (or env) of that scenario"
        )
    c = world.clock
    block = np.stack(
        (c[..., 5], c[..., 1] / CLOCK_REF, c[..., 0] / CLOCK_REF, c[..., 3] / CLOCK_REF, c[..., 4] / TRIES_REF), axis=-1
    )
    return np.clip(block, 0.0, 1.0).astype(np.float32)
