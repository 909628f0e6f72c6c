"""Per-robot observations in the robot's own frame, in fixed physical units, within [-1, 1].

An observation is a sequence of blocks (:class:`Block`), each one object with a name, a number of
items (slots), the fields of one item, their bounds and physical scales; :func:`observation_layout`
gives a scenario's blocks and their offsets, and everything that reads an observation (the policy's
feature encoders, the shield, the ONNX export) takes its offsets from there. Every scale is a
documented constant, never derived from the scenario, so the same local situation reads the same
numbers whatever the robot count, layout or arena size. What differs between scenarios and matters
to a policy (sensing radius, arrival radius, step) is an explicit feature.

Observation version 2 (:data:`OBSERVATION_VERSION`, ``Scenario.observation = 2``, the default; env
versions ``vcs_nav_v2`` and ``vcs_env/*-v2``). Blocks, in order:

``ego`` (1 item of ``EGO_DIM`` = 11 floats):

===== ============================ ===================================================
index feature                      scale
===== ============================ ===================================================
0     own speed                    / v_max, in [0, 1]
1     route distance               / GOAL_REF (20 m), clipped to [0, 1] (farther goals read 1)
2, 3  route bearing cos, sin       robot frame
4     v_max                        / V_REF (3 m/s)
5     a_max                        / A_REF (10 m/s^2)
6     omega_max                    / OMEGA_REF (2 pi rad/s)
7     own radius                   / R_REF (2 m)
8     sensing radius r_ca          / SENSE_REF (10 m), clipped to [0, 1]
9     arrival radius r_goal        / R_REF (2 m), clipped to [0, 1]
10    step dt                      / DT_REF (1 s)
===== ============================ ===================================================

The route features (1-3) follow the route the planners drive along (:func:`route_features`,
:mod:`vcs_env.routes`): among walls, the remaining length of the shortest route around them and the
bearing of its next waypoint (a door, a corner); without walls, or where no route is found, the
straight distance and bearing of the goal. (Observation v1 always reads the straight ones.)

``neighbors`` (``n_neighbors`` slots of ``NEIGHBOR_DIM`` = 9 floats): the nearest objects (robots
still in the world and obstacles) whose centres lie within ``r_ca``, nearest surface first,
zero-padded:

===== ============================ ===================================================
+0    mask                         1 for a real object, 0 for padding
+1,+2 relative position x, y       robot frame, / SENSE_REF (10 m), clipped to [-1, 1]
+3,+4 relative velocity x, y       object minus own velocity, robot frame, / (2 V_REF), clipped to [-1, 1]
                                   (never reached: speeds are validated <= V_REF)
+5    object radius                / R_REF, clipped to [-1, 1] (never reached: radii are validated <= R_REF)
+6    gap (distance - radii)       / SENSE_REF, clipped to [-1, 1]
+7    is-robot flag                1 robot, 0 obstacle
+8    parked flag                  1 for a robot that has finished (arrived, or crashed under
                                   ``on_collision="terminate"``) and stays where it is, 0 otherwise
===== ============================ ===================================================

``clock`` (with ``Scenario.stall_clock``; off by default):
1 item, the robot's stall clock
(:mod:`vcs_env.stall`, the memory the expert frees deadlocks with): ``detouring`` (1 while the
stall rule has the robot detour), ``detour_left``, ``stalled`` (time slow and away from the goal; 0 while
detouring), ``no_progress`` (time since the last progress mark: since it last came closer to its goal, or since
its last detour began, whichever is later) [s] / ``CLOCK_REF`` (5 s) in [0, 1], and ``tries`` (detours begun
since it last made progress) / 4, clipped to [0, 1].

``lidar`` (with ``Scenario.lidar``; off by default): one item per beam, ``range / max_range`` in
``[0, 1]`` (:mod:`vcs_env.lidar`).

``wall_points`` (with ``Scenario.n_wall_points = k`` > 0; 0, off, by default): k slots of the
nearest points on walls, nearest first (:func:`vcs_env.walls.nearest_wall_points`), each
``(valid, x / SENSE_REF, y / SENSE_REF)``: the point in the robot frame in metres over 10 m,
clipped to ``[-1, 1]``, 0 in empty slots; with ``Scenario.wall_segments`` four more fields, the
wall segment the point lies on: its unit direction ``tx, ty`` in the robot frame (turned to ``tx >= 0``),
and how far it runs from the point backward (along ``-t``) and forward ``back, ahead`` [m] / 10 m,
clipped to ``[0, 1]`` (at an end of the wall, a corner or a door post, one of them is 0): with them a
policy knows where a wall it drives at a slant toward meets its path, and that a door post is not a
wall across the door.

:func:`observation_config` names everything that fixes the layout and its scales (for v2 the blocks
with their items and fields); a checkpoint stores it (:mod:`agents.checkpoint`) and may only be used
where the config is the same, and a mismatch names the block. The sensing fields of a scenario
(:data:`SENSOR_FIELDS`) only shape what robots observe, never the episode: the evaluation harness
runs a checkpoint on any suite with the sensing it was trained with (:func:`with_sensors`).

Version history:

* v2, fix (2026-12-07): a wall segment square to the robot's heading within rounding reads ``ty = +1`` (its
  direction turned ahead, ``tx`` 0) at any heading; ``cos(pi / 2)`` is 6e-17, so a robot heading ``pi`` or ``pi / 2``
  read ``ty = -1`` (``back`` and ``ahead`` swapped) where one heading 0 read ``+1``. The released v2 network's results
  on the seven map suites are the same with it (every rate and time).
* v2, 2026-12-06: the optional segment fields of the wall points (``Scenario.wall_segments``, off by
  default, so every v2 observation without them reads as before).
* v2, 2026-11-28: the optional ``clock`` block (``Scenario.stall_clock``, off by default, so every
  v2 observation without it reads as before).
* v2: neighbour slots gain the parked flag (``NEIGHBOR_DIM`` 8 -> 9), so a policy can tell a robot
  that waits at its goal (it will not move out of the way) from one that is about to drive on;
  among walls the goal features follow the route (the next waypoint and the remaining route length),
  so a policy knows which door leads to its goal; observations are built from named blocks.
  ``Scenario(observation=1)`` (and the ``-v1`` ids) still give v1, so v1 checkpoints keep running.
* v1: fixed physical scales (goal distance / 20 m, positions and gaps / 10 m) and the scenario
  features 8-10 (``EGO_DIM`` 11); neighbour slots of 8 floats, without the parked flag.
* v0: divided the goal distance by ``2 * scenario.world_extent`` and relative positions and gaps by
  ``r_ca`` (scales that moved with n, layout and arena) and had no features 8-10 (``EGO_DIM`` was 8).
  Removed.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import kernels, lidar, routes
from .blocks import Block, Layout
from .lidar import LidarSpec
from .scenario import A_REF, OMEGA_REF, R_REF, V_REF, Scenario
from .stall import CLOCK_BLOCK_FIELDS, CLOCK_REF, TRIES_REF, clock_block
from .state import WorldState
from .walls import nearest_wall_points

OBSERVATION_VERSION = 2
"""Version of the observation layout and scales (module docstring); bumped with the env versions."""
OBSERVATION_VERSIONS = (1, 2)
"""Versions this vcs-env can still produce (``Scenario.observation``)."""
EGO_DIM = 11
"""Features of the robot itself and of the scenario (indices 0-10)."""
NEIGHBOR_FIELDS = ("mask", "x", "y", "vx", "vy", "radius", "gap", "is_robot", "parked")
"""Fields of a v2 neighbour slot (v1: all but the last)."""
NEIGHBOR_DIM = len(NEIGHBOR_FIELDS)
"""Features per v2 neighbour slot (9; v1 had 8)."""
GOAL_REF = 20.0
"""Goal distance that reads 1 [m]; farther goals read 1 too (the bearing still points at them)."""
SENSE_REF = 10.0
"""Scale of relative positions, gaps and the sensing radius [m]."""
WALL_POINT_FIELDS = ("valid", "x", "y", "tx", "ty", "back", "ahead")
"""Fields of a nearest-wall-point slot (the last four with ``Scenario.wall_segments`` only)."""
WALL_POINT_DIM = 3
"""Features per nearest-wall-point slot without ``Scenario.wall_segments`` (valid, x, y)."""
DT_REF = 1.0
"""Largest allowed step [s] (``Scenario.dt`` is in [0.001, 1])."""
SENSOR_FIELDS = ("observation", "n_neighbors", "lidar", "n_wall_points", "wall_segments", "stall_clock")
"""Scenario fields that only change what robots observe, never the episode's worlds."""
_SCALES = {
    "goal_ref": GOAL_REF,
    "sense_ref": SENSE_REF,
    "dt_ref": DT_REF,
    "v_ref": V_REF,
    "a_ref": A_REF,
    "omega_ref": OMEGA_REF,
    "r_ref": R_REF,
}


_EGO_FIELDS = ("speed", "route_distance", "route_cos", "route_sin", "v_max", "a_max", "omega_max", "radius", "r_ca",
               "r_goal", "dt")  # fmt: skip
_EGO_LOW = (0.0, 0.0, -1.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
_NEIGHBOR_LOW = (0.0, -1.0, -1.0, -1.0, -1.0, 0.0, -1.0, 0.0, 0.0)


def observation_layout(scenario: Scenario) -> Layout:
    """The blocks of ``scenario``'s observations (module docstring), in order."""
    version = scenario.observation
    nb = NEIGHBOR_DIM if version >= 2 else NEIGHBOR_DIM - 1
    blocks = [
        Block("ego", 1, _EGO_FIELDS, _EGO_LOW, "module docstring, ego table", "the robot itself and the scenario"),
        Block(
            "neighbors",
            scenario.n_neighbors,
            NEIGHBOR_FIELDS[:nb],
            _NEIGHBOR_LOW[:nb],
            f"positions and gaps / {SENSE_REF} m, velocities / {2 * V_REF} m/s, radii / {R_REF} m",
            "the nearest robots and obstacles within r_ca, nearest surface first",
        ),  # fmt: skip
    ]
    if scenario.stall_clock:
        blocks.append(
            Block("clock", 1, CLOCK_BLOCK_FIELDS, (0.0,) * len(CLOCK_BLOCK_FIELDS),
                  f"times / {CLOCK_REF} s, detours / {TRIES_REF}",
                  "the robot's stall clock: whether it detours, for how long, how long it has been stuck")
        )  # fmt: skip
    if scenario.lidar is not None:
        spec = scenario.lidar
        blocks.append(Block("lidar", spec.n_beams, ("range",), (0.0,), f"/ {spec.max_range} m", "range per beam"))
    if scenario.n_wall_points:
        blocks.append(
            Block("wall_points", scenario.n_wall_points, WALL_POINT_FIELDS[: 3 + 4 * scenario.wall_segments],
                  (0.0, -1.0, -1.0, -1.0, -1.0, 0.0, 0.0)[: 3 + 4 * scenario.wall_segments],
                  f"positions and extents / {SENSE_REF} m" + (", directions unit" if scenario.wall_segments else ""),
                  "the nearest points on walls, nearest first")
        )  # fmt: skip
    return Layout(version, tuple(blocks))


def observation_dim(scenario: Scenario) -> int:
    """Length D of one robot's observation."""
    return observation_layout(scenario).dim


def observation_config(scenario: Scenario) -> dict:
    """Everything that fixes the meaning of an observation vector of ``scenario``: version,
    blocks and scales. Two scenarios with equal configs give comparable observations, so a
    policy trained on one may be run on the other (checked by :mod:`agents.checkpoint`).
    Version 1 keeps the form v1 checkpoints stored."""
    if scenario.observation == 1:
        return (
            {
                "version": 1,
                "ego_dim": EGO_DIM,
                "n_neighbors": scenario.n_neighbors,
                "neighbor_dim": NEIGHBOR_DIM - 1,
                "scales": dict(_SCALES),
            }  # fmt: skip
            | ({"lidar": dataclasses.asdict(scenario.lidar)} if scenario.lidar is not None else {})
            | (
                {"n_wall_points": scenario.n_wall_points, "wall_point_dim": WALL_POINT_DIM}
                if scenario.n_wall_points
                else {}
            )
        )
    return {
        "version": scenario.observation,
        "blocks": [b.describe() for b in observation_layout(scenario).blocks],
        "scales": dict(_SCALES),
    } | ({"lidar": dataclasses.asdict(scenario.lidar)} if scenario.lidar is not None else {})


def sensors_of(config: dict) -> dict:
    """The scenario's sensing fields (:data:`SENSOR_FIELDS`) that give observation ``config``.

    Raises:
        ValueError: a config this vcs-env cannot produce (another version, an unknown block).
    """
    version = config.get("version") if isinstance(config, dict) else None
    if version not in OBSERVATION_VERSIONS:
        raise ValueError(
            f"observation version {version!r}: this vcs-env produces versions {list(OBSERVATION_VERSIONS)}"
        )
    spec = LidarSpec(**config["lidar"]) if config.get("lidar") is not None else None
    if version == 1:
        return {"observation": 1, "n_neighbors": config["n_neighbors"], "lidar": spec,
                "n_wall_points": config.get("n_wall_points", 0), "wall_segments": False,
                "stall_clock": False}  # fmt: skip
    items = {b["name"]: b["items"] for b in config["blocks"]}
    fields = {b["name"]: tuple(b.get("fields", ())) for b in config["blocks"]}
    unknown = set(items) - {"ego", "neighbors", "lidar", "wall_points", "clock"}
    if unknown:
        raise ValueError(f"observation blocks {sorted(unknown)} are not ones this vcs-env produces")
    return {"observation": version, "n_neighbors": items["neighbors"], "lidar": spec,
            "n_wall_points": items.get("wall_points", 0), "wall_segments": "tx" in fields.get("wall_points", ()),
            "stall_clock": "clock" in items}  # fmt: skip


def with_sensors(scenario: Scenario, config: dict) -> Scenario:
    """``scenario`` observed as ``config`` says (its worlds unchanged: only :data:`SENSOR_FIELDS` change)."""
    return dataclasses.replace(scenario, **sensors_of(config))


def sees_walls(scenario: Scenario) -> bool:
    """Whether ``scenario``'s observation shows walls (a lidar or a wall-points block)."""
    return scenario.lidar is not None or scenario.n_wall_points > 0


def observation_bounds(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds ``(D,)`` float32 of every robot's observation (the tables above)."""
    return observation_layout(scenario).bounds()


def sense(world: WorldState, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nearest sensed objects of every robot, nearest surface first (ties by index).

    Objects are the robots still in the world (not the robot itself) and the obstacles whose
    centres lie within ``r_ca``.

    Returns:
        features ``(B, n, k, 8)``: relative position x, y and relative velocity x, y in the
        robot's frame [m, m/s], radius [m], gap [m], is-robot flag, parked flag (a robot that is
        in the world but no longer active); and the valid mask ``(B, n, k)`` bool (padding slots
        are all zero).
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
    feats = np.empty((B, n, total, 8))
    feats[..., 0] = c * rel[..., 0] + s * rel[..., 1]
    feats[..., 1] = -s * rel[..., 0] + c * rel[..., 1]
    feats[..., 2] = c * rvel[..., 0] + s * rvel[..., 1]
    feats[..., 3] = -s * rvel[..., 0] + c * rvel[..., 1]
    feats[..., 4] = radius[:, None]
    feats[..., 5] = gap
    feats[..., 6] = np.arange(total) < n
    feats[..., 7] = np.concatenate((world.present & ~world.active, np.zeros((B, m), dtype=bool)), axis=1)[:, None]
    sel = np.take_along_axis(feats, idx[..., None], axis=2)
    valid = np.isfinite(np.take_along_axis(key, idx, axis=-1))
    sel *= valid[..., None]
    if kk < k:  # fewer objects than slots: zero padding (np.pad costs more than the rest here)
        full, full_valid = np.zeros((B, n, k, 8)), np.zeros((B, n, k), dtype=bool)
        full[:, :, :kk], full_valid[:, :, :kk] = sel, valid
        return full, full_valid
    return sel, valid


def observe(world: WorldState, scenario: Scenario) -> np.ndarray:
    """Observations of every robot ``(B, n, D)`` float32, within :func:`observation_bounds`.

    One compiled call for all worlds (:func:`vcs_env.kernels.observe`); :func:`reference_observe`
    is the same computation in readable numpy, the kernel's test oracle."""
    layout = observation_layout(scenario)
    obs = kernels.observe(
        world.pos, world.heading, world.speed, world.radius, world.goal, world.v_max, world.a_max,
        world.omega_max, world.present, world.active, world.obs_pos, world.obs_vel, world.obs_radius, world.r_ca,
        world.r_goal, world.dt, scenario.n_neighbors, layout.block("neighbors").item_dim, EGO_DIM, GOAL_REF,
        SENSE_REF, DT_REF, V_REF, A_REF, OMEGA_REF, R_REF, layout.dim,
    )  # fmt: skip
    if scenario.observation >= 2:
        route_features(obs, world)
    if "lidar" in layout:  # the optional blocks, written in place
        lidar.write_observation(obs[..., layout.span("lidar")], world, scenario.lidar)
    if "wall_points" in layout:
        obs[..., layout.span("wall_points")] = wall_points_block(world, scenario.n_wall_points, scenario.wall_segments)
    if "clock" in layout:
        obs[..., layout.span("clock")] = clock_block(world)
    return obs


def route_features(obs: np.ndarray, world: WorldState) -> None:
    """Write the route features of observation v2 into ``obs`` ``(B, n, D)`` in place: among walls,
    ego features 1-3 read the remaining route length and the bearing of the next waypoint
    (:func:`vcs_env.routes.waypoints`, the route the planners follow) instead of the straight
    distance and bearing of the goal. Without walls the route is the straight line: nothing changes."""
    if not routes.walled(world):
        return
    target, length = routes.waypoints(world)
    e = target - world.pos
    d = np.sqrt(np.einsum("...i,...i->...", e, e))
    far = d > 1e-12
    c, s = np.cos(world.heading), np.sin(world.heading)
    safe = np.where(far, d, 1.0)
    obs[..., 1] = np.minimum(length / GOAL_REF, 1.0)
    obs[..., 2] = np.clip(np.where(far, (c * e[..., 0] + s * e[..., 1]) / safe, 1.0), -1.0, 1.0)
    obs[..., 3] = np.clip(np.where(far, (-s * e[..., 0] + c * e[..., 1]) / safe, 0.0), -1.0, 1.0)


def wall_points_block(world: WorldState, k: int, segments: bool = False) -> np.ndarray:
    """The nearest-wall-points block ``(B, n, k * (3 + 4 segments))`` float32 (module docstring)."""
    points, valid, seg = nearest_wall_points(world, k, with_segments=segments)
    parts = [valid[..., None], np.clip(points / SENSE_REF, -1.0, 1.0)]
    if segments:
        parts += [seg[..., :2], np.clip(seg[..., 2:] / SENSE_REF, 0.0, 1.0)]
    return np.concatenate(parts, axis=-1).reshape(world.batch_size, world.n_robots, -1).astype(np.float32)


def _optional_blocks(obs: np.ndarray, world: WorldState, scenario: Scenario) -> np.ndarray:
    """``obs`` followed by the optional blocks the scenario turns on: the clock, lidar, then wall points."""
    if scenario.stall_clock:
        obs = np.concatenate((obs, clock_block(world)), axis=-1)
    if scenario.lidar is not None:
        obs = np.concatenate((obs, lidar.observation_block(world, scenario.lidar)), axis=-1)
    if scenario.n_wall_points:
        obs = np.concatenate((obs, wall_points_block(world, scenario.n_wall_points, scenario.wall_segments)), axis=-1)
    return obs


def reference_observe(world: WorldState, scenario: Scenario) -> np.ndarray:
    """:func:`observe` in readable numpy (with :func:`sense`): the oracle of the compiled kernel."""
    k = scenario.n_neighbors
    B, n = world.batch_size, world.n_robots
    nb_dim = observation_layout(scenario).block("neighbors").item_dim
    out = np.empty((B, n, EGO_DIM + k * nb_dim))
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
    nb = out[..., EGO_DIM:].reshape(B, n, k, nb_dim)
    nb[..., 0] = valid
    nb[..., 1:3] = feats[..., 0:2] / SENSE_REF
    nb[..., 3:5] = feats[..., 2:4] / (2.0 * V_REF)
    nb[..., 5] = feats[..., 4] / R_REF
    nb[..., 6] = feats[..., 5] / SENSE_REF
    nb[..., 7] = feats[..., 6]
    if nb_dim > 8:  # v2
        nb[..., 8] = feats[..., 7]
    # Far objects, long gaps, large r_ca or r_goal and rounding (an object exactly at r_ca) are clipped into the space.
    obs = np.clip(out, -1.0, 1.0).astype(np.float32)
    if scenario.observation >= 2:
        route_features(obs, world)
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
