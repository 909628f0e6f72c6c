"""Pure, vectorized plane geometry shared by the simulator and the planners.

Every function works on arrays with any leading shape ``(...)``; the last axis of a point or
vector is 2. Nothing here knows about robots, worlds or APIs.
"""

from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def wrap_angle(angle: np.ndarray | float) -> np.ndarray:
    """Map angles [rad] into ``(-pi, pi]``.

    Args:
        angle: any shape [rad].

    Returns:
        Same shape, wrapped [rad].
    """
    a = np.mod(np.asarray(angle, dtype=np.float64) + np.pi, TWO_PI) - np.pi
    # np.mod maps +pi to -pi; the interval is half-open at -pi, so move it to +pi.
    return np.where(a <= -np.pi, a + TWO_PI, a)


def unit(angle: np.ndarray | float) -> np.ndarray:
    """Unit vectors ``(cos a, sin a)``: shape ``(..., 2)`` for ``angle`` of shape ``(...)`` [rad]."""
    angle = np.asarray(angle, dtype=np.float64)
    return np.stack((np.cos(angle), np.sin(angle)), axis=-1)


def det(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """2-D cross product ``a_x b_y - a_y b_x``: ``(..., 2) x (..., 2) -> (...)``."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rotate(vec: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotate vectors ``(..., 2)`` counter-clockwise by ``angle`` ``(...)`` [rad]."""
    c, s = np.cos(angle), np.sin(angle)
    x, y = vec[..., 0], vec[..., 1]
    return np.stack((c * x - s * y, s * x + c * y), axis=-1)


def closest_approach(rel_start: np.ndarray, rel_end: np.ndarray) -> np.ndarray:
    """Minimum distance between two points moving linearly over one step.

    The relative position moves on the segment from ``rel_start`` to ``rel_end``; the closest
    point of that segment to the origin is the closest approach of the two moving points.
    Used for swept disc collisions: two discs collide within the step iff the result is below
    the sum of their radii.

    Args:
        rel_start: relative position at the start of the step ``(..., 2)`` [m].
        rel_end: relative position at the end of the step ``(..., 2)`` [m].

    Returns:
        Minimum distance over the step ``(...)`` [m].
    """
    d = rel_end - rel_start
    dd = np.einsum("...i,...i->...", d, d)
    # Parameter of the closest point on the infinite line, clamped to the segment.
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(dd > 0.0, -np.einsum("...i,...i->...", rel_start, d) / dd, 0.0)
    s = np.clip(s, 0.0, 1.0)
    closest = rel_start + s[..., None] * d
    return np.sqrt(np.einsum("...i,...i->...", closest, closest))


def time_to_collision(rel_pos: np.ndarray, rel_vel: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Smallest ``t >= 0`` with ``|rel_pos - rel_vel t| = radius``, or ``inf``.

    ``rel_pos`` points from the moving body to the other one and ``rel_vel`` is the velocity of
    the moving body relative to the other (the RVO Library convention). Already overlapping
    pairs give 0.

    Args:
        rel_pos: ``(..., 2)`` [m].
        rel_vel: ``(..., 2)`` [m/s].
        radius: combined radius ``(...)`` [m].

    Returns:
        Time to collision ``(...)`` [s]; ``inf`` when the bodies never touch.
    """
    c = np.einsum("...i,...i->...", rel_pos, rel_pos) - radius * radius
    a = np.einsum("...i,...i->...", rel_vel, rel_vel)
    b = np.einsum("...i,...i->...", rel_vel, rel_pos)
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (b - np.sqrt(np.maximum(disc, 0.0))) / a
    # Approaching (b > 0) along a line that enters the disc (disc >= 0).
    hit = (a > 0.0) & (b > 0.0) & (disc >= 0.0)
    return np.where(c <= 0.0, 0.0, np.where(hit, t, np.inf))


def point_segment_distance(point: np.ndarray, seg_start: np.ndarray, seg_end: np.ndarray) -> np.ndarray:
    """Distance from ``point`` to the segment ``[seg_start, seg_end]``, all ``(..., 2)`` -> ``(...)`` [m]."""
    return closest_approach(seg_start - point, seg_end - point)
