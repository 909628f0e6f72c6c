"""Diagnostic for stage I: play circle-24 episodes with a policy as it is, and with robots parked on
their goals shown to it as obstacles (is-robot flag 0 in their neighbour slots), nothing retrained.

    python results/generalist/stage-i/parked_as_obstacles.py POLICY.zip circle-24-v0 5000 5100
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.geometry import rotate
from vcs_env.observations import EGO_DIM, NEIGHBOR_DIM, SENSE_REF
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

spec, suite = sys.argv[1], sys.argv[2]
seeds = list(range(int(sys.argv[3]), int(sys.argv[4])))
scenario = get_suite(suite).scenario
base = resolve_policy(spec, scenario).controller
relabelled = [0]


def parked_as_obstacles(world, obs):
    """``base`` on ``obs`` (B, n, D) with the slots of parked robots (present, not active) flagged 0."""
    parked = world.present & ~world.active  # (B, n)
    if not parked.any():
        return base(world, obs)
    obs = obs.copy()
    B, n, _ = obs.shape
    k = scenario.n_neighbors
    slots = obs[..., EGO_DIM : EGO_DIM + k * NEIGHBOR_DIM].reshape(B, n, k, NEIGHBOR_DIM)
    # (B, n, k, 2) slot centres in the world frame [m]
    centre = world.pos[:, :, None] + rotate(slots[..., 1:3] * SENSE_REF, world.heading[:, :, None])
    for b in np.nonzero(parked.any(axis=1))[0]:
        p = world.pos[b][parked[b]]  # (p, 2) [m]
        d = np.linalg.norm(centre[b][:, :, None] - p, axis=-1).min(axis=-1)  # (n, k) [m]
        hit = (d < 1e-3) & (slots[b, ..., 0] > 0.5) & (slots[b, ..., 7] > 0.5)
        slots[b, ..., 7][hit] = 0.0
        relabelled[0] += int(hit.sum())
    obs[..., EGO_DIM : EGO_DIM + k * NEIGHBOR_DIM] = slots.reshape(B, n, k * NEIGHBOR_DIM)
    return base(world, obs)


for name, controller in (("as is", base), ("parked robots shown as obstacles", parked_as_obstacles)):
    episodes = run_episodes(scenario, controller, seeds)
    collision = np.mean([ep.collided.any() for ep in episodes])
    success = np.mean([(ep.reached_step >= 0).all() and not ep.collided.any() for ep in episodes])
    print(f"{spec} on {suite}, {len(seeds)} episodes, {name}: success {success:.3f}, collision {collision:.3f}")
print(f"slots relabelled: {relabelled[0]}")
