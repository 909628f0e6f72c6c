"""Stage 4, search: the point search over the window (vcs-method §2.11) and the batched entry
points :func:`plan_batch` (every robot of every world, vcs-method §2.14) and
:func:`evaluate_points` (arbitrary VCS points of one robot, for tests and plots)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from vcs_env.threads import twin_kernel

from .cost import admissible, blocker, consider, cost, ramp_clear, relevant, robot_context, safety_term
from .fallback import fallback_search
from .horizon import apply_horizons, contesting_movers, set_horizons
from .neighbours import setup_neighbours, work
from .records import INF, SQRT_HALF, STEP_SLACK, Grid
from .scalar import planning_steps, reach_steps, steps_for, wrap
from .walls import senses_wall
from .window import candidate, goal_step, threats, window


@njit(cache=True)
def grid_work(p):
    """Scratch arrays of the point search (:data:`~.records.Grid`)."""
    nv = p.n_v
    thmax = max(p.n_theta, p.n_theta_full)
    return Grid(
        np.empty(nv), np.empty(nv), np.empty(thmax), np.empty(thmax), np.empty(thmax), np.empty(thmax),
        np.empty(thmax), np.empty(thmax), np.empty(thmax), np.empty(thmax), np.empty(thmax), np.empty(nv * thmax),
        np.zeros(nv, dtype=np.bool_),
    )  # fmt: skip


@njit(cache=True)
def prepare_robot(b, i, world, inputs, st, p, wk):
    """Robot i of world b: its context and its neighbour records with horizons (stages 1 and 2,
    vcs-method §2.6-2.7): its context in ``wk.robot[0]``, its records in ``wk.nbs``, ordered by
    ``wk.order``. Returns the number of records."""
    steps = planning_steps(world.v_max[b, i], world.a_max[b, i], world.omega_max[b, i], st.dt, st.holo)
    robot_context(b, i, world, inputs, p, st.dt * steps, st.holo, wk.robot)  # counts in its planning period
    count = setup_neighbours(b, i, world, inputs.pref_comm, p, st.r_ca, st.dt, inputs.detour[b, i], wk, st.holo)
    r = wk.robot[0]
    r.walls = senses_wall(wk.nbs, count)
    turn = (r.walls or p.stall_turn) and inputs.detour[b, i] and r.v_r < r.dv1
    if turn:
        r.goal_vcs = True  # a stalled robot at rest turns in place toward its goal (vcs-method §2.13, vcs-method §2.18)
    set_horizons(wk, count, wk.robot[0], p)
    if turn and p.free_turn:
        free_heading(wk, count, r, p.n_theta_full)
    return count


@njit(cache=True)
def free_heading(wk, count, r, n_dir):
    """Aim a robot that turns in place from rest (``VCSParams.free_turn``, vcs-method §2.13) at the heading
    nearest its goal's, in steps of 2 pi / ``n_dir`` either side, along which a first step's speed (``dv1``) is
    admissible: ``r.gth`` is set to it (left as it is when the goal's own heading is, or none is)."""
    na, _ = relevant(wk.nbs, wk.order, count, r.tau_s, wk.adm, wk.js)
    for m in range(n_dir):  # offsets 0, +1, -1, +2, -2, ... steps from the goal's heading, the half turn once
        dth = r.gth + (1.0 if m % 2 else -1.0) * 2.0 * math.pi * ((m + 1) // 2) / n_dir
        if blocker(wk.nbs, wk.adm, na, r.dv1 * math.cos(r.th + dth), r.dv1 * math.sin(r.th + dth), 0) < 0:
            if m:
                r.gth = wrap(dth)
            return


@njit(cache=True)
def grid_axes(g, r, win):
    """Rows (speed change) and columns (direction change) of the window grid, precomputed."""
    dv1, dth1, th = r.dv1, r.dth1, r.th  # locals: stores to the grid cannot change them
    for a in range(win.nv):
        g.dv_row[a] = win.lo_v + (win.hi_v - win.lo_v) * a / (win.nv - 1)
        g.kv_row[a] = steps_for(g.dv_row[a], dv1)
    for t in range(win.nth):
        if win.full:
            dth = -math.pi + 2.0 * math.pi * t / win.nth
        else:
            dth = -win.half + 2.0 * win.half * t / (win.nth - 1)
        g.dth_col[t] = dth
        g.kt_col[t] = steps_for(dth, dth1)
        g.cth[t] = math.cos(th + dth)
        g.sth[t] = math.sin(th + dth)


@njit(cache=True)
def cheap_columns(g, r, nth):
    """Per-column parts of the neighbour-free cost: J_g^2 = g_row[a] + g_mul[a] e_col[t] +
    g_col[t] (separable in both goal metrics), the change, hysteresis and bias terms."""
    goal_vcs, gth, pvx, pvy, pdth, has_prev, wb = r.goal_vcs, r.gth, r.pvx, r.pvy, r.pdth, r.has_prev, r.wb
    for t in range(nth):
        if goal_vcs:
            g.e_col[t] = 0.0
            g.g_col[t] = 0.5 * (wrap(g.dth_col[t] - gth) / math.pi) ** 2
        else:
            g.e_col[t] = g.cth[t] * pvx + g.sth[t] * pvy
            g.g_col[t] = 0.0
        g.c_col[t] = (g.dth_col[t] / math.pi) ** 2
        g.h_col[t] = (wrap(g.dth_col[t] - pdth) / math.pi) ** 2 if has_prev else 0.0
        g.b_col[t] = wb * max(g.dth_col[t], 0.0) / math.pi


@njit(cache=True)
def holonomic_mask(g, r, win, wr):
    """The holonomic window is a disc of radius k a_max dt around the velocity: grid points
    beyond it get inf, the others their holonomic reach steps (weight ``wr``) in J_r."""
    nth = win.nth
    v_r, vrx, vry, dv1 = r.v_r, r.vrx, r.vry, r.dv1
    for a in range(win.nv):
        if not g.live[a]:
            continue
        s = v_r + g.dv_row[a]
        for t in range(nth):
            steps = math.ceil(math.sqrt((s * g.cth[t] - vrx) ** 2 + (s * g.sth[t] - vry) ** 2) / dv1 - STEP_SLACK)
            c = a * nth + t
            if steps > win.k:
                g.cheap[c] = INF
            else:
                g.cheap[c] += wr * (steps - max(g.kv_row[a], g.kt_col[t]))


BOUND_SLACK = 1e-9
"""Relative slack of a row's lower bound in :func:`cheap_grid`: a row is left out only when its bound
beats ``best`` by more than the rounding of the per-point sums could."""


@njit(cache=True)
def cheap_grid(g, r, win, best):
    """The neighbour-free part of J ("cheap", a lower bound of J) at every grid point; its rows
    and columns are separable, so the per-point work is three square roots. Points outside a
    holonomic window (the disc of radius k a_max dt) get inf. A row whose lower bound (each term at
    its least over the columns) is not below ``best`` is left out (``g.live[a]`` False, its values
    unset): none of its points can win (J >= cheap). Returns the least and the largest finite value
    of the rows kept (inf and 0 when none is kept)."""
    nv, nth = win.nv, win.nth
    cheap_columns(g, r, nth)
    inv_v = 1.0 / r.v_max
    pv2 = r.pvx * r.pvx + r.pvy * r.pvy
    wg = r.wg if r.goal_vcs else r.wg * 0.5 * inv_v
    wc = r.wc * SQRT_HALF
    wh = r.wh * SQRT_HALF if r.has_prev else 0.0
    wr = r.wr / r.kmax
    v_r, pdv, gv, goal_vcs = r.v_r, r.pdv, r.gv, r.goal_vcs
    e_lo, e_hi, g_lo, c_lo, h_lo, b_lo, kt_lo = INF, -INF, INF, INF, INF, INF, g.kt_col[0]
    for t in range(nth):
        e_lo, e_hi = min(e_lo, g.e_col[t]), max(e_hi, g.e_col[t])
        g_lo, c_lo, h_lo = min(g_lo, g.g_col[t]), min(c_lo, g.c_col[t]), min(h_lo, g.h_col[t])
        b_lo, kt_lo = min(b_lo, g.b_col[t]), min(kt_lo, g.kt_col[t])
    cut = best + BOUND_SLACK * (1.0 + abs(best))
    for a in range(nv):
        s = v_r + g.dv_row[a]
        c_row = (g.dv_row[a] * inv_v) ** 2
        h_row = ((g.dv_row[a] - pdv) * inv_v) ** 2
        if goal_vcs:
            g_row = 0.5 * ((g.dv_row[a] - gv) * inv_v) ** 2
            g_mul = 0.0
        else:
            g_row = s * s + pv2
            g_mul = -2.0 * s
        kv = g.kv_row[a]
        base = a * nth
        g_least = g_row + (g_lo if goal_vcs else g_mul * (e_hi if g_mul < 0.0 else e_lo))
        bound = (
            wg * math.sqrt(max(g_least, 0.0))
            + wc * math.sqrt(c_row + c_lo)
            + wh * math.sqrt(h_row + h_lo)
            + (0.0 if r.holo else wr * max(kv, kt_lo))  # the holonomic mask may lower J_r
            + b_lo
        )
        g.live[a] = bound < cut
        if not g.live[a]:
            continue
        for t in range(nth):
            steps = max(kv, g.kt_col[t])
            g.cheap[base + t] = (
                wg * math.sqrt(max(g_row + g_mul * g.e_col[t] + g.g_col[t], 0.0))
                + wc * math.sqrt(c_row + g.c_col[t])
                + wh * math.sqrt(h_row + g.h_col[t])
                + wr * steps
                + g.b_col[t]
            )
    if r.holo:
        holonomic_mask(g, r, win, wr)
    lo_c = INF
    hi_c = 0.0
    for a in range(nv):
        if not g.live[a]:
            continue
        for c in range(a * nth, (a + 1) * nth):
            if g.cheap[c] < lo_c:
                lo_c = g.cheap[c]
            if g.cheap[c] > hi_c and g.cheap[c] < INF:
                hi_c = g.cheap[c]
    return lo_c, hi_c


@njit(cache=True)
def extra_points(nbs, adm, na, js, nj, count, r, win, g1v, g1th):
    """The three extra points first (G, the origin, the one-step G): a good early best prunes
    much of the grid. Returns ``(best, dv, dth)`` (inf when none is admissible)."""
    best = INF
    bdv = 0.0
    bdth = 0.0
    ngrid = win.nv * win.nth
    for c in range(ngrid, ngrid + 3):
        dv, dth = candidate(c, win, r, g1v, g1th)
        s = r.v_r + dv
        steps = reach_steps(dv, dth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r)
        j = consider(
            nbs, adm, na, js, nj, count, r, dv, dth, s * math.cos(r.th + dth), s * math.sin(r.th + dth), steps, best
        )
        if j < best:
            best = j
            bdv = dv
            bdth = dth
    return best, bdv, bdth


@njit(cache=True)
def sweep_pass(nbs, adm, na, js, nj, count, r, g, win, lo_c, hi_c, best, checked):
    """One sweep of the thresholds upward from the least lower bound ``lo_c``: J = cheap + w_s J_s
    with J_s in [0, 1], so points with cheap >= best cannot win. Each pass visits the points with
    cheap in [t_prev, t) (each point once), the band doubling each pass. The check along the way
    (:func:`~.cost.ramp_clear`) is made as a point would win when ``checked``, else not at all.
    Returns the best ``(J, grid point)`` (point -1: none beats ``best``); of equal costs the first
    grid point wins."""
    nth = win.nth
    v_r, ws, tau_s = r.v_r, r.ws, r.tau_s
    best_c = -1
    delta = max(ws, 0.02)
    t_prev = -INF
    t_cur = lo_c + delta
    last = 0  # the last blocker (:func:`~.cost.blocker`)
    while True:
        for a in range(win.nv):
            if not g.live[a]:
                continue
            s = v_r + g.dv_row[a]
            for t in range(nth):
                c = a * nth + t
                x = g.cheap[c]
                if x < t_prev or x >= t_cur or x >= best:
                    continue
                vx = s * g.cth[t]
                vy = s * g.sth[t]
                q = blocker(nbs, adm, na, vx, vy, last)
                if q >= 0:
                    last = q
                    continue
                if checked and best == INF and not ramp_clear(nbs, count, r, g.dv_row[a], g.dth_col[t]):
                    continue  # any J beats inf: the check, not J, decides (J_s is costed only for a clear point)
                j = x
                if ws > 0.0:
                    j += ws * safety_term(nbs, js, nj, tau_s, vx, vy)
                if j < best or (j == best and c < best_c):
                    if checked and not ramp_clear(nbs, count, r, g.dv_row[a], g.dth_col[t]):
                        continue
                    best = j
                    best_c = c
        if t_cur >= best or t_cur > hi_c:
            break
        t_prev = t_cur
        delta *= 2.0
        t_cur = lo_c + delta
    return best, best_c


@njit(cache=True)
def sweep(nbs, adm, na, js, nj, count, r, g, win, lo_c, hi_c, best, bdv, bdth):
    """The grid swept by its neighbour-free lower bound (:func:`sweep_pass`). The check along the way,
    the costliest test, is put off: the sweep finds the cheapest admissible point, and only that one
    is checked; if it fails, it leaves the grid (its cheap set to inf) and a second sweep checks every
    point that would win, as found. Either way the winner is the cheapest admissible point that is
    clear along the way, the one a sweep checking every winner as found returns. Returns the new
    ``(best, dv, dth)``."""
    j, c = sweep_pass(nbs, adm, na, js, nj, count, r, g, win, lo_c, hi_c, best, False)
    if c >= 0 and not ramp_clear(nbs, count, r, g.dv_row[c // win.nth], g.dth_col[c % win.nth]):
        g.cheap[c] = INF
        j, c = sweep_pass(nbs, adm, na, js, nj, count, r, g, win, lo_c, hi_c, best, True)
    if c < 0:
        return best, bdv, bdth
    return j, g.dv_row[c // win.nth], g.dth_col[c % win.nth]


@njit(cache=True)
def search_point(nbs, count, r, p, wk, g):
    """The point search under the current horizons (vcs-method §2.9-2.11): threats, window,
    the extra points, then the grid swept by its neighbour-free lower bound. Returns ``(best,
    dv, dth, window, t*, n_threats, g1v, g1th)``; best is inf when no point is admissible."""
    tstar, n_threats = threats(nbs, count)
    win = window(r, p, tstar)
    g1v, g1th = goal_step(r)
    grid_axes(g, r, win)
    na, nj = relevant(nbs, wk.order, count, r.tau_s, wk.adm, wk.js)
    best, bdv, bdth = extra_points(nbs, wk.adm, na, wk.js, nj, count, r, win, g1v, g1th)
    lo_c, hi_c = cheap_grid(g, r, win, best)
    best, bdv, bdth = sweep(nbs, wk.adm, na, wk.js, nj, count, r, g, win, lo_c, hi_c, best, bdv, bdth)
    return best, bdv, bdth, win, tstar, n_threats, g1v, g1th


@njit(cache=True)
def search_retry(nbs, count, r, p, wk, g):
    """:func:`search_point`; under ``crowd_reach``, a search that finds nothing admissible is run
    once more with the horizons of the closing count (fewer contesting movers, shorter horizons;
    vcs-method §2.7). The horizons in ``wk.nbs`` are left as the returned point was found under."""
    res = search_point(nbs, count, r, p, wk, g)
    if res[0] == INF and p.crowd_reach:
        n_close = contesting_movers(nbs, count, r, p.t_max, False)
        if n_close < contesting_movers(nbs, count, r, p.t_max, True):
            apply_horizons(wk, count, r, p, n_close)
            res = search_point(nbs, count, r, p, wk, g)
    return res


@njit(cache=True)
def plan_robot(b, i, world, inputs, st, p, wk, g):
    """Plan active robot i of world b (vcs-method §2.14). Returns the target VCS point
    ``(dv*, dtheta*)``, its cost J, whether the fallback was used, the window size k*, the first
    threat time t* [s], the number of threats and the one-step-clipped goal point. The fallback
    comes only after :func:`search_retry` found nothing admissible."""
    count = prepare_robot(b, i, world, inputs, st, p, wk)
    r = wk.robot[0]
    nbs = wk.nbs
    best, bdv, bdth, win, tstar, n_threats, g1v, g1th = search_retry(nbs, count, r, p, wk, g)
    fell_back = best == INF
    if fell_back:
        best, bdv, bdth = fallback_search(nbs, count, r, win, g1v, g1th, p)
    return bdv, bdth, best, fell_back, int(win.k), tstar, n_threats, g1v, g1th


PLAN_BLOCK = 8
"""Worlds per block of :func:`plan_batch` (its scratch arrays are allocated once per block)."""


@twin_kernel(cache=True, min_batch=2 * PLAN_BLOCK)
def plan_batch(world, inputs, st, out):
    """Plan every active robot of every world that ``inputs.plan`` selects into ``out``
    (:data:`~.records.Outputs`, arrays ``(B, n, ...)``, see :func:`plan_robot`); the other robots
    get zeros and t* = inf. A world's plans depend on that world alone, so the world loop runs
    over blocks of worlds in parallel (:mod:`vcs_env.threads`: the same plans for any thread
    count), each block of :data:`PLAN_BLOCK` worlds with its own scratch arrays; from two blocks on (a
    world's plan costs far more than its step: the evaluation harness's batches of 25 worlds plan in
    parallel)."""
    B, n = world.pos.shape[0], world.pos.shape[1]
    for blk in prange((B + PLAN_BLOCK - 1) // PLAN_BLOCK):
        p = st.prm[0]  # inside: a record value does not pass into a parallel loop's body
        wk = work(n, world.obs_pos.shape[1], world.seg_present.shape[1], p)
        g = grid_work(p)
        for b in range(blk * PLAN_BLOCK, min(B, (blk + 1) * PLAN_BLOCK)):
            plan_world(b, n, world, inputs, st, p, wk, g, out)


@njit(cache=True)
def plan_world(b, n, world, inputs, st, p, wk, g, out):
    """:func:`plan_batch` of world b with scratch arrays ``wk`` and ``g``."""
    for i in range(n):
        if not (world.active[b, i] and inputs.plan[b, i]):
            out.target[b, i, 0] = 0.0
            out.target[b, i, 1] = 0.0
            out.cost[b, i] = 0.0
            out.fallback[b, i] = False
            out.k[b, i] = 0
            out.t_star[b, i] = INF
            out.threats[b, i] = 0
            continue
        res = plan_robot(b, i, world, inputs, st, p, wk, g)
        out.target[b, i, 0] = res[0]
        out.target[b, i, 1] = res[1]
        out.cost[b, i] = res[2]
        out.fallback[b, i] = res[3]
        out.k[b, i] = res[4]
        out.t_star[b, i] = res[5]
        out.threats[b, i] = res[6]
        out.goal_step[b, i, 0] = res[7]
        out.goal_step[b, i, 1] = res[8]


@njit(cache=True)
def evaluate_points(b, i, world, inputs, st, cand_dv, cand_dth, out_ok, out_cost, out_horizon):
    """Admissibility and cost of arbitrary VCS points ``(cand_dv, cand_dth)`` for robot i of world
    b (tests, plots). ``out_horizon`` receives the horizon T_h [s] of each sensed object (robots
    first, then obstacles, in index order, then the static twins of arriving robots by robot
    index, then walls by segment index; inf when not sensed)."""
    n = world.pos.shape[1]
    m = world.obs_pos.shape[1]
    p = st.prm[0]
    wk = work(n, m, world.seg_present.shape[1], p)
    count = prepare_robot(b, i, world, inputs, st, p, wk)
    r = wk.robot[0]
    nbs = wk.nbs
    if p.crowd_reach:  # the horizons the planner's own search ends with
        search_retry(nbs, count, r, p, wk, grid_work(p))
    na, nj = relevant(nbs, wk.order, count, r.tau_s, wk.adm, wk.js)
    for c in range(cand_dv.shape[0]):
        dv = cand_dv[c]
        dth = cand_dth[c]
        s = r.v_r + dv
        vx = s * math.cos(r.th + dth)
        vy = s * math.sin(r.th + dth)
        out_ok[c] = admissible(nbs, wk.adm, na, vx, vy) and ramp_clear(nbs, count, r, dv, dth)
        steps = reach_steps(dv, dth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r)
        out_cost[c] = cost(nbs, wk.js, nj, r, dv, dth, vx, vy, steps)
    for q in range(out_horizon.shape[0]):
        out_horizon[q] = INF
    for q in range(count):
        if nbs[q].twin and (nbs[q].idx >= n or nbs[q].idx < 0):
            continue  # a stopping obstacle's twin, or an arriving robot's at its goal: not reported
        out_horizon[nbs[q].idx + (n + m if nbs[q].twin else 0)] = nbs[q].th
