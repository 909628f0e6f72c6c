"""Lidar: range beams from every robot, cast against walls, obstacles and other robots.

Optional and off by default (``Scenario.lidar = None``). With a :class:`LidarSpec`, every robot
casts ``n_beams`` beams spread evenly over a field of view ``fov`` centred on its heading (beam
``k`` at ``heading - fov / 2 + (k + 1/2) fov / n_beams``: its direction in the robot frame, the cosine and
sine of that offset, rotated by the heading). A beam's range is the distance [m]
from the robot's centre to the first surface it meets: a wall segment itself (the same segments
the collision test and the route layer use, :mod:`vcs_env.walls`), the circle of an obstacle or
of another robot still in the world; ``max_range`` when it meets nothing. A robot whose centre
lies inside a disc reads 0 along every beam.

Noise (``noise`` > 0, the standard deviation [m]) is Gaussian, drawn from the world's
counter-based noise (:mod:`vcs_env.noise`): a pure function of the world key, the step and the
robot, so a scan depends on the world state only. Noisy ranges are clipped to ``[0, max_range]``.

In the observation (:mod:`vcs_env.observations`) the scan is appended after the neighbour slots (and the
stall clock's block, when the scenario keeps it) as ``range / max_range`` in ``[0, 1]``, beam 0 first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from . import noise
from .checks import check_int, check_range
from .state import WorldState
from .threads import WORLD_BLOCK, twin_kernel

_ROBOT_STRIDE = np.uint64(0x9FB21C651E98DF25)  # odd: robot i draws with key + (i + 1) * stride
_STREAM = 13


@dataclass(frozen=True)
class LidarSpec:
    """Beams of every robot's lidar."""

    n_beams: int = 16
    """Beams per robot, in [1, 1024]."""
    fov: float = 2.0 * math.pi
    """Field of view centred on the heading [rad], in (0, 2 pi]."""
    max_range: float = 4.0
    """Largest measured range [m], > 0; also the observation scale."""
    noise: float = 0.0
    """Standard deviation of Gaussian range noise [m], >= 0."""

    def __post_init__(self) -> None:
        check_int("lidar.n_beams", self.n_beams, 1, 1024)
        check_range("lidar.fov", self.fov, 0.0, 2.0 * math.pi, lo_open=True)
        check_range("lidar.max_range", self.max_range, 0.0, 1e4, lo_open=True)
        check_range("lidar.noise", self.noise, 0.0, 1e3)

    @property
    def offsets(self) -> np.ndarray:
        """Beam angles relative to the heading ``(n_beams,)`` [rad]."""
        return -0.5 * self.fov + (np.arange(self.n_beams) + 0.5) * self.fov / self.n_beams


@njit(cache=True, inline="always")
def _ray_disc(ox, oy, dx, dy, cx, cy, rho):
    """Distance along the unit ray ``o + t d`` to the circle of radius ``rho`` at ``c`` (0 from
    inside, inf if missed)."""
    px, py = cx - ox, cy - oy
    c = px * px + py * py - rho * rho
    if c <= 0.0:
        return 0.0
    b = px * dx + py * dy
    disc = b * b - c
    if b <= 0.0 or disc < 0.0:
        return np.inf
    return b - math.sqrt(disc)


@njit(cache=True, inline="always")
def _ray_segment(ox, oy, dx, dy, ax, ay, bx, by):
    """Distance along the unit ray ``o + t d`` to the segment ``[a, b]`` (inf if missed). A ray
    along the segment's own line (parallel within rounding, within 1e-9 m of it) meets its nearer
    end ahead, or reads 0 from a point on the segment."""
    ex, ey = bx - ax, by - ay
    wx, wy = ax - ox, ay - oy
    den = dx * ey - dy * ex
    if abs(den) <= 1e-12 * math.sqrt(ex * ex + ey * ey):
        if abs(wx * dy - wy * dx) > 1e-9:  # parallel, off the line
            return np.inf
        ta = wx * dx + wy * dy
        tb = (bx - ox) * dx + (by - oy) * dy
        if ta < 0.0 and tb < 0.0:
            return np.inf
        if ta < 0.0 or tb < 0.0:
            return 0.0
        return min(ta, tb)
    t = (wx * ey - wy * ex) / den
    u = (wx * dy - wy * dx) / den
    if t < 0.0 or u < 0.0 or u > 1.0:
        return np.inf
    return t


def cast(pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present, offsets, max_range):
    """Ranges ``(B, n, k)`` [m] of the beams at ``offsets`` ``(k,)`` [rad] from every robot (module
    docstring), without noise; robots not in the world read ``max_range``: :func:`cast_into`."""
    out = np.empty((*radius.shape, offsets.shape[0]))
    cast_into(
        pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present, offsets, max_range, out, 1.0
    )
    return out


@twin_kernel(cache=True)
def cast_into(
    pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present, offsets, max_range, out, scale
):
    """:func:`cast`'s ranges divided by ``scale`` [m] written into ``out`` ``(B, n, k)`` (any float
    dtype, e.g. float32 columns of the observation: no temporary array).

    Pruned, exact: per robot, only the discs and wall segments that come within ``max_range``
    (plus a slack over rounding: 1e-6 relative, 1e-9 m) of its centre are tested beam by beam
    (:func:`_cast_robot`); the others can only give ranges above ``max_range``, which the ``min``
    with ``max_range`` drops. Every range equals the brute force's (every beam against every
    body, ``tests/test_lidar.py``) bit for bit."""
    B, n = radius.shape
    m = obs_radius.shape[1]
    s = seg_present.shape[1]
    beams = np.empty((offsets.shape[0], 2))  # beam directions in the robot frame, rotated by each heading
    for q in range(offsets.shape[0]):
        beams[q, 0], beams[q, 1] = math.cos(offsets[q]), math.sin(offsets[q])
    for blk in prange((B + WORLD_BLOCK - 1) // WORLD_BLOCK):  # scratch arrays per block of worlds
        disc = np.empty((n + m, 3))  # candidate discs: centre relative to the robot [m], |c|^2 - rho^2 [m^2]
        segs = np.empty(s, dtype=np.int64)  # candidate segments
        for b in range(blk * WORLD_BLOCK, min(B, (blk + 1) * WORLD_BLOCK)):
            for i in range(n):
                if present[b, i]:
                    _cast_robot(
                        b, i, pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present,
                        beams, max_range, out, scale, disc, segs,
                    )  # fmt: skip
                else:
                    out[b, i, :] = max_range / scale


@njit(cache=True)
def _cast_robot(
    b, i, pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present, beams, max_range, out,
    scale, disc, segs,
):  # fmt: skip
    """Beams of robot ``i`` of world ``b`` into ``out[b, i]`` (:func:`cast_into`), with the beam directions
    ``beams`` ``(k, 2)`` in the robot frame (the cosine and sine of each offset) and the scratch arrays
    ``disc`` ``(n + m, 3)`` and ``segs`` ``(s,)``. A beam's direction is its robot-frame direction rotated
    by the heading; the per-beam arithmetic is :func:`_ray_disc`'s and :func:`_ray_segment`'s, operation
    for operation. Nothing within range: every beam reads ``max_range``."""
    n, m, s = radius.shape[1], obs_radius.shape[1], seg_present.shape[1]
    ox, oy = pos[b, i, 0], pos[b, i, 1]
    # A body farther than this is met beyond max_range: the slack covers the rounding of the ranges
    # but for a beam within 1e-10 rad of a wall's direction, whose range has relative error > 1e-6.
    reach = max_range * (1.0 + 1e-6) + 1e-9
    nd = 0
    for j in range(n + m):
        if j < n:
            if j == i or not present[b, j]:
                continue
            cx, cy, rho = pos[b, j, 0], pos[b, j, 1], radius[b, j]
        else:
            cx, cy, rho = obs_pos[b, j - n, 0], obs_pos[b, j - n, 1], obs_radius[b, j - n]
        px, py = cx - ox, cy - oy
        c = px * px + py * py - rho * rho
        if c <= 0.0:  # inside a disc: every beam reads 0
            out[b, i, :] = 0.0 / scale
            return
        if math.sqrt(px * px + py * py) - rho > reach:
            continue
        disc[nd, 0], disc[nd, 1], disc[nd, 2] = px, py, c
        nd += 1
    ns = 0
    for j in range(s):
        if seg_present[b, j]:
            ax, ay = seg_a[b, j, 0] - ox, seg_a[b, j, 1] - oy
            ex, ey = seg_b[b, j, 0] - seg_a[b, j, 0], seg_b[b, j, 1] - seg_a[b, j, 1]
            dd = ex * ex + ey * ey
            t = min(max(-(ax * ex + ay * ey) / dd if dd > 0.0 else 0.0, 0.0), 1.0)
            qx, qy = ax + t * ex, ay + t * ey
            if qx * qx + qy * qy <= reach * reach:  # the segment's nearest point is in range
                segs[ns] = j
                ns += 1
    if nd == 0 and ns == 0:
        out[b, i, :] = max_range / scale
        return
    ch, sh = math.cos(heading[b, i]), math.sin(heading[b, i])
    for q in range(beams.shape[0]):
        dx = ch * beams[q, 0] - sh * beams[q, 1]
        dy = sh * beams[q, 0] + ch * beams[q, 1]
        best = max_range
        for j in range(nd):  # without branches (a beam's hits are unpredictable): selects
            bb = disc[j, 0] * dx + disc[j, 1] * dy
            dsc = bb * bb - disc[j, 2]
            t = bb - math.sqrt(max(dsc, 0.0))
            best = min(best, t if (bb > 0.0) & (dsc >= 0.0) else np.inf)
        for j in range(ns):
            k = segs[j]
            best = min(
                best, _ray_segment(ox, oy, dx, dy, seg_a[b, k, 0], seg_a[b, k, 1], seg_b[b, k, 0], seg_b[b, k, 1])
            )
        out[b, i, q] = best / scale


def scan(world: WorldState, spec: LidarSpec) -> np.ndarray:
    """Every robot's lidar ranges ``(B, n, n_beams)`` [m], with the spec's noise, in ``[0, max_range]``."""
    ranges = cast(
        world.pos, world.heading, world.present, world.radius, world.obs_pos, world.obs_radius,
        world.seg_a, world.seg_b, world.seg_present, spec.offsets, float(spec.max_range),
    )  # fmt: skip
    if spec.noise > 0.0:
        B, n, k = ranges.shape
        with np.errstate(over="ignore"):
            keys = world.key.astype(np.uint64)[:, None] + np.arange(1, n + 1, dtype=np.uint64) * _ROBOT_STRIDE
        u = noise.uniform(keys.ravel(), np.repeat(world.steps, n), 2 * k, stream=_STREAM).reshape(B, n, 2, k)
        gauss = np.sqrt(-2.0 * np.log1p(-u[:, :, 0])) * np.cos(2.0 * np.pi * u[:, :, 1])  # Box-Muller
        ranges = np.clip(ranges + spec.noise * gauss, 0.0, spec.max_range)
    return ranges


def write_observation(out: np.ndarray, world: WorldState, spec: LidarSpec) -> None:
    """:func:`observation_block` written into ``out`` ``(B, n, n_beams)`` (e.g. the observation's
    lidar columns); without noise straight from the kernel (:func:`cast_into`)."""
    if spec.noise > 0.0:
        out[...] = observation_block(world, spec)
        return
    cast_into(
        world.pos, world.heading, world.present, world.radius, world.obs_pos, world.obs_radius,
        world.seg_a, world.seg_b, world.seg_present, spec.offsets, float(spec.max_range), out, float(spec.max_range),
    )  # fmt: skip


def observation_block(world: WorldState, spec: LidarSpec) -> np.ndarray:
    """The scan as observed: ``range / max_range`` ``(B, n, n_beams)`` float32 in ``[0, 1]``."""
    ranges = scan(world, spec)
    return np.divide(ranges, spec.max_range, out=ranges).astype(np.float32)  # no temporary
