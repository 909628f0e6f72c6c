"""Static walls: line segments (polygons are closed chains of them), one geometry for everything.

A world's walls are segments ``seg_a -> seg_b`` ``(B, s, 2)`` [m] with a mask ``seg_present
(B, s)`` (kinds of one scenario may use fewer segments than the array holds). The same segments
serve the swept collision test (:func:`vcs_env.kernels.wall_events`), the route layer
(:mod:`vcs_env.routes`), the renderers and ray casting: a robot of radius ``r`` touches a wall
when its centre comes within ``r`` of the segment, i.e. enters the *capsule* of the segment
grown by ``r``. The test is swept over the straight motion of a step, so a fast robot cannot
tunnel through a thin wall: the gap is the distance between the motion segment and the wall
segment (0 when they cross), minus the radius.

This module holds the readable numpy geometry (the oracle of the numba kernels in
:mod:`vcs_env.kernels`) and the helpers that build and check segment arrays.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .geometry import det, point_segment_distance

MIN_LENGTH = 1e-3
"""Shortest allowed wall segment [m]; shorter ones are degenerate and refused."""


def segment_distance(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance between the segments ``[p, q]`` and ``[a, b]``, all ``(..., 2)`` -> ``(...)`` [m].

    0 when they cross; otherwise the smallest distance from an end point of one to the other
    (the closest pair of two non-crossing segments always includes an end point).
    """
    ab, pq = b - a, q - p
    d1, d2 = det(ab, p - a), det(ab, q - a)
    d3, d4 = det(pq, a - p), det(pq, b - p)
    # Proper crossing: each segment's end points lie strictly on both sides of the other's line, and the bounding
    # boxes meet (rounding of the side tests of nearly collinear segments far apart can read a crossing).
    meet = (np.maximum(p, q) >= np.minimum(a, b)).all(-1) & (np.maximum(a, b) >= np.minimum(p, q)).all(-1)
    cross = (d1 * d2 < 0.0) & (d3 * d4 < 0.0) & meet
    ends = np.minimum(
        np.minimum(point_segment_distance(p, a, b), point_segment_distance(q, a, b)),
        np.minimum(point_segment_distance(a, p, q), point_segment_distance(b, p, q)),
    )
    return np.where(cross, 0.0, ends)


def reference_wall_events(pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided):
    """Numpy oracle of :func:`vcs_env.kernels.wall_events`: ``wall_hits (B, n, s)`` bool (robot
    ``i``'s motion from ``pos`` to ``new_pos`` ``(B, n, 2)`` [m] came within its radius of
    segment ``k``), ``sep`` ``(B, n)`` [m] lowered to the smallest swept gap to any wall
    (unchanged for robots that did not act or are not present) and ``collided`` ``(B, n)`` or
    any wall hit."""
    gap = (
        segment_distance(pos[:, :, None], new_pos[:, :, None], seg_a[:, None], seg_b[:, None]) - radius[..., None]
    )  # (B, n, s)
    live = (acted & present)[..., None] & seg_present[:, None, :]
    gap = np.where(live, gap, np.inf)
    min_gap = gap.min(axis=2) if gap.shape[2] else np.full(radius.shape, np.inf)
    hits = gap < 0.0
    return hits, np.minimum(sep, min_gap), collided | hits.any(axis=2)


def polygon_segments(vertices: Sequence[Sequence[float]]) -> np.ndarray:
    """The closed chain of a polygon: ``(v, 2)`` vertices [m] -> ``(v, 2, 2)`` segments
    ``[[a, b], ...]`` from each vertex to the next, the last back to the first."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3:
        raise ValueError(f"a polygon needs >= 3 vertices of shape (v, 2), got shape {v.shape}")
    return check_segments(np.stack((v, np.roll(v, -1, axis=0)), axis=1), "polygon")


def box_segments(half_x: float, half_y: float | None = None) -> np.ndarray:
    """The four walls ``(4, 2, 2)`` [m] of the rectangle ``[-half_x, half_x] x [-half_y, half_y]``; half sizes must be
    positive (a negative one drew the box of its size)."""
    hy = half_x if half_y is None else half_y
    for name, v in (("half_x", half_x), ("half_y", hy)):
        if isinstance(v, (int, float, np.number)) and not isinstance(v, bool) and v <= 0:
            raise ValueError(f"box_segments: {name} must be > 0 [m], got {v!r}")
    return polygon_segments(((-half_x, -hy), (half_x, -hy), (half_x, hy), (-half_x, hy)))


def check_segments(segments, what: str = "walls") -> np.ndarray:
    """``segments`` as a finite ``(s, 2, 2)`` float array (``[[ax, ay], [bx, by]]`` per row; a
    list of such arrays, e.g. one :func:`polygon_segments` per polygon, gives their rows together);
    raises ``ValueError`` naming ``what`` for a bad shape, non-finite values, or a degenerate
    segment shorter than :data:`MIN_LENGTH`."""
    try:
        seg = np.asarray(segments, dtype=np.float64)
    except (TypeError, ValueError):
        # A list of segment arrays of different lengths (one per polygon): their rows together.
        try:
            parts = [np.asarray(p, dtype=np.float64).reshape(-1, 2, 2) for p in segments]
            seg = np.concatenate(parts) if parts else np.zeros((0, 2, 2))
        except (TypeError, ValueError):
            raise ValueError(
                f"{what} must be segments of shape (s, 2, 2) ([[ax, ay], [bx, by]] each), or a list of such "
                f"arrays, got {type(segments).__name__} {segments!r:.80}"
            ) from None
    if seg.ndim == 4 and seg.shape[2:] == (2, 2):  # a list of segment arrays of one length
        seg = seg.reshape(-1, 2, 2)
    if seg.size == 0:
        return np.zeros((0, 2, 2))
    if seg.ndim != 3 or seg.shape[1:] != (2, 2):
        raise ValueError(f"{what} must be segments of shape (s, 2, 2) ([[ax, ay], [bx, by]] each), got {seg.shape}")
    if not np.all(np.isfinite(seg)):
        raise ValueError(f"{what} must be finite")
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=-1)
    if np.any(length < MIN_LENGTH):
        k = int(np.argmin(length))
        raise ValueError(
            f"{what}: segment {k} {seg[k].tolist()} is degenerate (length {length[k]:.2g} m < {MIN_LENGTH} m)"
        )
    return seg


def clearance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance from each point ``(..., 2)`` to the nearest of ``segments`` ``(s, 2, 2)`` [m]
    (inf without segments): ``(...)``."""
    points = np.asarray(points, dtype=np.float64)
    if len(segments) == 0:
        return np.full(points.shape[:-1], np.inf)
    d = point_segment_distance(points[..., None, :], segments[:, 0], segments[:, 1])
    return d.min(axis=-1)


def nearest_wall_points(world, k: int, with_segments: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The ``k`` nearest points on wall segments of every robot, in its frame: ``points`` ``(B, n,
    k, 2)`` [m] (x ahead, y to the left), ``valid`` ``(B, n, k)`` bool and ``segments`` ``(B, n, k, 4)``,
    nearest first; one point per present segment (its point nearest the robot) whose distance is within
    ``r_ca``. ``segments`` is the wall the point lies on: its unit direction ``(tx, ty)`` in the robot
    frame, turned to ``tx >= 0`` (ahead; ``ty > 0`` when square to the heading), then how far the segment
    runs from the point backward (along ``-t``) and forward (along ``+t``) [m]; at an end of the segment (a
    corner, a door post) one of them is 0; computed only ``with_segments`` (else None). Empty slots are 0 and not
    valid."""
    B, n = world.batch_size, world.n_robots
    points, valid = np.zeros((B, n, k, 2)), np.zeros((B, n, k), dtype=bool)
    segments = np.zeros((B, n, k, 4)) if with_segments else None
    if world.n_segments == 0 or k == 0:
        return points, valid, segments
    a, b = world.seg_a[:, None], world.seg_b[:, None]  # (B, 1, s, 2)
    p = world.pos[:, :, None]  # (B, n, 1, 2)
    u = b - a
    len2 = np.maximum(np.einsum("...i,...i->...", u, u), 1e-300)
    t = np.clip(np.einsum("...i,...i->...", p - a, u) / len2, 0.0, 1.0)
    rel = a + t[..., None] * u - p  # (B, n, s, 2) nearest point minus the robot [m]
    dist = np.sqrt(np.einsum("...i,...i->...", rel, rel))
    dist = np.where(world.seg_present[:, None] & (dist <= world.r_ca), dist, np.inf)
    order = np.argsort(dist, axis=-1, kind="stable")[..., :k]
    kk = order.shape[-1]
    c, s = np.cos(world.heading)[..., None], np.sin(world.heading)[..., None]

    def frame(v):  # (B, n, kk, 2): world vectors (B, n|1, s, 2) of the chosen segments in the robot frame
        v = np.take_along_axis(np.broadcast_to(v, rel.shape), order[..., None], axis=2)
        return np.stack((c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1]), axis=-1)

    points[:, :, :kk] = frame(rel)
    valid[:, :, :kk] = np.isfinite(np.take_along_axis(dist, order, axis=-1))
    points[~valid] = 0.0
    if not with_segments:
        return points, valid, None
    length = np.sqrt(len2)  # (B, 1, s) [m]
    tangent = frame(u / length[..., None])  # from a to b
    t_sel = np.take_along_axis(t, order, axis=-1)
    len_sel = np.take_along_axis(np.broadcast_to(length, t.shape), order, axis=-1)
    to_a, to_b = t_sel * len_sel, (1.0 - t_sel) * len_sel  # [m] from the point to each end
    # Square to the heading within rounding (cos(pi / 2) is 6e-17): ty > 0, as for an exact 0 (a wall ahead read
    # ty = +1 or -1 by the rounding of the robot's heading, e.g. at headings 0 and pi, the same situation otherwise).
    square = np.abs(tangent[..., 0]) <= 1e-12
    tangent[..., 0] = np.where(square, 0.0, tangent[..., 0])
    flip = np.where(square, tangent[..., 1] < 0.0, tangent[..., 0] < 0.0)
    segments[:, :, :kk, :2] = np.where(flip[..., None], -tangent, tangent)
    segments[:, :, :kk, 2] = np.where(flip, to_b, to_a)  # backward
    segments[:, :, :kk, 3] = np.where(flip, to_a, to_b)  # forward
    segments[~valid] = 0.0
    return points, valid, segments
