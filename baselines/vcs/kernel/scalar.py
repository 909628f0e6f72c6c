"""Scalar geometry shared by every stage: time to collision, angle wrap, reach steps, one step's reach."""

from __future__ import annotations

import math

from numba import njit

from .records import INF, K_RECIPROCAL, STEP_SLACK, TINY

PLAN_STEPS = 1024
"""The most steps a robot's search counts to cross its velocity space (``K_max``, :func:`crossing_steps`). Its
window, reach steps and ramp checks walk such steps one by one, so a world step far finer than the robot's limits
(``a_max dt`` of 1e-6 m/s) made a decision take seconds to minutes: there the robot's search counts in periods of
several world steps (:func:`planning_steps`, vcs-method §2.10)."""


@njit(cache=True)
def tau(px, py, wx, wy, r):
    """Time to collision (vcs-method §2.2), scalar form of ``vcs_env.geometry.time_to_collision``."""
    c = px * px + py * py - r * r
    if c <= 0.0:
        return 0.0
    a = wx * wx + wy * wy
    b = wx * px + wy * py
    if a <= 0.0 or b <= 0.0:
        return INF
    disc = b * b - a * c
    if disc < 0.0:
        return INF
    return (b - math.sqrt(disc)) / a


@njit(cache=True)
def tau_within(px, py, wx, wy, r, horizon):
    """``tau(p, w, r) <= horizon`` without the square root unless needed (finite tau only)."""
    c = px * px + py * py - r * r
    if c <= 0.0:
        return True
    a = wx * wx + wy * wy
    b = wx * px + wy * py
    if a <= 0.0 or b <= 0.0:
        return False
    disc = b * b - a * c
    if disc < 0.0:
        return False
    if horizon == INF:
        return True
    # (b - sqrt(disc)) / a <= T  <=>  b - a T <= sqrt(disc)
    e = b - a * horizon
    return e <= 0.0 or e * e <= disc


@njit(cache=True)
def wrap(x):
    """Angle into (-pi, pi]: ``(x + pi) % 2 pi - pi``, then (-pi, pi]. Within a turn either side, one
    subtraction or addition of 2 pi gives the remainder's very bits (fmod is exact, and so is
    ``y - 2 pi`` for y in [2 pi, 4 pi); below 0, Python's remainder adds 2 pi to y); the remainder
    stays for angles further out. The search wraps a column's angle difference at every grid
    column: with the remainder in its body this function cost about 9 ns a call, now about 1."""
    if -math.pi < x <= math.pi:
        return x
    turn = 2.0 * math.pi
    y = x + math.pi
    if turn <= y < 2.0 * turn:
        y -= turn
    elif -turn < y < 0.0:
        y += turn
    else:
        y %= turn
    y -= math.pi
    if y <= -math.pi:
        y += turn
    return y


@njit(cache=True)
def steps_for(change, per_step):
    """Steps to make ``change`` at ``per_step`` per step (vcs-method §2.7): ceil(|change| / per_step)."""
    return math.ceil(abs(change) / per_step - STEP_SLACK)


@njit(cache=True)
def reach_steps(dv, dth, dv1, dth1, holo, vrx, vry, th_r, v_r):
    """Steps to reach a VCS point with saturated per-step changes (vcs-method §2.7). Holonomic robots
    change the velocity vector by up to dv1 per step in any direction."""
    if holo:
        s = v_r + dv
        ex = s * math.cos(th_r + dth) - vrx
        ey = s * math.sin(th_r + dth) - vry
        return math.ceil(math.sqrt(ex * ex + ey * ey) / dv1 - STEP_SLACK)
    kv = steps_for(dv, dv1)
    kt = steps_for(dth, dth1)
    k = kv if kv > kt else kt
    return k if k > 0 else 0


@njit(cache=True)
def step_reach(speed, heading, v_max, a_max, omega_max, holo, dt, mx, my):
    """The farthest [m] a robot (``speed`` [m/s], ``heading`` [rad], limits ``v_max``, ``a_max``,
    ``omega_max``) can move along the unit vector ``(mx, my)`` in one step ``dt`` [s], whatever it
    picks (signed: negative when every reachable velocity moves away). A unicycle turns, then
    drives straight at its new speed; a holonomic velocity changes by at most ``a_max dt`` and is
    clipped to ``v_max`` (vcs_env.dynamics)."""
    dv1 = a_max * dt
    if holo:
        x = speed * (math.cos(heading) * mx + math.sin(heading) * my) + dv1
        if x >= 0.0:
            return min(x, v_max) * dt
        if speed + dv1 > v_max:  # clipped back onto the v_max disc: moves away less
            x *= v_max / (speed + dv1)
        return x * dt
    lo = max(speed - dv1, 0.0)
    hi = min(speed + dv1, v_max)
    turn = omega_max * dt
    off = abs(math.atan2(my, mx) - heading) % (2.0 * math.pi)
    off = min(off, 2.0 * math.pi - off)
    c = math.cos(max(off - turn, 0.0))
    return (hi * c if c >= 0.0 else lo * c) * dt


@njit(cache=True)
def split_share(nb, b, n, world, on, holo, dt):
    """The step-split fields of record ``nb`` of world ``b`` (``VCSParams.step_split`` = ``on``; see
    vcs-method §2.15): ``split`` for an active robot (not a twin, not a wall), and ``reach``, its farthest
    one-step advance toward the planning robot [m] (:func:`step_reach`; at least 0 for an arriving robot,
    which may park within the step: no credit for receding)."""
    j = nb.idx
    nb.split = on and not nb.wall and not nb.twin and nb.mover and 0 <= j < n and nb.d > TINY
    nb.reach = 0.0
    if nb.split:
        nb.reach = step_reach(
            world.speed[b, j], world.heading[b, j], world.v_max[b, j], world.a_max[b, j], world.omega_max[b, j],
            holo, dt, -nb.px / nb.d, -nb.py / nb.d,
        )  # fmt: skip
        if nb.kind != K_RECIPROCAL:
            nb.reach = max(nb.reach, 0.0)


@njit(cache=True)
def crossing_steps(v_max, dv1, dth1, holo):
    """``K_max``, the steps to cross the velocity space at per-step changes ``dv1`` [m/s] and ``dth1`` [rad]
    (vcs-method §2.10): to the top speed ``v_max`` [m/s] (twice that for a holonomic robot) or a half turn."""
    if holo:
        return float(max(math.ceil(2.0 * v_max / dv1 - STEP_SLACK), 1.0))
    return float(max(math.ceil(v_max / dv1 - STEP_SLACK), math.ceil(math.pi / dth1 - STEP_SLACK)))


@njit(cache=True)
def planning_steps(v_max, a_max, omega_max, dt, holo):
    """World steps per period of a robot's search (vcs-method §2.10): 1 while it crosses its velocity space in at most
    :data:`PLAN_STEPS` world steps of ``dt`` [s] (at ``a_max`` [m/s^2], ``omega_max`` [rad/s]), else the fewest that
    bring it within them."""
    k = crossing_steps(v_max, a_max * dt, omega_max * dt, holo)
    return 1 if k <= PLAN_STEPS else int(math.ceil(k / PLAN_STEPS))
