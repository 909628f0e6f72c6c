"""Stage 0, the period around the search: the robots' memory across periods, the stall and
detour rules (vcs-method §2.13), the symmetry-breaking noise (vcs-method §2.5), the obstacles as
the search sees them (movers that turn, the mirror images of bouncing ones, vcs-method §2.4), and
after the search the residual target and the polar targets (vcs-method §2.15).

These were numpy expressions on ``(B, n)`` arrays; with one world each of them cost more than its
arithmetic, so they run here, one compiled call per stage, robot by robot, with the same
operations in the same order (plans are bit for bit those of the numpy version). Everything that
calls ``sin``, ``cos`` or ``arctan2`` stays in numpy: numpy picks SVML or the C library for
those at run time (``tests/bitwise.py``), numba always the C library.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vcs_env.stall import stall_rules, uniform  # noqa: F401  (one implementation, shared with the clock)

from .scalar import planning_steps

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
    the same step keep it. ``mem_step``, ``mem_key`` ``(B,)`` become ``steps``, ``key``. A new
    period's ``out`` starts without a residual (``has_prev``): :func:`finish` gives one to the robots
    it plans, so a robot left out of every plan of the period has none, and one left out of a replan
    of the same period keeps the one its earlier plan gave it."""
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
                out.has_prev[b, i] = False
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
def finish(
    speed,
    heading,
    active,
    a_max,
    omega_max,
    holo,
    dt,
    planned,
    own,
    own_angle,
    out,
    cap,
    target,
    prev_out,
    has_prev_out,
    cost,
    goal_point,
):
    """After the search: the polar targets ``target`` ``(B, n, 2)`` (speed [m/s], heading [rad];
    robots that are done hold still), the residual of the planned point after this period's
    saturated command (``prev_out``, ``has_prev_out``, for J_h next period; of the robots planned
    only, the others' left as they are), the cost capped at
    ``cap`` and the goal point G = M^-1(own) ``(B, n, 2)`` (``own_angle`` its direction [rad]), from
    the robots' speeds [m/s], headings [rad], activity, ``a_max`` [m/s^2] and ``omega_max`` [rad/s]
    ``(B, n)``.

    The heading target is this period's turn (|cmd_dth| < pi), not the planned point: a planned
    half turn dth = -pi wraps to +pi, and the shortest-way turn toward it would go the other way
    round from the one the plan checked (vcs-method §2.15)."""
    B, n = planned.shape
    for b in range(B):
        for i in range(n):
            dv = out.target[b, i, 0]
            dth = out.target[b, i, 1]
            planned_i = planned[b, i]  # a robot not planned keeps its residual (sync_memory)
            if holo:  # the holonomic command reaches along the velocity change
                cmd_dth = dth
                if planned_i:
                    prev_out[b, i, 0] = 0.0
                    prev_out[b, i, 1] = 0.0
            else:
                dv1 = a_max[b, i] * dt
                dth1 = omega_max[b, i] * dt
                cmd_dv = min(max(dv, -dv1), dv1)
                cmd_dth = min(max(dth, -dth1), dth1)
                if planned_i:
                    prev_out[b, i, 0] = dv - cmd_dv
                    prev_out[b, i, 1] = wrap_angle(dth - cmd_dth)
            act = active[b, i]
            if planned_i:
                has_prev_out[b, i] = act
            target[b, i, 0] = speed[b, i] + dv if act else 0.0
            target[b, i, 1] = wrap_angle(heading[b, i] + cmd_dth) if act else heading[b, i]
            cost[b, i] = min(out.cost[b, i], cap)
            s = math.sqrt(own[b, i, 0] * own[b, i, 0] + own[b, i, 1] * own[b, i, 1])
            goal_point[b, i, 0] = s - speed[b, i]
            goal_point[b, i, 1] = wrap_angle(own_angle[b, i] - heading[b, i]) if s > 0.0 else 0.0


@njit(cache=True)
def remember_movers(steps, key, mem_step, mem_key, before, now, has, obs_vel):
    """The obstacles' velocities of the last period seen (``now``) and of the one before
    (``before``), ``(B, m, 2)`` [m/s], in place: a world one step on moves ``now`` into ``before``
    (``has`` ``(B,)``: ``before`` is the period just before); one replanning the same step keeps
    both; any other (a new episode, a jump) has no period before. ``mem_step``, ``mem_key``
    ``(B,)`` become ``steps``, ``key``."""
    B, m = obs_vel.shape[0], obs_vel.shape[1]
    for b in range(B):
        same = key[b] == mem_key[b]
        new = same and steps[b] == mem_step[b] + 1
        again = same and steps[b] == mem_step[b]
        for k in range(m):
            for c in range(2):
                if new:
                    before[b, k, c] = now[b, k, c]
                now[b, k, c] = obs_vel[b, k, c]
        has[b] = new or (again and has[b])
        mem_step[b] = steps[b]
        mem_key[b] = key[b]


@njit(cache=True)
def turn_leads(a0, a1, before, now, has, dt, lead, static_speed, max_turn, out):
    """Each obstacle's turn ``(B, m)`` [rad] to apply ``lead`` [s] ahead: its heading change from
    ``a0`` to ``a1`` [rad] (the directions of its velocities ``before`` and ``now`` ``(B, m, 2)``
    [m/s], one period ``dt`` [s] apart) times ``lead / dt``; 0 where the world has no period before
    (``has`` ``(B,)``), the obstacle was at rest in either (speed not above ``static_speed``) or it
    turned by more than ``max_turn`` [rad] (a jump)."""
    B, m = a0.shape
    scale = lead / dt
    for b in range(B):
        for k in range(m):
            turn = wrap_angle(a1[b, k] - a0[b, k])
            moving = (
                math.hypot(before[b, k, 0], before[b, k, 1]) > static_speed
                and math.hypot(now[b, k, 0], now[b, k, 1]) > static_speed
            )
            smooth = has[b] and moving and abs(turn) <= max_turn
            out[b, k] = turn * scale if smooth else 0.0


@njit(cache=True)
def mover_images(pos, vel, turn, cos_t, sin_t, radius, half, far, out_pos, out_vel, out_r):
    """The obstacles as the search sees them: positions ``pos`` ``(B, m, 2)`` [m] and velocities
    ``vel`` [m/s], with ``turn`` the velocities turned by the angles whose cosines and sines are
    ``cos_t``, ``sin_t`` ``(B, m)`` (``VCSParams.mover_turn_lead``), into ``out_pos``, ``out_vel``
    ``(B, m, 2)`` and ``out_r`` ``(B, m)`` (radii ``radius`` [m]); with arrays of ``4 m`` entries, the
    obstacles' mirror images in the arena's edges at +-``half`` [m] follow them
    (``VCSParams.mirror_bounces``): image q of obstacle k is entry ``q m + k``, its image in x, in
    y and in both (the corner), an axis the obstacle does not move along having its image at
    ``far`` [m] (``baselines.vcs.planner.bounce_images``)."""
    B, m = pos.shape[0], pos.shape[1]
    if m == 0:
        return
    images = out_pos.shape[1] // m
    for b in range(B):
        for k in range(m):
            x, y = vel[b, k, 0], vel[b, k, 1]
            vx, vy = x, y
            if turn:
                vx = cos_t[b, k] * x - sin_t[b, k] * y
                vy = sin_t[b, k] * x + cos_t[b, k] * y
            px, py = pos[b, k, 0], pos[b, k, 1]
            out_pos[b, k, 0], out_pos[b, k, 1] = px, py
            out_vel[b, k, 0], out_vel[b, k, 1] = vx, vy
            out_r[b, k] = radius[b, k]
            if images == 1:
                continue
            reach = half - radius[b, k]
            mx, fx = far, 0.0
            if vx != 0.0:
                mx, fx = 2.0 * ((1.0 if vx > 0.0 else -1.0) * reach) - px, -vx
            my, fy = far, 0.0
            if vy != 0.0:
                my, fy = 2.0 * ((1.0 if vy > 0.0 else -1.0) * reach) - py, -vy
            for q, ix, iy, jx, jy in ((1, mx, py, fx, vy), (2, px, my, vx, fy), (3, mx, my, fx, fy)):
                out_pos[b, q * m + k, 0], out_pos[b, q * m + k, 1] = ix, iy
                out_vel[b, q * m + k, 0], out_vel[b, q * m + k, 1] = jx, jy
                out_r[b, q * m + k] = radius[b, k]


@njit(cache=True)
def robot_planning_steps(v_max, a_max, omega_max, dt, holo):
    """:func:`~.scalar.planning_steps` of every robot ``(B, n)`` (limits ``(B, n)``, ``dt`` [s])."""
    B, n = v_max.shape
    out = np.ones((B, n), dtype=np.int64)
    for b in range(B):
        for i in range(n):
            out[b, i] = planning_steps(v_max[b, i], a_max[b, i], omega_max[b, i], dt, holo)
    return out
