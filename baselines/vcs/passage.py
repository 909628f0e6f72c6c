"""One at a time through a narrow passage (``VCSParams.narrow_pass``, vcs-method §2.20): of two robots head-on at a
passage too narrow for both side by side (a door), the later one waits before it."""

from __future__ import annotations

import numpy as np

from vcs_env.geometry import det, point_segment_distance
from vcs_env.state import WorldState

from .params import VCSParams

NARROW_STEP = 0.05
"""[m] Spacing of the points along the line between two robots at which the passage's width is measured."""


def narrow_pass(world: WorldState, p: VCSParams, route_pref: np.ndarray, pref: np.ndarray) -> np.ndarray:
    """Preferred velocities ``(B, n, 2)`` [m/s] after letting head-on traffic through a narrow passage one at a time,
    from the route's preferred velocities ``route_pref`` ``(B, n, 2)`` [m/s] (their directions) and those after giving
    way, ``pref`` ``(B, n, 2)`` [m/s].

    Robots i and j meet head-on when each is ahead of the other along its preferred direction and one is within
    ``r_i + r_j`` of the other's line. Along the segment ``[p_i, p_j]`` (sampled every :data:`NARROW_STEP`), the width
    at a point is its distance to the nearest wall on the left plus that to the nearest on the right (walls with ends
    on both sides of the line, or on it, are left out: they cross it); the *passage* is the stretch where the width is
    below ``2 (r_i + r_j) + narrow_pass_margin``. Each robot's distance to the passage's near end, over
    ``max(speed, give_way_speed v_max)``, says who reaches it first (ties: the lower index); both must be within
    ``give_way_range`` of it. A robot whose stopping point, ``r_i + r_j + give_way_margin`` before the passage (room
    for the other to come out and pass it), is behind it is committed and never waits; otherwise the later one, or
    the one whose counterpart is committed, caps its preferred speed to stop there, as at a goal."""
    B, n = world.batch_size, world.n_robots
    sp = np.sqrt(np.einsum("...i,...i->...", route_pref, route_pref))  # (B, n) [m/s]
    u = route_pref / np.maximum(sp, 1e-12)[..., None]
    going = world.active & (sp > 0)
    q = world.pos[:, None, :, :] - world.pos[:, :, None, :]  # p_j - p_i (B, n, n, 2) [m]
    dist = np.sqrt(np.einsum("...i,...i->...", q, q))
    ui = u[:, :, None, :]
    along = np.einsum("...i,...i->...", q, ui)  # j ahead of i along u_i [m]
    r2 = world.radius[:, :, None] + world.radius[:, None, :]  # (B, n, n) [m]
    near = np.abs(det(ui, q)) <= r2  # j within r_i + r_j of i's line
    pair = (
        going[:, :, None] & going[:, None, :] & (along > 0) & (np.swapaxes(along, 1, 2) > 0)
        & (near | np.swapaxes(near, 1, 2)) & (dist <= 2.0 * p.give_way_range)
    )  # fmt: skip
    pair &= np.triu(np.ones((n, n), dtype=bool), 1)  # each pair once, i < j
    bs, iis, jjs = np.nonzero(pair)
    if bs.size == 0:
        return pref
    # The width along [p_i, p_j] of the M pairs that meet.
    pi, d = world.pos[bs, iis], dist[bs, iis, jjs]  # (M, 2) [m], (M,) [m]
    e = (world.pos[bs, jjs] - pi) / d[:, None]
    K = int(np.ceil(d.max() / NARROW_STEP)) + 1
    t = np.minimum(np.arange(K)[None, :] * NARROW_STEP, d[:, None])  # (M, K) [m] from p_i
    x = pi[:, None, :] + t[..., None] * e[:, None, :]  # (M, K, 2) [m]
    a, b = world.seg_a[bs], world.seg_b[bs]  # (M, S, 2) [m]
    side_a, side_b = det(e[:, None, :], a - pi[:, None, :]), det(e[:, None, :], b - pi[:, None, :])  # (M, S)
    present = world.seg_present[bs]
    left, right = present & (side_a > 0) & (side_b > 0), present & (side_a < 0) & (side_b < 0)
    gap = point_segment_distance(x[:, :, None, :], a[:, None], b[:, None])  # (M, K, S) [m]
    width = np.where(left[:, None], gap, np.inf).min(-1) + np.where(right[:, None], gap, np.inf).min(-1)
    narrow = width < 2.0 * r2[bs, iis, jjs][:, None] + p.narrow_pass_margin  # (M, K)
    has = narrow.any(-1)
    if not has.any():
        return pref
    rows = np.arange(len(bs))
    s_i = t[rows, np.argmax(narrow, -1)]  # i to the passage's near end [m]
    s_j = d - t[rows, K - 1 - np.argmax(narrow[:, ::-1], -1)]  # j to its near end [m]
    floor = p.give_way_speed * world.v_max
    time_i = s_i / np.maximum(world.speed[bs, iis], floor[bs, iis])  # [s]
    time_j = s_j / np.maximum(world.speed[bs, jjs], floor[bs, jjs])
    back = r2[bs, iis, jjs] + p.give_way_margin
    stop_i, stop_j = s_i - back, s_j - back  # stopping points [m] ahead of each
    committed_i, committed_j = stop_i <= 0, stop_j <= 0
    ok = has & (s_i <= p.give_way_range) & (s_j <= p.give_way_range)
    i_waits = ok & ~committed_i & (committed_j | (time_i > time_j))  # ties: i (the lower index) goes first
    j_waits = ok & ~committed_j & ~i_waits & (committed_i | (time_j >= time_i))
    stop = np.full((B, n), np.inf)
    np.minimum.at(stop, (bs[i_waits], iis[i_waits]), stop_i[i_waits])
    np.minimum.at(stop, (bs[j_waits], jjs[j_waits]), stop_j[j_waits])
    return stop_within(world, pref, stop)


def stop_within(world: WorldState, pref: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """Preferred velocities ``pref`` ``(B, n, 2)`` [m/s] with each robot's speed capped so that it can stop within
    ``stop`` ``(B, n)`` [m] ahead (``inf``: not capped), as at a goal: ``min(d / dt, sqrt(2 a_max d))`` (giving way,
    vcs-method §2.19, and a narrow passage, vcs-method §2.20)."""
    sp = np.sqrt(np.einsum("...i,...i->...", pref, pref))  # (B, n) [m/s]
    room = np.maximum(stop, 0.0)
    cap = np.minimum(np.minimum(room / world.dt, np.sqrt(2.0 * world.a_max * room)), sp)
    scale = np.where(np.isfinite(stop), cap, sp) / np.maximum(sp, 1e-12)
    return pref * scale[..., None]
