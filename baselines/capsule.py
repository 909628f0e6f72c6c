"""Velocity obstacle of a static wall: time to collision with a capsule, for every planner.

A robot of radius ``r`` touches a wall segment ``[a, b]`` when its centre enters the *capsule*
of the segment grown by ``r`` (:mod:`vcs_env.walls`): the two end discs of radius ``r`` and the
rectangle between them. A candidate velocity ``w`` is forbidden within a horizon ``T`` when the
centre, moving at ``w`` from where it is, enters the capsule before ``T``: the velocity obstacle
of the capsule is the cone tangent to the two end discs, truncated at ``1 / T`` (Fiorini and
Shiller, IJRR 1998). Walls do not move or answer: full responsibility, no reciprocity.

Relative coordinates, as the disc time to collision of the planners (``baselines.vcs.kernel.tau``):
``a`` and ``b`` are the wall's end points relative to the robot [m], ``w`` the robot's velocity
[m/s]. A robot already inside the capsule (a contact) gets the half-plane rule of the disc
cones: a velocity that does not move it away from the nearest point of the wall collides now
(``t = 0``), one that does never meets that wall again (``t = inf``).

:func:`capsule_tau` and :func:`capsule_forbidden` are numba functions, callable from the
planners' kernels (the VO family here, the VCS kernel once wired); :func:`reference_capsule_tau`
is their readable numpy oracle (``tests/test_capsule.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vcs_env.geometry import time_to_collision

INF = math.inf
STOP_FACTOR = 4.0
"""A wall counts for a candidate velocity only when the robot would touch it within
``STOP_FACTOR`` times (the time to stop from that speed plus one step): see :func:`wall_horizon`."""


@njit(cache=True)
def wall_horizon(speed, a_max, dt):
    """Horizon [s] within which a wall is a threat to a candidate of ``speed`` [m/s]:
    ``STOP_FACTOR * (speed / a_max + dt)``. A wall the robot can comfortably stop before is no
    threat, so a goal beside a wall can be approached (an untruncated ``w / t_c`` penalty keeps
    robots away from every wall they face, however far); the factor leaves room for a unicycle's
    lag in turning and slowing (4 was the smallest of 1-4 without contacts on the corridor,
    room, intersection and walls maps with ``vo`` and ``hrvo``)."""
    return STOP_FACTOR * (speed / a_max + dt)


@njit(cache=True, inline="always")
def _disc_tau(px, py, wx, wy, r):
    """First ``t >= 0`` with ``|p - w t| = r`` for a point outside the disc of radius ``r`` at ``p``."""
    a = wx * wx + wy * wy
    b = wx * px + wy * py
    if a <= 0.0 or b <= 0.0:
        return INF
    disc = b * b - a * (px * px + py * py - r * r)
    if disc < 0.0:
        return INF
    return (b - math.sqrt(disc)) / a


@njit(cache=True)
def segment_range(ax, ay, bx, by):
    """Distance [m] from the robot (origin) to the segment from ``(ax, ay)`` to ``(bx, by)`` [m]."""
    ux, uy = bx - ax, by - ay
    length2 = ux * ux + uy * uy
    s = min(max(-(ax * ux + ay * uy) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
    cx, cy = ax + s * ux, ay + s * uy
    return math.sqrt(cx * cx + cy * cy)


@njit(cache=True)
def capsule_tau(ax, ay, bx, by, wx, wy, r):
    """Time to collision [s] of a robot at the origin moving at ``(wx, wy)`` [m/s] with the
    capsule of radius ``r`` [m] around the segment from ``(ax, ay)`` to ``(bx, by)`` [m]
    (module docstring; 0 or inf by the half-plane rule when already inside)."""
    ux, uy = bx - ax, by - ay
    length2 = ux * ux + uy * uy
    # Nearest point of the segment to the robot (origin).
    s = -(ax * ux + ay * uy) / length2 if length2 > 0.0 else 0.0
    s = min(max(s, 0.0), 1.0)
    cx, cy = ax + s * ux, ay + s * uy
    if cx * cx + cy * cy <= r * r:
        # Inside: only velocities that move away from the wall are safe.
        return 0.0 if wx * cx + wy * cy >= 0.0 else INF
    t = min(_disc_tau(ax, ay, wx, wy, r), _disc_tau(bx, by, wx, wy, r))
    if length2 > 0.0:
        length = math.sqrt(length2)
        nx, ny = -uy / length, ux / length
        h = -(ax * nx + ay * ny)  # signed distance of the robot from the wall's line
        vn = wx * nx + wy * ny
        if abs(h) > r and h * vn < 0.0:
            # The side of the capsule facing the robot: the line at distance r, between the ends.
            ts = (abs(h) - r) / abs(vn)
            along = (wx * ts - ax) * ux + (wy * ts - ay) * uy
            if 0.0 <= along <= length2:
                t = min(t, ts)
    return t


@njit(cache=True)
def capsule_forbidden(ax, ay, bx, by, wx, wy, r, horizon):
    """Is the velocity ``(wx, wy)`` [m/s] inside the wall's velocity obstacle truncated at
    ``horizon`` [s] (does the robot enter the capsule before ``horizon``)?"""
    return capsule_tau(ax, ay, bx, by, wx, wy, r) < horizon


def reference_capsule_tau(a: np.ndarray, b: np.ndarray, w: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Numpy oracle of :func:`capsule_tau` over any leading shape: ``a``, ``b`` ``(..., 2)`` [m]
    relative to the robot, ``w`` ``(..., 2)`` [m/s], ``r`` ``(...)`` [m] -> ``(...)`` [s].

    The capsule is the union of the two end discs and the rectangle; the first contact is the
    earliest of the discs' times to collision and the time the centre crosses the rectangle's
    near side within the segment's extent."""
    a, b, w = (np.asarray(x, dtype=np.float64) for x in (a, b, w))
    r = np.asarray(r, dtype=np.float64)
    u = b - a
    length2 = np.einsum("...i,...i->...", u, u)
    s = np.clip(-np.einsum("...i,...i->...", a, u) / length2, 0.0, 1.0)
    c = a + s[..., None] * u
    inside = np.einsum("...i,...i->...", c, c) <= r * r
    toward = np.einsum("...i,...i->...", w, c) >= 0.0
    t_disc = np.minimum(time_to_collision(a, w, r), time_to_collision(b, w, r))
    nrm = np.stack((-u[..., 1], u[..., 0]), -1) / np.sqrt(length2)[..., None]
    h = -np.einsum("...i,...i->...", a, nrm)
    vn = np.einsum("...i,...i->...", w, nrm)
    with np.errstate(divide="ignore", invalid="ignore"):
        ts = (np.abs(h) - r) / np.abs(vn)
        hit = w * ts[..., None] - a
        along = np.einsum("...i,...i->...", hit, u)
    side_ok = (np.abs(h) > r) & (h * vn < 0.0) & (along >= 0.0) & (along <= length2)
    t = np.minimum(t_disc, np.where(side_ok, ts, np.inf))
    return np.where(inside, np.where(toward, 0.0, np.inf), t)
