"""Stage 5, fallback: the least-bad candidate when none is admissible (vcs-method §2.13)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .cost import goal_term, ramp_line, ramp_velocity, split_excess, wall_ramp_clear
from .neighbours import collision_time, forbidden, inside_buffer
from .records import INF, K_MOVER, K_STATIC, SPLIT_COST, STEP_GAP, T_FLOOR, TINY, WALL_COST
from .scalar import reach_steps, tau
from .window import candidate


@njit(cache=True)
def first_step(r, dv, dth, vx, vy):
    """The velocity [m/s] after the first step toward the candidate (what this period commands)."""
    if r.holo:
        ex = vx - r.vrx
        ey = vy - r.vry
        f = min(1.0, r.dv1 / max(math.sqrt(ex * ex + ey * ey), TINY))
        return r.vrx + f * ex, r.vry + f * ey
    s1 = r.v_r + min(max(dv, -r.dv1), r.dv1)
    th1 = r.th + min(max(dth, -r.dth1), r.dth1)
    return s1 * math.cos(th1), s1 * math.sin(th1)


@njit(cache=True)
def contact_time(nb, vx, vy, clearance):
    """Time to contact [s] with the contact radius ``min(r_eff, r0 + clearance)``; ``clearance < 0``
    and walls: the regulated radius r_eff (:func:`~.neighbours.collision_time`)."""
    if clearance < 0.0 or nb.wall:
        return collision_time(nb, vx, vy)  # walls keep their regulated radius (they are hard)
    rc = min(nb.reff, nb.r0 + clearance)
    s = nb.jscale
    return tau(nb.px, nb.py, s * (vx - nb.jax), s * (vy - nb.jay), rc)


@njit(cache=True)
def refusals(nbs, count, r, v1x, v1y, tmax):
    """Least harm's refusals of a candidate whose first step reaches velocity (v1x, v1y) [m/s]
    (vcs-method §2.13): the first step must not close faster than now on a threat (a body it
    would hit within T_max, or already touches), by speeding up, or (a static body) by turning
    toward it. Returns ``(faster, static)``: some threat is closed on faster (refused if the
    candidate speeds up, dv > 0), and some static threat is, while closing (always refused)."""
    faster = False
    static = False
    for q in range(count):
        nb = nbs[q]
        if nb.overlap or nb.tc0 <= tmax or collision_time(nb, v1x, v1y) <= tmax:
            ux = nb.px / max(nb.d, TINY)
            uy = nb.py / max(nb.d, TINY)
            if (v1x - r.vrx) * ux + (v1y - r.vry) * uy > TINY:
                faster = True
                if nb.kind == K_STATIC and (v1x - nb.vjx) * ux + (v1y - nb.vjy) * uy > TINY:
                    static = True
    return faster, static


@njit(cache=True)
def refused(nbs, count, r, dv, dth, vx, vy, tmax):
    """Is the candidate (dv, dth), velocity (vx, vy), refused by least harm (:func:`refusals`)?"""
    v1x, v1y = first_step(r, dv, dth, vx, vy)
    faster, static = refusals(nbs, count, r, v1x, v1y, tmax)
    return (dv > TINY and faster) or static


@njit(cache=True)
def contact_clearance(nbs, count, least_harm, clearance, eps):
    """The clearance [m] :func:`fallback_cost` ranks contact times with: ``clearance``
    (``VCSParams.fallback_clearance``; < 0: none) only with ``least_harm`` and while the robot is
    already inside a body's regulated buffer (r_eff was shrunk to d - eps), where the buffered times
    saturate; else -1 (the regulated radii). The same for every candidate of a search."""
    if least_harm and clearance >= 0.0:
        for q in range(count):
            if not nbs[q].wall and inside_buffer(nbs[q], eps):
                return clearance
    return -1.0


@njit(cache=True)
def fallback_cost(
    nbs, count, r, dv, dth, vx, vy, kappa, least_harm, clearance, contact_clear, bound, contact, horizon, movers, met
):
    """Cost of a candidate when nothing is admissible (vcs-method §2.13), unless least harm refuses
    it (:func:`refused`, the caller's test). The RVO-style penalty ``kappa / t_c + J_g`` (t_c: the
    least time to collision over the neighbours, at ``clearance``, :func:`contact_clearance`), and
    with ``least_harm`` an overlap counts by how much the candidate fails to separate (the overlap
    half-plane's violation [m/s], weighted kappa / dt). Walls stay hard (vcs-method §2.18): a
    candidate inside a wall's truncated velocity obstacle costs :data:`~.records.WALL_COST` more
    than any that is not. With ``least_harm`` and ``contact`` > 0 [s] (``VCSParams.fallback_contact``),
    a candidate that meets a moving obstacle within ``horizon`` [s] (:func:`mover_contact` at
    ``contact_clear`` [m], first at t_m [s], driving toward it at v_t [m/s] then) costs
    ``contact (1 / t_m + v_t)`` more (t_m in s, v_t in m/s).

    Returns inf as soon as the cost is known to be at least ``bound`` (the best so far, which it
    then cannot beat): every term is non-negative and only grows over the neighbours, so the
    partial sum, in the same order, is never above the full one. ``movers``: the play-out's records
    (:func:`contact_movers` with ``contact_clear`` and ``horizon``), ``met`` a scratch of their size."""
    g = goal_term(r, dv, dth, vx, vy)
    if g >= bound:
        return INF
    tmin = INF
    viol = 0.0
    walled = 0.0
    for q in range(count):
        nb = nbs[q]
        if nb.wall and walled == 0.0 and forbidden(nb, vx, vy):
            walled = WALL_COST
        if least_harm and nb.overlap:
            e = nb.hx * (vx - nb.apx) + nb.hy * (vy - nb.apy)
            if e > viol:
                viol = e
        else:
            tc = contact_time(nb, vx, vy, clearance) if least_harm else collision_time(nb, vx, vy)
            if tc < tmin:
                tmin = tc
        if harm(kappa, tmin, r.dt, viol, g, least_harm) + walled >= bound:
            return INF
    j = harm(kappa, tmin, r.dt, viol, g, least_harm) + walled
    if contact > 0.0 and least_harm and j < bound:  # the play-out only adds: skip it for a loser
        t, toward = play_out(nbs, movers, met, r, dv, dth, contact_clear, horizon)
        if t < INF:
            j += contact * (1.0 / max(t, T_FLOOR) + max(toward, 0.0))
    return j


@njit(cache=True)
def mover_contact(nbs, count, r, dv, dth, clear, horizon):
    """The candidate (dv, dth) against the moving obstacles (vcs-method §2.13): the robot ramps
    to it at the maximal per-step rates (:func:`~.cost.ramp_velocity`) and holds it, each moving
    obstacle keeps its (planned) velocity; the first time [s] within ``horizon`` at which some
    obstacle comes within its combined physical radius plus ``clear`` [m] (inf: none), and the
    largest speed [m/s] of the robot toward an obstacle's centre at that obstacle's first
    contact (0 if none). Driving and parked robots, static bodies and walls are not counted."""
    movers = contact_movers(nbs, count, r, clear, horizon)
    return play_out(nbs, movers, np.empty(movers.size, dtype=np.bool_), r, dv, dth, clear, horizon)


@njit(cache=True)
def contact_movers(nbs, count, r, clear, horizon):
    """The records :func:`mover_contact` plays a ramp out against: moving obstacles (not an overlap,
    least harm's violation term already) that the robot, at its present speed plus full
    acceleration, and the obstacle could bring together within the play-out (``horizon`` [s]
    rounded to whole steps), with contact at their physical radii plus ``clear`` [m]. The same
    for every candidate of a search."""
    out = np.empty(count, dtype=np.int64)
    n = 0
    span = int(horizon / r.dt + 0.5) * r.dt  # [s] the play-out's length
    for q in range(count):
        nb = nbs[q]
        if nb.kind != K_MOVER or nb.mover or nb.overlap:
            continue
        rc = nb.r0 + clear
        if nb.d - rc > (math.sqrt(nb.vjx * nb.vjx + nb.vjy * nb.vjy) + r.v_r + r.dv1 / r.dt * span) * span:
            continue  # cannot meet within the horizon
        out[n] = q
        n += 1
    return out[:n]


@njit(cache=True)
def play_out(nbs, movers, met, r, dv, dth, clear, horizon):
    """:func:`mover_contact` against the records ``movers`` (:func:`contact_movers`), ``met`` a
    scratch of their size: the ramp is walked once, every mover checked at each step until its
    first contact (the ramp's velocities are worked out once per step, not once per mover)."""
    first = INF
    toward = 0.0
    if movers.size == 0:
        return first, toward
    line = ramp_line(r, dv, dth)
    steps = int(horizon / r.dt + 0.5)
    met[:] = False
    left = movers.size
    px = 0.0
    py = 0.0
    for k in range(1, steps + 1):
        vx, vy = ramp_velocity(r, dv, dth, line, k)
        px += vx * r.dt
        py += vy * r.dt
        t = k * r.dt
        for m in range(movers.size):
            if met[m]:
                continue
            nb = nbs[movers[m]]
            rc = nb.r0 + clear
            gx = nb.px + nb.vjx * t - px
            gy = nb.py + nb.vjy * t - py
            d2 = gx * gx + gy * gy
            if d2 < rc * rc:
                first = min(first, t)
                toward = max(toward, (vx * gx + vy * gy) / math.sqrt(max(d2, TINY)))
                met[m] = True
                left -= 1
        if left == 0:
            break
    return first, toward


@njit(cache=True)
def harm(kappa, tmin, dt, viol, g, least_harm):
    """The fallback's cost before the wall term: ``kappa / t_c (+ kappa / dt violation) + J_g``."""
    if least_harm:
        return kappa / max(tmin, T_FLOOR) + kappa / dt * viol + g
    return kappa / max(tmin, T_FLOOR) + g


@njit(cache=True)
def fallback_search(nbs, count, r, win, g1v, g1th, p):
    """The candidate of least :func:`fallback_cost` over the window grid and the extra points
    (a holonomic window is the disc of radius k a_max dt). Near a wall, with ``wall_brake``
    (vcs-method §2.18), a candidate whose ramp (:func:`~.cost.wall_ramp_clear`: its first step
    too) touches a wall, or leaves the robot unable to brake straight to a stop short of it,
    costs twice :data:`~.records.WALL_COST` more, so it ranks below one that can stop but whose end
    velocity lies in a wall's velocity obstacle (one ``WALL_COST``): a fallback that turned toward its
    goal point, or sped up while turning away, swept into the wall, and one that turned away from a
    wall it was closing on, toward its goal, where braking straight would have stopped clear of it.
    Returns ``(cost, dv, dth)``.

    A unicycle's first step clips the speed and direction changes to one step's, so the grid
    points beyond one step share their first step: least harm's refusals are worked out once per
    first step (per run of equal clipped rows times run of equal clipped columns)."""
    best = INF
    bdv = 0.0
    bdth = 0.0
    ngrid = win.nv * win.nth
    brake = r.walls and r.wall_brake and r.ramp
    memo = p.least_harm and not r.holo
    contact_clear = max(p.fallback_clearance, 0.0)
    movers = contact_movers(nbs, count, r, contact_clear, p.t_max)
    met = np.empty(movers.size, dtype=np.bool_)
    clearance = contact_clearance(nbs, count, p.least_harm, p.fallback_clearance, p.eps)
    if memo:
        row_run, col_run = first_step_runs(win, r)
        seen = np.zeros((win.nv, win.nth), dtype=np.int8)  # per first step: 0 unknown, else 1 + faster + 2 static
    for c in range(ngrid + 3):
        dv, dth = candidate(c, win, r, g1v, g1th)
        if r.holo and c < ngrid and reach_steps(dv, dth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r) > win.k:
            continue
        s = r.v_r + dv
        vx = s * math.cos(r.th + dth)
        vy = s * math.sin(r.th + dth)
        if p.least_harm:
            if memo and c < ngrid:
                a, t = row_run[c // win.nth], col_run[c % win.nth]
                if seen[a, t] == 0:
                    v1x, v1y = first_step(r, dv, dth, vx, vy)
                    faster, static = refusals(nbs, count, r, v1x, v1y, p.t_max)
                    seen[a, t] = 1 + (1 if faster else 0) + (2 if static else 0)
                code = seen[a, t] - 1
                out = (dv > TINY and code & 1 != 0) or code & 2 != 0
            else:
                out = refused(nbs, count, r, dv, dth, vx, vy, p.t_max)
            if out:
                continue
        j = fallback_cost(
            nbs, count, r, dv, dth, vx, vy, p.kappa, p.least_harm, clearance, contact_clear, best,
            p.fallback_contact, p.t_max, movers, met,
        )  # fmt: skip
        if brake and j < INF and not wall_ramp_clear(nbs, count, r, dv, dth):
            j += 2.0 * WALL_COST
        if r.split and j < best:  # a first step beyond its share of a gap to a robot (vcs-method §2.15)
            v1x, v1y = first_step(r, dv, dth, vx, vy)
            e = split_excess(nbs, count, r.dt, v1x, v1y)
            if e > 0.0:
                j += SPLIT_COST * (1.0 + e / STEP_GAP)
        if j < best:
            best = j
            bdv = dv
            bdth = dth
    return best, bdv, bdth


@njit(cache=True)
def first_step_runs(win, r):
    """For each grid row (column), the first row (column) whose first step has the same speed
    (heading): rows and columns clip to one step's change at both ends, so equal first steps lie
    in runs."""
    rows = np.empty(win.nv, dtype=np.int64)
    cols = np.empty(win.nth, dtype=np.int64)
    for a in range(win.nv):
        rows[a] = rows[a - 1] if a > 0 and clip_row(win, r, a) == clip_row(win, r, a - 1) else a
    for t in range(win.nth):
        cols[t] = cols[t - 1] if t > 0 and clip_col(win, r, t) == clip_col(win, r, t - 1) else t
    return rows, cols


@njit(cache=True)
def clip_row(win, r, a):
    """The first step's speed [m/s] toward grid row a (as :func:`first_step` clips it)."""
    dv, _ = candidate(a * win.nth, win, r, 0.0, 0.0)
    return r.v_r + min(max(dv, -r.dv1), r.dv1)


@njit(cache=True)
def clip_col(win, r, t):
    """The first step's heading [rad] toward grid column t (as :func:`first_step` clips it)."""
    _, dth = candidate(t, win, r, 0.0, 0.0)
    return r.th + min(max(dth, -r.dth1), r.dth1)
