"""The per-step work of the simulator compiled with numba: one call per step for all worlds.

One implementation serves ``B = 1`` (the PettingZoo and Gymnasium envs) and ``B > 1`` (the
batched engine): each kernel loops over worlds, then robots, so a world's result never depends
on the others and stepping B worlds together equals stepping them one by one, bit for bit.

The kernels repeat, float operation for float operation, the readable numpy geometry that stays
the test oracle (:mod:`vcs_env.dynamics`, :mod:`vcs_env.geometry`, :func:`vcs_env.observations.sense`);
``tests/test_kernels.py`` checks every kernel against it on random inputs. They give identical
bits except for ``atan2`` (holonomic robots' heading): numba calls the C library, numpy its own
vectorized ``arctan2``, which differ by at most one unit in the last place.

Kernels are compiled on first use and cached on disk (``cache=True``; ``NUMBA_CACHE_DIR`` moves
the cache; :mod:`vcs_env.kernel_cache` clears it when a source changed). The world loop
is a ``prange``: each kernel is compiled serial and parallel over worlds (:mod:`vcs_env.threads`;
results do not depend on the thread count).
"""

from __future__ import annotations

import math
import os

import numpy as np
from numba import njit, prange

from .threads import WORLD_BLOCK, twin_kernel

_PI = np.pi
_TWO_PI = 2.0 * np.pi


@njit(cache=True, inline="always")
def _wrap(a):
    """:func:`vcs_env.geometry.wrap_angle` of one angle [rad]."""
    w = np.mod(a + _PI, _TWO_PI) - _PI
    return w + _TWO_PI if w <= -_PI else w


@njit(cache=True, inline="always")
def _clip(x, lo, hi):
    """``np.clip`` of one number (``minimum(maximum(x, lo), hi)``)."""
    return min(max(x, lo), hi)


@njit(cache=True, inline="always")
def _disc_scale(x, y, radius):
    """The factor of ``dynamics._clip_disc``: scales ``(x, y)`` longer than ``radius`` onto the disc."""
    norm = math.sqrt(x * x + y * y)
    return radius / max(norm, 1e-300) if norm > radius else 1.0


@njit(cache=True, inline="always")
def _closest_approach(sx, sy, ex, ey):
    """:func:`vcs_env.geometry.closest_approach` of one relative motion from ``(sx, sy)`` to ``(ex, ey)`` [m]."""
    dx = ex - sx
    dy = ey - sy
    dd = dx * dx + dy * dy
    s = -(sx * dx + sy * dy) / dd if dd > 0.0 else 0.0
    s = _clip(s, 0.0, 1.0)
    cx = sx + s * dx
    cy = sy + s * dy
    return math.sqrt(cx * cx + cy * cy)


@twin_kernel(cache=True)
def integrate(pos, heading, speed, v_max, a_max, omega_max, acted, actions, dt, holonomic, absolute):
    """New speed ``(B, n)`` [m/s], heading ``(B, n)`` [rad] and position ``(B, n, 2)`` [m] after
    one step of ``actions`` ``(B, n, 2)`` (checked finite), as :func:`vcs_env.dynamics.integrate`
    followed by the simulator's masking: robots that did not act (``acted`` false) keep their
    position and heading and get speed 0."""
    B, n = speed.shape
    new_speed = np.empty((B, n))
    new_heading = np.empty((B, n))
    new_pos = np.empty((B, n, 2))
    for b in prange(B):
        for i in range(n):
            if not acted[b, i]:
                new_speed[b, i] = 0.0
                new_heading[b, i] = heading[b, i]
                new_pos[b, i, 0] = pos[b, i, 0]
                new_pos[b, i, 1] = pos[b, i, 1]
                continue
            a0 = _clip(actions[b, i, 0], -1.0, 1.0)
            a1 = _clip(actions[b, i, 1], -1.0, 1.0)
            dv_max = a_max[b, i] * dt
            h = heading[b, i]
            if holonomic:
                c = math.cos(h)
                s = math.sin(h)
                vx = speed[b, i] * c
                vy = speed[b, i] * s
                f = _disc_scale(a0, a1, 1.0)
                ux = a0 * f
                uy = a1 * f
                if not absolute:
                    # Velocity change in the robot frame, rotated into the world frame.
                    dx = (c * ux - s * uy) * dv_max
                    dy = (s * ux + c * uy) * dv_max
                else:
                    tx = ux * v_max[b, i] - vx
                    ty = uy * v_max[b, i] - vy
                    g = _disc_scale(tx, ty, dv_max)
                    dx = tx * g
                    dy = ty * g
                wx = vx + dx
                wy = vy + dy
                g = _disc_scale(wx, wy, v_max[b, i])
                wx = wx * g
                wy = wy * g
                sp = math.sqrt(wx * wx + wy * wy)
                hd = math.atan2(wy, wx) if sp > 1e-12 else h
            else:
                dth_max = omega_max[b, i] * dt
                if not absolute:
                    dv = a0 * dv_max
                    dth = a1 * dth_max
                else:
                    dv = _clip((a0 + 1.0) * 0.5 * v_max[b, i] - speed[b, i], -dv_max, dv_max)
                    dth = _clip(_wrap(a1 * _PI - h), -dth_max, dth_max)
                sp = _clip(speed[b, i] + dv, 0.0, v_max[b, i])
                hd = _wrap(h + dth)
            new_speed[b, i] = sp
            new_heading[b, i] = hd
            step = sp * dt
            new_pos[b, i, 0] = pos[b, i, 0] + step * math.cos(hd)
            new_pos[b, i, 1] = pos[b, i, 1] + step * math.sin(hd)
    return new_speed, new_heading, new_pos


@twin_kernel(cache=True)
def stop_at_goal(pos, new_pos, goal, acted, r_goal):
    """Arrivals within a step, in place on ``new_pos`` ``(B, n, 2)`` [m]: an acting robot whose straight
    step from ``pos`` passes within ``r_goal`` [m] of its ``goal`` ``(B, n, 2)`` but ends farther stops at
    the point of the step nearest the goal (:func:`vcs_env.dynamics.stop_at_goal`, the oracle).

    Returns ``stopped (B, n)`` (bool): the robots whose step was cut short there.
    """
    B, n = acted.shape
    r2 = r_goal * r_goal
    stopped = np.zeros((B, n), dtype=np.bool_)
    for b in prange(B):  # squared distances, no square root: this runs for every robot at every step
        for i in range(n):
            if not acted[b, i]:
                continue
            sx, sy = pos[b, i, 0] - goal[b, i, 0], pos[b, i, 1] - goal[b, i, 1]
            ex, ey = new_pos[b, i, 0] - goal[b, i, 0], new_pos[b, i, 1] - goal[b, i, 1]
            if ex * ex + ey * ey <= r2:
                continue  # it ends inside the disc
            dx, dy = ex - sx, ey - sy
            along = -(sx * dx + sy * dy)  # the nearest point's fraction of the step, times its squared length
            dd = dx * dx + dy * dy
            if along >= dd:
                continue  # the nearest point is the end, outside
            s = along / dd if along > 0.0 else 0.0
            cx, cy = sx + s * dx, sy + s * dy
            if cx * cx + cy * cy > r2:
                continue
            new_pos[b, i, 0] = pos[b, i, 0] + s * dx
            new_pos[b, i, 1] = pos[b, i, 1] + s * dy
            stopped[b, i] = True
    return stopped


@twin_kernel(cache=True)
def swept_events(pos, new_pos, radius, present, acted, goal, obs_pos, new_obs, obs_radius, r_goal):
    """Swept collision and goal tests of one step (straight motions from ``pos`` to ``new_pos``
    ``(B, n, 2)`` and ``obs_pos`` to ``new_obs`` ``(B, m, 2)`` [m]).

    Returns ``robot_hits (B, n, n)``, ``obstacle_hits (B, n, m)``, ``collided (B, n)``,
    ``reached (B, n)`` (bool), ``min_separation (B, n)``, ``goal_dist_before (B, n)`` and
    ``goal_dist_after (B, n)`` [m], as defined by :class:`vcs_env.sim.StepEvents`.
    """
    B, n = radius.shape
    m = obs_radius.shape[1]
    robot_hits = np.zeros((B, n, n), dtype=np.bool_)
    obstacle_hits = np.zeros((B, n, m), dtype=np.bool_)
    collided = np.zeros((B, n), dtype=np.bool_)
    reached = np.zeros((B, n), dtype=np.bool_)
    min_sep = np.empty((B, n))
    before = np.empty((B, n))
    after = np.empty((B, n))
    for b in prange(B):
        for i in range(n):
            px, py = pos[b, i, 0], pos[b, i, 1]
            qx, qy = new_pos[b, i, 0], new_pos[b, i, 1]
            gx, gy = goal[b, i, 0], goal[b, i, 1]
            bx, by = gx - px, gy - py
            ax, ay = gx - qx, gy - qy
            before[b, i] = math.sqrt(bx * bx + by * by)
            after[b, i] = math.sqrt(ax * ax + ay * ay)
            if not acted[b, i]:
                min_sep[b, i] = np.inf
                continue
            reached[b, i] = _closest_approach(px - gx, py - gy, qx - gx, qy - gy) <= r_goal
            sep = np.inf
            hit = False
            if present[b, i]:
                for j in range(n):
                    if j == i or not present[b, j]:
                        continue
                    gap = _closest_approach(
                        pos[b, j, 0] - px, pos[b, j, 1] - py, new_pos[b, j, 0] - qx, new_pos[b, j, 1] - qy
                    ) - (radius[b, i] + radius[b, j])
                    sep = min(sep, gap)
                    if gap < 0.0:
                        robot_hits[b, i, j] = True
                        hit = True
                for k in range(m):
                    gap = _closest_approach(
                        obs_pos[b, k, 0] - px, obs_pos[b, k, 1] - py, new_obs[b, k, 0] - qx, new_obs[b, k, 1] - qy
                    ) - (radius[b, i] + obs_radius[b, k])
                    sep = min(sep, gap)
                    if gap < 0.0:
                        obstacle_hits[b, i, k] = True
                        hit = True
            collided[b, i] = hit
            min_sep[b, i] = sep
    return robot_hits, obstacle_hits, collided, reached, min_sep, before, after


@njit(cache=True, inline="always")
def _det(ax, ay, bx, by):
    """:func:`vcs_env.geometry.det` of two vectors."""
    return ax * by - ay * bx


@njit(cache=True, inline="always")
def _crossing(px, py, qx, qy, ax, ay, bx, by):
    """:func:`vcs_env.walls.segment_distance`'s crossing test of ``[p, q]`` and ``[a, b]``: each segment's end
    points strictly on both sides of the other's line, and their bounding boxes meet (rounding of the side
    tests of nearly collinear segments far apart along their line can read a crossing)."""
    abx, aby, pqx, pqy = bx - ax, by - ay, qx - px, qy - py
    d1 = _det(abx, aby, px - ax, py - ay)
    d2 = _det(abx, aby, qx - ax, qy - ay)
    d3 = _det(pqx, pqy, ax - px, ay - py)
    d4 = _det(pqx, pqy, bx - px, by - py)
    return (
        d1 * d2 < 0.0
        and d3 * d4 < 0.0
        and max(px, qx) >= min(ax, bx)
        and max(ax, bx) >= min(px, qx)
        and max(py, qy) >= min(ay, by)
        and max(ay, by) >= min(py, qy)
    )


@njit(cache=True)
def _segment_distance(px, py, qx, qy, ax, ay, bx, by):
    """:func:`vcs_env.walls.segment_distance` of the segments ``[p, q]`` and ``[a, b]`` [m]."""
    if _crossing(px, py, qx, qy, ax, ay, bx, by):
        return 0.0  # the segments cross
    e1 = _closest_approach(ax - px, ay - py, bx - px, by - py)
    e2 = _closest_approach(ax - qx, ay - qy, bx - qx, by - qy)
    e3 = _closest_approach(px - ax, py - ay, qx - ax, qy - ay)
    e4 = _closest_approach(px - bx, py - by, qx - bx, qy - by)
    return min(min(e1, e2), min(e3, e4))


@twin_kernel(cache=True)
def observe(
    pos,
    heading,
    speed,
    radius,
    goal,
    v_max,
    a_max,
    omega_max,
    present,
    active,
    obs_pos,
    obs_vel,
    obs_radius,
    r_ca,
    r_goal,
    dt,
    k,
    nb_dim,
    ego_dim,
    goal_ref,
    sense_ref,
    dt_ref,
    v_ref,
    a_ref,
    omega_ref,
    r_ref,
    width,
):
    """Observations ``(B, n, width)`` float32 as documented in :mod:`vcs_env.observations`: the
    first ``ego_dim + nb_dim k`` features of every robot, zeros after them (room for the optional
    blocks, filled by the caller without a copy of the whole array). ``nb_dim`` is 8 (observation
    v1) or 9 (v2: the parked flag, a robot ``present`` but not ``active``).

    The neighbour slots hold the ``k`` sensed objects (robots still in the world, then
    obstacles, whose centres lie within ``r_ca``) with the smallest gap, ties by index (robots
    before obstacles), in the order of :func:`vcs_env.observations.sense`.
    """
    B, n = speed.shape
    m = obs_radius.shape[1]
    total = n + m
    out = np.zeros((B, n, width), dtype=np.float32)
    for blk in prange((B + WORLD_BLOCK - 1) // WORLD_BLOCK):  # scratch arrays per block of worlds
        gaps = np.empty(total)
        order = np.empty(total, dtype=np.int64)
        cos_h, sin_h, vel = np.empty(n), np.empty(n), np.empty((n, 2))
        for b in range(blk * WORLD_BLOCK, min(B, (blk + 1) * WORLD_BLOCK)):
            for i in range(n):  # every robot's frame and velocity, once per world
                cos_h[i] = math.cos(heading[b, i])
                sin_h[i] = math.sin(heading[b, i])
                vel[i, 0] = speed[b, i] * cos_h[i]
                vel[i, 1] = speed[b, i] * sin_h[i]
            for i in range(n):
                c, s = cos_h[i], sin_h[i]
                vx, vy = vel[i, 0], vel[i, 1]
                px, py = pos[b, i, 0], pos[b, i, 1]
                gx, gy = goal[b, i, 0] - px, goal[b, i, 1] - py
                d_goal = math.sqrt(gx * gx + gy * gy)
                o = out[b, i]
                o[0] = _clip(speed[b, i] / v_max[b, i], -1.0, 1.0)
                o[1] = _clip(min(d_goal / goal_ref, 1.0), -1.0, 1.0)
                if d_goal > 1e-12:
                    o[2] = _clip((c * gx + s * gy) / d_goal, -1.0, 1.0)
                    o[3] = _clip((-s * gx + c * gy) / d_goal, -1.0, 1.0)
                else:
                    o[2] = 1.0
                    o[3] = 0.0
                o[4] = _clip(v_max[b, i] / v_ref, -1.0, 1.0)
                o[5] = _clip(a_max[b, i] / a_ref, -1.0, 1.0)
                o[6] = _clip(omega_max[b, i] / omega_ref, -1.0, 1.0)
                o[7] = _clip(radius[b, i] / r_ref, -1.0, 1.0)
                o[8] = _clip(r_ca / sense_ref, -1.0, 1.0)
                o[9] = _clip(r_goal / r_ref, -1.0, 1.0)
                o[10] = _clip(dt / dt_ref, -1.0, 1.0)
                # Sensed objects and their gaps [m], kept sorted by (gap, index): insertion sort,
                # cheap for the few objects within r_ca.
                count = 0
                for j in range(total):
                    if j < n:
                        if j == i or not present[b, j]:
                            continue
                        rx, ry, rj = pos[b, j, 0] - px, pos[b, j, 1] - py, radius[b, j]
                    else:
                        q = j - n
                        rx, ry, rj = obs_pos[b, q, 0] - px, obs_pos[b, q, 1] - py, obs_radius[b, q]
                    dist = math.sqrt(rx * rx + ry * ry)
                    if not dist <= r_ca:
                        continue
                    gap = dist - rj - radius[b, i]
                    t = count
                    while t > 0 and gaps[t - 1] > gap:
                        gaps[t] = gaps[t - 1]
                        order[t] = order[t - 1]
                        t -= 1
                    gaps[t] = gap
                    order[t] = j
                    count += 1
                for t in range(min(k, count)):
                    j = order[t]
                    if j < n:
                        rx, ry = pos[b, j, 0] - px, pos[b, j, 1] - py
                        ux, uy = vel[j, 0], vel[j, 1]
                        rj = radius[b, j]
                    else:
                        q = j - n
                        rx, ry = obs_pos[b, q, 0] - px, obs_pos[b, q, 1] - py
                        ux, uy = obs_vel[b, q, 0], obs_vel[b, q, 1]
                        rj = obs_radius[b, q]
                    wx, wy = ux - vx, uy - vy
                    base = ego_dim + nb_dim * t
                    o[base] = 1.0
                    o[base + 1] = _clip((c * rx + s * ry) / sense_ref, -1.0, 1.0)
                    o[base + 2] = _clip((-s * rx + c * ry) / sense_ref, -1.0, 1.0)
                    o[base + 3] = _clip((c * wx + s * wy) / (2.0 * v_ref), -1.0, 1.0)
                    o[base + 4] = _clip((-s * wx + c * wy) / (2.0 * v_ref), -1.0, 1.0)
                    o[base + 5] = _clip(rj / r_ref, -1.0, 1.0)
                    o[base + 6] = _clip(gaps[t] / sense_ref, -1.0, 1.0)
                    o[base + 7] = 1.0 if j < n else 0.0
                    if nb_dim > 8 and j < n and not active[b, j]:
                        o[base + 8] = 1.0
    return out


@twin_kernel(cache=True)
def arbitrary_velocity(heading, speed, rates, period, t, dt):
    """:class:`vcs_env.obstacles.Arbitrary` motion: turn every obstacle's ``heading`` ``(B, m)``
    [rad] (updated in place) at the rate ``rates`` ``(B, m, P)`` [rad/s] of the period that
    contains time ``t`` ``(B,)`` [s] (periods of ``period`` ``(B, m)`` [s]), and return the
    velocity over the step ``(B, m, 2)`` [m/s] at ``speed`` ``(B, m)`` [m/s]."""
    B, m = heading.shape
    last = rates.shape[2] - 1
    vel = np.empty((B, m, 2))
    for b in prange(B):
        for q in range(m):
            k = min(max(np.int64(math.floor(t[b] / period[b, q] + 1e-9)), 0), last)
            h = heading[b, q] + rates[b, q, k] * dt
            heading[b, q] = h
            vel[b, q, 0] = math.cos(h) * speed[b, q]
            vel[b, q, 1] = math.sin(h) * speed[b, q]
    return vel


@twin_kernel(cache=True)
def bounce(obs_pos, vel, obs_radius, half, dt):
    """Arena walls at ``+-half`` [m]: reverse each velocity component ``(B, m, 2)`` [m/s] that
    would carry its disc through a wall during the step. Returns the new velocities and the
    ``flip`` mask ``(B, m, 2)`` (the motion model is told with ``reflect``)."""
    B, m = obs_radius.shape
    out = np.empty((B, m, 2))
    flip = np.zeros((B, m, 2), dtype=np.bool_)
    for b in prange(B):
        for q in range(m):
            r = obs_radius[b, q]
            for d in range(2):
                v = vel[b, q, d]
                nxt = obs_pos[b, q, d] + v * dt
                f = (nxt + r > half and v > 0) or (nxt - r < -half and v < 0)
                flip[b, q, d] = f
                out[b, q, d] = -v if f else v
    return out, flip


@twin_kernel(cache=True)
def commit(active, present, reached_ever, collided_ever, speed, reached, collided, terminate, park):
    """End of a step, in place on the world's ``(B, n)`` arrays: record the step's ``reached``
    and ``collided`` events; robots that arrived (or crashed, with ``terminate``) stop being
    active and get speed 0 [m/s]; without ``park`` they also leave the world (``present``)."""
    B, n = active.shape
    for b in prange(B):
        for i in range(n):
            reached_ever[b, i] |= reached[b, i]
            collided_ever[b, i] |= collided[b, i]
            stopped = reached[b, i] or (terminate and collided[b, i])
            if stopped:
                active[b, i] = False
                if not park:
                    present[b, i] = False
            if not active[b, i]:
                speed[b, i] = 0.0


# The wall contact kernels (wall_kernels.py) and terminate's stop at first contact (stop_kernels.py)
# build on the helpers above (hence the import here); they are part of this module's interface.
from .stop_kernels import stop_at_contact  # noqa: E402, F401
from .wall_kernels import WALL_REACH, wall_cache, wall_events, wall_events_cached  # noqa: E402, F401


def on_disk(*kernels) -> bool:
    """Whether numba's on-disk cache holds every one of ``kernels`` (``cache=True`` dispatchers)
    already, so that the first call loads it instead of compiling it (which takes tens of
    seconds for the whole simulator and planner). An index file written for older sources counts
    as present: the first call then still recompiles."""
    for kernel in kernels:
        kernel = getattr(kernel, "serial", kernel)  # a TwinKernel: its serial twin (the B = 1 envs')
        index = getattr(getattr(getattr(kernel, "_cache", None), "_cache_file", None), "_index_path", None)
        if index is None or not os.path.exists(index):
            return False
    return True
