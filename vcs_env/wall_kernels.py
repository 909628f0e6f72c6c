"""The swept wall contact kernel of the simulator (numba), with its per-robot cache of wall
candidates; part of :mod:`vcs_env.kernels` (imported there), split off for size.

The oracle is :func:`vcs_env.walls.reference_wall_events`; results equal it bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .kernels import _clip, _closest_approach, _crossing
from .threads import WORLD_BLOCK, twin_kernel


@njit(cache=True, inline="always")
def _swept_wall_distance(px, py, qx, qy, ax, ay, bx, by, mx, my, h):
    """:func:`vcs_env.kernels._segment_distance` of the motion ``[p, q]`` (midpoint ``m``, half
    length ``h``) and the wall ``[a, b]`` [m], bit for bit, without the distance of a wall end
    point to the motion when it cannot be the smallest: it is at least the end point's distance
    to ``m`` minus ``h``, and the smaller of the motion end points' distances to the wall is
    known first."""
    if _crossing(px, py, qx, qy, ax, ay, bx, by):
        return 0.0  # the segments cross
    e = min(
        _closest_approach(ax - px, ay - py, bx - px, by - py), _closest_approach(ax - qx, ay - qy, bx - qx, by - qy)
    )
    far = e + h + 1e-9  # an end point farther than this from m is farther than e from the motion
    if (ax - mx) * (ax - mx) + (ay - my) * (ay - my) <= far * far:
        e = min(e, _closest_approach(px - ax, py - ay, qx - ax, qy - ay))
    if (bx - mx) * (bx - mx) + (by - my) * (by - my) <= far * far:
        e = min(e, _closest_approach(px - bx, py - by, qx - bx, qy - by))
    return e


WALL_REACH = 0.5
"""Radius [m] of the ball around a robot's reference point that its wall candidates cover
(:func:`wall_events_cached`): a robot re-scans all segments when it leaves the ball. A speed
knob only (larger: fewer re-scans, more candidates); the results do not depend on it."""


def wall_cache(B, n, s):
    """An empty (all invalid) cache of :func:`wall_events_cached` for ``B`` worlds of ``n``
    robots and ``s`` segments: ``(ball (B, n, 4), order (B, n, s), dist (B, n, s), count (B, n))``."""
    ball = np.zeros((B, n, 4))
    ball[:, :, 2] = -1.0
    return ball, np.zeros((B, n, s), dtype=np.int32), np.zeros((B, n, s)), np.zeros((B, n), dtype=np.int64)


def wall_events(pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided):
    """Swept wall contacts of one step, as :func:`vcs_env.walls.reference_wall_events`:
    ``wall_hits (B, n, s)`` bool, ``sep`` ``(B, n)`` [m] (the smallest gap so far, e.g. to
    robots and obstacles) lowered to the smallest gap to a wall, and ``collided`` ``(B, n)``
    (contacts so far) or a wall contact, for the straight motions from
    ``pos`` to ``new_pos`` ``(B, n, 2)`` [m] against the segments ``seg_a -> seg_b`` ``(B, s, 2)``
    [m] (``seg_present`` ``(B, s)``): :func:`wall_events_cached` with an empty cache."""
    cache = wall_cache(*radius.shape, seg_present.shape[1])
    return wall_events_cached(
        pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided, *cache, WALL_REACH
    )


@twin_kernel(cache=True)
def wall_events_cached(
    pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided, ball, order, dist, count, reach
):
    """:func:`wall_events` with a per-robot cache of wall candidates that persists from step to
    step (walls are static between resets), updated in place: the cache of :func:`wall_cache`.

    A robot's cache is a reference point ``c`` (the midpoint of the motion it was built on), a
    radius ``R`` [m] (``ball[b, i] = (cx, cy, R, radius)``, ``R < 0``: no cache) and its
    candidates: the present segments ``k`` whose distance ``d_k`` from ``c`` is at most
    ``max(d_min + 2 R, radius + R)``, sorted by ``d_k`` (``order``, ``dist``, ``count``). While the
    step's motion stays in the ball of radius ``R`` around ``c`` (and the robot's radius has not
    grown), no other segment can touch the robot or be the nearest: the swept distance to
    segment ``k`` lies within ``d_k +- R`` (distance is 1-Lipschitz), so a non-candidate is
    farther than ``radius`` and than the segment nearest ``c``. A robot outside its ball scans
    all segments and builds a new ball (``R = max(reach, half its step)``) at its motion's
    midpoint.

    Narrow phase, exact: candidates are taken nearest ``c`` first, and the scan stops at the
    first whose lower bound on the gap ``d_k - |motion - c| - radius`` is above both 0 and the
    smallest gap found so far (``sep`` at first): the later ones, farther from ``c``, can then
    neither touch the robot nor lower ``sep``. A candidate whose bound by the distance from the
    motion's midpoint (minus half the motion's length) is as high is skipped; the others get
    the exact swept gap (:func:`_swept_wall_distance`: the oracle's
    :func:`vcs_env.kernels._segment_distance`). The bounds keep a 1e-9 m slack over rounding, so
    results are the oracle's bit for bit whatever the cache holds, as long as the segments have
    not changed since it was built (the simulator empties a world's cache when it resets it).
    """
    B, n = radius.shape
    s = seg_present.shape[1]
    hits = np.zeros((B, n, s), dtype=np.bool_)
    out = sep.copy()
    hit_any = collided.copy()
    for blk in prange((B + WORLD_BLOCK - 1) // WORLD_BLOCK):  # a scratch array per block of worlds
        d2 = np.empty(s)
        for b in range(blk * WORLD_BLOCK, min(B, (blk + 1) * WORLD_BLOCK)):
            for i in range(n):
                if not (acted[b, i] and present[b, i]):
                    continue
                px, py, qx, qy = pos[b, i, 0], pos[b, i, 1], new_pos[b, i, 0], new_pos[b, i, 1]
                r = radius[b, i]
                cx, cy, R = ball[b, i, 0], ball[b, i, 1], ball[b, i, 2]
                dp = (px - cx) * (px - cx) + (py - cy) * (py - cy)
                dq = (qx - cx) * (qx - cx) + (qy - cy) * (qy - cy)
                if R >= 0.0 and r <= ball[b, i, 3] and dp <= R * R and dq <= R * R:
                    moved = math.sqrt(max(dp, dq))  # the motion lies in the ball of this radius around c
                else:  # a new ball at the motion's midpoint: scan every segment
                    cx, cy = 0.5 * (px + qx), 0.5 * (py + qy)
                    moved = 0.5 * math.sqrt((qx - px) * (qx - px) + (qy - py) * (qy - py))
                    R = max(reach, moved)
                    d2min = np.inf
                    for k in range(s):
                        d2[k] = np.inf
                        if seg_present[b, k]:
                            sx, sy = seg_a[b, k, 0] - cx, seg_a[b, k, 1] - cy
                            dx, dy = seg_b[b, k, 0] - seg_a[b, k, 0], seg_b[b, k, 1] - seg_a[b, k, 1]
                            dd = dx * dx + dy * dy
                            t = _clip(-(sx * dx + sy * dy) / dd if dd > 0.0 else 0.0, 0.0, 1.0)
                            ex, ey = sx + t * dx, sy + t * dy
                            d2[k] = ex * ex + ey * ey
                            d2min = min(d2min, d2[k])
                    keep = max(math.sqrt(d2min) + 2.0 * R, r + R) + 1e-9
                    c = 0
                    for k in range(s):
                        if seg_present[b, k] and d2[k] <= keep * keep:  # insert k, sorted by distance
                            d = math.sqrt(d2[k])
                            j = c
                            while j > 0 and dist[b, i, j - 1] > d:
                                dist[b, i, j], order[b, i, j] = dist[b, i, j - 1], order[b, i, j - 1]
                                j -= 1
                            dist[b, i, j], order[b, i, j] = d, k
                            c += 1
                    count[b, i] = c
                    ball[b, i, 0], ball[b, i, 1], ball[b, i, 2], ball[b, i, 3] = cx, cy, R, r
                best = out[b, i]
                mx, my = 0.5 * (px + qx), 0.5 * (py + qy)
                h = 0.5 * math.sqrt((qx - px) * (qx - px) + (qy - py) * (qy - py))
                for j in range(count[b, i]):
                    if dist[b, i, j] > max(best, 0.0) + 1e-9 + moved + r:
                        break  # this one and the farther ones cannot touch nor lower best
                    k = order[b, i, j]
                    sx, sy = seg_a[b, k, 0] - mx, seg_a[b, k, 1] - my
                    dx, dy = seg_b[b, k, 0] - seg_a[b, k, 0], seg_b[b, k, 1] - seg_a[b, k, 1]
                    dd = dx * dx + dy * dy
                    t = _clip(-(sx * dx + sy * dy) / dd if dd > 0.0 else 0.0, 0.0, 1.0)
                    ex, ey = sx + t * dx, sy + t * dy
                    reach_k = max(best, 0.0) + 1e-9 + h + r
                    if ex * ex + ey * ey > reach_k * reach_k:
                        continue  # by the distance from the motion's midpoint, as above
                    ax, ay, bx, by = seg_a[b, k, 0], seg_a[b, k, 1], seg_b[b, k, 0], seg_b[b, k, 1]
                    gap = _swept_wall_distance(px, py, qx, qy, ax, ay, bx, by, mx, my, h) - r
                    best = min(best, gap)
                    if gap < 0.0:
                        hits[b, i, k] = True
                        hit_any[b, i] = True
                out[b, i] = best
    return hits, out, hit_any
