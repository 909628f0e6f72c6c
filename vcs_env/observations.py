"""Per-robot observations in the robot's own frame, in fixed physical units, within [-1, 1].

Observation version 1 (:data:`OBSERVATION_VERSION`; env versions ``vcs_nav_v1`` and
``vcs_env/*-v1``). Every scale is a documented constant, never derived from the scenario, so the
same local situation reads the same numbers whatever the robot count, layout or arena size.
What differs between scenarios and matters to a policy (sensing radius, arrival radius, step)
is an explicit feature. Layout of one robot's vector (``EGO_DIM + n_neighbors * NEIGHBOR_DIM``
floats):

===== ============================ ===================================================
index feature                      scale
===== ============================ ===================================================
0     own speed                    / v_max, in [0, 1]
1     goal distance                / GOAL_REF (20 m), clipped to [0, 1] (farther goals read 1)
2, 3  goal bearing cos, sin        robot frame
4     v_max                        / V_REF (3 m/s)
5     a_max                        / A_REF (10 m/s^2)
6     omega_max                    / OMEGA_REF (2 pi rad/s)
7     own radius                   / R_REF (2 m)
8     sensing radius r_ca          / SENSE_REF (10 m), clipped to [0, 1]
9     arrival radius r_goal        / R_REF (2 m), clipped to [0, 1]
10    step dt                      / DT_REF (1 s)
===== ============================ ===================================================

then ``n_neighbors`` slots for the nearest objects (robots still in the world and obstacles)
whose centres lie within ``r_ca``, nearest surface first, zero-padded:

===== ============================ ===================================================
+0    mask                         1 for a real object, 0 for padding
+1,+2 relative position x, y       robot frame, / SENSE_REF (10 m), clipped to [-1, 1]
+3,+4 relative velocity x, y       object minus own velocity, robot frame, / (2 V_REF)
+5    object radius                / R_REF
+6    gap (distance - radii)       / SENSE_REF, clipped to [-1, 1]
+7    is-robot flag                1 robot, 0 obstacle
===== ============================ ===================================================

:func:`observation_config` names everything that fixes this layout and its scales; a checkpoint
stores it (:mod:`agents.checkpoint`) and may only be used where the config is the same. New
blocks (e.g. a lidar scan) go after the neighbour slots, with their size in
:func:`observation_dim`, their bounds in :func:`observation_bounds` and their parameters in
:func:`observation_config`.

Version history: v0 divided the goal distance by ``2 * scenario.world_extent`` and relative
positions and gaps by ``r_ca`` (scales that moved with n, layout and arena) and had no
features 8-10 (``EGO_DIM`` was 8).

With ``scenario.lidar`` (off by default) the lidar ranges follow, ``range / max_range`` in
``[0, 1]``, one per beam (:mod:`vcs_env.lidar`). With ``scenario.n_wall_points = k`` (0, off, by
default) k slots of the nearest points on walls follow, nearest first
(:func:`vcs_env.walls.nearest_wall_points`), each ``(valid, x / SENSE_REF, y / SENSE_REF)``: the
point in the robot frame in metres over 10 m, clipped to ``[-1, 1]``, 0 in empty slots.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import kernels, lidar
from .scenario import A_REF, OMEGA_REF, R_REF, V_REF, Scenario
from .state import WorldState
from .walls import nearest_wall_points

OBSERVATION_VERSION = 1
"""Version of the observation layout and scales (module docstring); bumped with the env versions."""
EGO_DIM = 11
"""Features of the robot itself and of the scenario (indices 0-10)."""
NEIGHBOR_DIM = 8
"""Features per neighbour slot."""
GOAL_REF = 20.0
"""Goal distance that reads 1 [m]; farther goals read 1 too (the bearing still points at them)."""
SENSE_REF = 10.0
"""Scale of relative positions, gaps and the sensing radius [m]."""
WALL_POINT_DIM = 3
"""Features per nearest-wall-point slot (valid, x, y)."""
DT_REF = 1.0
"""Largest allowed step [s] (``Scenario.dt`` is in (0, 1])."""


def observation_dim(scenario: Scenario) -> int:
    """Length D of one robot's observation."""
    lidar = scenario.lidar.n_beams if scenario.lidar is not None else 0
    return EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM + lidar + scenario.n_wall_points * WALL_POINT_DIM


def observation_config(scenario: Scenario) -> dict:
    """Everything that fixes the meaning of an observation vector of ``scenario``: version,
    block sizes and scales. Two scenarios with equal configs give comparable observations, so a
    policy trained on one may be run on the other (checked by :mod:`agents.checkpoint`)."""
    return (
        {
            "version": OBSERVATION_VERSION,
            "ego_dim": EGO_DIM,
            "n_neighbors": scenario.n_neighbors,
            "neighbor_dim": NEIGHBOR_DIM,
            "scales": {
                "goal_ref": GOAL_REF,
                "sense_ref": SENSE_REF,
                "dt_ref": DT_REF,
                "v_ref": V_REF,
                "a_ref": A_REF,
                "omega_ref": OMEGA_REF,
                "r_ref": R_REF,
            },
        }
        | ({"lidar": dataclasses.asdict(scenario.lidar)} if scenario.lidar is not None else {})
        | (
            {"n_wall_points": scenario.n_wall_points, "wall_point_dim": WALL_POINT_DIM}
            if scenario.n_wall_points
            else {}
        )
    )


def observation_bounds(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds ``(D,)`` float32 of every robot's observation (the tables above)."""
    dim = observation_dim(scenario)
    low = np.full(dim, -1.0, dtype=np.float32)
    low[[0, 1, 4, 5, 6, 7, 8, 9, 10]] = 0.0
    slots = EGO_DIM + NEIGHBOR_DIM * np.arange(scenario.n_neighbors)
    for off in (0, 5, 7):
        low[slots + off] = 0.0
    if scenario.lidar is not None:
        low[EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM :][: scenario.lidar.n_beams] = 0.0
    if scenario.n_wall_points:
        low[dim - scenario.n_wall_points * WALL_POINT_DIM :: WALL_POINT_DIM] = 0.0  # the valid flags
    return low, np.ones(dim, dtype=np.float32)


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
        world.r_goal, world.dt, scenario.n_neighbors, EGO_DIM, GOAL_REF, SENSE_REF, DT_REF, V_REF, A_REF,
        OMEGA_REF, R_REF, observation_dim(scenario),
    )  # fmt: skip
    at = EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM  # the optional blocks, written in place
    if scenario.lidar is not None:
        lidar.write_observation(obs[..., at : at + scenario.lidar.n_beams], world, scenario.lidar)
        at += scenario.lidar.n_beams
    if scenario.n_wall_points:
        obs[..., at:] = wall_points_block(world, scenario.n_wall_points)
    return obs


def wall_points_block(world: WorldState, k: int) -> np.ndarray:
    """The nearest-wall-points block ``(B, n, k * WALL_POINT_DIM)`` float32 (module docstring)."""
    points, valid = nearest_wall_points(world, k)
    block = np.concatenate((valid[..., None], np.clip(points / SENSE_REF, -1.0, 1.0)), axis=-1)
    return block.reshape(world.batch_size, world.n_robots, -1).astype(np.float32)


def _optional_blocks(obs: np.ndarray, world: WorldState, scenario: Scenario) -> np.ndarray:
    """``obs`` followed by the optional blocks the scenario turns on: lidar, then wall points."""
    if scenario.lidar is not None:
        obs = np.concatenate((obs, lidar.observation_block(world, scenario.lidar)), axis=-1)
    if scenario.n_wall_points:
        obs = np.concatenate((obs, wall_points_block(world, scenario.n_wall_points)), axis=-1)
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
    out[..., 1] = np.minimum(d_goal / GOAL_REF, 1.0)
    out[..., 2] = np.where(far, (c * gx + s * gy) / safe, 1.0)  # goal bearing in the robot frame
    out[..., 3] = np.where(far, (-s * gx + c * gy) / safe, 0.0)
    out[..., 4] = world.v_max / V_REF
    out[..., 5] = world.a_max / A_REF
    out[..., 6] = world.omega_max / OMEGA_REF
    out[..., 7] = world.radius / R_REF
    out[..., 8] = world.r_ca / SENSE_REF
    out[..., 9] = world.r_goal / R_REF
    out[..., 10] = world.dt / DT_REF
    feats, valid = sense(world, k)
    nb = out[..., EGO_DIM:].reshape(B, n, k, NEIGHBOR_DIM)
    nb[..., 0] = valid
    nb[..., 1:3] = feats[..., 0:2] / SENSE_REF
    nb[..., 3:5] = feats[..., 2:4] / (2.0 * V_REF)
    nb[..., 5] = feats[..., 4] / R_REF
    nb[..., 6] = feats[..., 5] / SENSE_REF
    nb[..., 7] = feats[..., 6]
    # Far objects, long gaps, large r_ca or r_goal and rounding (an object exactly at r_ca) are clipped into the space.
    obs = np.clip(out, -1.0, 1.0).astype(np.float32)
    return _optional_blocks(obs, world, scenario)


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
