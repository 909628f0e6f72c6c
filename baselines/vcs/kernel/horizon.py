"""Stage 2, horizons: the time T_need to leave each cone and the horizon T_h = min(T_max,
T_need + T_m) of every neighbour record (vcs-method §2.7), with the pruning bounds."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .neighbours import forbidden_within, in_untruncated_cone
from .records import K_MOVER, K_RECIPROCAL, STEP_SLACK, TINY
from .scalar import steps_for


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
        kv = steps_for(dv, dv1)
        for t in range(nth):
            if holo:
                s = v_r + dv
                k = math.ceil(math.sqrt((s * ccos[t] - vrx) ** 2 + (s * csin[t] - vry) ** 2) / dv1 - STEP_SLACK)
            else:
                kt = steps_for(-math.pi + 2.0 * math.pi * t / nth, dth1)
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
def mark_escapes(nbs, pending, need, blk, npend, nblk, vx, vy, level, tmax):
    """Pending cones that point (vx, vy) leaves through an open escape get T_need / dt = ``level``.
    Returns how many it settled."""
    free = -1  # is the point an open escape? (computed once, when first needed)
    done = 0
    for q in range(npend):
        x = pending[q]
        if need[x] < 0.0 and not in_untruncated_cone(nbs[x], vx, vy):
            if free < 0:
                free = 1 if escape_open(nbs, blk, nblk, vx, vy, tmax) else 0
            if free == 0:
                continue
            need[x] = level
            done += 1
    return done


@njit(cache=True)
def order_axes(rows, cols, v_r, v_max_r, nv, nth):
    """Coarse rows (speeds v_max a / (nv - 1)) ordered by |speed change| outward from v_r, and
    columns (directions -pi + 2 pi t / nth) by |direction change| outward from 0."""
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
    c0 = nth // 2
    for q in range(nth):
        cols[q] = c0 + ((q + 1) // 2) * (1 if q % 2 == 0 else -1) if q > 0 else c0


@njit(cache=True)
def need_unicycle(wk, npend, nblk, r, nv, nth, lmax, tmax):
    """T_need / dt of the pending neighbours (whose cone holds the current velocity): the least
    reach level of a coarse-grid point outside the cone that is an escape (vcs-method §2.7,
    :func:`escape_open`).

    A unicycle's reach level is max(speed level, turn level), so the points of level <= L are
    the rows of speed level <= L times the columns of turn level <= L. Rows and columns are
    ordered by level (outward from "no change"), and each level adds a border of new points;
    points are visited level by level until every pending cone is left (or ``lmax``).
    """
    rows, cols, ccos, csin = wk.rows, wk.cols, wk.ccos, wk.csin
    nbs, pending, need, blk = wk.nbs, wk.pending, wk.need, wk.blk
    v_r, v_max, dv1, dth1, th = r.v_r, r.v_max, r.dv1, r.dth1, r.th  # locals: stores cannot change them
    order_axes(rows, cols, v_r, v_max, nv, nth)
    nr_prev = 0
    nc_prev = 0
    left_todo = npend
    for lev in range(lmax + 1):
        nr = nr_prev
        while nr < nv and steps_for(v_max * rows[nr] / (nv - 1) - v_r, dv1) <= lev:
            nr += 1
        nc = nc_prev
        while nc < nth and 0 <= cols[nc] < nth and steps_for(-math.pi + 2.0 * math.pi * cols[nc] / nth, dth1) <= lev:
            t = cols[nc]
            ccos[t] = math.cos(th - math.pi + 2.0 * math.pi * t / nth)
            csin[t] = math.sin(th - math.pi + 2.0 * math.pi * t / nth)
            nc += 1
        # New points of this level: new rows x all columns so far, old rows x new columns.
        for part in range(2):
            r_lo, r_hi, c_lo, c_hi = (nr_prev, nr, 0, nc) if part == 0 else (0, nr_prev, nc_prev, nc)
            for ri in range(r_lo, r_hi):
                sp = v_max * rows[ri] / (nv - 1)
                for ci in range(c_lo, c_hi):
                    t = cols[ci]
                    left_todo -= mark_escapes(
                        nbs, pending, need, blk, npend, nblk, sp * ccos[t], sp * csin[t], lev, tmax
                    )
                    if left_todo == 0:
                        return
        nr_prev = nr
        nc_prev = nc


@njit(cache=True)
def need_holonomic(wk, npend, nblk, r, nv, nth, tmax):
    """T_need / dt of the pending neighbours of a holonomic robot: the coarse grid sorted by
    reach steps, so the first open escape out of a cone is the least (vcs-method §2.7)."""
    build_coarse(r.v_r, r.th, r.v_max, r.dv1, r.dth1, True, nv, nth, wk.cspeed, wk.ccol, wk.cstep, wk.ccos, wk.csin)
    todo = npend
    nbs, pending, need, blk = wk.nbs, wk.pending, wk.need, wk.blk
    cspeed, ccol, cstep, ccos, csin = wk.cspeed, wk.ccol, wk.cstep, wk.ccos, wk.csin
    vrx, vry = r.vrx, r.vry
    for c in range(1, cspeed.shape[0]):
        col = ccol[c]
        vx = cspeed[c] * ccos[col] if col >= 0 else vrx
        vy = cspeed[c] * csin[col] if col >= 0 else vry
        todo -= mark_escapes(nbs, pending, need, blk, npend, nblk, vx, vy, cstep[c], tmax)
        if todo == 0:
            break


@njit(cache=True)
def contesting_movers(nbs, count, r, tmax, reach):
    """Non-reactive movers that can contest the robot's escapes within T_max. Each can close
    the escape from another, so the margin of every mover is T_m per contesting mover (not
    capped at T_max): a lone mover keeps the un-conservative T_m, a crowd is watched further
    ahead (vcs-method §2.7).

    ``reach=False`` counts the movers closing on the robot at its current velocity that reach
    it within T_max (gap <= closing speed T_max). ``reach=True`` counts every mover the robot
    could meet within T_max whatever velocity it picks: gap <= (v_max + the mover's approach
    speed, if positive) T_max. A slow or stopped robot closes on nothing, yet the crowd around
    it still closes its escapes; the reach count is a superset of the closing count."""
    n_contest = 0
    for q in range(count):
        nb = nbs[q]
        if nb.kind == K_MOVER and not nb.mover:
            inv_d = 1.0 / max(nb.d, TINY)
            approach = -(nb.vjx * nb.px + nb.vjy * nb.py) * inv_d  # mover's speed towards the robot [m/s]
            gap = nb.d - nb.r0
            if reach:
                if gap <= (r.v_max + max(approach, 0.0)) * tmax:
                    n_contest += 1
            else:
                closing = (r.vrx * nb.px + r.vry * nb.py) * inv_d + approach
                if closing > 0.0 and gap <= closing * tmax:
                    n_contest += 1
    return n_contest


@njit(cache=True)
def horizon_of(nb, need, p, v_r, dt, n_contest):
    """T_h = min(T_max, T_need + T_m) of one record, T_m by kind (vcs-method §2.7); a
    non-reactive mover under the crowd margin gets T_need + T_m n_contest, uncapped."""
    if p.horizon >= 0.0:  # classic VO (inf) or a fixed horizon
        return p.horizon
    tmax = p.t_max
    t_need = tmax if need < 0.0 else min(need * dt, tmax)
    if nb.mover:
        margin = p.t_margin_robots
    elif nb.kind == K_MOVER:
        if p.crowd_margin:  # T_m per contesting mover, not capped at T_max (vcs-method §2.7)
            return t_need + p.t_margin * max(1, n_contest)
        margin = p.t_margin
    else:
        margin = p.t_margin
    if nb.stopk > 0.0:  # static: the margin covers the robot's own stopping time v_R / a_max
        margin = max(margin, nb.stopk * v_r)
    return min(tmax, t_need + margin)


@njit(cache=True)
def set_horizons(wk, count, r, p):
    """T_need and the horizon T_h of every record (vcs-method §2.7), and the pruning bounds.
    T_need is the least reach time over a coarse grid of the VCS domain of the points outside
    the neighbour's untruncated cone (0 if the current velocity is)."""
    nbs, need, pending = wk.nbs, wk.need, wk.pending
    tmax = p.t_max
    adaptive = p.horizon < 0.0
    vrx, vry = r.vrx, r.vry  # locals: stores cannot change them
    npend = 0
    for q in range(count):
        need[q] = 0.0
        if adaptive and in_untruncated_cone(nbs[q], vrx, vry):
            need[q] = -1.0
            pending[npend] = q
            npend += 1
    n_contest = contesting_movers(nbs, count, r, tmax, p.crowd_reach)
    nblk = 0
    if p.joint_escape:
        for q in range(count):
            if nbs[q].kind != K_RECIPROCAL:
                wk.blk[nblk] = q
                nblk += 1
    if npend > 0:
        if r.holo:
            need_holonomic(wk, npend, nblk, r, p.coarse_n_v, p.coarse_n_theta, tmax)
        else:
            # Levels beyond (T_max - t_margin) / dt give every capped record T_h = T_max; a mover under the
            # crowd margin (uncapped) left there gets T_need = T_max, a horizon up to t_margin longer, never shorter.
            lmax = int(math.ceil((tmax - p.t_margin) / r.dt - STEP_SLACK))
            need_unicycle(wk, npend, nblk, r, p.coarse_n_v, p.coarse_n_theta, lmax, tmax)
    apply_horizons(wk, count, r, p, n_contest)


@njit(cache=True)
def apply_horizons(wk, count, r, p, n_contest):
    """The horizon T_h of every record from its T_need (``wk.need``) and the number of
    contesting movers (:func:`contesting_movers`), and the pruning bounds."""
    nbs, need = wk.nbs, wk.need
    v_max, v_r, dt = r.v_max, r.v_r, r.dt
    for q in range(count):
        nb = nbs[q]
        nb.th = horizon_of(nb, need[q], p, v_r, dt, n_contest)
        # Pruning: every candidate has |w| <= scale (v_max + |apex|), so tau >= gap / that.
        if nb.overlap:
            nb.bound = 0.0
            nb.jbound = 0.0
        else:
            gap = nb.d - nb.reff
            nb.bound = gap / (nb.scale * (v_max + math.sqrt(nb.apx**2 + nb.apy**2)) + TINY)
            nb.jbound = gap / (nb.jscale * (v_max + math.sqrt(nb.jax**2 + nb.jay**2)) + TINY)
