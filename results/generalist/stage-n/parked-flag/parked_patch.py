"""Diagnostic (run.sh): parked robots read as obstacles. Replaces ``vcs_env.engine.observe`` so that the
is-robot flag (slot feature +7) is 0 for robots that no longer drive; the observation's size and
every other number stay those of observation version 1, so v1 weights load and train unchanged."""

import numpy as np

import vcs_env.engine as E
import vcs_env.observations as O

_orig = O.observe


def observe(world, scenario):
    obs = _orig(world, scenario)
    k = scenario.n_neighbors
    B, n = world.batch_size, world.n_robots
    # Which object sits in each slot: redo the ordering of O.sense with the object index as a feature.
    pos = np.concatenate((world.pos, world.obs_pos), axis=1)
    radius = np.concatenate((world.radius, world.obs_radius), axis=1)
    present = np.concatenate((world.present, np.ones((B, world.n_obstacles), dtype=bool)), axis=1)
    rel = pos[:, None] - world.pos[:, :, None]
    dist = np.sqrt((rel**2).sum(-1))
    gap = dist - radius[:, None] - world.radius[:, :, None]
    sensed = present[:, None] & (dist <= world.r_ca)
    sensed[:, np.arange(n), np.arange(n)] = False
    key = np.where(sensed, gap, np.inf)
    idx = np.argsort(key, axis=-1, kind="stable")[..., :k]
    valid = np.isfinite(np.take_along_axis(key, idx, -1))
    parked_all = np.concatenate((world.present & ~world.active, np.zeros((B, world.n_obstacles), bool)), axis=1)
    parked = np.take_along_axis(np.broadcast_to(parked_all[:, None], key.shape), idx, -1) & valid
    kk = idx.shape[-1]
    nb = obs[..., O.EGO_DIM : O.EGO_DIM + kk * O.NEIGHBOR_DIM].reshape(B, n, kk, O.NEIGHBOR_DIM)
    nb[..., 7] = np.where(parked, 0.0, nb[..., 7])
    return obs


E.observe = observe
