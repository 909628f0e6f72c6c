"""Diagnostic (run.sh): parked robots read as obstacles. Replaces ``vcs_env.engine.observe`` so that the
is-robot flag (slot feature +7) is 0 for robots that no longer drive; the observation's size and
every other number stay those of observation version 1, so v1 weights load and train unchanged.

With ``INTENT_REF`` [m] set in the environment (../intent-flag), the flag of a robot still driving also says how
close it is to stopping: ``0.5 + 0.5 * min(1, remaining / INTENT_REF)``, ``remaining`` its distance to the
arrival circle (goal distance minus ``r_goal``) [m], so a robot about to arrive and stop dead reads between 0.5
and 1, one far from its goal 1 as before, a parked robot 0."""

import os

import numpy as np

import vcs_env.engine as E
import vcs_env.observations as O

_orig = O.observe
INTENT_REF = float(os.environ.get("INTENT_REF", "0"))  # [m]; 0: the parked flag only


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
    flag = nb[..., 7]
    if INTENT_REF:
        remaining = np.linalg.norm(world.goal - world.pos, axis=-1) - world.r_goal  # (B, n) [m]
        intent = 0.5 + 0.5 * np.clip(remaining / INTENT_REF, 0.0, 1.0)
        intent_all = np.concatenate((intent, np.zeros((B, world.n_obstacles))), axis=1)
        flag = np.where(flag > 0, np.take_along_axis(np.broadcast_to(intent_all[:, None], key.shape), idx, -1), flag)
    nb[..., 7] = np.where(parked, 0.0, flag)
    return obs


E.observe = observe
