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
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from .geometry import rotate
from .scenario import A_REF, OMEGA_REF, R_REF, V_REF, Scenario
from .state import WorldState

EGO_DIM = 8
NEIGHBOR_DIM = 8


def observation_dim(scenario: Scenario) -> int:
    return EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM


def observation_space(scenario: Scenario) -> spaces.Box:
    """The Box every robot's observation lives in."""
    dim = observation_dim(scenario)
    low = np.full(dim, -1.0, dtype=np.float32)
    low[[0, 1, 4, 5, 6, 7]] = 0.0
    slots = EGO_DIM + NEIGHBOR_DIM * np.arange(scenario.n_neighbors)
    for off in (0, 5, 7):
        low[slots + off] = 0.0
    return spaces.Box(low=low, high=np.ones(dim, dtype=np.float32), dtype=np.float32)


def goal_scale(scenario: Scenario) -> float:
    return 2.0 * scenario.world_extent


def neighbor_objects(world: WorldState) -> tuple[np.ndarray, ...]:
    """All objects a robot may sense: the robots first, then the obstacles.

    Returns:
        pos ``(B, n+m, 2)``, vel ``(B, n+m, 2)``, radius ``(B, n+m)``, is_robot ``(B, n+m)``,
        present ``(B, n+m)`` bool.
    """
    B, n, m = world.batch_size, world.n_robots, world.n_obstacles
    pos = np.concatenate((world.pos, world.obs_pos), axis=1)
    vel = np.concatenate((world.vel, world.obs_vel), axis=1)
    radius = np.concatenate((world.radius, world.obs_radius), axis=1)
    is_robot = np.concatenate((np.ones((B, n)), np.zeros((B, m))), axis=1)
    present = np.concatenate((world.present, np.ones((B, m), dtype=bool)), axis=1)
    return pos, vel, radius, is_robot, present


def nearest_neighbors(world: WorldState, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``k`` nearest sensed objects of every robot (by surface gap; ties by index).

    Returns:
        index ``(B, n, k)`` into the object list of :func:`neighbor_objects`, valid mask
        ``(B, n, k)`` bool, gap ``(B, n, k)`` [m].
    """
    pos, _, radius, _, present = neighbor_objects(world)
    n = world.n_robots
    rel = pos[:, None, :, :] - world.pos[:, :, None, :]  # (B, n, n+m, 2)
    dist = np.sqrt(np.einsum("...i,...i->...", rel, rel))
    gap = dist - radius[:, None, :] - world.radius[:, :, None]
    sensed = present[:, None, :] & (dist <= world.r_ca)
    sensed[:, np.arange(n), np.arange(n)] = False
    key = np.where(sensed, gap, np.inf)
    total = key.shape[-1]
    kk = min(k, total)
    if kk < total:
        part = np.argpartition(key, kk - 1, axis=-1)[..., :kk]
        order = np.argsort(np.take_along_axis(key, part, axis=-1), axis=-1, kind="stable")
        idx = np.take_along_axis(part, order, axis=-1)
    else:
        idx = np.argsort(key, axis=-1, kind="stable")
    sel = np.take_along_axis(key, idx, axis=-1)
    valid = np.isfinite(sel)
    sel_gap = np.where(valid, sel, 0.0)
    if kk < k:  # fewer objects than slots: pad
        pad = [(0, 0), (0, 0), (0, k - kk)]
        idx, valid, sel_gap = np.pad(idx, pad), np.pad(valid, pad), np.pad(sel_gap, pad)
    return idx, valid, sel_gap


def observe(world: WorldState, scenario: Scenario) -> np.ndarray:
    """Observations of every robot ``(B, n, D)`` float32, inside :func:`observation_space`."""
    k = scenario.n_neighbors
    B, n = world.batch_size, world.n_robots
    ego = np.empty((B, n, EGO_DIM))
    ego[..., 0] = world.speed / world.v_max
    to_goal = rotate(world.goal - world.pos, -world.heading)
    d_goal = np.sqrt(np.einsum("...i,...i->...", to_goal, to_goal))
    ego[..., 1] = np.minimum(d_goal / goal_scale(scenario), 1.0)
    safe = np.maximum(d_goal, 1e-12)
    ego[..., 2] = np.where(d_goal > 1e-12, to_goal[..., 0] / safe, 1.0)
    ego[..., 3] = np.where(d_goal > 1e-12, to_goal[..., 1] / safe, 0.0)
    ego[..., 4] = world.v_max / V_REF
    ego[..., 5] = world.a_max / A_REF
    ego[..., 6] = world.omega_max / OMEGA_REF
    ego[..., 7] = world.radius / R_REF

    pos, vel, radius, is_robot, _ = neighbor_objects(world)
    idx, valid, gap = nearest_neighbors(world, k)
    n_obj = pos.shape[1]
    nb = np.zeros((B, n, k, NEIGHBOR_DIM))
    if n_obj:
        sel_pos = np.take_along_axis(pos[:, None, :, :], idx[..., None], axis=2)
        sel_vel = np.take_along_axis(vel[:, None, :, :], idx[..., None], axis=2)
        head = world.heading[..., None]
        nb[..., 0] = 1.0
        nb[..., 1:3] = rotate(sel_pos - world.pos[:, :, None, :], -head) / world.r_ca
        nb[..., 3:5] = rotate(sel_vel - world.vel[:, :, None, :], -head) / (2.0 * V_REF)
        nb[..., 5] = np.take_along_axis(radius[:, None, :], idx, axis=2) / R_REF
        nb[..., 6] = np.clip(gap / world.r_ca, -1.0, 1.0)
        nb[..., 7] = np.take_along_axis(is_robot[:, None, :], idx, axis=2)
        nb *= valid[..., None]
    out = np.concatenate((ego, nb.reshape(B, n, k * NEIGHBOR_DIM)), axis=-1)
    # Rounding can push |x| a hair above 1 (e.g. an object exactly at r_ca); keep the space exact.
    return np.clip(out, -1.0, 1.0).astype(np.float32)


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


def state_space(scenario: Scenario) -> spaces.Box:
    dim = 10 * scenario.n_robots + 5 * scenario.n_obstacles
    return spaces.Box(low=-np.inf, high=np.inf, shape=(dim,), dtype=np.float32)
