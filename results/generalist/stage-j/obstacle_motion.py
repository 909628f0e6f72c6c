"""dynamic-v0 with other obstacle motions: is unpredictability what the policy misses?

Usage: python results/generalist/stage-j/obstacle_motion.py START STOP MOTION[,MOTION...] POLICY [POLICY...]
(seeds START..STOP-1; POLICY as for vcs-env evaluate: vcs, hrvo or a checkpoint). Success and collision as
the suites count them (vcs_env.metrics.EpisodeFacts).
"""

import dataclasses
import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.metrics import EpisodeFacts
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

seeds = list(range(int(sys.argv[1]), int(sys.argv[2])))
base = get_suite("dynamic-v0").scenario
for motion in sys.argv[3].split(","):
    sc = dataclasses.replace(base, obstacle_motion=motion)
    for spec in sys.argv[4:]:
        eps = run_episodes(sc, resolve_policy(spec, sc).controller, seeds)
        facts = [EpisodeFacts(ep) for ep in eps]  # the suites' success and collision
        success = np.mean([f.success for f in facts])
        collision = np.mean([f.collided for f in facts])
        print(f"{motion:12s} {spec}: success {success:.3f} collision {collision:.3f}", flush=True)
