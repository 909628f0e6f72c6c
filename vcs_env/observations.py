"""Per-robot observations in the robot's own frame, normalized into [-1, 1].

Layout of one robot's vector (``EGO_DIM + n_neighbors * NEIGHBOR_DIM`` floats):

===== ============================ ===================================================
index feature                      normalization
===== ============================ ===================================================
0     own speed                    / v_max, in [0, 1]
1     goal distance                / goal_scale, clipped to [0, 1] (far goals read 1)
2, 3  goal bearing cos, sin        robot frame
4     v_max                        / V_REF (3 m/s)
5     a_max                        / A_REF (10 m/s^2)
6     omega_max                    / OMEGA_REF (2 pi rad/s)
7     own radius                   / R_REF (2 m)
===== ============================ ===================================================

then ``n_neighbors`` slots for the nearest objects (robots still in the world and obstacles)
whose centres lie within ``r_ca``, nearest surface first, zero-padded:

===== ============================ ===================================================
+0    mask                         1 for a real object, 0 for padding
+1,+2 relative position x, y       robot frame, / r_ca
+3,+4 relative velocity x, y       object minus own velocity, robot frame, / (2 V_REF)
+5    object radius                / R_REF
+6    gap (distance - radii)       / r_ca, clipped to [-1, 1]
+7    is-robot flag                1 robot, 0 obstacle
===== ============================ ===================================================

``goal_scale`` is ``2 * scenario.world_extent`` (large enough to hold every start-goal pair of
the generated layouts).

With ``scenario.lidar`` (off by default) the lidar ranges follow, ``range / max_range`` in
``[0, 1]``, one per beam (:mod:`vcs_env.lidar`).
"""

from __future__ import annotations

import numpy as np

from . import kernels, lidar
from .scenario import A_REF, OMEGA_REF, R_REF, V_REF, Scenario
from .state import WorldState

EGO_DIM = 8
NEIGHBOR_DIM = 8


def observation_dim(scenario: Scenario) -> int:
    lidar = scenario.lidar.n_beams if scenario.lidar is not None else 0
    return EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM + lidar


def observation_bounds(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds ``(D,)`` float32 of every robot's observation (the tables above)."""
    dim = observation_dim(scenario)
    low = np.full(dim, -1.0, dtype=np.float32)
    low[[0, 1, 4, 5, 6, 7]] = 0.0
    slots = EGO_DIM + NEIGHBOR_DIM * np.arange(scenario.n_neighbors)
    for off in (0, 5, 7):
        low[slots + off] = 0.0
    if scenario.lidar is not None:
        low[-scenario.lidar.n_beams :] = 0.0
    return low, np.ones(dim, dtype=np.float32)


def goal_scale(scenario: Scenario) -> float:
    return 2.0 * scenario.world_extent


def sense(world: WorldState, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nearest sensed objects of every robot, nearest surface first (ties by index).

    Objects are the robots still in the world (not the robot itself) and the obstacles whose
    centres lie within ``r_ca``.

    Returns:
        features ``(B, n, k, 7)``: relative position x, y and relative velocity x, y in the
        robot's frame [m, m/s], radius [m], gap [m], is-robot flag; and the valid mask
        ``(B, n, k)`` bool (padding slots are all zero).
    """
    B, n, m = world.batch_size, world.n_robots, world.n_obstacles
    pos = np.concatenate((world.pos, world.obs_pos), axis=1)  # (B, N, 2), robots first
    vel = np.concatenate((world.vel, world.obs_vel), axis=1)
    radius = np.concatenate((world.radius, world.obs_radius), axis=1)
    present = np.concatenate((world.present, np.ones((B, m), dtype=bool)), axis=1)
    rel = pos[:, None] - world.pos[:, :, None]  # (B, n, N, 2)
    rvel = vel[:, None] - world.vel[:, :, None]
    dist = np.sqrt(rel[..., 0] ** 2 + rel[..., 1] ** 2)
    gap = dist - radius[:, None] - world.radius[:, :, None]
    sensed = present[:, None] & (dist <= world.r_ca)
    sensed[:, np.arange(n), np.arange(n)] = False
    key = np.where(sensed, gap, np.inf)
    total = key.shape[-1]
    kk = min(k, total)
    if kk < total:
        part = np.argpartition(key, kk - 1, axis=-1)[..., :kk]
        idx = np.take_along_axis(part, np.argsort(np.take_along_axis(key, part, -1), -1, kind="stable"), -1)
    else:
        idx = np.argsort(key, axis=-1, kind="stable")
    # Every object's features in each robot's frame, then one gather of the k nearest.
    c = np.cos(world.heading)[..., None]
    s = np.sin(world.heading)[..., None]
    feats = np.empty((B, n, total, 7))
    feats[..., 0] = c * rel[..., 0] + s * rel[..., 1]
    feats[..., 1] = -s * rel[..., 0] + c * rel[..., 1]
    feats[..., 2] = c * rvel[..., 0] + s * rvel[..., 1]
    feats[..., 3] = -s * rvel[..., 0] + c * rvel[..., 1]
    feats[..., 4] = radius[:, None]
    feats[..., 5] = gap
    feats[..., 6] = np.arange(total) < n
    sel = np.take_along_axis(feats, idx[..., None], axis=2)
    valid = np.isfinite(np.take_along_axis(key, idx, axis=-1))
    sel *= valid[..., None]
    if kk < k:  # fewer objects than slots: zero padding (np.pad costs more than the rest here)
        full, full_valid = np.zeros((B, n, k, 7)), np.zeros((B, n, k), dtype=bool)
        full[:, :, :kk], full_valid[:, :, :kk] = sel, valid
        return full, full_valid
    return sel, valid


def observe(world: WorldState, scenario: Scenario) -> np.ndarray:
    """Observations of every robot ``(B, n, D)`` float32, within :func:`observation_bounds`.

    One compiled call for all worlds (:func:`vcs_env.kernels.observe`); :func:`reference_observe`
    is the same computation in readable numpy, the kernel's test oracle."""
    obs = kernels.observe(
        world.pos, world.heading, world.speed, world.radius, world.goal, world.v_max, world.a_max,
        world.omega_max, world.present, world.obs_pos, world.obs_vel, world.obs_radius, world.r_ca,
        goal_scale(scenario), scenario.n_neighbors, V_REF, A_REF, OMEGA_REF, R_REF,
    )  # fmt: skip
    if scenario.lidar is not None:
        obs = np.concatenate((obs, lidar.observation_block(world, scenario.lidar)), axis=-1)
    return obs


def reference_observe(world: WorldState, scenario: Scenario) -> np.ndarray:
    """:func:`observe` in readable numpy (with :func:`sense`): the oracle of the compiled kernel."""
    k = scenario.n_neighbors
    B, n = world.batch_size, world.n_robots
    out = np.empty((B, n, EGO_DIM + k * NEIGHBOR_DIM))
    c, s = np.cos(world.heading), np.sin(world.heading)
    gx, gy = world.goal[..., 0] - world.pos[..., 0], world.goal[..., 1] - world.pos[..., 1]
    d_goal = np.sqrt(gx * gx + gy * gy)
    far = d_goal > 1e-12
    safe = np.where(far, d_goal, 1.0)
    out[..., 0] = world.speed / world.v_max
    out[..., 1] = np.minimum(d_goal / goal_scale(scenario), 1.0)
    out[..., 2] = np.where(far, (c * gx + s * gy) / safe, 1.0)  # goal bearing in the robot frame
    out[..., 3] = np.where(far, (-s * gx + c * gy) / safe, 0.0)
    out[..., 4] = world.v_max / V_REF
    out[..., 5] = world.a_max / A_REF
    out[..., 6] = world.omega_max / OMEGA_REF
    out[..., 7] = world.radius / R_REF
    feats, valid = sense(world, k)
    nb = out[..., EGO_DIM:].reshape(B, n, k, NEIGHBOR_DIM)
    nb[..., 0] = valid
    nb[..., 1:3] = feats[..., 0:2] / world.r_ca
    nb[..., 3:5] = feats[..., 2:4] / (2.0 * V_REF)
    nb[..., 5] = feats[..., 4] / R_REF
    nb[..., 6] = feats[..., 5] / world.r_ca
    nb[..., 7] = feats[..., 6]
    # Gaps beyond +-r_ca and rounding (an object exactly at r_ca) are clipped into the space.
    obs = np.clip(out, -1.0, 1.0).astype(np.float32)
    if scenario.lidar is not None:
        obs = np.concatenate((obs, lidar.observation_block(world, scenario.lidar)), axis=-1)
    return obs


def state_vector(world: WorldState) -> np.ndarray:
    """Global state of each world ``(B, S)`` float32: per robot (x, y, cos, sin, speed, goal x,
    goal y, radius, active, present), then per obstacle (x, y, vx, vy, radius); SI units."""
    B = world.batch_size
    robots = np.concatenate(
        (
            world.pos,
            np.cos(world.heading)[..., None],
            np.sin(world.heading)[..., None],
            world.speed[..., None],
            world.goal,
            world.radius[..., None],
            world.active[..., None],
            world.present[..., None],
        ),
        axis=-1,
    ).reshape(B, -1)
    obstacles = np.concatenate((world.obs_pos, world.obs_vel, world.obs_radius[..., None]), axis=-1).reshape(B, -1)
    return np.concatenate((robots, obstacles), axis=-1).astype(np.float32)


def state_dim(scenario: Scenario) -> int:
    """Length S of :func:`state_vector`."""
    return 10 * scenario.n_robots + 5 * scenario.n_obstacles
