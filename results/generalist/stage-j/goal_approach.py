"""Time from first coming within R of the goal to arriving [s], per robot that arrives.

Usage: python results/generalist/stage-j/goal_approach.py SUITE START STOP POLICY [POLICY...]
(seeds START..STOP-1 of the suite's scenario; POLICY as for vcs-env evaluate).
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

suite, start, stop = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
sc = get_suite(suite).scenario
for spec in sys.argv[4:]:
    eps = run_episodes(sc, resolve_policy(spec, sc).controller, list(range(start, stop)))
    for radius in (0.5, 0.3):
        lat = []
        for ep in eps:
            d = np.linalg.norm(ep.pos - ep.goal[None], axis=-1)  # (T+1, n) [m]
            for i in range(ep.n_robots):
                inside = np.flatnonzero(d[:, i] < radius)
                if len(inside) and ep.reached_step[i] >= 0:
                    lat.append((ep.reached_step[i] - inside[0]) * ep.dt)
        lat = np.array(lat)
        print(
            f"{spec} R={radius} m: {len(lat)} robots, mean {lat.mean():.2f} s, p90 {np.percentile(lat, 90):.2f} s, "
            f"over 2 s: {np.mean(lat > 2):.3f}, max {lat.max():.1f} s"
        )
