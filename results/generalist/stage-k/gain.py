"""Hedging test: does the policy lose dynamic-v0 episodes by acting too softly? Scale its deterministic
action by k (clipped to [-1, 1]) and score the episodes.

Usage: python results/generalist/stage-k/gain.py POLICY START STOP K[,K...] [SUITE]
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.metrics import EpisodeFacts
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

spec, start, stop = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
fam = sys.argv[5] if len(sys.argv) > 5 else "dynamic-v0"
sc = get_suite(fam).scenario
seeds = list(range(start, stop))
for k in (float(x) for x in sys.argv[4].split(",")):
    pol = resolve_policy(spec, sc).controller

    def ctl(world, obs, k=k, pol=pol):
        return np.clip(k * pol(world, obs), -1.0, 1.0)

    facts = [EpisodeFacts(ep) for ep in run_episodes(sc, ctl, seeds)]
    success, collision = np.mean([f.success for f in facts]), np.mean([f.collided for f in facts])
    print(f"{fam} k={k}: success {success:.3f} collision {collision:.3f}", flush=True)
