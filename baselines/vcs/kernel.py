"""The VCS planner's inner loops, compiled with numba (one call plans every robot of every world).

Scalar math mirrors :mod:`baselines.vcs.geometry` (which is the readable reference; tests check
that both agree). Per robot (vcs-method §2.14):

1. neighbours within r_ca: regulated radius r_eff (vcs-method §2.6), cone and apex
   (vcs-method §2.1, vcs-method §2.4), current time to collision t_c0, time needed to leave the
   cone T_need and horizon T_h (vcs-method §2.7);
2. window W_k* sized by the first threat (vcs-method §2.10);
3. point search over a grid of W_k* plus {G, 0, clip1(G)} (vcs-method §2.11): admissible points keep every
   truncated VO beyond its horizon; the cheapest under the multi-objective cost J (vcs-method §2.12)
   wins, or the fallback penalty when none is admissible (vcs-method §2.13).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

INF = np.inf

# Parameter vector layout (floats), see VCSPlanner._param_vector.
P_DELTA_MIN, P_DELTA_S, P_EPS, P_TMAX, P_TM, P_HORIZON, P_TAU_S, P_KAPPA = 0, 1, 2, 3, 4, 5, 6, 7
P_WG, P_WS, P_WC, P_WR, P_WH, P_WB = 8, 9, 10, 11, 12, 13
P_NV, P_NTH, P_NTH_FULL, P_CNV, P_CNTH, P_ONE_STEP, P_RECIP, P_MARGIN = 14, 15, 16, 17, 18, 19, 20, 21
P_GMETRIC, P_TM_ROBOT = 22, 23
P_STOP, P_JOINT, P_RAMP, P_ARRIVE, P_LEAST_HARM, P_CROWD = 24, 25, 26, 27, 28, 29
N_PARAMS = 30
# Reciprocity codes.
R_HRVO, R_RVO, R_VO = 0, 1, 2
# Neighbour record columns (float64 scratch array).
(
    F_PX,
    F_PY,
    F_D,
    F_R0,
    F_REFF,
    F_APX,
    F_APY,
    F_SCALE,
    F_JAX,
    F_JAY,
    F_JSCALE,
    F_OVL,
    F_HX,
    F_HY,
    F_TC0,
    F_TH,
    F_BOUND,
    F_JBOUND,
    F_VJX,
    F_VJY,
    F_IDX,
    F_MOVER,
    F_KIND,
    F_STOPK,
) = range(24)
N_FIELDS = 24
# Neighbour kinds (responsibility by kind): a driving robot shares the avoidance (reciprocity);
# everything else (parked robots, robots arriving at their goal, obstacles) is non-reactive and
# the robot takes full responsibility; a non-reactive object that does not move is static.
K_RECIPROCAL, K_MOVER, K_STATIC = 0, 1, 2
STATIC_SPEED = 1e-6
"""Below this speed [m/s] a non-reactive object counts as static."""


@njit(cache=True)
def tau(px, py, wx, wy, r):
    """Time to collision (vcs-method §2.2), scalar form of ``vcs_env.geometry.time_to_collision``."""
    c = px * px + py * py - r * r
    if c <= 0.0:
        return 0.0
    a = wx * wx + wy * wy
    b = wx * px + wy * py
    if a <= 0.0 or b <= 0.0:
        return INF
    disc = b * b - a * c
    if disc < 0.0:
        return INF
    return (b - math.sqrt(disc)) / a


@njit(cache=True)
def wrap(x):
    """Angle into (-pi, pi]."""
    if -math.pi < x <= math.pi:
        return x
    y = (x + math.pi) % (2.0 * math.pi) - math.pi
    if y <= -math.pi:
        y += 2.0 * math.pi
    return y


@njit(cache=True)
def reach_steps(dv, dth, dv1, dth1, holo, vrx, vry, th_r, v_r):
    """Steps to reach a VCS point with saturated per-step changes (vcs-method §2.7). Holonomic robots
    change the velocity vector by up to dv1 per step in any direction."""
    if holo:
        s = v_r + dv
        ex = s * math.cos(th_r + dth) - vrx
        ey = s * math.sin(th_r + dth) - vry
        return math.ceil(math.sqrt(ex * ex + ey * ey) / dv1 - 1e-9)
    kv = math.ceil(abs(dv) / dv1 - 1e-9)
    kt = math.ceil(abs(dth) / dth1 - 1e-9)
    k = kv if kv > kt else kt
    return k if k > 0 else 0


@njit(cache=True)
def tau_within(px, py, wx, wy, r, horizon):
    """``tau(p, w, r) <= horizon`` without the square root unless needed (finite tau only)."""
    c = px * px + py * py - r * r
    if c <= 0.0:
        return True
    a = wx * wx + wy * wy
    b = wx * px + wy * py
    if a <= 0.0 or b <= 0.0:
        return False
    disc = b * b - a * c
    if disc < 0.0:
        return False
    if horizon == INF:
        return True
    # (b - sqrt(disc)) / a <= T  <=>  b - a T <= sqrt(disc)
    e = b - a * horizon
    return e <= 0.0 or e * e <= disc


@njit(cache=True)
def forbidden(nb, vx, vy):
    """Is velocity (vx, vy) inside neighbour nb's truncated forbidden set (vcs-method §2.7)?"""
    if nb[F_OVL] > 0.5:
        # Overlap: half-plane of velocities that do not separate fast enough (vcs-method §2.4).
        return nb[F_HX] * (vx - nb[F_APX]) + nb[F_HY] * (vy - nb[F_APY]) > 0.0
    s = nb[F_SCALE]
    return tau_within(nb[F_PX], nb[F_PY], s * (vx - nb[F_APX]), s * (vy - nb[F_APY]), nb[F_REFF], nb[F_TH])


@njit(cache=True)
def forbidden_within(nb, vx, vy, horizon):
    """Is velocity (vx, vy) inside neighbour nb's forbidden set truncated at ``horizon`` [s]?"""
    if nb[F_OVL] > 0.5:
        return nb[F_HX] * (vx - nb[F_APX]) + nb[F_HY] * (vy - nb[F_APY]) > 0.0
    s = nb[F_SCALE]
    return tau_within(nb[F_PX], nb[F_PY], s * (vx - nb[F_APX]), s * (vy - nb[F_APY]), nb[F_REFF], horizon)


@njit(cache=True)
def in_untruncated_cone(nb, vx, vy):
    if nb[F_OVL] > 0.5:
        return nb[F_HX] * (vx - nb[F_APX]) + nb[F_HY] * (vy - nb[F_APY]) > 0.0
    s = nb[F_SCALE]
    return tau(nb[F_PX], nb[F_PY], s * (vx - nb[F_APX]), s * (vy - nb[F_APY]), nb[F_REFF]) < INF


@njit(cache=True)
def collision_time(nb, vx, vy):
    """t_c,j(v) = tau(p, w_j(v), r_eff) with the class's relative velocity (vcs-method §2.12 J_s)."""
    s = nb[F_JSCALE]
    return tau(nb[F_PX], nb[F_PY], s * (vx - nb[F_JAX]), s * (vy - nb[F_JAY]), nb[F_REFF])


@njit(cache=True)
def setup_neighbors(
    b,
    i,
    pos,
    heading,
    speed,
    radius,
    active,
    present,
    obs_pos,
    obs_vel,
    obs_radius,
    pref_comm,
    v_max,
    a_max,
    prm,
    r_ca,
    dt,
    nbs,
    order,
    detour,
):
    """Fill the neighbour records of robot i in world b (everything but T_need/T_h). Returns the
    number of neighbours; ``order`` lists them nearest surface first. During a stall detour
    the regulated buffer shrinks to delta_min, so gaps the full buffer closes open up.

    Responsibility by kind: only a robot that is still driving is reciprocal. A robot within
    braking distance of its goal (its communicated preferred speed is below its v_max) is about
    to park, and may stop at any moment (it parks on reaching its goal) or keep going: it gets
    two records, a non-reactive mover at its current velocity and a static twin, and the robot
    takes full responsibility for both (vcs-method §2.4). Records: at most ``2 n + m``."""
    n = pos.shape[1]
    m = obs_pos.shape[1]
    px0 = pos[b, i, 0]
    py0 = pos[b, i, 1]
    v_r = speed[b, i]
    vrx = v_r * math.cos(heading[b, i])
    vry = v_r * math.sin(heading[b, i])
    recip = int(prm[P_RECIP])
    count = 0
    for jj in range(n + m + n):
        twin = jj >= n + m  # the static twin of an arriving robot
        j = jj - (n + m) if twin else jj
        if j < n:
            if j == i or not present[b, j] or (twin and not active[b, j]):
                continue
            qx = pos[b, j, 0] - px0
            qy = pos[b, j, 1] - py0
            rj = radius[b, j]
            if active[b, j]:
                vjx = speed[b, j] * math.cos(heading[b, j])
                vjy = speed[b, j] * math.sin(heading[b, j])
                arriving = prm[P_ARRIVE] > 0.5 and (
                    pref_comm[b, j, 0] ** 2 + pref_comm[b, j, 1] ** 2 < (v_max[b, j] * (1.0 - 1e-6)) ** 2
                )
                if twin:
                    if not arriving or speed[b, j] <= STATIC_SPEED:
                        continue
                    vjx = 0.0
                    vjy = 0.0
                is_robot = recip != R_VO and not arriving
                mover = 1.0
            else:  # parked or crashed robots are static obstacles
                vjx = 0.0
                vjy = 0.0
                is_robot = False
                mover = 0.0
        else:
            k = j - n
            qx = obs_pos[b, k, 0] - px0
            qy = obs_pos[b, k, 1] - py0
            rj = obs_radius[b, k]
            vjx = obs_vel[b, k, 0]
            vjy = obs_vel[b, k, 1]
            is_robot = False
            mover = 0.0
        d = math.sqrt(qx * qx + qy * qy)
        if d > r_ca:
            continue
        nb = nbs[count]
        r0 = radius[b, i] + rj
        nb[F_PX] = qx
        nb[F_PY] = qy
        nb[F_D] = d
        nb[F_R0] = r0
        nb[F_VJX] = vjx
        nb[F_VJY] = vjy
        nb[F_IDX] = j
        nb[F_MOVER] = mover  # an active robot (whatever the reciprocity rule)
        if is_robot:
            nb[F_KIND] = K_RECIPROCAL
        elif vjx * vjx + vjy * vjy > STATIC_SPEED * STATIC_SPEED:
            nb[F_KIND] = K_MOVER
        else:
            nb[F_KIND] = K_STATIC
        # Static objects: the margin also covers the robot's own stopping time (set_horizons).
        nb[F_STOPK] = 1.0 / a_max[b, i] if (nb[F_KIND] == K_STATIC and prm[P_STOP] > 0.5) else 0.0
        # Current-course time to collision with the physical radius (vcs-method §2.6).
        tc0 = tau(qx, qy, vrx - vjx, vry - vjy, r0)
        nb[F_TC0] = tc0
        # Size regulation: buffer grows with the collision-time and collision-distance factors.
        kt = 0.0 if tc0 == INF else min(max((prm[P_TMAX] - tc0) / prm[P_TMAX], 0.0), 1.0)
        kd = min(max(1.0 - (d - r0) / r_ca, 0.0), 1.0)
        reff = r0 + prm[P_DELTA_MIN] + (0.0 if detour else prm[P_DELTA_S] * max(kt, kd))
        if d <= reff:
            reff = max(r0, d - prm[P_EPS])  # keep the cone defined while not truly colliding
        nb[F_REFF] = reff
        # Relative velocity used by J_s: passive v - v_j; robots 2 v - v_R - v_j = 2 (v - m_j).
        if is_robot:
            nb[F_JAX] = 0.5 * (vrx + vjx)
            nb[F_JAY] = 0.5 * (vry + vjy)
            nb[F_JSCALE] = 2.0
        else:
            nb[F_JAX] = vjx
            nb[F_JAY] = vjy
            nb[F_JSCALE] = 1.0
        if d <= r0:
            # True penetration: forbidden half-plane (vcs-method §2.4 overlap rule).
            nb[F_OVL] = 1.0
            hx = qx / max(d, 1e-12)
            hy = qy / max(d, 1e-12)
            nb[F_HX] = hx
            nb[F_HY] = hy
            depth = (r0 - d) / dt
            if is_robot:
                nb[F_APX] = 0.5 * (vrx + vjx) - 0.5 * depth * hx
                nb[F_APY] = 0.5 * (vry + vjy) - 0.5 * depth * hy
            else:
                nb[F_APX] = vjx - depth * hx
                nb[F_APY] = vjy - depth * hy
            nb[F_SCALE] = 1.0
        else:
            nb[F_OVL] = 0.0
            if is_robot:
                nb[F_SCALE] = 2.0
                mx = 0.5 * (vrx + vjx)
                my = 0.5 * (vry + vjy)
                if recip == R_RVO:
                    nb[F_APX] = mx
                    nb[F_APY] = my
                else:
                    # HRVO apex by explicit line intersection (vcs-method §2.4, vcs-method §2.17).
                    # Tangents n = u(phi - alpha), l = u(phi + alpha): p_hat rotated by -/+ alpha.
                    sa = min(reff / d, 1.0)
                    ca = math.sqrt(1.0 - sa * sa)
                    ux = qx / d
                    uy = qy / d
                    nx = ux * ca + uy * sa
                    ny = -ux * sa + uy * ca
                    lx = ux * ca - uy * sa
                    ly = ux * sa + uy * ca
                    rpx = pref_comm[b, i, 0] - pref_comm[b, j, 0]
                    rpy = pref_comm[b, i, 1] - pref_comm[b, j, 1]
                    if qx * rpy - qy * rpx > 0.0:
                        # pass on the left: VO right side {v_j + s n} meets RVO left side {m + t l}
                        a1x, a1y, d1x, d1y, a2x, a2y, d2x, d2y = vjx, vjy, nx, ny, mx, my, lx, ly
                    else:
                        a1x, a1y, d1x, d1y, a2x, a2y, d2x, d2y = vjx, vjy, lx, ly, mx, my, nx, ny
                    den = d1x * d2y - d1y * d2x
                    if abs(den) < 1e-12:  # degenerate (alpha ~ 0 or pi/2): fall back to RVO
                        nb[F_APX] = mx
                        nb[F_APY] = my
                    else:
                        s = ((a2x - a1x) * d2y - (a2y - a1y) * d2x) / den
                        nb[F_APX] = a1x + s * d1x
                        nb[F_APY] = a1y + s * d1y
            else:
                nb[F_SCALE] = 1.0
                nb[F_APX] = vjx
                nb[F_APY] = vjy
        order[count] = count
        count += 1
    # Nearest surface first, so that inadmissible candidates are rejected early.
    for a in range(1, count):
        x = order[a]
        key = nbs[x, F_D] - nbs[x, F_REFF]
        c = a - 1
        while c >= 0 and nbs[order[c], F_D] - nbs[order[c], F_REFF] > key:
            order[c + 1] = order[c]
            c -= 1
        order[c + 1] = x
    return count


@njit(cache=True)
def build_coarse(v_r, th_r, v_max_r, dv1, dth1, holo, nv, nth, cspeed, ccol, cstep, ccos, csin):
    """Coarse grid over the VCS domain D (plus the origin), sorted by reach steps (vcs-method §2.7) with a
    counting sort. Point c has speed ``cspeed[c]`` and direction column ``ccol[c]`` (-1: the
    current heading), whose unit vector is ``(ccos, csin)[col]``."""
    total = nv * nth + 1
    vrx = v_r * math.cos(th_r)
    vry = v_r * math.sin(th_r)
    for t in range(nth):
        ccos[t] = math.cos(th_r - math.pi + 2.0 * math.pi * t / nth)
        csin[t] = math.sin(th_r - math.pi + 2.0 * math.pi * t / nth)
    level = np.empty(total, dtype=np.int64)
    level[0] = 0
    top = 0
    for a in range(nv):
        dv = -v_r + v_max_r * a / (nv - 1)
        kv = math.ceil(abs(dv) / dv1 - 1e-9)
        for t in range(nth):
            if holo:
                s = v_r + dv
                k = math.ceil(math.sqrt((s * ccos[t] - vrx) ** 2 + (s * csin[t] - vry) ** 2) / dv1 - 1e-9)
            else:
                kt = math.ceil(abs(-math.pi + 2.0 * math.pi * t / nth) / dth1 - 1e-9)
                k = kv if kv > kt else kt
            level[1 + a * nth + t] = k
            if k > top:
                top = k
    start = np.zeros(top + 2, dtype=np.int64)
    for c in range(total):
        start[level[c] + 1] += 1
    for k in range(top + 1):
        start[k + 1] += start[k]
    for c in range(total):
        k = level[c]
        slot = start[k]
        start[k] += 1
        if c == 0:
            cspeed[slot] = v_r
            ccol[slot] = -1
        else:
            cspeed[slot] = v_max_r * ((c - 1) // nth) / (nv - 1)
            ccol[slot] = (c - 1) % nth
        cstep[slot] = k


@njit(cache=True)
def escape_open(nbs, blk, nblk, vx, vy, tmax):
    """Is velocity (vx, vy) an escape that no non-reactive object closes within T_max? A way out
    of one object's cone that runs into another (a crowd, a row of parked robots) is no way out:
    the time needed to leave the cone is the time to reach an *open* escape, so the horizon
    grows where the crowd closes the nearby ones (vcs-method §2.7). ``blk`` lists the
    non-reactive neighbours (empty when the joint rule is off)."""
    for q in range(nblk):
        if forbidden_within(nbs[blk[q]], vx, vy, tmax):
            return False
    return True


@njit(cache=True)
def need_unicycle(
    nbs, pending, npend, need, v_r, th_r, v_max_r, dv1, dth1, nv, nth, lmax, rows, cols, ccos, csin, blk, nblk, tmax
):
    """T_need / dt of the ``pending`` neighbours (whose cone holds the current velocity): the
    least reach level of a coarse-grid point outside the cone that is an escape (vcs-method §2.7,
    :func:`escape_open`).

    A unicycle's reach level is max(speed level, turn level), so the points of level <= L are
    the rows of speed level <= L times the columns of turn level <= L. Rows and columns are
    ordered by level (outward from "no change"), and each level adds a border of new points;
    points are visited level by level until every pending cone is left (or ``lmax``).
    """
    # Rows: coarse speeds v_max a / (nv - 1), ordered by |speed change| outward from v_r.
    right = 0
    while right < nv and v_max_r * right / (nv - 1) < v_r:
        right += 1
    left = right - 1
    for q in range(nv):
        if right >= nv or (left >= 0 and v_r - v_max_r * left / (nv - 1) <= v_max_r * right / (nv - 1) - v_r):
            rows[q] = left
            left -= 1
        else:
            rows[q] = right
            right += 1
    # Columns: directions -pi + 2 pi t / nth, ordered by |direction change| outward from 0.
    c0 = nth // 2
    for q in range(nth):
        cols[q] = c0 + ((q + 1) // 2) * (1 if q % 2 == 0 else -1) if q > 0 else c0
    nr_prev = 0
    nc_prev = 0
    left_todo = npend
    for lev in range(lmax + 1):
        nr = nr_prev
        while nr < nv and math.ceil(abs(v_max_r * rows[nr] / (nv - 1) - v_r) / dv1 - 1e-9) <= lev:
            nr += 1
        nc = nc_prev
        while (
            nc < nth
            and 0 <= cols[nc] < nth
            and math.ceil(abs(-math.pi + 2.0 * math.pi * cols[nc] / nth) / dth1 - 1e-9) <= lev
        ):
            t = cols[nc]
            ccos[t] = math.cos(th_r - math.pi + 2.0 * math.pi * t / nth)
            csin[t] = math.sin(th_r - math.pi + 2.0 * math.pi * t / nth)
            nc += 1
        # New points of this level: new rows x all columns so far, old rows x new columns.
        for part in range(2):
            r_lo, r_hi, c_lo, c_hi = (nr_prev, nr, 0, nc) if part == 0 else (0, nr_prev, nc_prev, nc)
            for ri in range(r_lo, r_hi):
                sp = v_max_r * rows[ri] / (nv - 1)
                for ci in range(c_lo, c_hi):
                    t = cols[ci]
                    vx = sp * ccos[t]
                    vy = sp * csin[t]
                    free = -1  # is the point an open escape? (computed once, when first needed)
                    for q in range(npend):
                        x = pending[q]
                        if need[x] < 0.0 and not in_untruncated_cone(nbs[x], vx, vy):
                            if free < 0:
                                free = 1 if escape_open(nbs, blk, nblk, vx, vy, tmax) else 0
                            if free == 0:
                                continue
                            need[x] = lev
                            left_todo -= 1
                    if left_todo == 0:
                        return
        nr_prev = nr
        nc_prev = nc


@njit(cache=True)
def set_horizons(
    nbs, count, v_r, th_r, v_max_r, dv1, dth1, holo, dt, prm, cspeed, ccol, cstep, ccos, csin, pending, need,
    rows, cols, blk,
):  # fmt: skip
    """T_need and the horizon T_h = min(T_max, T_need + T_m) of every neighbour (vcs-method §2.7), and
    the pruning bounds. T_need is the least reach time over a coarse grid of the VCS domain of
    the points outside the neighbour's untruncated cone (0 if the current velocity is)."""
    vrx = v_r * math.cos(th_r)
    vry = v_r * math.sin(th_r)
    fixed = prm[P_HORIZON]
    tmax = prm[P_TMAX]
    npend = 0
    for q in range(count):
        need[q] = 0.0
        if fixed < 0.0 and in_untruncated_cone(nbs[q], vrx, vry):
            need[q] = -1.0
            pending[npend] = q
            npend += 1
    nblk = 0
    # Contesting movers: non-reactive movers closing on the robot (at its current velocity)
    # that can reach it within T_max. Each can close the escape from another, so the margin of
    # every mover is T_m per contesting mover (capped at T_max): a lone mover keeps the
    # un-conservative T_m, a crowd is watched further ahead (vcs-method §2.7).
    n_contest = 0
    vr_x = v_r * math.cos(th_r)
    vr_y = v_r * math.sin(th_r)
    for q in range(count):
        if nbs[q, F_KIND] == K_MOVER and nbs[q, F_MOVER] < 0.5:
            nb = nbs[q]
            wx = vr_x - nb[F_VJX]
            wy = vr_y - nb[F_VJY]
            closing = (wx * nb[F_PX] + wy * nb[F_PY]) / max(nb[F_D], 1e-12)
            if closing > 0.0 and nb[F_D] - nb[F_R0] <= closing * tmax:
                n_contest += 1
    if prm[P_JOINT] > 0.5:
        for q in range(count):
            if nbs[q, F_KIND] != K_RECIPROCAL:
                blk[nblk] = q
                nblk += 1
    if npend > 0:
        # Levels beyond (T_max - T_m) / dt all give T_h = T_max.
        lmax = int(math.ceil((tmax - prm[P_TM]) / dt - 1e-9))
        if holo:
            build_coarse(
                v_r, th_r, v_max_r, dv1, dth1, holo, int(prm[P_CNV]), int(prm[P_CNTH]), cspeed, ccol, cstep, ccos, csin
            )
            todo = npend
            for c in range(1, cspeed.shape[0]):  # sorted by reach steps: the first hit is the least
                col = ccol[c]
                vx = cspeed[c] * ccos[col] if col >= 0 else vrx
                vy = cspeed[c] * csin[col] if col >= 0 else vry
                free = -1
                for q in range(npend):
                    x = pending[q]
                    if need[x] < 0.0 and not in_untruncated_cone(nbs[x], vx, vy):
                        if free < 0:
                            free = 1 if escape_open(nbs, blk, nblk, vx, vy, tmax) else 0
                        if free == 0:
                            continue
                        need[x] = cstep[c]
                        todo -= 1
                if todo == 0:
                    break
        else:
            need_unicycle(
                nbs,
                pending,
                npend,
                need,
                v_r,
                th_r,
                v_max_r,
                dv1,
                dth1,
                int(prm[P_CNV]),
                int(prm[P_CNTH]),
                lmax,
                rows,
                cols,
                ccos,
                csin,
                blk,
                nblk,
                tmax,
            )
    for q in range(count):
        nb = nbs[q]
        if fixed >= 0.0:  # classic VO (inf) or a fixed horizon
            th = fixed
        else:
            t_need = tmax if need[q] < 0.0 else min(need[q] * dt, tmax)
            if nb[F_MOVER] > 0.5:
                margin = prm[P_TM_ROBOT]
            elif nb[F_KIND] == K_MOVER:
                margin = min(tmax, prm[P_TM] * max(1, n_contest)) if prm[P_CROWD] > 0.5 else prm[P_TM]
            else:
                margin = prm[P_TM]
            if nb[F_STOPK] > 0.0:  # static: the margin covers the robot's own stopping time v_R / a_max
                margin = max(margin, nb[F_STOPK] * v_r)
            th = min(tmax, t_need + margin)
        nb[F_TH] = th
        # Pruning: every candidate has |w| <= scale (v_max + |apex|), so tau >= gap / that.
        if nb[F_OVL] > 0.5:
            nb[F_BOUND] = 0.0
            nb[F_JBOUND] = 0.0
        else:
            gap = nb[F_D] - nb[F_REFF]
            nb[F_BOUND] = gap / (nb[F_SCALE] * (v_max_r + math.sqrt(nb[F_APX] ** 2 + nb[F_APY] ** 2)) + 1e-12)
            nb[F_JBOUND] = gap / (nb[F_JSCALE] * (v_max_r + math.sqrt(nb[F_JAX] ** 2 + nb[F_JAY] ** 2)) + 1e-12)


# Robot context vector (floats) passed to the candidate evaluation.
C_VR, C_TH, C_VMAX, C_DV1, C_DTH1, C_KMAX, C_PVX, C_PVY, C_WG, C_WS, C_WC, C_WR, C_WH, C_WB = range(14)
C_HPREV, C_PDV, C_PDTH, C_HOLO, C_TAUS, C_GV, C_GTH, C_GVCS = 14, 15, 16, 17, 18, 19, 20, 21
C_RAMP, C_DT, C_RAMP_GAP = 22, 23, 24
N_CTX = 25


@njit(cache=True)
def relevant(nbs, order, count, tau_s, adm, js):
    """Neighbours that can matter for some candidate: ``adm`` those that may forbid one
    (tau can fall within T_h), ``js`` those that may enter the safety band. Nearest first.
    Returns both counts."""
    na = 0
    nj = 0
    for q in range(count):
        x = order[q]
        if nbs[x, F_BOUND] <= nbs[x, F_TH]:
            adm[na] = x
            na += 1
        if nbs[x, F_JBOUND] <= nbs[x, F_TH] + tau_s:
            js[nj] = x
            nj += 1
    return na, nj


@njit(cache=True)
def admissible(nbs, adm, na, vx, vy):
    """Outside every neighbour's truncated forbidden set (vcs-method §2.11)."""
    for q in range(na):
        if forbidden(nbs[adm[q]], vx, vy):
            return False
    return True


@njit(cache=True)
def goal_term(ctx, dv, dth, vx, vy):
    """J_g in [0, 1]: distance to the goal point, in the VCS (``goal_metric="vcs"``) or in
    velocity space (``"velocity"``: |v - v_pref| / (2 v_max), the RVO distance) (vcs-method §2.12)."""
    if ctx[C_GVCS] > 0.5:
        return (
            math.sqrt(((dv - ctx[C_GV]) / ctx[C_VMAX]) ** 2 + (wrap(dth - ctx[C_GTH]) / math.pi) ** 2)
            * 0.7071067811865476
        )
    return math.sqrt((vx - ctx[C_PVX]) ** 2 + (vy - ctx[C_PVY]) ** 2) / (2.0 * ctx[C_VMAX])


@njit(cache=True)
def cost_parts(ctx, dv, dth, vx, vy, steps, bound):
    """The terms of J that do not depend on neighbours (vcs-method §2.12), a lower bound of J. Stops
    early (returning a value >= bound) once the partial sum reaches ``bound``."""
    v_max = ctx[C_VMAX]
    j = ctx[C_WG] * goal_term(ctx, dv, dth, vx, vy)
    if j >= bound:
        return j
    j += ctx[C_WR] * steps / ctx[C_KMAX]
    if dth > 0.0:
        j += ctx[C_WB] * dth / math.pi
    j += ctx[C_WC] * math.sqrt((dv / v_max) ** 2 + (dth / math.pi) ** 2) * 0.7071067811865476
    if j >= bound:
        return j
    if ctx[C_HPREV] > 0.5:
        j += (
            ctx[C_WH]
            * math.sqrt(((dv - ctx[C_PDV]) / v_max) ** 2 + (wrap(dth - ctx[C_PDTH]) / math.pi) ** 2)
            * 0.7071067811865476
        )
    return j


@njit(cache=True)
def safety_term(nbs, js, nj, ctx, vx, vy):
    """J_s: soft band just beyond each neighbour's horizon (vcs-method §2.12)."""
    out = 0.0
    tau_s = ctx[C_TAUS]
    for q in range(nj):
        nb = nbs[js[q]]
        sc = nb[F_JSCALE]
        wx = sc * (vx - nb[F_JAX])
        wy = sc * (vy - nb[F_JAY])
        if not tau_within(nb[F_PX], nb[F_PY], wx, wy, nb[F_REFF], nb[F_TH] + tau_s):
            continue  # beyond the band: contributes 0
        tc = tau(nb[F_PX], nb[F_PY], wx, wy, nb[F_REFF])
        val = min(max(1.0 - (tc - nb[F_TH]) / tau_s, 0.0), 1.0)
        if val > out:
            out = val
    return out


@njit(cache=True)
def cost(nbs, js, nj, ctx, dv, dth, vx, vy, steps):
    """Multi-objective cost J of a candidate (vcs-method §2.12)."""
    j = cost_parts(ctx, dv, dth, vx, vy, steps, INF)
    if ctx[C_WS] > 0.0:
        j += ctx[C_WS] * safety_term(nbs, js, nj, ctx, vx, vy)
    return j


@njit(cache=True)
def ramp_clear(nbs, count, ctx, dv, dth):
    """Admissible along the way (vcs-method §2.15): the motion that reaches the candidate, speed
    and heading ramping at the maximal per-step rates (a holonomic velocity along the straight
    line), keeps clear of every non-reactive neighbour, extrapolated at its velocity. The
    velocity obstacles judge the end velocity only, as if it were reached at once; a turn that
    sweeps through a parked robot on the way is caught here. Clear means a gap of at least
    delta_min / 2, or no smaller than now if the robot is already closer."""
    if ctx[C_RAMP] < 0.5:
        return True
    v_r = ctx[C_VR]
    th_r = ctx[C_TH]
    dv1 = ctx[C_DV1]
    dth1 = ctx[C_DTH1]
    dt = ctx[C_DT]
    holo = ctx[C_HOLO] > 0.5
    vrx = v_r * math.cos(th_r)
    vry = v_r * math.sin(th_r)
    steps = reach_steps(dv, dth, dv1, dth1, holo, vrx, vry, th_r, v_r)
    if steps <= 1:
        return True  # reached within the step: the velocity obstacles judge it
    s_end = v_r + dv
    ex = s_end * math.cos(th_r + dth) - vrx
    ey = s_end * math.sin(th_r + dth) - vry
    e = math.sqrt(ex * ex + ey * ey)
    px = 0.0
    py = 0.0
    for k in range(1, steps + 1):
        if holo:
            f = min(1.0, k * dv1 / max(e, 1e-12))
            vx = vrx + f * ex
            vy = vry + f * ey
        else:
            sk = v_r + min(max(dv, -k * dv1), k * dv1)
            tk = th_r + min(max(dth, -k * dth1), k * dth1)
            vx = sk * math.cos(tk)
            vy = sk * math.sin(tk)
        px += vx * dt
        py += vy * dt
        t = k * dt
        for q in range(count):
            nb = nbs[q]
            if nb[F_KIND] == K_RECIPROCAL or nb[F_OVL] > 0.5:
                continue
            gx = nb[F_PX] + nb[F_VJX] * t - px
            gy = nb[F_PY] + nb[F_VJY] * t - py
            clear = min(nb[F_R0] + ctx[C_RAMP_GAP], nb[F_D])
            if gx * gx + gy * gy < clear * clear:
                return False
    return True


@njit(cache=True)
def consider(nbs, adm, na, js, nj, count, ctx, dv, dth, vx, vy, steps, best):
    """J of a candidate if it is admissible (also along the way) and may beat ``best``, else inf."""
    j = cost_parts(ctx, dv, dth, vx, vy, steps, best)
    if j >= best:
        return INF  # J_s >= 0: cannot win (ties keep the earlier candidate)
    if not admissible(nbs, adm, na, vx, vy):
        return INF
    if ctx[C_WS] > 0.0:
        j += ctx[C_WS] * safety_term(nbs, js, nj, ctx, vx, vy)
    if j < best and not ramp_clear(nbs, count, ctx, dv, dth):
        return INF
    return j


@njit(cache=True)
def fallback_cost(nbs, count, ctx, dv, dth, vx, vy, kappa, least_harm, tmax):
    """Cost of a candidate when nothing is admissible (vcs-method §2.13). The RVO-style penalty
    ``kappa / t_c + J_g`` (t_c: the least time to collision over the neighbours), and with
    ``least_harm``: an overlap counts by how much the candidate fails to separate (the overlap
    half-plane's violation [m/s], weighted kappa / dt), and a candidate that speeds up while it
    closes faster than now on something it would hit within T_max (or already touches) is
    refused (inf): braking and turning away remain, and keeping the current velocity always
    does (vcs-method §2.13)."""
    tmin = INF
    viol = 0.0
    v_r = ctx[C_VR]
    vrx = v_r * math.cos(ctx[C_TH])
    vry = v_r * math.sin(ctx[C_TH])
    # The velocity after the first step toward the candidate (what this period commands).
    if ctx[C_HOLO] > 0.5:
        ex = vx - vrx
        ey = vy - vry
        f = min(1.0, ctx[C_DV1] / max(math.sqrt(ex * ex + ey * ey), 1e-12))
        v1x = vrx + f * ex
        v1y = vry + f * ey
    else:
        s1 = v_r + min(max(dv, -ctx[C_DV1]), ctx[C_DV1])
        th1 = ctx[C_TH] + min(max(dth, -ctx[C_DTH1]), ctx[C_DTH1])
        v1x = s1 * math.cos(th1)
        v1y = s1 * math.sin(th1)
    for q in range(count):
        nb = nbs[q]
        if least_harm and nb[F_OVL] > 0.5:
            e = nb[F_HX] * (vx - nb[F_APX]) + nb[F_HY] * (vy - nb[F_APY])
            if e > viol:
                viol = e
            tc = 0.0
        else:
            tc = collision_time(nb, vx, vy)
            if tc < tmin:
                tmin = tc
        if least_harm and dv > 1e-12 and (nb[F_OVL] > 0.5 or nb[F_TC0] <= tmax or collision_time(nb, v1x, v1y) <= tmax):
            # The first step toward the candidate must not close faster on the threat than now.
            ux = nb[F_PX] / max(nb[F_D], 1e-12)
            uy = nb[F_PY] / max(nb[F_D], 1e-12)
            if (v1x - vrx) * ux + (v1y - vry) * uy > 1e-12:
                return INF  # speeds up toward a threat
    if least_harm:
        return kappa / max(tmin, 1e-9) + kappa / ctx[C_DT] * viol + goal_term(ctx, dv, dth, vx, vy)
    return kappa / max(tmin, 1e-9) + goal_term(ctx, dv, dth, vx, vy)


@njit(cache=True)
def robot_context(b, i, heading, speed, v_max, a_max, omega_max, vpref, no_safety, prev, has_prev, prm, dt, holo):
    ctx = np.empty(N_CTX)
    v_r = speed[b, i]
    ctx[C_VR] = v_r
    ctx[C_TH] = heading[b, i]
    ctx[C_VMAX] = v_max[b, i]
    dv1 = a_max[b, i] * dt
    ctx[C_DV1] = dv1
    if holo:
        ctx[C_DTH1] = math.pi
        ctx[C_KMAX] = max(math.ceil(2.0 * v_max[b, i] / dv1 - 1e-9), 1.0)
    else:
        dth1 = omega_max[b, i] * dt
        ctx[C_DTH1] = dth1
        ctx[C_KMAX] = max(math.ceil(v_max[b, i] / dv1 - 1e-9), math.ceil(math.pi / dth1 - 1e-9))
    ctx[C_PVX] = vpref[b, i, 0]
    ctx[C_PVY] = vpref[b, i, 1]
    ctx[C_WG] = prm[P_WG]
    # A detour after a stall (vcs-method §2.13) drops the safety band and the smoothness terms, which can
    # otherwise make staying stopped cheaper than the large turn the robot needs.
    detour = no_safety[b, i]
    ctx[C_WS] = 0.0 if detour else prm[P_WS]
    ctx[C_WC] = 0.0 if detour else prm[P_WC]
    ctx[C_WR] = 0.0 if detour else prm[P_WR]
    ctx[C_WH] = 0.0 if detour else prm[P_WH]
    ctx[C_WB] = prm[P_WB]
    ctx[C_HPREV] = 1.0 if has_prev[b, i] else 0.0
    ctx[C_PDV] = prev[b, i, 0]
    ctx[C_PDTH] = prev[b, i, 1]
    ctx[C_HOLO] = 1.0 if holo else 0.0
    ctx[C_TAUS] = prm[P_TAU_S]
    # Goal point G = M^-1(v_pref) (vcs-method §2.9); G = (-v_R, 0) when v_pref = 0.
    pvx = vpref[b, i, 0]
    pvy = vpref[b, i, 1]
    ps = math.sqrt(pvx * pvx + pvy * pvy)
    if ps > 1e-12:
        ctx[C_GV] = ps - v_r
        ctx[C_GTH] = wrap(math.atan2(pvy, pvx) - heading[b, i])
    else:
        ctx[C_GV] = -v_r
        ctx[C_GTH] = 0.0
    ctx[C_GVCS] = prm[P_GMETRIC]
    ctx[C_RAMP] = prm[P_RAMP]
    ctx[C_DT] = dt
    ctx[C_RAMP_GAP] = 0.5 * prm[P_DELTA_MIN]
    return ctx


@njit(cache=True)
def neighbour_work(n, m, prm):
    """Work arrays of :func:`prepare_robot` for ``n`` robots and ``m`` obstacles."""
    ctotal = int(prm[P_CNV]) * int(prm[P_CNTH]) + 1
    return (
        np.zeros((2 * n + m, N_FIELDS)),  # nbs: neighbour records (arriving robots have a static twin)
        np.zeros(2 * n + m, dtype=np.int64),  # order: nearest surface first
        np.empty(ctotal),  # cspeed, ccol, cstep: sorted coarse grid (holonomic)
        np.empty(ctotal, dtype=np.int64),
        np.empty(ctotal),
        np.empty(int(prm[P_CNTH])),  # ccos, csin: coarse column directions
        np.empty(int(prm[P_CNTH])),
        np.empty(2 * n + m, dtype=np.int64),  # pending: cones holding the current velocity
        np.empty(2 * n + m),  # need: T_need / dt per neighbour
        np.empty(int(prm[P_CNV]), dtype=np.int64),  # rows, cols: coarse grid by level
        np.empty(int(prm[P_CNTH]), dtype=np.int64),
        np.empty(2 * n + m, dtype=np.int64),  # blk: non-reactive neighbours that can close an escape
    )


@njit(cache=True)
def prepare_robot(
    b, i, pos, heading, speed, radius, v_max, a_max, omega_max, active, present, obs_pos, obs_vel, obs_radius,
    vpref, pref_comm, no_safety, prev, has_prev, prm, r_ca, dt, holo, work,
):  # fmt: skip
    """Robot i of world b: its context vector and its neighbour records with horizons (vcs-method §2.6-2.7).
    Returns ``(ctx, count)``; the records are in ``work[0]``, ordered by ``work[1]``."""
    nbs, order, cspeed, ccol, cstep, ccos, csin, pending, need, rows, cols, blk = work
    ctx = robot_context(b, i, heading, speed, v_max, a_max, omega_max, vpref, no_safety, prev, has_prev, prm, dt, holo)
    count = setup_neighbors(
        b, i, pos, heading, speed, radius, active, present, obs_pos, obs_vel, obs_radius, pref_comm, v_max, a_max, prm,
        r_ca, dt, nbs, order, no_safety[b, i],
    )  # fmt: skip
    set_horizons(
        nbs, count, ctx[C_VR], ctx[C_TH], ctx[C_VMAX], ctx[C_DV1], ctx[C_DTH1], holo, dt, prm, cspeed, ccol, cstep,
        ccos, csin, pending, need, rows, cols, blk,
    )  # fmt: skip
    return ctx, count


@njit(cache=True)
def candidate(c, ngrid, nv, nth, full, lo_v, hi_v, half, gv, gth, g1v, g1th, v_r, vmax):
    """Candidate c of the point search (vcs-method §2.11): the window grid, then G (clipped to the domain
    D), the origin (keep the current velocity) and the one-step-clipped G."""
    if c < ngrid:
        ai = c // nth
        ti = c % nth
        dv = lo_v + (hi_v - lo_v) * ai / (nv - 1)
        if full:
            dth = -math.pi + 2.0 * math.pi * ti / nth
        else:
            dth = -half + 2.0 * half * ti / (nth - 1)
        return dv, dth
    if c == ngrid:
        return min(max(gv, -v_r), vmax - v_r), gth
    if c == ngrid + 1:
        return 0.0, 0.0
    return g1v, g1th


@njit(cache=True)
def plan_batch(
    pos,
    heading,
    speed,
    radius,
    v_max,
    a_max,
    omega_max,
    active,
    present,
    obs_pos,
    obs_vel,
    obs_radius,
    vpref,
    pref_comm,
    no_safety,
    prev,
    has_prev,
    prm,
    r_ca,
    dt,
    holo,
    out_target,
    out_cost,
    out_fallback,
    out_k,
    out_tstar,
    out_threats,
    out_g1,
):
    """Plan every active robot of every world (vcs-method §2.14). Outputs per robot: the target VCS
    point (dv*, dtheta*), its cost J, whether the fallback was used, the window size k*, the
    first threat time t*, the number of threats and the one-step-clipped goal point."""
    B = pos.shape[0]
    n = pos.shape[1]
    m = obs_pos.shape[1]
    work = neighbour_work(n, m, prm)
    nbs, order = work[0], work[1]
    nv = int(prm[P_NV])
    margin = prm[P_MARGIN]
    gmax = nv * max(int(prm[P_NTH]), int(prm[P_NTH_FULL]))
    cheap = np.empty(gmax)
    adm = np.zeros(2 * n + m, dtype=np.int64)
    js = np.zeros(2 * n + m, dtype=np.int64)
    thmax = max(int(prm[P_NTH]), int(prm[P_NTH_FULL]))
    dv_row = np.empty(nv)
    kv_row = np.empty(nv)
    dth_col = np.empty(thmax)
    kt_col = np.empty(thmax)
    cth = np.empty(thmax)
    sth = np.empty(thmax)
    e_col = np.empty(thmax)
    g_col = np.empty(thmax)
    c_col = np.empty(thmax)
    h_col = np.empty(thmax)
    b_col = np.empty(thmax)
    kappa = prm[P_KAPPA]
    least_harm = prm[P_LEAST_HARM] > 0.5
    for b in range(B):
        for i in range(n):
            if not active[b, i]:
                out_target[b, i, 0] = 0.0
                out_target[b, i, 1] = 0.0
                out_cost[b, i] = 0.0
                out_fallback[b, i] = False
                out_k[b, i] = 0
                out_tstar[b, i] = INF
                out_threats[b, i] = 0
                continue
            ctx, count = prepare_robot(
                b, i, pos, heading, speed, radius, v_max, a_max, omega_max, active, present, obs_pos, obs_vel,
                obs_radius, vpref, pref_comm, no_safety, prev, has_prev, prm, r_ca, dt, holo, work,
            )  # fmt: skip
            v_r = ctx[C_VR]
            th_r = ctx[C_TH]
            vmax = ctx[C_VMAX]
            dv1 = ctx[C_DV1]
            dth1 = ctx[C_DTH1]
            kmax = ctx[C_KMAX]
            vrx = v_r * math.cos(th_r)
            vry = v_r * math.sin(th_r)
            # Threats: the current course collides within the horizon (vcs-method §2.7); the window
            # is sized by the first (vcs-method §2.10).
            tstar = INF
            threats = 0
            for q in range(count):
                tc0 = nbs[q, F_TC0]
                if tc0 < INF and tc0 <= nbs[q, F_TH]:
                    threats += 1
                    if tc0 < tstar:
                        tstar = tc0
            if prm[P_ONE_STEP] > 0.5:
                k = 1.0
            elif tstar == INF:
                k = kmax
            else:
                k = min(max(math.floor((tstar - margin * dt) / dt + 1e-9), 1.0), kmax)
            lo_v = max(-v_r, -k * dv1)
            hi_v = min(vmax - v_r, k * dv1)
            half = min(math.pi, k * dth1)
            if holo:
                lo_v = -v_r
                hi_v = vmax - v_r
            full = half >= math.pi - 1e-12
            nth = int(prm[P_NTH_FULL]) if full else int(prm[P_NTH])
            # Goal point G (vcs-method §2.9) and its one-step clip.
            pvx = ctx[C_PVX]
            pvy = ctx[C_PVY]
            ps = math.sqrt(pvx * pvx + pvy * pvy)
            if ps > 1e-12:
                gv = ps - v_r
                gth = wrap(math.atan2(pvy, pvx) - th_r)
            else:
                gv = -v_r
                gth = 0.0
            if holo:
                ex = pvx - vrx
                ey = pvy - vry
                e = math.sqrt(ex * ex + ey * ey)
                if e > dv1:
                    ex *= dv1 / e
                    ey *= dv1 / e
                s1 = math.sqrt((vrx + ex) ** 2 + (vry + ey) ** 2)
                g1v = s1 - v_r
                g1th = wrap(math.atan2(vry + ey, vrx + ex) - th_r) if s1 > 1e-12 else 0.0
            else:
                g1v = min(max(gv, max(-v_r, -dv1)), min(vmax - v_r, dv1))
                g1th = min(max(gth, -dth1), dth1)
            out_g1[b, i, 0] = g1v
            out_g1[b, i, 1] = g1th
            ngrid = nv * nth
            # Rows (speed change) and columns (direction change) of the grid, precomputed.
            for a in range(nv):
                dv_row[a] = lo_v + (hi_v - lo_v) * a / (nv - 1)
                kv_row[a] = math.ceil(abs(dv_row[a]) / dv1 - 1e-9)
            for t in range(nth):
                dth = -math.pi + 2.0 * math.pi * t / nth if full else -half + 2.0 * half * t / (nth - 1)
                dth_col[t] = dth
                kt_col[t] = math.ceil(abs(dth) / dth1 - 1e-9)
                cth[t] = math.cos(th_r + dth)
                sth[t] = math.sin(th_r + dth)
            na, nj = relevant(nbs, order, count, ctx[C_TAUS], adm, js)
            best = INF
            best_c = -1
            bdv = 0.0
            bdth = 0.0
            # The three extra points first: a good early best prunes much of the grid.
            for c in range(ngrid, ngrid + 3):
                dv, dth = candidate(c, ngrid, nv, nth, full, lo_v, hi_v, half, gv, gth, g1v, g1th, v_r, vmax)
                s = v_r + dv
                j = consider(
                    nbs,
                    adm,
                    na,
                    js,
                    nj,
                    count,
                    ctx,
                    dv,
                    dth,
                    s * math.cos(th_r + dth),
                    s * math.sin(th_r + dth),
                    reach_steps(dv, dth, dv1, dth1, holo, vrx, vry, th_r, v_r),
                    best,
                )
                if j < best:
                    best = j
                    bdv = dv
                    bdth = dth
            # Grid: the neighbour-free part of J ("cheap") is a lower bound of J. Its rows and
            # columns are separable, so the per-point work is three square roots.
            inv_v = 1.0 / vmax
            pv2 = pvx * pvx + pvy * pvy
            vcs_goal = ctx[C_GVCS] > 0.5
            for t in range(nth):
                # J_g^2 = g_row[a] + g_mul[a] e_col[t] + g_col[t] (separable in both metrics)
                if vcs_goal:
                    e_col[t] = 0.0
                    g_col[t] = 0.5 * (wrap(dth_col[t] - ctx[C_GTH]) / math.pi) ** 2
                else:
                    e_col[t] = cth[t] * pvx + sth[t] * pvy
                    g_col[t] = 0.0
                c_col[t] = (dth_col[t] / math.pi) ** 2
                h_col[t] = (wrap(dth_col[t] - ctx[C_PDTH]) / math.pi) ** 2 if ctx[C_HPREV] > 0.5 else 0.0
                b_col[t] = ctx[C_WB] * max(dth_col[t], 0.0) / math.pi
            wg = ctx[C_WG] if vcs_goal else ctx[C_WG] * 0.5 * inv_v
            wc = ctx[C_WC] * 0.7071067811865476
            wh = ctx[C_WH] * 0.7071067811865476 if ctx[C_HPREV] > 0.5 else 0.0
            wr = ctx[C_WR] / ctx[C_KMAX]
            for a in range(nv):
                s = v_r + dv_row[a]
                c_row = (dv_row[a] * inv_v) ** 2
                h_row = ((dv_row[a] - ctx[C_PDV]) * inv_v) ** 2
                if vcs_goal:
                    g_row = 0.5 * ((dv_row[a] - ctx[C_GV]) * inv_v) ** 2
                    g_mul = 0.0
                else:
                    g_row = s * s + pv2
                    g_mul = -2.0 * s
                kv = kv_row[a]
                base = a * nth
                for t in range(nth):
                    steps = max(kv, kt_col[t])
                    cheap[base + t] = (
                        wg * math.sqrt(max(g_row + g_mul * e_col[t] + g_col[t], 0.0))
                        + wc * math.sqrt(c_row + c_col[t])
                        + wh * math.sqrt(h_row + h_col[t])
                        + wr * steps
                        + b_col[t]
                    )
            if holo:  # the holonomic window is a disc of radius k a_max dt around the velocity
                for a in range(nv):
                    s = v_r + dv_row[a]
                    for t in range(nth):
                        steps = math.ceil(math.sqrt((s * cth[t] - vrx) ** 2 + (s * sth[t] - vry) ** 2) / dv1 - 1e-9)
                        c = a * nth + t
                        if steps > k:
                            cheap[c] = INF
                        else:
                            cheap[c] += wr * (steps - max(kv_row[a], kt_col[t]))
            lo_c = INF
            hi_c = 0.0
            for c in range(ngrid):
                if cheap[c] < lo_c:
                    lo_c = cheap[c]
                if cheap[c] > hi_c and cheap[c] < INF:
                    hi_c = cheap[c]
            # Sweep thresholds upward from the least lower bound: J = cheap + w_s J_s with
            # J_s in [0, 1], so points with cheap >= best cannot win. Each pass visits the
            # points with cheap in [t_prev, t) (each point once), the band doubling each pass.
            delta = max(ctx[C_WS], 0.02)
            t_prev = -INF
            t_cur = lo_c + delta
            while True:
                for c in range(ngrid):
                    x = cheap[c]
                    if x < t_prev or x >= t_cur or x >= best:
                        continue
                    a = c // nth
                    t = c % nth
                    s = v_r + dv_row[a]
                    vx = s * cth[t]
                    vy = s * sth[t]
                    if not admissible(nbs, adm, na, vx, vy):
                        continue
                    j = x
                    if ctx[C_WS] > 0.0:
                        j += ctx[C_WS] * safety_term(nbs, js, nj, ctx, vx, vy)
                    if j < best or (j == best and c < best_c):
                        if not ramp_clear(nbs, count, ctx, dv_row[a], dth_col[t]):
                            continue
                        best = j
                        best_c = c
                        bdv = dv_row[a]
                        bdth = dth_col[t]
                if t_cur >= best or t_cur > hi_c:
                    break
                t_prev = t_cur
                delta *= 2.0
                t_cur = lo_c + delta
            fell_back = best == INF
            if fell_back:
                for c in range(ngrid + 3):
                    dv, dth = candidate(c, ngrid, nv, nth, full, lo_v, hi_v, half, gv, gth, g1v, g1th, v_r, vmax)
                    if holo and c < ngrid and reach_steps(dv, dth, dv1, dth1, holo, vrx, vry, th_r, v_r) > k:
                        continue
                    s = v_r + dv
                    j = fallback_cost(
                        nbs, count, ctx, dv, dth, s * math.cos(th_r + dth), s * math.sin(th_r + dth), kappa,
                        least_harm, prm[P_TMAX],
                    )  # fmt: skip
                    if j < best:
                        best = j
                        bdv = dv
                        bdth = dth
            out_target[b, i, 0] = bdv
            out_target[b, i, 1] = bdth
            out_cost[b, i] = best
            out_fallback[b, i] = fell_back
            out_k[b, i] = int(k)
            out_tstar[b, i] = tstar
            out_threats[b, i] = threats


@njit(cache=True)
def evaluate_points(
    b,
    i,
    pos,
    heading,
    speed,
    radius,
    v_max,
    a_max,
    omega_max,
    active,
    present,
    obs_pos,
    obs_vel,
    obs_radius,
    vpref,
    pref_comm,
    no_safety,
    prev,
    has_prev,
    prm,
    r_ca,
    dt,
    holo,
    cand_dv,
    cand_dth,
    out_ok,
    out_cost,
    out_horizon,
):
    """Admissibility and cost of arbitrary VCS points for robot i of world b (tests, plots).
    ``out_horizon`` receives the horizon T_h of each sensed object (robots first, then
    obstacles, in index order, then the static twins of arriving robots by robot index; inf
    when not sensed)."""
    n = pos.shape[1]
    m = obs_pos.shape[1]
    work = neighbour_work(n, m, prm)
    nbs, order = work[0], work[1]
    ctx, count = prepare_robot(
        b, i, pos, heading, speed, radius, v_max, a_max, omega_max, active, present, obs_pos, obs_vel, obs_radius,
        vpref, pref_comm, no_safety, prev, has_prev, prm, r_ca, dt, holo, work,
    )  # fmt: skip
    v_r = ctx[C_VR]
    th_r = ctx[C_TH]
    vrx = v_r * math.cos(th_r)
    vry = v_r * math.sin(th_r)
    adm = np.zeros(2 * n + m, dtype=np.int64)
    js = np.zeros(2 * n + m, dtype=np.int64)
    na, nj = relevant(nbs, order, count, ctx[C_TAUS], adm, js)
    for c in range(cand_dv.shape[0]):
        dv = cand_dv[c]
        dth = cand_dth[c]
        s = v_r + dv
        vx = s * math.cos(th_r + dth)
        vy = s * math.sin(th_r + dth)
        out_ok[c] = admissible(nbs, adm, na, vx, vy) and ramp_clear(nbs, count, ctx, dv, dth)
        steps = reach_steps(dv, dth, ctx[C_DV1], ctx[C_DTH1], holo, vrx, vry, th_r, v_r)
        out_cost[c] = cost(nbs, js, nj, ctx, dv, dth, vx, vy, steps)
    for q in range(out_horizon.shape[0]):
        out_horizon[q] = INF
    for q in range(count):
        twin = nbs[q, F_KIND] == K_STATIC and nbs[q, F_MOVER] > 0.5  # an active robot taken as static
        out_horizon[int(nbs[q, F_IDX]) + (n + m if twin else 0)] = nbs[q, F_TH]
