"""Stage 4a, window: the multi-step window W_k sized by the first threat (vcs-method §2.10), the
goal point's one-step clip and the candidates of the point search (vcs-method §2.11)."""

from __future__ import annotations

import math

from numba import njit

from .records import INF, STEP_SLACK, TINY, Window
from .scalar import wrap


@njit(cache=True)
def threats(nbs, count):
    """Threats: the current course collides within the horizon (vcs-method §2.7). Returns the
    first threat time t* [s] (inf: none) and the number of threats."""
    tstar = INF
    n_threats = 0
    for q in range(count):
        tc0 = nbs[q].tc0
        if tc0 < INF and tc0 <= nbs[q].th:
            n_threats += 1
            if tc0 < tstar:
                tstar = tc0
    return tstar, n_threats


@njit(cache=True)
def window(r, p, tstar):
    """The window W_k (vcs-method §2.10): k steps, keeping ``window_margin`` steps in hand before
    the first threat at ``tstar`` [s]; a holonomic window is the disc of radius R = k a_max dt around
    the velocity, cut from the grid by the search: the grid spans every speed and direction, or
    with ``holonomic_window_fit`` the disc's bounds, speeds within R of v_R and, while the disc
    leaves out the origin (R < v_R), directions within asin(R / v_R) of the heading."""
    if p.one_step:
        k = 1.0
    elif tstar == INF:
        k = r.kmax
    else:
        k = min(max(math.floor((tstar - p.window_margin * r.dt) / r.dt + STEP_SLACK), 1.0), r.kmax)
    lo_v = max(-r.v_r, -k * r.dv1)
    hi_v = min(r.v_max - r.v_r, k * r.dv1)
    half = min(math.pi, k * r.dth1)
    if r.holo:
        if p.holonomic_window_fit:  # the speeds above; the directions of the disc
            half = math.pi if k * r.dv1 >= r.v_r else math.asin(k * r.dv1 / r.v_r)
        else:
            lo_v = -r.v_r
            hi_v = r.v_max - r.v_r
    full = half >= math.pi - TINY
    nth = p.n_theta_full if full else p.n_theta
    return Window(k, lo_v, hi_v, half, full, p.n_v, nth)


@njit(cache=True)
def goal_step(r):
    """The goal point G clipped to the one-step window (vcs-method §2.9): ``(dv, dtheta)``."""
    if not r.holo:
        g1v = min(max(r.gv, max(-r.v_r, -r.dv1)), min(r.v_max - r.v_r, r.dv1))
        return g1v, min(max(r.gth, -r.dth1), r.dth1)
    ex = r.pvx - r.vrx
    ey = r.pvy - r.vry
    e = math.sqrt(ex * ex + ey * ey)
    if e > r.dv1:
        ex *= r.dv1 / e
        ey *= r.dv1 / e
    s1 = math.sqrt((r.vrx + ex) ** 2 + (r.vry + ey) ** 2)
    g1th = wrap(math.atan2(r.vry + ey, r.vrx + ex) - r.th) if s1 > TINY else 0.0
    return s1 - r.v_r, g1th


@njit(cache=True)
def candidate(c, win, r, g1v, g1th):
    """Candidate c of the point search (vcs-method §2.11): the window grid, then G (clipped to the domain
    D), the origin (keep the current velocity) and the one-step-clipped G ``(g1v, g1th)``."""
    ngrid = win.nv * win.nth
    if c < ngrid:
        ai = c // win.nth
        ti = c % win.nth
        dv = win.lo_v + (win.hi_v - win.lo_v) * ai / (win.nv - 1)
        if win.full:
            dth = -math.pi + 2.0 * math.pi * ti / win.nth
        else:
            dth = -win.half + 2.0 * win.half * ti / (win.nth - 1)
        return dv, dth
    if c == ngrid:
        return min(max(r.gv, -r.v_r), r.v_max - r.v_r), r.gth
    if c == ngrid + 1:
        return 0.0, 0.0
    return g1v, g1th
