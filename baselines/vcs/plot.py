"""The paper's picture of one decision: the Velocity Change Space of one robot at one instant.

:func:`plot_decision` draws, side by side, the VCS plane (direction change vs speed change)
with each object's forbidden region, the domain, the multi-step window ``W_k*``, the one-step
window, the goal point ``G`` and the chosen point ``p*``; and its velocity-space twin. The
forbidden regions are computed by :func:`object_forbidden_masks`, the numpy reference of the
planner kernel's forbidden sets (tests check that both agree).
"""

from __future__ import annotations

import math

import numpy as np

from vcs_env.geometry import point_segment_distance
from vcs_env.state import WorldState

from ..capsule import reference_capsule_tau
from ..common import preferred_velocity
from . import geometry as G
from .kernel.records import WALL_RAMP_GAP
from .planner import VCSPlanner, planning_period


def object_forbidden_masks(
    world: WorldState, planner: VCSPlanner, b: int, i: int, vel: np.ndarray, horizon: np.ndarray
) -> dict[int, np.ndarray]:
    """Which candidate velocities each sensed object forbids, from the numpy geometry (a
    unicycle's candidates; the readable reference of the kernel's admissibility).

    Responsibility by kind (vcs-method §2.4): a driving robot is reciprocal; a robot within braking distance
    of its goal (preferred speed below v_max) is a non-reactive mover plus a static twin; parked
    robots and obstacles are non-reactive. An object also forbids the candidates whose ramp
    (the steps until the candidate is reached) comes closer than ``min(r0 + delta_min / 2, d)``
    to it, extrapolated at its velocity; ``min(r0, d)`` for a reciprocal robot (vcs-method §2.15).
    A wall also forbids those with a ramp state that cannot brake straight to a stop clear of it
    (``wall_brake``, vcs-method §2.18).

    Args:
        world: the state.
        planner: supplies the parameters (size regulation, reciprocity).
        b, i: world and robot.
        vel: candidate velocities ``(k, 2)`` [m/s].
        horizon: the horizon T_h of each object ``(2 n + m + s,)`` [s] (``VCSPlanner.evaluate``).

    Returns:
        ``{object index: (k,) bool}``: robots (index j), obstacles (n + k), twins (n + m + j),
        walls (2 n + m + k: the capsule's velocity obstacle, vcs-method §2.18).
    """
    p = planner.params
    n, m = world.n_robots, world.n_obstacles
    pref = preferred_velocity(world)[b]
    v_r = world.vel[b, i]
    r_ca = world.r_ca if p.r_ca is None else p.r_ca
    dv, dth = G.velocity_to_vcs(vel, world.speed[b, i], world.heading[b, i])
    dt = planning_period(world)[b, i]  # the step robot i's search counts in [s]
    a_max, omega_max = world.a_max[b, i], world.omega_max[b, i]
    ramp = G.ramp_positions(dv, dth, world.speed[b, i], world.heading[b, i], a_max, omega_max, dt)
    ramp_t = dt * np.arange(1, ramp.shape[1] + 1)
    steps_k = np.arange(1, ramp.shape[1] + 1)
    dv_k, dth_k = steps_k * a_max * dt, steps_k * omega_max * dt
    ramp_vel = (world.speed[b, i] + np.clip(dv[:, None], -dv_k, dv_k))[..., None] * G.unit(
        world.heading[b, i] + np.clip(dth[:, None], -dth_k, dth_k)
    )
    steps = G.reach_steps(dv, dth, a_max, omega_max, dt)
    on_ramp = (np.arange(1, ramp.shape[1] + 1) <= steps[:, None]) & (steps[:, None] > 1)  # (k, K)
    out = {}
    objects = []  # (index, position, velocity, other radius, reciprocal)
    for j in range(n):
        if j == i or not world.present[b, j]:
            continue
        if not world.active[b, j]:
            objects.append((j, world.pos[b, j], np.zeros(2), world.radius[b, j], False))
            continue
        arriving = p.arriving_non_reactive and np.linalg.norm(pref[j]) < world.v_max[b, j] * (1 - 1e-6)
        objects.append(
            (j, world.pos[b, j], world.vel[b, j], world.radius[b, j], not arriving and p.reciprocity != "vo")
        )
        if arriving and world.speed[b, j] > 1e-6:
            objects.append((n + m + j, world.pos[b, j], np.zeros(2), world.radius[b, j], False))
    obs_vel = planner.obstacle_velocities(world)[b]  # as the planner takes them (mover_turn_lead)
    objects += [(n + k, world.obs_pos[b, k], obs_vel[k], world.obs_radius[b, k], False) for k in range(m)]
    for idx, pos, v_j, r_j, reciprocal in objects:
        r0 = world.radius[b, i] + r_j
        rel = pos - world.pos[b, i]
        d = float(np.linalg.norm(rel))
        if d > r_ca:
            continue
        if d <= r0:  # overlap: the half-plane rule (vcs-method §2.4)
            apex, p_hat = G.overlap_apex(rel, np.array(r0), v_r, v_j, dt, np.array(reciprocal))
            out[idx] = (vel - apex) @ p_hat > 0.0
            continue
        # Size regulation (vcs-method §2.6).
        tc0 = G.time_to_collision(rel, v_r - v_j, r0)
        kt = 0.0 if np.isinf(tc0) else float(np.clip((p.t_max - tc0) / p.t_max, 0, 1))
        kd = float(np.clip(1 - (d - r0) / r_ca, 0, 1))
        reff = r0 + p.delta_min + p.delta_s * max(kt, kd)
        if d <= reff:
            reff = max(r0, d - p.eps_overlap)
        if reciprocal and p.reciprocity == "hrvo":
            apex = G.hrvo_apex(rel, np.array(reff), v_r, v_j, pref[i], pref[idx])
        elif reciprocal:
            apex = G.rvo_apex(v_r, v_j)
        else:
            apex = v_j
        k = len(vel)
        scale = np.full(k, 2.0 if reciprocal else 1.0)
        mask = G.forbidden(vel, np.broadcast_to(rel, vel.shape), apex, scale, np.full(k, reff), horizon[idx])
        if p.ramp_check:  # admissible along the way (vcs-method §2.15)
            if reciprocal:  # the other takes the mirror of the change: 2 P(t) - (v_R + v_j) t
                gap = np.linalg.norm(rel + ramp_t[:, None] * (v_r + v_j) - 2.0 * ramp, axis=-1)
            else:
                gap = np.linalg.norm(rel + ramp_t[:, None] * v_j - ramp, axis=-1)
            clear = min(r0 + (0.0 if reciprocal else 0.5 * p.delta_min), d)
            mask |= (on_ramp & (gap < clear)).any(axis=1)
        out[idx] = mask
    r = world.radius[b, i]
    for k in np.flatnonzero(world.seg_present[b]):  # walls (vcs-method §2.18)
        a, e = world.seg_a[b, k] - world.pos[b, i], world.seg_b[b, k] - world.pos[b, i]
        near = a + np.clip(-(a @ (e - a)) / ((e - a) @ (e - a)), 0.0, 1.0) * (e - a)
        d = float(np.linalg.norm(near))
        if d > r_ca:
            continue
        if d <= r:  # touching: the half-plane rule, as for a static disc
            h = near / max(d, 1e-12)
            out[2 * n + m + k] = (vel + (r - d) / dt * h) @ h > 0.0
            continue
        reff = r + p.delta_min if d > r + p.delta_min else max(r, d - p.eps_overlap)
        kk = len(vel)
        tau = reference_capsule_tau(
            np.broadcast_to(a, vel.shape), np.broadcast_to(e, vel.shape), vel, np.full(kk, reff)
        )
        mask = np.isfinite(tau) & (tau <= horizon[2 * n + m + k])
        if p.ramp_check:
            gap = point_segment_distance(ramp, a, e)  # (k, K) [m]
            need = min(r + WALL_RAMP_GAP, d)
            mask |= (on_ramp & (gap < need)).any(axis=1)
            if p.wall_brake:  # every state of the ramp can brake straight to a stop clear of it
                a_max = world.a_max[b, i]
                now = path_segment_distance(np.zeros(2), v_r * np.linalg.norm(v_r) / (2 * a_max), a, e)
                tail = ramp_vel * np.linalg.norm(ramp_vel, axis=-1, keepdims=True) / (2 * a_max)
                brake = path_segment_distance(ramp, ramp + tail, a, e)
                mask |= (on_ramp & (brake < min(need, float(now)))).any(axis=1)
        out[2 * n + m + k] = mask
    return out


def path_segment_distance(p: np.ndarray, q: np.ndarray, a: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Distance [m] from the straight paths ``p``-``q`` ``(..., 2)`` to the segment ``a``-``e``
    ``(2,)``: 0 where they cross, else the least end-to-segment distance (the numpy twin of
    ``kernel.walls.wall_path_gap``)."""
    p, q = np.broadcast_arrays(np.asarray(p, float), np.asarray(q, float))

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    d1, d2 = cross(q - p, a - p), cross(q - p, e - p)
    d3, d4 = cross(e - a, p - a), cross(e - a, q - a)
    ends = np.minimum(point_segment_distance(p, a, e), point_segment_distance(q, a, e))
    ends = np.minimum(ends, np.minimum(point_segment_distance(a, p, q), point_segment_distance(e, p, q)))
    return np.where((d1 * d2 < 0) & (d3 * d4 < 0), 0.0, ends)


def plot_decision(
    world: WorldState, b: int = 0, i: int = 0, planner: VCSPlanner | None = None, axes=None, resolution: int = 181
):
    """Draw robot ``i``'s decision in world ``b`` (see the module docstring).

    Args:
        world: the state (plan with the same planner first if it carries memory).
        b, i: world and robot.
        planner: the VCS planner (a fresh default one if None).
        axes: two matplotlib axes (VCS plane, velocity space), or None for a new figure.
        resolution: grid points per axis.

    Returns:
        The matplotlib figure.
    """
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    planner = planner if planner is not None else VCSPlanner()
    planner.plan(world)
    info = planner.last
    v_r, th_r, v_max = world.speed[b, i], world.heading[b, i], world.v_max[b, i]
    dv = np.linspace(-v_r, v_max - v_r, resolution)
    dth = np.linspace(-math.pi, math.pi, 2 * resolution)
    DV, DTH = np.meshgrid(dv, dth, indexing="ij")
    ok, _, horizon = planner.evaluate(world, b, i, DV.ravel(), DTH.ravel())
    vel = G.vcs_to_velocity(DV.ravel(), DTH.ravel(), v_r, th_r)
    masks = object_forbidden_masks(world, planner, b, i, vel, horizon)

    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    else:
        fig = axes[0].figure
    ax, axv = axes
    cmap = plt.get_cmap("tab10")
    for c, (idx, mask) in enumerate(sorted(masks.items())):
        if not mask.any():
            continue
        n, m = world.n_robots, world.n_obstacles
        name = f"robot_{idx}" if idx < n else f"obstacle_{idx - n}" if idx < n + m else f"twin of robot_{idx - n - m}"
        name = f"wall_{idx - 2 * n - m}" if idx >= 2 * n + m else name
        color = cmap(c % 10)
        grid = mask.reshape(DV.shape)
        ax.contourf(DTH, DV, grid.astype(float), levels=[0.5, 1.5], colors=[color], alpha=0.35)
        ax.plot([], [], color=color, lw=6, alpha=0.5, label=f"forbidden: {name} (T_h {horizon[idx]:.1f} s)")
        axv.scatter(vel[mask, 0], vel[mask, 1], s=2, color=color, alpha=0.25)
    # Domain, windows, points.
    k = int(info["k"][b, i])
    period = planning_period(world)[b, i]  # k counts periods [s]
    dth1 = world.omega_max[b, i] * period
    lo, hi, half = G.window(k, v_r, v_max, world.a_max[b, i], world.omega_max[b, i], period)
    ax.add_patch(
        Rectangle(
            (-half, lo), 2 * half, hi - lo, fill=False, ls="--", lw=1.5, color="k", label=f"window W_{k} (k* = {k})"
        )
    )
    lo1, hi1, _ = G.window(1, v_r, v_max, world.a_max[b, i], world.omega_max[b, i], period)
    ax.add_patch(
        Rectangle((-dth1, lo1), 2 * dth1, hi1 - lo1, fill=False, lw=1.5, color="tab:green", label="one-step window W_1")
    )
    pref = preferred_velocity(world)[b, i]
    g_dv, g_dth = G.velocity_to_vcs(pref, v_r, th_r)
    target = info["target"][b, i]
    ax.plot(g_dth, g_dv, marker="*", ms=14, color="gold", mec="k", ls="", label="goal point G")
    ax.plot(
        target[1],
        target[0],
        marker="o",
        ms=9,
        color="tab:red",
        mec="k",
        ls="",
        label="chosen p*" + (" (fallback)" if info["fallback"][b, i] else ""),
    )
    ax.plot(0, 0, marker="+", ms=12, color="k", ls="", label="current velocity")
    ax.set_xlim(-math.pi, math.pi)
    ax.set_ylim(-v_r, v_max - v_r)
    ax.set_xlabel("direction change [rad]")
    ax.set_ylabel("speed change [m/s]")
    ax.set_title(f"VCS of robot_{i} at t = {world.time[b]:.1f} s")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=7)
    # Velocity-space twin.
    circle = np.linspace(0, 2 * math.pi, 200)
    axv.plot(v_max * np.cos(circle), v_max * np.sin(circle), color="0.5", lw=1)
    ring = np.array(
        [
            [s * math.cos(th_r + a), s * math.sin(th_r + a)]
            for s in np.linspace(max(0, v_r + lo), v_r + hi, 20)
            for a in np.linspace(-half, half, 40)
        ]
    )
    axv.scatter(ring[:, 0], ring[:, 1], s=1, color="k", alpha=0.3, label="window (velocities)")
    chosen = G.vcs_to_velocity(np.array(target[0]), np.array(target[1]), v_r, th_r)
    axv.plot(*world.vel[b, i], marker="+", ms=12, color="k", ls="", label="current velocity")
    axv.plot(*pref, marker="*", ms=14, color="gold", mec="k", ls="", label="preferred velocity")
    axv.plot(*chosen, marker="o", ms=9, color="tab:red", mec="k", ls="", label="chosen velocity")
    axv.set_aspect("equal")
    axv.set_xlim(-1.1 * v_max, 1.1 * v_max)
    axv.set_ylim(-1.1 * v_max, 1.1 * v_max)
    axv.set_xlabel("v_x [m/s]")
    axv.set_ylabel("v_y [m/s]")
    axv.set_title("velocity space")
    axv.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=7)
    fig.tight_layout()
    return fig
