"""Where the policy loses its dynamic-v0 episodes: drive with the policy, but let the VCS expert act
for robots within R of their goal (and, for comparison, the other way round).

Usage: python results/generalist/stage-j/near_goal_hybrid.py POLICY START STOP R[,R...]
(seeds START..STOP-1; the expert is called every step so its memory follows the episode either way).
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.metrics import EpisodeFacts
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

spec, start, stop = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
sc = get_suite("dynamic-v0").scenario
seeds = list(range(start, stop))


def hybrid(radius: float, expert_near: bool):
    policy = resolve_policy(spec, sc).controller
    expert = resolve_policy("vcs", sc).controller

    def act(world, obs):
        a, e = policy(world, obs), expert(world, obs)
        near = np.linalg.norm(world.goal - world.pos, axis=-1) < radius  # (B, n)
        return np.where((near if expert_near else ~near)[..., None], e, a)

    return act


for radius in (float(r) for r in sys.argv[4].split(",")):
    for expert_near in (True, False):
        eps = run_episodes(sc, hybrid(radius, expert_near), seeds)
        facts = [EpisodeFacts(ep) for ep in eps]  # the suites' success and collision
        success = np.mean([f.success for f in facts])
        collision = np.mean([f.collided for f in facts])
        who = "expert within, policy beyond" if expert_near else "policy within, expert beyond"
        print(f"R={radius} m, {who}: success {success:.3f} collision {collision:.3f}", flush=True)
