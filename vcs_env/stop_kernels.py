"""Robots that crash stop where they touched (``on_collision="terminate"``): the swept contact
kernel of the simulator's terminate mode (numba); part of :mod:`vcs_env.kernels` (imported there).

Time inside a step is the fraction ``t`` in [0, 1] of the step; robot ``i`` moves along
``pos_i + t d_i`` (``d_i = new_pos_i - pos_i`` [m], its straight motion of the step) until its
*stop* time ``s_i`` and stands still after it; obstacles move straight over the whole step (they
never stop); walls stand. :func:`stop_at_contact` plays the contacts of a step in time order:
the earliest first contact of any still-moving robot with any body (a robot, moving or
standing, an obstacle or a wall segment) stops that robot there (and a moving robot it touched
at that moment), then the others' contacts are looked for again against the new motions. A
crashed robot therefore parks touching what it hit, never on or beyond a wall nor inside
another robot, whatever ``dt`` and speed. A contact is a distance below the sum of radii
(strict, as in :func:`vcs_env.kernels.swept_events`); the contact time is where the distance
reaches the sum.

The test oracle is ``tests/test_stop.py``'s scalar twin (fine time sampling of the same motions).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .kernels import _closest_approach, _segment_distance
from .threads import WORLD_BLOCK, twin_kernel


@njit(cache=True, inline="always")
def _entry_and_gap(rx, ry, wx, wy, R, lo, hi):
    """For the relative position ``(rx, ry) + (t - lo) (wx, wy)`` [m] over ``t`` in ``[lo, hi]``:
    the first ``t`` at which its length is below ``R`` [m] (inf if never) and its smallest
    length minus ``R`` [m]."""
    span = hi - lo
    gap = _closest_approach(rx, ry, rx + span * wx, ry + span * wy) - R
    c = rx * rx + ry * ry - R * R
    if c < 0.0:
        return lo, gap  # inside at the start of the piece
    a = wx * wx + wy * wy
    b = rx * wx + ry * wy
    if a > 0.0 and b < 0.0:  # closing in: the smaller root of |r + tau w| = R, if real
        disc = b * b - a * c
        if disc > 0.0:
            tau = c / (-b + math.sqrt(disc))  # = (-b - sqrt(disc)) / a, without cancellation
            if tau <= span:
                return lo + tau, gap
    return np.inf, gap


@njit(cache=True)
def _pair(ax, ay, dax, day, sa, bx, by, dbx, dby, sb, R):
    """Body ``a`` at ``(ax, ay) + min(t, sa) (dax, day)`` and body ``b`` likewise [m], over ``t``
    in [0, 1]: the first ``t`` at which their centres are closer than ``R`` [m] (inf if never)
    and their smallest distance minus ``R`` [m]. The relative motion is straight between the
    break points ``sa`` and ``sb``."""
    first, gap = np.inf, np.inf
    t1, t2 = min(sa, sb), max(sa, sb)
    for k in range(3):
        lo = 0.0 if k == 0 else (t1 if k == 1 else t2)
        hi = t1 if k == 0 else (t2 if k == 1 else 1.0)
        ua = 1.0 if lo < sa else 0.0  # does a still move in this piece?
        ub = 1.0 if lo < sb else 0.0
        rx = (bx + min(lo, sb) * dbx) - (ax + min(lo, sa) * dax)
        ry = (by + min(lo, sb) * dby) - (ay + min(lo, sa) * day)
        e, g = _entry_and_gap(rx, ry, ub * dbx - ua * dax, ub * dby - ua * day, R, lo, hi)
        first = min(first, e)
        gap = min(gap, g)
    return first, gap


@njit(cache=True, inline="always")
def _slab(x0, v, lo_v, hi_v, t_lo, t_hi, strict):
    """Clip ``[t_lo, t_hi]`` to the times at which ``x0 + t v`` lies in ``[lo_v, hi_v]`` (open
    interval with ``strict``); empty: ``t_lo > t_hi``."""
    if v == 0.0:
        inside = (lo_v < x0 < hi_v) if strict else (lo_v <= x0 <= hi_v)
        return (t_lo, t_hi) if inside else (1.0, 0.0)
    u1, u2 = (lo_v - x0) / v, (hi_v - x0) / v
    return max(t_lo, min(u1, u2)), min(t_hi, max(u1, u2))


@njit(cache=True)
def _wall(px, py, dx, dy, s, ax, ay, bx, by, r):
    """A robot of radius ``r`` [m] at ``(px, py) + min(t, s) (dx, dy)`` and the wall segment
    ``[a, b]`` [m]: the first ``t`` in [0, 1] at which it is closer than ``r`` (inf if never)
    and its smallest distance minus ``r`` [m]."""
    qx, qy = px + s * dx, py + s * dy
    gap = _segment_distance(px, py, qx, qy, ax, ay, bx, by) - r
    if gap >= 0.0:
        return np.inf, gap
    if _segment_distance(px, py, px, py, ax, ay, bx, by) < r:
        return 0.0, gap  # touching from the start
    # First entry into the r-neighbourhood of the segment: two end discs and a band.
    first = min(
        _entry_and_gap(px - ax, py - ay, dx, dy, r, 0.0, s)[0], _entry_and_gap(px - bx, py - by, dx, dy, r, 0.0, s)[0]
    )
    ex, ey = bx - ax, by - ay
    length = math.sqrt(ex * ex + ey * ey)
    if length > 0.0:
        ux, uy = ex / length, ey / length
        rx, ry = px - ax, py - ay
        lo, hi = _slab(ux * rx + uy * ry, ux * dx + uy * dy, 0.0, length, 0.0, s, False)
        lo, hi = _slab(-uy * rx + ux * ry, -uy * dx + ux * dy, -r, r, lo, hi, True)
        if lo < hi:
            first = min(first, lo)
    return first, gap


@njit(cache=True)
def _first_contact(b, i, pos, d, stop, radius, present, obs_pos, obs_d, obs_radius, seg_a, seg_b, seg_present, hits):
    """Robot ``i`` of world ``b`` under the current stop times: its first contact time with any
    body (inf if none), the robot it touches then (-1 if it is not a robot) and its smallest gap
    to any body over the step [m]. With ``hits`` (a robot's row of ``(n + m + s,)`` bool, robots,
    obstacles, then walls) every body it comes within :data:`TOUCH` of is marked."""
    px, py, dx, dy, si, ri = pos[b, i, 0], pos[b, i, 1], d[b, i, 0], d[b, i, 1], stop[b, i], radius[b, i]
    n, m = radius.shape[1], obs_radius.shape[1]
    first, other, sep = np.inf, -1, np.inf
    for j in range(n + m + seg_present.shape[1]):
        if j < n:
            if j == i or not present[b, j]:
                continue
            qx, qy, ex, ey, sj, rj = pos[b, j, 0], pos[b, j, 1], d[b, j, 0], d[b, j, 1], stop[b, j], radius[b, j]
            e, g = _pair(px, py, dx, dy, si, qx, qy, ex, ey, sj, ri + rj)
        elif j < n + m:
            k = j - n
            qx, qy, ex, ey, rk = obs_pos[b, k, 0], obs_pos[b, k, 1], obs_d[b, k, 0], obs_d[b, k, 1], obs_radius[b, k]
            e, g = _pair(px, py, dx, dy, si, qx, qy, ex, ey, 1.0, ri + rk)
        else:
            k = j - n - m
            if not seg_present[b, k]:
                continue
            e, g = _wall(px, py, dx, dy, si, seg_a[b, k, 0], seg_a[b, k, 1], seg_b[b, k, 0], seg_b[b, k, 1], ri)
        sep = min(sep, g)
        if e < first:
            first, other = e, (j if j < n else -1)
        if hits.size and g < TOUCH:
            hits[j] = True
    return first, other, sep


TOUCH = 1e-9
"""[m] a crashed robot touches every body it is within this gap of over its (stopped) motion."""


@twin_kernel(cache=True)
def stop_at_contact(
    pos, new_pos, radius, present, acted, obs_pos, new_obs, obs_radius, seg_a, seg_b, seg_present, redo
):
    """Stop times ``(B, n)`` (fractions of the step, 1: no contact) of the robots of the worlds
    ``redo`` ``(B,)`` bool, and their events over the stopped motions: ``hits (B, n, n + m + s)``
    bool (robots, obstacles, walls touched; only crashed robots touch), ``collided (B, n)`` bool
    and ``min_sep (B, n)`` [m] (smallest gap over the step, inf for robots that did not act).
    Motions: ``pos -> new_pos`` ``(B, n, 2)`` [m] for robots that ``acted`` and are ``present``
    (others stand), ``obs_pos -> new_obs`` ``(B, m, 2)`` [m], walls ``seg_a -> seg_b``
    ``(B, s, 2)`` [m] where ``seg_present``. See the module docstring."""
    B, n = radius.shape
    total = n + obs_radius.shape[1] + seg_present.shape[1]
    d = new_pos - pos
    obs_d = new_obs - obs_pos
    stop = np.ones((B, n))
    hits = np.zeros((B, n, total), dtype=np.bool_)
    collided = np.zeros((B, n), dtype=np.bool_)
    min_sep = np.full((B, n), np.inf)
    for blk in prange((B + WORLD_BLOCK - 1) // WORLD_BLOCK):  # scratch arrays per block of worlds
        times, partner = np.empty(n), np.empty(n, dtype=np.int64)
        for b in range(blk * WORLD_BLOCK, min(B, (blk + 1) * WORLD_BLOCK)):
            if redo[b]:
                _stop_world(
                    b, pos, d, acted, present, radius, obs_pos, obs_d, obs_radius, seg_a, seg_b, seg_present,
                    stop, hits, collided, min_sep, times, partner,
                )  # fmt: skip
    return stop, hits, collided, min_sep


@njit(cache=True)
def _stop_world(
    b, pos, d, acted, present, radius, obs_pos, obs_d, obs_radius, seg_a, seg_b, seg_present,
    stop, hits, collided, min_sep, times, partner,
):  # fmt: skip
    """World ``b`` of :func:`stop_at_contact`, written into its outputs (and ``d``: robots that
    stand get motion 0), with the scratch arrays ``times``, ``partner`` ``(n,)``."""
    n = radius.shape[1]
    none = np.zeros(0, dtype=np.bool_)
    for i in range(n):
        if not (acted[b, i] and present[b, i]):
            d[b, i, 0] = d[b, i, 1] = 0.0  # stands
    for _ in range(n):  # each round stops at least one robot
        best = np.inf
        for i in range(n):
            times[i] = np.inf
            if acted[b, i] and present[b, i] and not collided[b, i]:
                times[i], partner[i], _ = _first_contact(
                    b, i, pos, d, stop, radius, present, obs_pos, obs_d, obs_radius, seg_a, seg_b, seg_present, none
                )
                best = min(best, times[i])
        if not best <= 1.0:
            break
        for i in range(n):
            if times[i] == best:  # the earliest contacts: stop there (and the moving robot touched)
                for k in (i, partner[i]):
                    if k >= 0 and acted[b, k] and present[b, k] and not collided[b, k]:
                        stop[b, k], collided[b, k] = best, True
    for i in range(n):
        if acted[b, i] and present[b, i]:
            row = hits[b, i] if collided[b, i] else none
            min_sep[b, i] = _first_contact(
                b, i, pos, d, stop, radius, present, obs_pos, obs_d, obs_radius, seg_a, seg_b, seg_present, row
            )[2]
