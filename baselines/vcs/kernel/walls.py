"""Walls in the VCS kernel (vcs-method §2.18): every wall segment within r_ca is a static body with
full responsibility, one :data:`~.records.NEIGHBOUR` record whose forbidden set is the velocity
obstacle of its capsule (:mod:`baselines.capsule`) instead of a disc's cone.

A wall record keeps the disc fields every stage reads: ``p`` is the nearest point of the segment
(relative to the robot [m]) and ``d`` its distance, so the nearest-surface order, the pruning
bounds, the overlap half-plane (vcs-method §2.4) and the fallback's "closing on a threat" read it
unchanged; ``(ax, ay)``-``(bx, by)`` are the segment's ends relative to the robot [m]. The stages
that compute a time to collision or a gap call :func:`wall_tau` and :func:`wall_gap`.
"""

from __future__ import annotations

import math

from numba import njit

from ...capsule import capsule_tau, segment_range
from .records import INF, K_STATIC


@njit(cache=True)
def wall_tau(nb, wx, wy, r):
    """Time to collision [s] at velocity ``(wx, wy)`` [m/s] with the capsule of radius ``r`` [m]
    around the wall of record ``nb`` (inf: never)."""
    return capsule_tau(nb.ax, nb.ay, nb.bx, nb.by, wx, wy, r)


@njit(cache=True)
def wall_gap(nb, px, py):
    """Distance [m] from the point ``(px, py)`` [m] (relative to the robot now) to the wall of
    record ``nb``."""
    return segment_range(nb.ax - px, nb.ay - py, nb.bx - px, nb.by - py)


@njit(cache=True)
def wall_path_gap(nb, px, py, qx, qy):
    """Distance [m] from the straight path ``(px, py)``-``(qx, qy)`` [m] (relative to the robot
    now) to the wall of record ``nb``: 0 if they cross, else the least of the four end-to-segment
    distances."""
    ax, ay, bx, by = nb.ax, nb.ay, nb.bx, nb.by
    d1 = (qx - px) * (ay - py) - (qy - py) * (ax - px)
    d2 = (qx - px) * (by - py) - (qy - py) * (bx - px)
    d3 = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    d4 = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
    if d1 * d2 < 0.0 and d3 * d4 < 0.0:
        return 0.0
    g = min(segment_range(ax - px, ay - py, bx - px, by - py), segment_range(ax - qx, ay - qy, bx - qx, by - qy))
    return min(g, segment_range(px - ax, py - ay, qx - ax, qy - ay), segment_range(px - bx, py - by, qx - bx, qy - by))


@njit(cache=True)
def brake_gap(nb, px, py, vx, vy, a_max):
    """Distance [m] from the wall of record ``nb`` to the path of a robot at ``(px, py)`` [m]
    (relative to the robot now) moving at ``(vx, vy)`` [m/s] that brakes straight to a stop at
    ``a_max`` [m/s^2] (``s^2 / (2 a_max)`` along its velocity)."""
    f = math.sqrt(vx * vx + vy * vy) / (2.0 * a_max)
    return wall_path_gap(nb, px, py, px + f * vx, py + f * vy)


@njit(cache=True)
def fill_wall(nb, ax, ay, bx, by, k, r0, vrx, vry, a_max_i, p):
    """Fill record ``nb`` with wall ``k`` from ``(ax, ay)`` to ``(bx, by)`` relative to the robot
    [m], for a robot of radius ``r0`` [m] at velocity ``(vrx, vry)`` [m/s] (all but the
    horizon, stage 2). Its buffer is ``delta_min`` only: a wall neither moves nor is uncertain,
    and the regulated buffer would close a door one robot diameter plus 0.2 m wide."""
    ux, uy = bx - ax, by - ay
    length2 = ux * ux + uy * uy
    s = min(max(-(ax * ux + ay * uy) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
    cx, cy = ax + s * ux, ay + s * uy
    d = math.sqrt(cx * cx + cy * cy)
    nb.ax, nb.ay, nb.bx, nb.by = ax, ay, bx, by
    nb.wall = True
    nb.px, nb.py, nb.d, nb.r0 = cx, cy, d, r0
    nb.vjx, nb.vjy, nb.jax, nb.jay, nb.jscale = 0.0, 0.0, 0.0, 0.0, 1.0
    nb.idx = k
    nb.kind = K_STATIC
    nb.mover = False
    nb.twin = False
    nb.stopk = 1.0 / a_max_i if p.stop_margin else 0.0
    nb.tc0 = capsule_tau(ax, ay, bx, by, vrx, vry, r0)
    reff = r0 + p.delta_min
    if d <= reff:
        reff = max(r0, d - p.eps)  # keep the capsule's cone defined while not truly touching
    nb.reff = reff


@njit(cache=True)
def sensed_walls(b, i, world, p, r_ca, vrx, vry, nbs, key, count, first):
    """Append a record for every present wall segment of world b within ``r_ca`` [m] of robot i
    (its nearest point) to ``nbs`` from slot ``count``, with ``key`` its surface distance
    ``d - r_eff`` [m]; record ``idx`` is ``first`` + the segment's index. Returns the new count.
    The cone (or overlap half-plane) is set by the caller (:func:`~.neighbours.set_cone`)."""
    seg_a, seg_b, present = world.seg_a, world.seg_b, world.seg_present
    x, y = world.pos[b, i, 0], world.pos[b, i, 1]
    for k in range(present.shape[1]):
        if not present[b, k]:
            continue
        ax, ay = seg_a[b, k, 0] - x, seg_a[b, k, 1] - y
        bx, by = seg_b[b, k, 0] - x, seg_b[b, k, 1] - y
        if segment_range(ax, ay, bx, by) > r_ca:
            continue
        nb = nbs[count]
        fill_wall(nb, ax, ay, bx, by, first + k, world.radius[b, i], vrx, vry, world.a_max[b, i], p)
        key[count] = nb.d - nb.reff
        count += 1
    return count


@njit(cache=True)
def wall_within(nb, wx, wy, horizon):
    """Does velocity ``(wx, wy)`` [m/s] enter the wall's regulated capsule within ``horizon`` [s]
    (finite times only, as :func:`~.scalar.tau_within`)?"""
    t = wall_tau(nb, wx, wy, nb.reff)
    return t < INF and t <= horizon


@njit(cache=True)
def senses_wall(nbs, count):
    """Is any of the first ``count`` records a wall?"""
    for q in range(count):
        if nbs[q].wall:
            return True
    return False
