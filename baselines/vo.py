"""``vo``, ``rvo``, ``hrvo``: sampling velocity-obstacle planners in the style of the RVO Library.

The RVO Library (van den Berg, Lin and Manocha, ICRA 2008, "Reciprocal Velocity Obstacles for
real-time multi-agent navigation") picks, every period, among the preferred velocity and random
samples of the disc ``|v| <= v_max`` the candidate of least penalty (vcs-method §2.13)::

    penalty(v) = w / t_c(v) + |v - v_pref|,      t_c(v) = min_j tau(p_j, w_j(v), r_j)

with ``w = 7.5`` [s m/s] (the library's safety factor), ``tau`` the time to collision (vcs-method §2.2),
``p_j`` the position of neighbour ``j`` relative to the robot, ``r_j`` the combined radius and
``w_j(v)`` the relative velocity of the cone the method uses against ``j`` (the HRVO apex is that
of vcs-method §2.4):

========  ==============================================  ===========================
method    active robot neighbours                         obstacles, parked robots
========  ==============================================  ===========================
``vo``    ``v - v_j`` (apex ``v_j``)                      ``v - v_j`` (passive)
``rvo``   ``2 v - v_R - v_j`` (apex ``(v_R + v_j) / 2``)  ``v - v_j``
``hrvo``  ``2 (v - a_j)``, ``a_j`` the HRVO apex            ``v - v_j``
========  ==============================================  ===========================

Only objects whose centres are within ``r_ca`` count; parked robots have ``v_j = 0``. Walls
within ``r_ca`` count like passive obstacles through their capsule's time to collision
(:mod:`baselines.capsule`), when it falls within the stopping horizon ``wall_horizon``. The cones
use the physical combined radius (no size regulation). Overlapping pairs (centre distance
``<= r_j``: the cone is undefined) use the half-plane rule of the HRVO library: a candidate that
does not move the pair apart, ``(v - a_j) . p_j >= 0`` with the passive apex ``v_j`` or the RVO
apex ``(v_R + v_j) / 2`` (``rvo`` and ``hrvo``), has ``t_c = 0``; one that does never meets that
neighbour again (``t_c = inf``). ``t_c`` is floored at :data:`T_FLOOR` so that when every
candidate has ``t_c = 0`` the least ``|v - v_pref|`` still decides.

Like ORCA (:mod:`baselines.orca`), these methods choose a velocity, not a motion the robot can make: a unicycle
tracks the choice at its limits (:func:`~vcs_env.dynamics.target_to_action`), so a choice to step aside from a body
a few centimetres ahead, whose side can flip from one step to the next, turns the robot little while it speeds up
along its heading, into that body (an outside review, 2026-12-07: contacts within 1-5 steps from a 5 cm gap).

Random samples come from :mod:`vcs_env.noise`, keyed by ``world.key``, ``world.steps`` and the
robot index, so a plan depends only on the world state (no generator is kept). The robot-pair
apexes are computed with numpy (:func:`pair_apexes`, HRVO apex from
:func:`baselines.vcs.geometry.hrvo_apex`); sensing, the overlap rule and the candidate loop are
compiled with numba (:func:`choose`, sensing shared with the VCS kernel:
:func:`baselines.vcs.kernel.neighbours.sense`), one call for all robots of all worlds.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vcs_env import noise
from vcs_env.state import WorldState

from .capsule import capsule_tau, segment_range, wall_horizon
from .common import VelocityPlanner, preferred_velocity
from .vcs.geometry import hrvo_apex, rvo_apex
from .vcs.kernel.neighbours import sense, sort_nearest
from .vcs.kernel.records import SENSED
from .vcs.kernel.scalar import tau, tau_within

SAFETY_WEIGHT = 7.5
"""Default ``w`` of the penalty [s m/s]: the RVO Library's safety factor."""
N_SAMPLES = 250
"""Default number of random samples besides the preferred velocity."""
T_FLOOR = 1e-9
"""Smallest time to collision used in ``w / t_c`` [s]: keeps penalties finite and ordered."""
MAX_SAMPLES = 8000
"""Largest ``n_samples``: the noise counter layout gives each robot key 16384 numbers per step."""
METHODS = ("vo", "rvo", "hrvo")
_ROBOT_STRIDE = np.uint64(0xD1B54A32D192ED03)  # odd constant: robot i draws with key + (i + 1) * stride
_STREAM = 7  # noise stream of the samples


def sample_uniforms(world: WorldState, n_samples: int) -> np.ndarray:
    """Uniform numbers in [0, 1) for the random candidates, ``(B, n, n_samples, 2)``.

    A pure function of ``world.key``, ``world.steps`` and the robot index (:mod:`vcs_env.noise`):
    robot ``i`` draws with the key ``key + (i + 1) * stride``.
    """
    B, n = world.batch_size, world.n_robots
    with np.errstate(over="ignore"):
        keys = world.key.astype(np.uint64)[:, None] + np.arange(1, n + 1, dtype=np.uint64)[None, :] * _ROBOT_STRIDE
    u = noise.uniform(keys.ravel(), np.repeat(world.steps, n), 2 * n_samples, stream=_STREAM)
    return u.reshape(B, n, n_samples, 2)


def pair_apexes(world: WorldState, method: str, pref: np.ndarray) -> np.ndarray:
    """Cone apex of every robot pair, ``(B, n, n, 2)`` [m/s]: entry ``[b, i, j]`` is the apex robot
    ``i`` uses against robot ``j`` when both are active and apart (``|p| > r``); otherwise the
    planner uses the passive apex ``v_j`` or the overlap rule.

    ``vo``: ``v_j``; ``rvo``: ``(v_i + v_j) / 2``; ``hrvo``: the HRVO apex by line intersection
    (:func:`baselines.vcs.geometry.hrvo_apex`, side from the preferred velocities ``pref``
    ``(B, n, 2)`` [m/s]), or the RVO apex when the cone is a near half-plane (sides parallel).
    """
    B, n = world.batch_size, world.n_robots
    vel = world.vel
    v_r = np.broadcast_to(vel[:, :, None], (B, n, n, 2))
    v_j = np.broadcast_to(vel[:, None], (B, n, n, 2))
    if method == "vo":
        return np.ascontiguousarray(v_j)
    mid = rvo_apex(v_r, v_j)
    if method == "rvo":
        return mid
    p = world.pos[:, None] - world.pos[:, :, None]
    r = world.radius[:, :, None] + world.radius[:, None]
    d = np.sqrt(np.einsum("...i,...i->...", p, p))
    with np.errstate(divide="ignore", invalid="ignore"):
        apart = d > r  # also False on the diagonal
        pref_r = np.broadcast_to(pref[:, :, None], p.shape)
        h = hrvo_apex(p, r, v_r, v_j, pref_r, np.broadcast_to(pref[:, None], p.shape))
        # det(n, l) = sin(2 alpha) with sin(alpha) = r / d: the sides are parallel as d -> r.
        sa = r / d
        ok = apart & (2.0 * sa * np.sqrt(np.maximum(1.0 - sa * sa, 0.0)) >= 1e-12) & np.isfinite(h).all(axis=-1)
    return np.where(ok[..., None], h, mid)


@njit(cache=True)
def threatened(rec, order, count, vx, vy, horizon):
    """Does candidate ``(vx, vy)`` [m/s] meet some neighbour record within ``horizon`` [s] (> 0)?
    (No square root: :func:`baselines.vcs.kernel.scalar.tau_within`.)"""
    for q in range(count):
        rc = rec[order[q]]
        wx = vx - rc[2]
        wy = vy - rc[3]
        if rc[6] > 0.5:
            if wx * rc[0] + wy * rc[1] >= 0.0:  # overlap, not separating: t_c = 0
                return True
        elif tau_within(rc[0], rc[1], rc[4] * wx, rc[4] * wy, rc[5], horizon):
            return True
    return False


@njit(cache=True)
def choose(
    pos,
    vel,
    radius,
    v_max,
    active,
    present,
    obs_pos,
    obs_vel,
    obs_radius,
    pref,
    uniforms,
    apexes,
    reciprocal,
    r_ca,
    weight,
    store,
    out_vel,
    out_cand,
    out_pen,
    seg_a,
    seg_b,
    seg_present,
    a_max,
    dt,
):
    """Least-penalty candidate of every active robot of every world (module docstring).

    Args:
        pos, radius, v_max, active, present, obs_pos, obs_vel, obs_radius: world arrays
            (:class:`~vcs_env.state.WorldState`); vel: robot velocities ``(B, n, 2)`` [m/s].
        pref: preferred velocities ``(B, n, 2)`` [m/s]: candidate 0.
        uniforms: :func:`sample_uniforms` ``(B, n, N, 2)``: candidates 1..N, uniform in the disc
            of radius ``v_max``.
        apexes: :func:`pair_apexes` ``(B, n, n, 2)`` [m/s].
        reciprocal: active robots answer in kind (``rvo``, ``hrvo``); False for ``vo``.
        r_ca: sensing radius [m]; weight: ``w`` [s m/s].
        store: if True, fill ``out_cand (B, n, N + 1, 2)`` [m/s] and ``out_pen (B, n, N + 1)``
            with every candidate and its penalty (no early exit); otherwise they are not touched.
        out_vel: chosen velocities ``(B, n, 2)`` [m/s] (0 for inactive robots).
        seg_a, seg_b, seg_present: wall segments ``(B, s, 2)`` [m] and mask ``(B, s)``; walls
            within ``r_ca`` count with their capsule's time to collision
            (:func:`baselines.capsule.capsule_tau`, full responsibility) when it is within
            :func:`baselines.capsule.wall_horizon` of the candidate's speed (``a_max``
            ``(B, n)`` [m/s^2], ``dt`` [s]).
    """
    B = pos.shape[0]
    n = pos.shape[1]
    m = obs_pos.shape[1]
    ns = uniforms.shape[2]
    # Neighbour records: relative position p [m] (0, 1), apex [m/s] (2, 3), scale (4; the relative
    # velocity is scale (v - apex)), combined radius [m] (5), overlap flag (6).
    rec = np.empty((n + m, 7))
    key = np.empty(n + m)
    order = np.empty(n + m, dtype=np.int64)
    sensed = np.empty(n + m, dtype=SENSED)
    walls = np.empty((seg_present.shape[1], 4))  # sensed walls' end points relative to the robot [m]
    for b in range(B):
        for i in range(n):
            out_vel[b, i, 0] = 0.0
            out_vel[b, i, 1] = 0.0
            if not active[b, i]:
                continue
            count = sense(b, i, pos, radius, present, obs_pos, obs_radius, r_ca, sensed)
            for q in range(count):
                o = sensed[q]
                j = o.idx
                if j < n:
                    recip = reciprocal and active[b, j]
                    # Parked robots stand still.
                    vjx = vel[b, j, 0] if active[b, j] else 0.0
                    vjy = vel[b, j, 1] if active[b, j] else 0.0
                else:
                    recip = False
                    vjx = obs_vel[b, j - n, 0]
                    vjy = obs_vel[b, j - n, 1]
                rc = rec[q]
                rc[0] = o.px
                rc[1] = o.py
                rc[5] = o.r
                if o.d <= o.r:
                    # Overlap: the cone is undefined; half-plane through the RVO or passive apex.
                    rc[2] = 0.5 * (vel[b, i, 0] + vjx) if recip else vjx
                    rc[3] = 0.5 * (vel[b, i, 1] + vjy) if recip else vjy
                    rc[4] = 1.0
                    rc[6] = 1.0
                else:
                    rc[2] = apexes[b, i, j, 0] if recip else vjx
                    rc[3] = apexes[b, i, j, 1] if recip else vjy
                    rc[4] = 2.0 if recip else 1.0
                    rc[6] = 0.0
                key[q] = o.d - o.r
            # Nearest surface first, so that the candidate loop can stop early.
            sort_nearest(order, key, count)
            n_walls = 0
            for k in range(seg_present.shape[1]):
                if not seg_present[b, k]:
                    continue
                ax, ay = seg_a[b, k, 0] - pos[b, i, 0], seg_a[b, k, 1] - pos[b, i, 1]
                bx, by = seg_b[b, k, 0] - pos[b, i, 0], seg_b[b, k, 1] - pos[b, i, 1]
                if segment_range(ax, ay, bx, by) > r_ca:  # not sensed
                    continue
                walls[n_walls, 0], walls[n_walls, 1], walls[n_walls, 2], walls[n_walls, 3] = ax, ay, bx, by
                n_walls += 1
            best = np.inf
            for c in range(ns + 1):
                if c == 0:
                    vx = pref[b, i, 0]
                    vy = pref[b, i, 1]
                else:
                    # Uniform in the disc: radius ~ sqrt(U) (equal area), angle ~ U(0, 2 pi).
                    s = v_max[b, i] * math.sqrt(uniforms[b, i, c - 1, 0])
                    a = 2.0 * math.pi * uniforms[b, i, c - 1, 1]
                    vx = s * math.cos(a)
                    vy = s * math.sin(a)
                dv = math.sqrt((vx - pref[b, i, 0]) ** 2 + (vy - pref[b, i, 1]) ** 2)
                if not store:
                    # Early exits that never change the choice (the penalty is >= dv >= best, or
                    # some neighbour is met before t_lo, so w / t_c >= (best - dv) (1 + 1e-9)).
                    if dv >= best:
                        continue
                    t_lo = weight / (best - dv) * (1.0 - 1e-9)
                    if t_lo >= T_FLOOR and threatened(rec, order, count, vx, vy, t_lo):
                        continue
                tc = np.inf
                for q in range(count):
                    rc = rec[order[q]]
                    wx = vx - rc[2]
                    wy = vy - rc[3]
                    if rc[6] > 0.5:
                        # Overlap: only candidates that separate are safe, the others collide now.
                        t = np.inf if wx * rc[0] + wy * rc[1] < 0.0 else 0.0
                    else:
                        t = tau(rc[0], rc[1], rc[4] * wx, rc[4] * wy, rc[5])
                    tc = min(tc, t)
                if n_walls:
                    stop = wall_horizon(math.sqrt(vx * vx + vy * vy), a_max[b, i], dt)
                    for q in range(n_walls):
                        t = capsule_tau(walls[q, 0], walls[q, 1], walls[q, 2], walls[q, 3], vx, vy, radius[b, i])
                        if t < stop:
                            tc = min(tc, t)
                pen = weight / max(tc, T_FLOOR) + dv
                if store:
                    out_cand[b, i, c, 0] = vx
                    out_cand[b, i, c, 1] = vy
                    out_pen[b, i, c] = pen
                if pen < best:  # strict: the first of equal penalties wins (pref first)
                    best = pen
                    out_vel[b, i, 0] = vx
                    out_vel[b, i, 1] = vy


class SamplingVOPlanner(VelocityPlanner):
    """RVO Library-style sampling planner, batched over worlds and robots (module docstring).

    Args:
        method: ``"vo"``, ``"rvo"`` or ``"hrvo"``: the cone used against active robots.
        n_samples: random candidates per robot and step besides the preferred velocity, in
            [1, 8000].
        weight: safety weight ``w`` of ``w / t_c`` [s m/s], > 0.
        r_ca: sensing radius [m]; None uses ``world.r_ca``.
    """

    name = "sampling-vo"  # replaced by the method name per instance

    def __init__(
        self, method: str = "rvo", n_samples: int = N_SAMPLES, weight: float = SAFETY_WEIGHT, r_ca: float | None = None
    ):
        if method not in METHODS:
            raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}")
        if (
            isinstance(n_samples, bool)
            or not isinstance(n_samples, (int, np.integer))
            or not (1 <= n_samples <= MAX_SAMPLES)
        ):
            raise ValueError(f"n_samples must be an int in [1, {MAX_SAMPLES}], got {n_samples!r}")

        def number(x) -> bool:  # a bool is no number here (True would be 1)
            return isinstance(x, (int, float, np.number)) and not isinstance(x, (bool, np.bool_)) and np.isfinite(x)

        if not (number(weight) and weight > 0.0):
            raise ValueError(f"weight must be finite and > 0 [s m/s], got {weight!r}")
        if r_ca is not None and not (number(r_ca) and r_ca > 0.0):
            raise ValueError(f"r_ca must be finite and > 0 [m] (or None), got {r_ca!r}")
        self.name = method
        self.method = method
        self.n_samples = int(n_samples)
        self.weight = float(weight)
        self.r_ca = r_ca

    def _run(self, world: WorldState, store: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        pref = preferred_velocity(world)
        B, n = world.batch_size, world.n_robots
        shape = (B, n, self.n_samples + 1) if store else (0, 0, 0)
        out_vel = np.zeros((B, n, 2))
        out_cand = np.full(shape + (2,), np.nan)
        out_pen = np.full(shape, np.nan)
        r_ca = world.r_ca if self.r_ca is None else self.r_ca
        choose(
            world.pos,
            world.vel,
            world.radius,
            world.v_max,
            world.active,
            world.present,
            world.obs_pos,
            world.obs_vel,
            world.obs_radius,
            pref,
            sample_uniforms(world, self.n_samples),
            pair_apexes(world, self.method, pref),
            self.method != "vo",
            float(r_ca),
            self.weight,
            store,
            out_vel,
            out_cand,
            out_pen,
            world.seg_a,
            world.seg_b,
            world.seg_present,
            world.a_max,
            float(world.dt),
        )
        return out_vel, out_cand, out_pen

    def desired_velocity(self, world: WorldState) -> np.ndarray:
        """The least-penalty candidate ``(B, n, 2)`` [m/s] (0 for inactive robots)."""
        return self._run(world, False)[0]

    def penalties(self, world: WorldState) -> tuple[np.ndarray, np.ndarray]:
        """Every candidate and its penalty, for tests and plots.

        Returns:
            candidates ``(B, n, N + 1, 2)`` [m/s] (index 0: the preferred velocity) and
            penalties ``(B, n, N + 1)``; NaN for inactive robots.
        """
        _, cand, pen = self._run(world, True)
        return cand, pen
