"""Stage 0, the period around the search: the robots' memory across periods, the stall and
detour rules (vcs-method §2.13), the symmetry-breaking noise (vcs-method §2.5), and after the
search the residual target and the polar targets (vcs-method §2.15).

These were numpy expressions on ``(B, n)`` arrays; with one world each of them cost more than its
arithmetic, so they run here, one compiled call per stage, robot by robot, with the same
operations in the same order (plans are bit for bit those of the numpy version). Everything that
calls ``sin``, ``cos`` or ``arctan2`` stays in numpy: numpy picks SVML or the C library for
those at run time (``tests/bitwise.py``), numba always the C library.
"""

from __future__ import annotations

import math

from numba import njit

from vcs_env.stall import stall_rules, uniform  # noqa: F401  (one implementation, shared with the clock)

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def wrap_angle(a):
    """:func:`vcs_env.geometry.wrap_angle` of one angle [rad], bit for bit: into (-pi, pi]. Unlike
    :func:`~.scalar.wrap`, an angle already in range goes through the same arithmetic (whose
    rounding can move it by one bit)."""
    a = (a + math.pi) % TWO_PI - math.pi
    return a + TWO_PI if a <= -math.pi else a


@njit(cache=True)
def sync_memory(steps, key, mem_step, mem_key, inp, out):
    """Last period's memory ``out`` becomes this period's ``inp`` in the worlds that advanced one
    step; worlds on a new episode (step 0, a new key) or that jumped clear it; worlds replanning
    the same step keep it. ``mem_step``, ``mem_key`` ``(B,)`` become ``steps``, ``key``."""
    B, n = inp.stall.shape
    for b in range(B):
        fresh = steps[b] == 0 or key[b] != mem_key[b]
        advance = not fresh and steps[b] == mem_step[b] + 1
        same = not fresh and steps[b] == mem_step[b]
        if not same:
            for i in range(n):
                for c in range(2):
                    inp.prev[b, i, c] = out.prev[b, i, c] if advance else 0.0
                inp.has_prev[b, i] = out.has_prev[b, i] if advance else False
                inp.stall[b, i] = out.stall[b, i] if advance else 0.0
                inp.detour[b, i] = out.detour[b, i] if advance else 0.0
                inp.ref[b, i] = out.ref[b, i] if advance else 0.0
                inp.wait[b, i] = out.wait[b, i] if advance else 0.0
                inp.tries[b, i] = out.tries[b, i] if advance else 0.0
        mem_step[b] = steps[b]
        mem_key[b] = key[b]


@njit(cache=True)
def push(pref, v_max, d_goal, r_goal, perturbation, cos_psi, sin_psi, own):
    """Own preferred velocity ``own`` ``(B, n, 2)`` [m/s]: ``pref`` plus the symmetry-breaking
    push of speed ``perturbation v_max`` in direction psi for robots away from their goal."""
    B, n = d_goal.shape
    for b in range(B):
        for i in range(n):
            far = d_goal[b, i] > r_goal
            k = perturbation * v_max[b, i]
            own[b, i, 0] = pref[b, i, 0] + (k * cos_psi[b, i] if far else 0.0)
            own[b, i, 1] = pref[b, i, 1] + (k * sin_psi[b, i] if far else 0.0)


@njit(cache=True)
def finish(world, holo, dt, planned, own, own_angle, out, cap, target, prev_out, has_prev_out, cost, goal_point):
    """After the search: the polar targets ``target`` ``(B, n, 2)`` (speed [m/s], heading [rad];
    robots that are done hold still), the residual of the planned point after this period's
    saturated command (``prev_out``, ``has_prev_out``, for J_h next period), the cost capped at
    ``cap`` and the goal point G = M^-1(own) ``(B, n, 2)`` (``own_angle`` its direction [rad]).

    The heading target is this period's turn (|cmd_dth| < pi), not the planned point: a planned
    half turn dth = -pi wraps to +pi, and the shortest-way turn toward it would go the other way
    round from the one the plan checked (vcs-method §2.15)."""
    B, n = planned.shape
    for b in range(B):
        for i in range(n):
            dv = out.target[b, i, 0]
            dth = out.target[b, i, 1]
            if holo:  # the holonomic command reaches along the velocity change
                cmd_dth = dth
                prev_out[b, i, 0] = 0.0
                prev_out[b, i, 1] = 0.0
            else:
                dv1 = world.a_max[b, i] * dt
                dth1 = world.omega_max[b, i] * dt
                cmd_dv = min(max(dv, -dv1), dv1)
                cmd_dth = min(max(dth, -dth1), dth1)
                prev_out[b, i, 0] = dv - cmd_dv
                prev_out[b, i, 1] = wrap_angle(dth - cmd_dth)
            active = world.active[b, i]
            has_prev_out[b, i] = active and planned[b, i]
            target[b, i, 0] = world.speed[b, i] + dv if active else 0.0
            target[b, i, 1] = wrap_angle(world.heading[b, i] + cmd_dth) if active else world.heading[b, i]
            cost[b, i] = min(out.cost[b, i], cap)
            s = math.sqrt(own[b, i, 0] * own[b, i, 0] + own[b, i, 1] * own[b, i, 1])
            goal_point[b, i, 0] = s - world.speed[b, i]
            goal_point[b, i, 1] = wrap_angle(own_angle[b, i] - world.heading[b, i]) if s > 0.0 else 0.0
