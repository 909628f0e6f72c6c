"""ORCA for pedestrians: the half-planes and the 2D linear program of RVO2, compiled, batched.

A readable rewrite of the agent part of RVO2 2.0.3 (``Agent::computeNewVelocity`` and its
``linearProgram1/2/3``; van den Berg, Guy, Lin and Manocha, "Reciprocal n-body collision
avoidance", ISRR 2009), in float64 and without static obstacles (pedestrians do not see walls).
Each agent gets one half-plane of permitted velocities per neighbour; the new velocity is the
point of their intersection, inside the disc of radius ``max_speed``, closest to the preferred
velocity (``_lp2``); when the half-planes leave nothing, the velocity that violates them least
(``_lp3``). Neighbours are the ``max_neighbors`` nearest within ``neighbor_dist``, nearest first,
as RVO2's kd-tree returns them.

:func:`orca_velocities` steps every world in one call; ``tests/test_pedestrians.py`` holds it
to the RVO2 library (``pyrvo``) on random states.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

EPSILON = 1e-5
"""RVO2's ``RVO_EPSILON``: lines closer to parallel than this are treated as parallel."""


@njit(cache=True, inline="always")
def _det(ax, ay, bx, by):
    """2D cross product ``a x b``."""
    return ax * by - ay * bx


@njit(cache=True)
def _lp1(point, direction, line, radius, opt_x, opt_y, direction_opt, result):
    """Optimum on line ``line`` subject to the lines before it and the speed disc; False if infeasible.

    ``point``, ``direction`` ``(L, 2)``: the lines (permitted side: left of ``direction``);
    ``result`` ``(2,)`` is written in place.
    """
    px, py = point[line, 0], point[line, 1]
    dx, dy = direction[line, 0], direction[line, 1]
    dot = px * dx + py * dy
    disc = dot * dot + radius * radius - (px * px + py * py)
    if disc < 0.0:  # the speed disc misses the line entirely
        return False
    root = math.sqrt(disc)
    t_left, t_right = -dot - root, -dot + root
    for i in range(line):
        denom = _det(dx, dy, direction[i, 0], direction[i, 1])
        numer = _det(direction[i, 0], direction[i, 1], px - point[i, 0], py - point[i, 1])
        if abs(denom) <= EPSILON:  # parallel lines: either all of this one is allowed or none
            if numer < 0.0:
                return False
            continue
        t = numer / denom
        if denom >= 0.0:  # line i bounds this one on the right
            t_right = min(t_right, t)
        else:  # ... on the left
            t_left = max(t_left, t)
        if t_left > t_right:
            return False
    if direction_opt:  # optimise a direction: take the far end along it
        t = t_right if opt_x * dx + opt_y * dy > 0.0 else t_left
    else:  # optimise a point: project it on the line, clamped to the feasible interval
        t = dx * (opt_x - px) + dy * (opt_y - py)
        t = min(max(t, t_left), t_right)
    result[0] = px + t * dx
    result[1] = py + t * dy
    return True


@njit(cache=True)
def _lp2(point, direction, n_lines, radius, opt_x, opt_y, direction_opt, result):
    """The velocity in the speed disc and left of all ``n_lines`` lines closest to ``opt``
    (or farthest along it with ``direction_opt``); returns the first line it failed on
    (``n_lines`` on success). ``result`` ``(2,)`` is written in place."""
    if direction_opt:  # opt is a unit direction
        result[0], result[1] = opt_x * radius, opt_y * radius
    elif opt_x * opt_x + opt_y * opt_y > radius * radius:  # outside the disc: start on its rim
        norm = math.sqrt(opt_x * opt_x + opt_y * opt_y)
        result[0], result[1] = opt_x / norm * radius, opt_y / norm * radius
    else:
        result[0], result[1] = opt_x, opt_y
    for i in range(n_lines):
        if _det(direction[i, 0], direction[i, 1], point[i, 0] - result[0], point[i, 1] - result[1]) > 0.0:
            # The current optimum violates line i: the new optimum lies on line i.
            keep_x, keep_y = result[0], result[1]
            if not _lp1(point, direction, i, radius, opt_x, opt_y, direction_opt, result):
                result[0], result[1] = keep_x, keep_y
                return i
    return n_lines


@njit(cache=True)
def _lp3(point, direction, n_lines, begin, radius, result):
    """Infeasible half-planes: the velocity that minimises the largest violation of lines
    ``begin..n_lines`` (RVO2's ``linearProgram3`` with no obstacle lines)."""
    distance = 0.0
    proj_point = np.empty((n_lines, 2))
    proj_dir = np.empty((n_lines, 2))
    for i in range(begin, n_lines):
        dix, diy = direction[i, 0], direction[i, 1]
        if _det(dix, diy, point[i, 0] - result[0], point[i, 1] - result[1]) <= distance:
            continue  # line i is violated no more than the current worst
        k = 0
        for j in range(i):
            djx, djy = direction[j, 0], direction[j, 1]
            determinant = _det(dix, diy, djx, djy)
            if abs(determinant) <= EPSILON:
                if dix * djx + diy * djy > 0.0:  # same direction: line j adds nothing
                    continue
                # Opposite directions: the bisector between the two lines.
                qx, qy = 0.5 * (point[i, 0] + point[j, 0]), 0.5 * (point[i, 1] + point[j, 1])
            else:  # where lines i and j cross
                s = _det(djx, djy, point[i, 0] - point[j, 0], point[i, 1] - point[j, 1]) / determinant
                qx, qy = point[i, 0] + s * dix, point[i, 1] + s * diy
            ux, uy = djx - dix, djy - diy
            norm = math.sqrt(ux * ux + uy * uy)
            proj_point[k, 0], proj_point[k, 1] = qx, qy
            proj_dir[k, 0], proj_dir[k, 1] = ux / norm, uy / norm
            k += 1
        keep_x, keep_y = result[0], result[1]
        # Farthest point along the inward normal of line i, subject to the projected lines.
        if _lp2(proj_point, proj_dir, k, radius, -diy, dix, True, result) < k:
            result[0], result[1] = keep_x, keep_y  # rounding: keep the last result
        distance = _det(dix, diy, point[i, 0] - result[0], point[i, 1] - result[1])


@njit(cache=True)
def _orca_one(i, pos, vel, radius, max_speed, pref, present, tau, dt, neighbor_dist, max_neighbors, out):
    """New velocity of agent ``i`` of one world (arrays ``(a, ...)``), written to ``out`` ``(2,)``."""
    a = pos.shape[0]
    # Neighbours: the max_neighbors nearest present agents within neighbor_dist, nearest first.
    dist_sq = np.full(a, np.inf)
    for j in range(a):
        if j != i and present[j]:
            d2 = (pos[j, 0] - pos[i, 0]) ** 2 + (pos[j, 1] - pos[i, 1]) ** 2
            if d2 < neighbor_dist * neighbor_dist:
                dist_sq[j] = d2
    order = np.argsort(dist_sq, kind="mergesort")  # stable: ties keep index order
    point = np.empty((a, 2))
    direction = np.empty((a, 2))
    n_lines = 0
    inv_tau = 1.0 / tau
    for k in range(min(a, max_neighbors)):
        j = order[k]
        if not np.isfinite(dist_sq[j]):
            break
        rpx, rpy = pos[j, 0] - pos[i, 0], pos[j, 1] - pos[i, 1]  # relative position
        rvx, rvy = vel[i, 0] - vel[j, 0], vel[i, 1] - vel[j, 1]  # relative velocity
        d2 = rpx * rpx + rpy * rpy
        r = radius[i] + radius[j]
        if d2 > r * r:  # apart: the velocity obstacle is a cone truncated at tau
            wx, wy = rvx - inv_tau * rpx, rvy - inv_tau * rpy  # from the cut-off centre to rel. velocity
            w2 = wx * wx + wy * wy
            dot1 = wx * rpx + wy * rpy
            if dot1 < 0.0 and dot1 * dot1 > r * r * w2:  # closest to the cut-off circle
                wl = math.sqrt(w2)
                ux, uy = wx / wl, wy / wl
                dx, dy = uy, -ux
                scale = r * inv_tau - wl
                u_x, u_y = scale * ux, scale * uy
            else:  # closest to a leg of the cone
                leg = math.sqrt(d2 - r * r)
                if _det(rpx, rpy, wx, wy) > 0.0:  # left leg
                    dx, dy = (rpx * leg - rpy * r) / d2, (rpx * r + rpy * leg) / d2
                else:  # right leg (direction reversed so that the permitted side is on the left)
                    dx, dy = -(rpx * leg + rpy * r) / d2, -(-rpx * r + rpy * leg) / d2
                dot2 = rvx * dx + rvy * dy
                u_x, u_y = dot2 * dx - rvx, dot2 * dy - rvy
        else:  # overlapping: push apart within one step
            inv_dt = 1.0 / dt
            wx, wy = rvx - inv_dt * rpx, rvy - inv_dt * rpy
            wl = math.sqrt(wx * wx + wy * wy)
            ux, uy = wx / wl, wy / wl
            dx, dy = uy, -ux
            scale = r * inv_dt - wl
            u_x, u_y = scale * ux, scale * uy
        # Reciprocity: each agent takes half of the change u.
        point[n_lines, 0], point[n_lines, 1] = vel[i, 0] + 0.5 * u_x, vel[i, 1] + 0.5 * u_y
        direction[n_lines, 0], direction[n_lines, 1] = dx, dy
        n_lines += 1
    fail = _lp2(point, direction, n_lines, max_speed[i], pref[i, 0], pref[i, 1], False, out)
    if fail < n_lines:
        _lp3(point, direction, n_lines, fail, max_speed[i], out)


@njit(cache=True)
def orca_velocities(pos, vel, radius, max_speed, pref, present, n_planning, tau, dt, neighbor_dist, max_neighbors):
    """ORCA velocities of the first ``n_planning`` agents of every world.

    Args:
        pos: ``(B, a, 2)`` agent positions [m] (pedestrians first, then whatever they see).
        vel: ``(B, a, 2)`` current velocities [m/s].
        radius: ``(B, a)`` ORCA radii [m].
        max_speed: ``(B, a)`` [m/s].
        pref: ``(B, a, 2)`` preferred velocities [m/s].
        present: ``(B, a)`` bool, agents that exist (the others are ignored).
        n_planning: agents ``0..n_planning-1`` get a new velocity.
        tau: time horizon [s]; dt: step [s] (used when two agents overlap).
        neighbor_dist: [m]; max_neighbors: most half-planes per agent.

    Returns:
        ``(B, n_planning, 2)`` new velocities [m/s] (0 for absent agents).
    """
    B = pos.shape[0]
    out = np.zeros((B, n_planning, 2))
    for b in range(B):
        for i in range(n_planning):
            if present[b, i]:
                _orca_one(
                    i, pos[b], vel[b], radius[b], max_speed[b], pref[b], present[b], tau, dt,
                    neighbor_dist, max_neighbors, out[b, i],
                )  # fmt: skip
    return out
