"""Stage 3, cost: the robot's context, admissibility of a candidate and its multi-objective cost
J (vcs-method §2.11, vcs-method §2.12), and the check along the way (vcs-method §2.15)."""

from __future__ import annotations

import math

from numba import njit

from .neighbours import forbidden
from .records import INF, K_RECIPROCAL, SQRT_HALF, STEP_GAP, TINY, WALL_RAMP_GAP
from .scalar import crossing_steps, reach_steps, tau, tau_within, wrap
from .walls import brake_gap, wall_gap, wall_tau


@njit(cache=True)
def robot_context(b, i, world, inputs, p, dt, holo, rec):
    """Robot i of world b as the search sees it, written into ``rec[0]`` (a :data:`~.records.ROBOT`
    record), with its goal point G = M^-1(v_pref) (vcs-method §2.9); G = (-v_R, 0) when v_pref = 0."""
    v_r = world.speed[b, i]
    th = world.heading[b, i]
    v_max = world.v_max[b, i]
    dv1 = world.a_max[b, i] * dt
    dth1 = math.pi if holo else world.omega_max[b, i] * dt
    kmax = crossing_steps(v_max, dv1, dth1, holo)
    pvx = inputs.vpref[b, i, 0]
    pvy = inputs.vpref[b, i, 1]
    ps = math.sqrt(pvx * pvx + pvy * pvy)
    if ps > TINY:
        gv = ps - v_r
        gth = wrap(math.atan2(pvy, pvx) - th)
    else:
        gv = -v_r
        gth = 0.0
    r = rec[0]
    r.v_r, r.th, r.vrx, r.vry, r.v_max = v_r, th, v_r * math.cos(th), v_r * math.sin(th), v_max
    r.dv1, r.dth1, r.kmax, r.pvx, r.pvy, r.gv, r.gth = dv1, dth1, kmax, pvx, pvy, gv, gth
    # A detour after a stall (vcs-method §2.13) drops the safety band and the smoothness terms, which can
    # otherwise make staying stopped cheaper than the large turn the robot needs.
    detour = inputs.detour[b, i]
    r.wg = p.w_goal
    r.ws = 0.0 if detour else p.w_safety
    r.wc = 0.0 if detour else p.w_change
    r.wr = 0.0 if detour else p.w_reach
    r.wh = 0.0 if detour else p.w_hysteresis
    r.wb = p.w_bias
    r.has_prev = inputs.has_prev[b, i]
    r.pdv = inputs.prev[b, i, 0]
    r.pdth = inputs.prev[b, i, 1]
    r.holo = holo
    r.tau_s = p.tau_s
    r.goal_vcs = p.goal_vcs
    r.ramp = p.ramp_check
    r.split = p.step_split
    r.dt = dt
    r.ramp_gap = 0.5 * p.delta_min
    r.ramp_hint = -1
    r.wall_brake = p.wall_brake


@njit(cache=True)
def relevant(nbs, order, count, tau_s, adm, js):
    """Neighbours that can matter for some candidate: ``adm`` those that may forbid one
    (tau can fall within T_h), ``js`` those that may enter the safety band. Nearest first.
    Returns both counts."""
    na = 0
    nj = 0
    for q in range(count):
        x = order[q]
        if nbs[x].bound <= nbs[x].th:
            adm[na] = x
            na += 1
        if nbs[x].jbound <= nbs[x].th + tau_s:
            js[nj] = x
            nj += 1
    return na, nj


@njit(cache=True)
def blocker(nbs, adm, na, vx, vy, first):
    """Where in ``adm`` a neighbour is whose truncated forbidden set holds velocity (vx, vy),
    trying position ``first`` before the others (the search passes the last blocker: neighbouring
    grid points are mostly blocked by the same neighbour); -1 when (vx, vy) is admissible."""
    if first < na and forbidden(nbs[adm[first]], vx, vy):
        return first
    for q in range(na):
        if q != first and forbidden(nbs[adm[q]], vx, vy):
            return q
    return -1


@njit(cache=True)
def admissible(nbs, adm, na, vx, vy):
    """Outside every neighbour's truncated forbidden set (vcs-method §2.11)."""
    return blocker(nbs, adm, na, vx, vy, 0) < 0


@njit(cache=True)
def goal_term(r, dv, dth, vx, vy):
    """J_g in [0, 1]: distance to the goal point, in the VCS (``goal_metric="vcs"``) or in
    velocity space (``"velocity"``: |v - v_pref| / (2 v_max), the RVO distance) (vcs-method §2.12)."""
    if r.goal_vcs:
        return math.sqrt(((dv - r.gv) / r.v_max) ** 2 + (wrap(dth - r.gth) / math.pi) ** 2) * SQRT_HALF
    return math.sqrt((vx - r.pvx) ** 2 + (vy - r.pvy) ** 2) / (2.0 * r.v_max)


@njit(cache=True)
def cost_parts(r, dv, dth, vx, vy, steps, bound):
    """The terms of J that do not depend on neighbours (vcs-method §2.12), a lower bound of J. Stops
    early (returning a value >= bound) once the partial sum reaches ``bound``."""
    v_max = r.v_max
    j = r.wg * goal_term(r, dv, dth, vx, vy)
    if j >= bound:
        return j
    j += r.wr * steps / r.kmax
    if dth > 0.0:
        j += r.wb * dth / math.pi
    j += r.wc * math.sqrt((dv / v_max) ** 2 + (dth / math.pi) ** 2) * SQRT_HALF
    if j >= bound:
        return j
    if r.has_prev:
        j += r.wh * math.sqrt(((dv - r.pdv) / v_max) ** 2 + (wrap(dth - r.pdth) / math.pi) ** 2) * SQRT_HALF
    return j


@njit(cache=True)
def safety_term(nbs, js, nj, tau_s, vx, vy):
    """J_s: soft band of width ``tau_s`` [s] just beyond each neighbour's horizon (vcs-method §2.12)."""
    out = 0.0
    for q in range(nj):
        nb = nbs[js[q]]
        if nb.wall:
            tc = wall_tau(nb, vx, vy, nb.reff)
            if not tc <= nb.th + tau_s:
                continue
        else:
            sc = nb.jscale
            wx = sc * (vx - nb.jax)
            wy = sc * (vy - nb.jay)
            if not tau_within(nb.px, nb.py, wx, wy, nb.reff, nb.th + tau_s):
                continue  # beyond the band: contributes 0
            tc = tau(nb.px, nb.py, wx, wy, nb.reff)
        val = min(max(1.0 - (tc - nb.th) / tau_s, 0.0), 1.0)
        if val > out:
            out = val
    return out


@njit(cache=True)
def cost(nbs, js, nj, r, dv, dth, vx, vy, steps):
    """Multi-objective cost J of a candidate (vcs-method §2.12)."""
    j = cost_parts(r, dv, dth, vx, vy, steps, INF)
    if r.ws > 0.0:
        j += r.ws * safety_term(nbs, js, nj, r.tau_s, vx, vy)
    return j


@njit(cache=True)
def ramp_line(r, dv, dth):
    """The ramp toward VCS point (dv, dth), for :func:`ramp_velocity`: the velocity change ``(ex,
    ey)`` [m/s] and its length ``e`` (a holonomic ramp's straight line), and the cosine and sine of
    the end heading (a unicycle's, held once its turn is made)."""
    s_end = r.v_r + dv
    c_end = math.cos(r.th + dth)
    s_dir = math.sin(r.th + dth)
    ex = s_end * c_end - r.vrx
    ey = s_end * s_dir - r.vry
    return ex, ey, math.sqrt(ex * ex + ey * ey), c_end, s_dir


@njit(cache=True)
def ramp_velocity(r, dv, dth, line, k):
    """Velocity [m/s] after ``k`` steps toward VCS point (dv, dth) at the maximal per-step rates
    (``line``: :func:`ramp_line`; holonomic: along its straight line). A unicycle's heading is its
    end heading once the turn is made (the trig of :func:`ramp_line`, the same bits), before that
    the heading turned by k steps."""
    ex, ey, e, c_end, s_dir = line
    if r.holo:
        f = min(1.0, k * r.dv1 / max(e, TINY))
        return r.vrx + f * ex, r.vry + f * ey
    sk = r.v_r + min(max(dv, -k * r.dv1), k * r.dv1)
    turn = k * r.dth1
    if -turn <= dth <= turn:
        return sk * c_end, sk * s_dir
    tk = r.th + min(max(dth, -turn), turn)
    return sk * math.cos(tk), sk * math.sin(tk)


@njit(cache=True)
def ramp_clear(nbs, count, r, dv, dth):
    """Admissible along the way (vcs-method §2.15): the motion that reaches the candidate, speed
    and heading ramping at the maximal per-step rates (a holonomic velocity along the straight
    line), keeps clear of every non-reactive neighbour, extrapolated at its velocity, and out
    of contact with every driving robot, which takes the mirror of the change (the reciprocal
    assumption: relative displacement 2 P(t) - (v_R + v_j) t). The velocity obstacles judge the
    end velocity only, as if it were reached at once; a turn that sweeps through a parked or a
    driving robot on the way is caught here. Clear means a gap of at least delta_min / 2 (0 for
    a driving robot), or no smaller than now if the robot is already closer. Near a wall, with
    ``wall_brake``, every state along the ramp must also be able to brake straight to a stop
    clear of it (vcs-method §2.18). With ``step_split`` the first step must also keep its share of
    the gap to every active robot (:func:`step_clear`)."""
    if r.split and not step_clear(nbs, count, r, dv, dth):
        return False
    if not r.ramp:
        return True
    return ramp_walk(nbs, count, r, dv, dth, False)


@njit(cache=True)
def split_excess(nbs, count, dt, v1x, v1y):
    """By how much [m] a first step at velocity (v1x, v1y) [m/s] oversteps its share of the gap to
    the active robots (``VCSParams.step_split``; 0: it keeps every share). Its advance towards each
    along the line of their centres is at most ``max(g / 2, g - U_j, 0)`` (``g``: the surface gap
    less ``STEP_GAP``; ``U_j``: the other's farthest advance towards it, ``nb.reach``)."""
    out = 0.0
    for q in range(count):
        nb = nbs[q]
        if not nb.split or nb.overlap:
            continue
        u = (v1x * nb.px + v1y * nb.py) / nb.d * dt
        if u <= 0.0:
            continue
        g = nb.d - nb.r0 - STEP_GAP
        e = u - max(0.5 * g, g - nb.reach, 0.0)
        if e > out:
            out = e
    return out


@njit(cache=True)
def step_clear(nbs, count, r, dv, dth):
    """The first step toward VCS point (dv, dth) shares the gap with every active robot
    (:func:`split_excess`). Every robot moves a whole period on the velocity it picks, from the
    same snapshot: the velocity obstacles' guess of the other's next velocity is off by up to
    2 a_max dt, a distance of 2 a_max dt^2 within the step; two robots that both keep their share
    cannot touch within it, whatever each picks (vcs-method §2.15)."""
    line = ramp_line(r, dv, dth)
    v1x, v1y = ramp_velocity(r, dv, dth, line, 1)
    return split_excess(nbs, count, r.dt, v1x, v1y) <= 0.0


@njit(cache=True)
def wall_ramp_clear(nbs, count, r, dv, dth):
    """:func:`ramp_clear` against the walls only (the fallback's, vcs-method §2.18)."""
    return ramp_walk(nbs, count, r, dv, dth, True)


@njit(cache=True)
def ramp_walk(nbs, count, r, dv, dth, walls_only):
    """The ramp of :func:`ramp_clear`; ``walls_only``: against the walls only, from the first step on,
    with contact (gap r, or no smaller than now) as the limit (the fallback's test). The record
    that broke the robot's last ramp (``r.ramp_hint``) is walked alone first: the ramps a search
    refuses mostly run into the same neighbour, found then within a few steps instead of after
    every record at each step before (the same answer: a ramp is clear when no record breaks it
    at any step)."""
    steps = reach_steps(dv, dth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r)
    if walls_only:
        steps = max(steps, 1)  # the fallback's candidates: its first step too
    elif steps <= 1:
        return True  # reached within the step: the velocity obstacles judge it
    line = ramp_line(r, dv, dth)
    a_max = r.dv1 / r.dt
    hint = r.ramp_hint
    if 0 <= hint < count and ramp_breaker(nbs, hint, hint + 1, -1, r, dv, dth, line, steps, a_max, walls_only) >= 0:
        return False
    q = ramp_breaker(nbs, 0, count, hint, r, dv, dth, line, steps, a_max, walls_only)
    if q >= 0:
        r.ramp_hint = q
        return False
    return True


@njit(cache=True)
def ramp_breaker(nbs, lo, hi, skip, r, dv, dth, line, steps, a_max, walls_only):
    """The first record of ``nbs[lo:hi]`` (but ``skip``) that the ramp of :func:`ramp_walk` (``steps``
    steps along ``line``, :func:`ramp_line`) breaks, at its earliest step; -1 when none does."""
    px = 0.0
    py = 0.0
    for k in range(1, steps + 1):
        vx, vy = ramp_velocity(r, dv, dth, line, k)
        px += vx * r.dt
        py += vy * r.dt
        t = k * r.dt
        for q in range(lo, hi):
            if q != skip and ramp_breaks(nbs[q], r, px, py, vx, vy, t, a_max, walls_only):
                return q
    return -1


@njit(cache=True)
def ramp_breaks(nb, r, px, py, vx, vy, t, a_max, walls_only):
    """Does the ramp's state at time ``t`` [s] (the robot moved by (px, py) [m] at velocity (vx, vy)
    [m/s]) break the limit :func:`ramp_walk` keeps from neighbour record ``nb``?"""
    if nb.overlap:
        return False
    if nb.wall:  # a wall does not move: its gap only has to stay open (vcs-method §2.18)
        need = min(nb.r0 + (0.0 if walls_only else WALL_RAMP_GAP), nb.d)
        if wall_gap(nb, px, py) < need:
            return True
        if r.wall_brake:
            # ... and the robot must be able to stop there, braking straight, clear of it
            # (or no closer than a stop from now would come).
            need = min(need, brake_gap(nb, 0.0, 0.0, r.vrx, r.vry, a_max))
            if brake_gap(nb, px, py, vx, vy, a_max) < need:
                return True
        return False
    if walls_only:
        return False
    clear = min(nb.r0 + (0.0 if nb.kind == K_RECIPROCAL else r.ramp_gap), nb.d)
    if nb.kind == K_RECIPROCAL:
        # The other robot takes the mirror of this change (the reciprocal assumption):
        # relative displacement 2 P(t) - (v_R + v_j) t.
        gx = nb.px + (r.vrx + nb.vjx) * t - 2.0 * px
        gy = nb.py + (r.vry + nb.vjy) * t - 2.0 * py
    else:
        gx = nb.px + nb.vjx * t - px
        gy = nb.py + nb.vjy * t - py
    return gx * gx + gy * gy < clear * clear


@njit(cache=True)
def consider(nbs, adm, na, js, nj, count, r, dv, dth, vx, vy, steps, best):
    """J of a candidate if it is admissible (also along the way) and may beat ``best``, else inf."""
    j = cost_parts(r, dv, dth, vx, vy, steps, best)
    if j >= best:
        return INF  # J_s >= 0: cannot win (ties keep the earlier candidate)
    if not admissible(nbs, adm, na, vx, vy):
        return INF
    if r.ws > 0.0:
        j += r.ws * safety_term(nbs, js, nj, r.tau_s, vx, vy)
    if j < best and not ramp_clear(nbs, count, r, dv, dth):
        return INF
    return j
