"""Stage 1, neighbours: what robot i senses within r_ca, one :data:`~.records.NEIGHBOUR` record
each (vcs-method §2.4, vcs-method §2.6), and the tests of a velocity against a record."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...capsule import segment_range
from .records import (
    ARRIVING_SLACK,
    INF,
    K_MOVER,
    K_RECIPROCAL,
    K_STATIC,
    NEIGHBOUR,
    R_RVO,
    R_VO,
    ROBOT,
    SENSED,
    STATIC_SPEED,
    TINY,
    Work,
)
from .scalar import split_share, tau, tau_within
from .walls import sensed_walls, wall_tau, wall_within


@njit(cache=True)
def sense(b, i, pos, radius, present, obs_pos, obs_radius, r_ca, out):
    """What robot i of world b senses: every other present robot, then every obstacle, whose
    centre is within ``r_ca`` [m], into ``out`` (:data:`~.records.SENSED` records, in index
    order): index, relative position [m], centre distance [m] and combined radius [m]. Returns
    their number. Shared by the VCS kernel and the sampling VO planners."""
    n = pos.shape[1]
    count = 0
    for j in range(n + obs_pos.shape[1]):
        if j < n:
            if j == i or not present[b, j]:
                continue
            qx = pos[b, j, 0] - pos[b, i, 0]
            qy = pos[b, j, 1] - pos[b, i, 1]
            rj = radius[b, j]
        else:
            qx = obs_pos[b, j - n, 0] - pos[b, i, 0]
            qy = obs_pos[b, j - n, 1] - pos[b, i, 1]
            rj = obs_radius[b, j - n]
        d = math.sqrt(qx * qx + qy * qy)
        if d > r_ca:
            continue
        o = out[count]
        o.idx = j
        o.px = qx
        o.py = qy
        o.d = d
        o.r = radius[b, i] + rj
        count += 1
    return count


@njit(cache=True)
def sort_nearest(order, key, count):
    """``order[:count]``: the indices 0..count-1 sorted by ``key`` (a stable insertion sort)."""
    for a in range(count):
        x = a
        c = a - 1
        while c >= 0 and key[order[c]] > key[x]:
            order[c + 1] = order[c]
            c -= 1
        order[c + 1] = x


@njit(cache=True)
def robot_role(twin, active, speed, heading, v_max, pcx, pcy, p):
    """Velocity [m/s] and role of a robot neighbour (``active``, ``speed`` [m/s], ``heading``
    [rad], ``v_max`` [m/s], communicated preferred velocity ``(pcx, pcy)`` [m/s]):
    ``(sensed, vjx, vjy, reciprocal, mover)``.

    Responsibility by kind: only a robot that is still driving is reciprocal. A robot within
    braking distance of its goal (its communicated preferred speed is below its v_max) is about
    to park, and may stop at any moment (it parks on reaching its goal) or keep going: it gets
    two records, a non-reactive mover at its current velocity and a static ``twin``, and the
    robot takes full responsibility for both (vcs-method §2.4). Parked or crashed robots are
    static obstacles."""
    if not active:
        return not twin, 0.0, 0.0, False, False
    vjx = speed * math.cos(heading)
    vjy = speed * math.sin(heading)
    arriving = p.arriving_non_reactive and (pcx**2 + pcy**2 < (v_max * (1.0 - ARRIVING_SLACK)) ** 2)
    if twin:
        if not arriving or speed <= STATIC_SPEED:
            return False, 0.0, 0.0, False, False
        return True, 0.0, 0.0, p.reciprocity != R_VO and not arriving, True
    return True, vjx, vjy, p.reciprocity != R_VO and not arriving, True


GOAL_TWIN_SLACK = 1.0
"""An arriving robot faster than its preferred speed plus this many steps of braking cannot brake to its goal."""


@njit(cache=True)
def has_walls(b, world):
    """Has world b any wall segment? Among walls a robot's preferred velocity follows its route
    and may give way at crossings (vcs-method §2.18, vcs-method §2.19): it no longer tells where its goal
    is."""
    for k in range(world.seg_present.shape[1]):
        if world.seg_present[b, k]:
            return True
    return False


@njit(cache=True)
def parking_offset(active, speed, heading, v_max, a_max, omega_max, holo, pcx, pcy, dt, p):
    """Where an arriving robot will park, relative to it [m] (``VCSParams.arriving_goal_twin``,
    vcs-method §2.4): ``(ok, gx, gy)``. A robot's preferred speed is ``min(v_max, d / dt,
    sqrt(2 a_max d))`` at distance ``d`` of its goal (vcs-method §2.5), a unicycle's (``holo``
    False) also at most ``omega_max d / (2 |sin beta|)`` for its goal at bearing ``beta`` from its
    ``heading``; each cap grows with ``d``, so a communicated speed ``s`` below v_max tells
    ``d = max(s dt, s^2 / (2 a_max), 2 s |sin beta| / omega_max)``, and its direction where the
    goal lies. An arriving robot faster than ``s`` plus one step of braking (``a_max dt``) cannot
    brake to its goal: it parks there, dead, at speed. ``ok`` is False for a robot that is not
    arriving, or can still brake."""
    if not (active and p.arriving_non_reactive and p.arriving_goal_twin) or speed <= STATIC_SPEED:
        return False, 0.0, 0.0
    s2 = pcx * pcx + pcy * pcy
    if s2 >= (v_max * (1.0 - ARRIVING_SLACK)) ** 2 or s2 <= TINY:
        return False, 0.0, 0.0
    s = math.sqrt(s2)
    if speed <= s + GOAL_TWIN_SLACK * a_max * dt:  # it can still brake to its goal
        return False, 0.0, 0.0
    d = max(s * dt, 0.5 * s2 / a_max)
    if not holo:
        ux, uy = pcx / s, pcy / s
        hx, hy = math.cos(heading), math.sin(heading)
        sin_b = abs(hx * uy - hy * ux) if hx * ux + hy * uy >= 0.0 else 1.0
        d = max(d, 2.0 * s * sin_b / omega_max)
    return True, pcx / s * d, pcy / s * d


@njit(cache=True)
def goal_twins(b, world, pref_comm, p, r_ca, dt, detour, holo, sensed, ns, nbs, count, vrx, vry, a_max_i):
    """Append to ``nbs`` from slot ``count`` a static twin where each sensed arriving robot that
    cannot brake to its goal will park (:func:`parking_offset`), record ``idx`` ``-1 - j``; none
    where the planning robot already is. Returns the new count."""
    n = world.pos.shape[1]
    for s in range(ns):
        o = sensed[s]
        j = o.idx
        if j >= n:
            continue
        ok, gx, gy = parking_offset(
            world.active[b, j], world.speed[b, j], world.heading[b, j], world.v_max[b, j], world.a_max[b, j],
            world.omega_max[b, j], holo, pref_comm[b, j, 0], pref_comm[b, j, 1], dt, p,
        )  # fmt: skip
        if not ok:
            continue
        qx, qy = o.px + gx, o.py + gy
        d = math.sqrt(qx * qx + qy * qy)
        if d <= o.r:  # the robot is on that spot already: the other records handle j
            continue
        nb = nbs[count]
        fill_record(nb, qx, qy, d, o.r, 0.0, 0.0, -1 - j, False, True, vrx, vry, a_max_i, p, r_ca, detour)
        nb.twin = True
        count += 1
    return count


@njit(cache=True)
def fill_record(nb, qx, qy, d, r0, vjx, vjy, j, is_robot, mover, vrx, vry, a_max_i, p, r_ca, detour):
    """Everything of a record but the cone (:func:`set_cone`) and the horizon (stage 2)."""
    nb.px = qx
    nb.py = qy
    nb.d = d
    nb.r0 = r0
    nb.vjx = vjx
    nb.vjy = vjy
    nb.idx = j
    nb.mover = mover
    nb.wall = False
    if is_robot:
        nb.kind = K_RECIPROCAL
    elif vjx * vjx + vjy * vjy > STATIC_SPEED * STATIC_SPEED:
        nb.kind = K_MOVER
    else:
        nb.kind = K_STATIC
    # Static objects: the margin also covers the robot's own stopping time (stage 2).
    nb.stopk = 1.0 / a_max_i if (nb.kind == K_STATIC and p.stop_margin) else 0.0
    # Current-course time to collision with the physical radius (vcs-method §2.6).
    tc0 = tau(qx, qy, vrx - vjx, vry - vjy, r0)
    nb.tc0 = tc0
    # Size regulation: buffer grows with the collision-time and collision-distance factors.
    kt = 0.0 if tc0 == INF else min(max((p.t_max - tc0) / p.t_max, 0.0), 1.0)
    kd = min(max(1.0 - (d - r0) / r_ca, 0.0), 1.0)
    reff = r0 + p.delta_min + (0.0 if detour else p.delta_s * max(kt, kd))
    if d <= reff:
        reff = max(r0, d - p.eps)  # keep the cone defined while not truly colliding
    nb.reff = reff
    # Relative velocity used by J_s: passive v - v_j; robots 2 v - v_R - v_j = 2 (v - m_j).
    if is_robot:
        nb.jax = 0.5 * (vrx + vjx)
        nb.jay = 0.5 * (vry + vjy)
        nb.jscale = 2.0
    else:
        nb.jax = vjx
        nb.jay = vjy
        nb.jscale = 1.0


@njit(cache=True)
def hrvo_apex(qx, qy, d, reff, vjx, vjy, mx, my, rpx, rpy):
    """HRVO apex by explicit line intersection (vcs-method §2.4, vcs-method §2.17); the RVO apex
    ``(mx, my)`` when the sides are parallel. ``(rpx, rpy)``: communicated preferred velocity of
    the robot minus that of the neighbour [m/s] (the side to pass on)."""
    # Tangents n = u(phi - alpha), l = u(phi + alpha): p_hat rotated by -/+ alpha.
    sa = min(reff / d, 1.0)
    ca = math.sqrt(1.0 - sa * sa)
    ux = qx / d
    uy = qy / d
    nx = ux * ca + uy * sa
    ny = -ux * sa + uy * ca
    lx = ux * ca - uy * sa
    ly = ux * sa + uy * ca
    if qx * rpy - qy * rpx > 0.0:
        # pass on the left: VO right side {v_j + s n} meets RVO left side {m + t l}
        d1x, d1y, d2x, d2y = nx, ny, lx, ly
    else:
        d1x, d1y, d2x, d2y = lx, ly, nx, ny
    den = d1x * d2y - d1y * d2x
    if abs(den) < TINY:  # degenerate (alpha ~ 0 or pi/2): fall back to RVO
        return mx, my
    s = ((mx - vjx) * d2y - (my - vjy) * d2x) / den
    return vjx + s * d1x, vjy + s * d1y


@njit(cache=True)
def inside_buffer(nb, eps):
    """Is the robot inside the record's regulated buffer (r_eff shrunk to d - eps, stage 1)?"""
    return nb.d - nb.reff <= eps + 1e-9


@njit(cache=True)
def set_cone(nb, is_robot, vrx, vry, dt, reciprocity, rpx, rpy, eps=0.0, no_follow=False, a_max=0.0):
    """Apex and scale of the record's velocity obstacle, or the overlap half-plane (vcs-method §2.4)."""
    vjx = nb.vjx
    vjy = nb.vjy
    if nb.d <= nb.r0:
        # True penetration: forbidden half-plane (vcs-method §2.4 overlap rule).
        nb.overlap = True
        hx = nb.px / max(nb.d, TINY)
        hy = nb.py / max(nb.d, TINY)
        nb.hx = hx
        nb.hy = hy
        depth = (nb.r0 - nb.d) / dt
        if is_robot:
            nb.apx = 0.5 * (vrx + vjx) - 0.5 * depth * hx
            nb.apy = 0.5 * (vry + vjy) - 0.5 * depth * hy
        else:
            nb.apx = vjx - depth * hx
            nb.apy = vjy - depth * hy
        nb.scale = 1.0
        return
    nb.overlap = False
    if not is_robot:
        nb.scale = 1.0
        nb.apx = vjx
        nb.apy = vjy
        if no_follow and nb.kind == K_MOVER and inside_buffer(nb, eps):
            # Inside a mover's buffer, close on it no faster than the robot could brake within the gap
            # (the mover may stop): the apex keeps at most that much of its receding speed.
            ux = nb.px / nb.d
            uy = nb.py / nb.d
            excess = vjx * ux + vjy * uy - math.sqrt(2.0 * a_max * max(nb.d - nb.r0, 0.0))
            if excess > 0.0:
                nb.apx = vjx - excess * ux
                nb.apy = vjy - excess * uy
        return
    nb.scale = 2.0
    mx = 0.5 * (vrx + vjx)
    my = 0.5 * (vry + vjy)
    if reciprocity == R_RVO:
        nb.apx = mx
        nb.apy = my
    else:
        nb.apx, nb.apy = hrvo_apex(nb.px, nb.py, nb.d, nb.reff, vjx, vjy, mx, my, rpx, rpy)


@njit(cache=True)
def setup_neighbours(b, i, world, pref_comm, p, r_ca, dt, detour, wk, holo):
    """Fill the records of robot i in world b (all but the horizons, stage 2) into ``wk.nbs``; returns their number,
    ``wk.order`` nearest surface first. A stall detour shrinks the regulated buffer to delta_min. Records: robots,
    obstacles, the static twins of arriving robots (and, with ``stopping_obstacles``, of moving obstacles), with
    ``arriving_goal_twin`` the twins of arriving robots where they will park (``idx`` ``-1 - j``), then walls, at most
    ``3 n + 2 m + s``. ``dt``: the world's step [s], with which the goal twins invert the preferred speed's cap; the
    rest counts in the robot's planning period (``wk.robot[0].dt``, set by ``robot_context``)."""
    n = world.pos.shape[1]
    speed, heading, v_max, active, obs_vel = world.speed, world.heading, world.v_max, world.active, world.obs_vel
    sensed, nbs, key = wk.sensed, wk.nbs, wk.key
    ns = sense(b, i, world.pos, world.radius, world.present, world.obs_pos, world.obs_radius, r_ca, sensed)
    v_r = speed[b, i]
    vrx = v_r * math.cos(heading[b, i])
    vry = v_r * math.sin(heading[b, i])
    a_max_i = world.a_max[b, i]
    count = 0
    for twin in (False, True):  # then the static twins of arriving robots (and of stopping obstacles)
        for s in range(ns):
            o = sensed[s]
            j = o.idx
            if j >= n:
                vjx, vjy = obs_vel[b, j - n, 0], obs_vel[b, j - n, 1]
                if twin:  # a moving obstacle that may stop: static where it is now
                    if not p.stopping_obstacles or vjx * vjx + vjy * vjy <= STATIC_SPEED * STATIC_SPEED:
                        continue
                    vjx, vjy = 0.0, 0.0
                ok, is_robot, mover = True, False, False
            else:
                ok, vjx, vjy, is_robot, mover = robot_role(
                    twin,
                    active[b, j],
                    speed[b, j],
                    heading[b, j],
                    v_max[b, j],
                    pref_comm[b, j, 0],
                    pref_comm[b, j, 1],
                    p,
                )
            if not ok:
                continue
            nb = nbs[count]
            fill_record(nb, o.px, o.py, o.d, o.r, vjx, vjy, j, is_robot, mover, vrx, vry, a_max_i, p, r_ca, detour)
            nb.twin = twin
            count += 1
    if p.arriving_goal_twin and not has_walls(b, world):  # where an arriving robot will park (vcs-method §2.4)
        count = goal_twins(b, world, pref_comm, p, r_ca, dt, detour, holo, sensed, ns, nbs, count, vrx, vry, a_max_i)
    first = count  # then the walls (vcs-method §2.18): static, full responsibility
    count = sensed_walls(b, i, world, p, r_ca, vrx, vry, nbs, key, count, 2 * n + world.obs_pos.shape[1])
    if p.fit_clearance >= 0.0:
        clear = max(p.fit_clearance, 0.5 * v_r * v_r / a_max_i)  # at least the robot's braking distance [m]
        fit_buffers(nbs, first, count, world.radius[b, i], clear)
        if p.fit_discs:
            fit_disc_pairs(nbs, first, world.radius[b, i], clear, pref_comm[b, i, 0], pref_comm[b, i, 1])
    for q in range(count):
        nb = nbs[q]
        split_share(nb, b, n, world, p.step_split, holo, wk.robot[0].dt)  # one planning period
        is_robot = nb.kind == K_RECIPROCAL
        rpx = 0.0
        rpy = 0.0
        if is_robot:
            rpx = pref_comm[b, i, 0] - pref_comm[b, nb.idx, 0]
            rpy = pref_comm[b, i, 1] - pref_comm[b, nb.idx, 1]
        set_cone(nb, is_robot, vrx, vry, wk.robot[0].dt, p.reciprocity, rpx, rpy, p.eps, p.no_follow, a_max_i)
        key[q] = nb.d - nb.reff  # nearest surface first: inadmissible candidates fail early
    sort_nearest(wk.order, key, count)
    return count


@njit(cache=True)
def _gap_to_wall(a, c, r_i):
    """Surface gap [m] between the disc of record ``a`` and the wall of record ``c``, for a robot
    of radius ``r_i`` [m] (records hold combined radii)."""
    ux, uy = c.bx - c.ax, c.by - c.ay
    length2 = ux * ux + uy * uy
    s = min(max(((a.px - c.ax) * ux + (a.py - c.ay) * uy) / length2, 0.0), 1.0) if length2 > 0.0 else 0.0
    gx, gy = c.ax + s * ux - a.px, c.ay + s * uy - a.py
    return math.sqrt(gx * gx + gy * gy) - (a.r0 - r_i)


@njit(cache=True)
def fit_buffers(nbs, discs, count, r_i, clearance):
    """Fit the buffers to the free space (``VCSParams.fit_clearance``, vcs-method §2.6) among the
    records ``nbs[:count]`` of a robot of radius ``r_i`` [m], discs first and walls from
    ``discs``: for every static disc ``j`` (a parked robot, a standing obstacle) and wall ``k``
    whose surface gap ``g`` lets the robot through with ``clearance`` [m] (the larger of
    ``fit_clearance`` and the robot's braking distance) on both sides, the buffers of both
    beyond their physical radius are at most ``max(clearance, (g - 2 r_i) / 4)``. Gaps the
    robot does not fit through stay as they are."""
    for j in range(discs):
        a = nbs[j]
        if a.kind != K_STATIC or a.reff <= a.r0 + clearance or a.d <= a.r0:  # nothing to shrink, or an overlap
            continue
        for q in range(discs, count):
            fit_gap(a, nbs[q], _gap_to_wall(a, nbs[q], r_i), r_i, clearance)


@njit(cache=True)
def fit_gap(a, c, gap, r_i, clearance):
    """The cap of :func:`fit_buffers` on records ``a`` (a static disc) and ``c``, whose surface gap is
    ``gap`` [m]: if the robot (radius ``r_i`` [m]) fits through with ``clearance`` [m] on both sides, the
    buffers of both beyond their physical radius are at most ``max(clearance, (gap - 2 r_i) / 4)``."""
    if gap < 2.0 * (r_i + clearance):
        return
    room = max(clearance, 0.25 * (gap - 2.0 * r_i))
    a.reff = max(min(a.reff, a.r0 + room), a.r0)
    if c.reff > c.r0 + room and c.d > c.r0:
        c.reff = c.r0 + room


@njit(cache=True)
def fit_disc_pairs(nbs, discs, r_i, clearance, ux, uy):
    """:func:`fit_buffers` between two static discs (``VCSParams.fit_discs``, vcs-method §2.6): for every
    two static disc records among ``nbs[:discs]`` (parked robots, standing obstacles, not the static
    twins) whose surface gap lets the robot (radius ``r_i`` [m]) through with ``clearance`` [m] on both
    sides, and whose bodies the ray from the robot along its preferred velocity ``(ux, uy)`` [m/s]
    passes between (up to where it crosses the segment between their centres, it keeps out of both
    discs: the gate it heads for), the buffers of both beyond their physical radius are at most
    ``max(clearance, (g - 2 r_i) / 4)``. Fitted all round, or for a ray into a body, the buffers let a
    robot into a pocket it does not fit through, or close in on a robot parked in its lane (vcs-calibration §7)."""
    for j in range(discs):
        a = nbs[j]
        if a.kind != K_STATIC or a.twin or a.d <= a.r0:
            continue
        for q in range(j + 1, discs):
            c = nbs[q]
            if c.kind != K_STATIC or c.twin or c.d <= c.r0:
                continue
            if a.reff <= a.r0 + clearance and c.reff <= c.r0 + clearance:
                continue
            # the ray from the robot along (ux, uy) crosses the segment between the two centres
            ex, ey = c.px - a.px, c.py - a.py
            den = ux * ey - uy * ex
            if abs(den) < 1e-12:
                continue
            t = (a.px * ey - a.py * ex) / den
            s = (a.px * uy - a.py * ux) / den
            if t <= 0.0 or s <= 0.0 or s >= 1.0:
                continue  # not ahead (past the line between the centres it is inside their buffers, vcs-method §2.6)
            # the ray from the robot to the crossing, seen from each centre, keeps the body's own radius
            if (
                segment_range(-a.px, -a.py, t * ux - a.px, t * uy - a.py) < a.r0 - r_i
                or segment_range(-c.px, -c.py, t * ux - c.px, t * uy - c.py) < c.r0 - r_i
            ):
                continue  # it runs into one of the two bodies before it reaches the way between them
            gap = math.sqrt(ex * ex + ey * ey) - (a.r0 - r_i) - (c.r0 - r_i)
            fit_gap(a, c, gap, r_i, clearance)


@njit(cache=True)
def forbidden_within(nb, vx, vy, horizon):
    """Is velocity (vx, vy) inside the record's forbidden set truncated at ``horizon`` [s]?"""
    if nb.overlap:
        # Overlap: half-plane of velocities that do not separate fast enough (vcs-method §2.4).
        return nb.hx * (vx - nb.apx) + nb.hy * (vy - nb.apy) > 0.0
    if nb.wall:
        return wall_within(nb, vx, vy, horizon)
    s = nb.scale
    return tau_within(nb.px, nb.py, s * (vx - nb.apx), s * (vy - nb.apy), nb.reff, horizon)


@njit(cache=True)
def forbidden(nb, vx, vy):
    """Is velocity (vx, vy) inside the record's truncated forbidden set (vcs-method §2.7)?"""
    return forbidden_within(nb, vx, vy, nb.th)


@njit(cache=True)
def in_untruncated_cone(nb, vx, vy):
    """Is velocity (vx, vy) inside the record's cone (or overlap half-plane), at any horizon?"""
    if nb.overlap:
        return nb.hx * (vx - nb.apx) + nb.hy * (vy - nb.apy) > 0.0
    if nb.wall:
        return wall_tau(nb, vx, vy, nb.reff) < INF
    s = nb.scale
    return tau(nb.px, nb.py, s * (vx - nb.apx), s * (vy - nb.apy), nb.reff) < INF


@njit(cache=True)
def collision_time(nb, vx, vy):
    """t_c,j(v) = tau(p, w_j(v), r_eff) with the class's relative velocity (vcs-method §2.12 J_s)."""
    if nb.wall:
        return wall_tau(nb, vx, vy, nb.reff)
    s = nb.jscale
    return tau(nb.px, nb.py, s * (vx - nb.jax), s * (vy - nb.jay), nb.reff)


@njit(cache=True)
def work(n, m, s, p):
    """Scratch arrays of stages 1 and 2 for ``n`` robots, ``m`` obstacles and ``s`` wall segments
    (:data:`~.records.Work`)."""
    ctotal = p.coarse_n_v * p.coarse_n_theta + 1
    k = 3 * n + 2 * m + s  # arriving robots have two static twins (and stopping obstacles one)
    return Work(
        np.zeros(1, dtype=ROBOT),  # robot: the planning robot's context
        np.zeros(n + m, dtype=SENSED),  # sensed: objects within r_ca
        np.zeros(k, dtype=NEIGHBOUR),  # nbs: neighbour records
        np.zeros(k, dtype=np.int64),  # order: nearest surface first
        np.empty(k),  # key: surface distance d - r_eff [m]
        np.empty(ctotal),  # cspeed, ccol, cstep: sorted coarse grid (holonomic)
        np.empty(ctotal, dtype=np.int64),
        np.empty(ctotal),
        np.empty(p.coarse_n_theta),  # ccos, csin: coarse column directions
        np.empty(p.coarse_n_theta),
        np.empty(k, dtype=np.int64),  # pending: cones holding the current velocity
        np.empty(k),  # need: T_need / dt per neighbour
        np.empty(p.coarse_n_v, dtype=np.int64),  # rows, cols: coarse grid by level
        np.empty(p.coarse_n_theta, dtype=np.int64),
        np.empty(k, dtype=np.int64),  # blk: non-reactive neighbours that can close an escape
        np.zeros(k, dtype=np.int64),  # adm: neighbours that may forbid a candidate
        np.zeros(k, dtype=np.int64),  # js: neighbours that may enter the safety band
    )
