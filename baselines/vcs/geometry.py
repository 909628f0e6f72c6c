"""Velocity-obstacle and Velocity-Change-Space geometry: pure numpy, any leading shape.

These are the readable reference forms (used by tests, plots and the optimiser check); the
planner runs the same math in :mod:`baselines.vcs.kernel`. Sections are those of
``docs/vcs-method.md``. Conventions: ``p`` points from the robot to the other body, ``w`` is
the robot's velocity relative to it, ``r`` the combined radius.
"""

from __future__ import annotations

import numpy as np

from vcs_env.geometry import det, time_to_collision, unit, wrap_angle

__all__ = [
    "cone",
    "in_cone",
    "rvo_apex",
    "hrvo_apex",
    "line_intersection",
    "overlap_apex",
    "forbidden",
    "vcs_to_velocity",
    "velocity_to_vcs",
    "reach_steps",
    "k_max",
    "window",
    "static_collision_time",
    "column_speed_interval",
    "time_to_collision",
]


def cone(p: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Collision cone of relative velocities (vcs-method §2.1), defined for ``|p| > r``.

    Returns:
        ``phi`` (direction of p) [rad], ``alpha`` = asin(r/|p|) in (0, pi/2) [rad], right
        tangent ``n = u(phi - alpha)`` and left tangent ``l = u(phi + alpha)``, each ``(..., 2)``.
    """
    d = np.sqrt(np.einsum("...i,...i->...", p, p))
    phi = np.arctan2(p[..., 1], p[..., 0])
    alpha = np.arcsin(np.clip(r / d, 0.0, 1.0))
    return phi, alpha, unit(phi - alpha), unit(phi + alpha)


def in_cone(w: np.ndarray, n: np.ndarray, l: np.ndarray) -> np.ndarray:
    """``w`` strictly inside the cone between the right tangent ``n`` and left tangent ``l``."""
    return (det(n, w) > 0.0) & (det(l, w) < 0.0)


def rvo_apex(v_r: np.ndarray, v_j: np.ndarray) -> np.ndarray:
    """RVO apex: the mean of both velocities (each robot takes half the avoidance) [standard]."""
    return 0.5 * (v_r + v_j)


def line_intersection(a1: np.ndarray, d1: np.ndarray, a2: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """Intersection of the lines ``a1 + s d1`` and ``a2 + t d2`` (not parallel), ``(..., 2)``."""
    s = det(a2 - a1, d2) / det(d1, d2)
    return a1 + s[..., None] * d1


def hrvo_apex(
    p: np.ndarray, r: np.ndarray, v_r: np.ndarray, v_j: np.ndarray, pref_r: np.ndarray, pref_j: np.ndarray
) -> np.ndarray:
    """HRVO apex by explicit line intersection (vcs-method §2.4; it avoids the sign error of the
    HRVO reference code, vcs-method §2.17).

    If the relative preferred velocity lies left of the centre line (``det(p, pref_r - pref_j)
    > 0``), the robot passes on its left: the left side comes from the RVO (half effort) and
    the right side from the VO; otherwise mirrored.
    """
    _, _, n, l = cone(p, r)
    m = rvo_apex(v_r, v_j)
    left = (det(p, pref_r - pref_j) > 0.0)[..., None]
    # Passing left: VO right side {v_j + s n} meets RVO left side {m + t l}.
    a_left = line_intersection(v_j, n, m, l)
    # Passing right: VO left side {v_j + s l} meets RVO right side {m + t n}.
    a_right = line_intersection(v_j, l, m, n)
    return np.where(left, a_left, a_right)


def overlap_apex(p: np.ndarray, r0: np.ndarray, v_r: np.ndarray, v_j: np.ndarray, dt: float, reciprocal: np.ndarray):
    """Apex of the forbidden half-plane ``{v : p_hat . (v - a) > 0}`` used when ``|p| <= r0``
    (true penetration, vcs-method §2.4): move apart fast enough to clear the robot's share in one step.

    Returns:
        apex ``(..., 2)`` and ``p_hat`` ``(..., 2)``.
    """
    d = np.sqrt(np.einsum("...i,...i->...", p, p))
    p_hat = p / np.maximum(d, 1e-12)[..., None]
    depth = ((r0 - d) / dt)[..., None] * p_hat
    apex = np.where(reciprocal[..., None], 0.5 * (v_r + v_j) - 0.5 * depth, v_j - depth)
    return apex, p_hat


def forbidden(v: np.ndarray, p: np.ndarray, apex: np.ndarray, scale: np.ndarray, r: np.ndarray, horizon) -> np.ndarray:
    """Time-truncated VO membership ``tau(p, scale (v - apex), r) <= horizon`` (vcs-method §2.3, vcs-method §2.7).

    ``scale`` is 1 for passive obstacles and 2 for the HRVO/RVO rule (``tau^H``, vcs-method §2.4). The
    finiteness test keeps ``horizon = inf`` (classic VO) from forbidding everything (vcs-method §2.17).
    """
    tau = time_to_collision(p, scale[..., None] * (v - apex), r)
    return np.isfinite(tau) & (tau <= horizon)


def vcs_to_velocity(dv: np.ndarray, dth: np.ndarray, v_r: np.ndarray, theta_r: np.ndarray) -> np.ndarray:
    """The map M (vcs-method §2.9): VCS point (speed change, direction change) -> velocity ``(..., 2)``."""
    return (v_r + dv)[..., None] * unit(theta_r + dth)


def velocity_to_vcs(v: np.ndarray, v_r: np.ndarray, theta_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inverse map M^-1 (vcs-method §2.9); at zero velocity the direction change is 0."""
    s = np.sqrt(np.einsum("...i,...i->...", v, v))
    ang = np.arctan2(v[..., 1], v[..., 0])
    return s - v_r, np.where(s > 0.0, wrap_angle(ang - theta_r), 0.0)


def reach_steps(dv: np.ndarray, dth: np.ndarray, a_max, omega_max, dt: float) -> np.ndarray:
    """Steps needed to reach a VCS point with saturated per-step changes (vcs-method §2.7: T_reach / dt)."""
    kv = np.ceil(np.abs(dv) / (a_max * dt) - 1e-9)
    kt = np.ceil(np.abs(dth) / (omega_max * dt) - 1e-9)
    return np.maximum(np.maximum(kv, kt), 0.0)


def ramp_positions(dv: np.ndarray, dth: np.ndarray, v_r: float, theta_r: float, a_max, omega_max, dt: float):
    """Positions ``(k, K, 2)`` [m] (relative to the start) of a unicycle ramping toward VCS points
    ``(k,)`` at its maximal per-step rates, for steps 1..K with K the largest reach steps
    (vcs-method §2.15); points reached earlier hold their velocity. Euler steps like the simulator."""
    dv = np.asarray(dv, dtype=float)
    dth = np.asarray(dth, dtype=float)
    K = int(max(reach_steps(dv, dth, a_max, omega_max, dt).max(initial=0), 1))
    k = np.arange(1, K + 1)
    s = v_r + np.clip(dv[:, None], -k * a_max * dt, k * a_max * dt)
    th = theta_r + np.clip(dth[:, None], -k * omega_max * dt, k * omega_max * dt)
    return np.cumsum((s * dt)[..., None] * unit(th), axis=1)


def k_max(v_max, a_max, omega_max, dt: float):
    """Window size in steps that covers the whole VCS domain (vcs-method §2.10)."""
    return np.maximum(np.ceil(v_max / (a_max * dt) - 1e-9), np.ceil(np.pi / (omega_max * dt) - 1e-9))


def window(k, v_r, v_max, a_max, omega_max, dt: float):
    """The k-step velocity change window W_k (vcs-method §2.10): ``(dv_lo, dv_hi, dth_half)``."""
    lo = np.maximum(-v_r, -k * a_max * dt)
    hi = np.minimum(v_max - v_r, k * a_max * dt)
    half = np.minimum(np.pi, k * omega_max * dt)
    return lo, hi, half


def static_collision_time(s: np.ndarray, delta: np.ndarray, d: float, r: float) -> np.ndarray:
    """Closed form for a static disc (vcs-method §2.9): time to collision at speed ``s`` in the direction
    ``delta`` off the centre direction: ``(d cos(delta) - sqrt(r^2 - d^2 sin^2(delta))) / s``;
    ``inf`` outside the band ``|delta| < asin(r/d)`` or for non-positive speeds."""
    disc = r * r - (d * np.sin(delta)) ** 2
    inside = (disc >= 0.0) & (np.cos(delta) > 0.0) & (s > 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (d * np.cos(delta) - np.sqrt(np.maximum(disc, 0.0))) / s
    return np.where(inside, t, np.inf)


def column_speed_interval(
    u: np.ndarray, apex: np.ndarray, n: np.ndarray, l: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Speeds ``s >= 0`` with ``s u - apex`` inside the open cone (n, l): one interval per
    column of the VCS (the cone is convex, vcs-method §2.9).

    Each cone side is a linear inequality in ``s``; intersecting the two half-lines with
    ``s >= 0`` gives ``[lo, hi]`` (empty when ``lo >= hi``; ``hi`` may be inf).
    """
    lo = np.zeros(u.shape[:-1])
    hi = np.full(u.shape[:-1], np.inf)
    for side, sign in ((n, 1.0), (l, -1.0)):
        # sign * (s det(side, u) - det(side, apex)) > 0
        c_u = sign * det(side, u)
        c_a = sign * det(side, apex)
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = c_a / c_u
        lo = np.where(c_u > 0.0, np.maximum(lo, bound), lo)
        hi = np.where(c_u < 0.0, np.minimum(hi, bound), hi)
        # c_u == 0: the side holds for every s iff 0 > c_a ... i.e. -c_a > 0.
        never = (c_u == 0.0) & ~(-c_a > 0.0)
        hi = np.where(never, -np.inf, hi)
    return lo, hi
