"""Stage 5, fallback: the least-bad candidate when none is admissible (vcs-method §2.13)."""

from __future__ import annotations

import math

from numba import njit

from .cost import goal_term, wall_ramp_clear
from .neighbours import collision_time, forbidden
from .records import INF, K_STATIC, T_FLOOR, TINY, WALL_COST
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
def fallback_cost(nbs, count, r, dv, dth, vx, vy, kappa, least_harm, tmax, clearance=-1.0, eps=0.0):
    """Cost of a candidate when nothing is admissible (vcs-method §2.13). The RVO-style penalty
    ``kappa / t_c + J_g`` (t_c: the least time to collision over the neighbours), and with
    ``least_harm``: an overlap counts by how much the candidate fails to separate (the overlap
    half-plane's violation [m/s], weighted kappa / dt), and a candidate whose first step closes
    faster than now on something it would hit within T_max (or already touches), by speeding up
    or, for a static body, by turning toward it, is refused (inf): braking and turning away
    remain, and keeping the current velocity always does (vcs-method §2.13). Walls stay hard
    (vcs-method §2.18): a candidate inside a wall's truncated velocity obstacle costs
    :data:`~.records.WALL_COST` more than any that is not."""
    tmin = INF
    viol = 0.0
    walled = 0.0
    v1x, v1y = first_step(r, dv, dth, vx, vy)
    if least_harm and clearance >= 0.0:
        # Only while the robot is already inside a body's regulated buffer (r_eff was shrunk to
        # d - eps) do the buffered times saturate; then time to contact at r0 + clearance ranks.
        inside = False
        for q in range(count):
            if not nbs[q].wall and nbs[q].d - nbs[q].reff <= eps + 1e-9:
                inside = True
        if not inside:
            clearance = -1.0
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
        if least_harm and (nb.overlap or nb.tc0 <= tmax or collision_time(nb, v1x, v1y) <= tmax):
            # The first step toward the candidate must not close faster on the threat than now:
            # by speeding up, or (a static body) by turning toward it.
            ux = nb.px / max(nb.d, TINY)
            uy = nb.py / max(nb.d, TINY)
            closing = (v1x - nb.vjx) * ux + (v1y - nb.vjy) * uy > TINY
            if (dv > TINY or (closing and nb.kind == K_STATIC)) and (v1x - r.vrx) * ux + (v1y - r.vry) * uy > TINY:
                return INF  # closes faster on a threat
    if least_harm:
        return kappa / max(tmin, T_FLOOR) + kappa / r.dt * viol + goal_term(r, dv, dth, vx, vy) + walled
    return kappa / max(tmin, T_FLOOR) + goal_term(r, dv, dth, vx, vy) + walled


@njit(cache=True)
def fallback_search(nbs, count, r, win, g1v, g1th, p):
    """The candidate of least :func:`fallback_cost` over the window grid and the extra points
    (a holonomic window is the disc of radius k a_max dt). Near a wall, with ``wall_brake``
    (vcs-method §2.18), a candidate whose ramp (:func:`~.cost.wall_ramp_clear`: its first step
    too) touches a wall, or leaves the robot unable to brake straight to a stop short of it,
    costs :data:`~.records.WALL_COST` more: a fallback that turned toward its goal point, or
    sped up while turning away, swept into the wall. Returns ``(cost, dv, dth)``."""
    best = INF
    bdv = 0.0
    bdth = 0.0
    ngrid = win.nv * win.nth
    brake = r.walls and r.wall_brake and r.ramp
    for c in range(ngrid + 3):
        dv, dth = candidate(c, win, r, g1v, g1th)
        if r.holo and c < ngrid and reach_steps(dv, dth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r) > win.k:
            continue
        s = r.v_r + dv
        j = fallback_cost(
            nbs,
            count,
            r,
            dv,
            dth,
            s * math.cos(r.th + dth),
            s * math.sin(r.th + dth),
            p.kappa,
            p.least_harm,
            p.t_max,
            p.fallback_clearance,
            p.eps,
        )
        if brake and j < INF and not wall_ramp_clear(nbs, count, r, dv, dth):
            j += WALL_COST
        if j < best:
            best = j
            bdv = dv
            bdth = dth
    return best, bdv, bdth
