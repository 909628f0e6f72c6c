"""At D s before each first contact of the policy on dynamic-v0 (and every 0.2 s until it): the policy's and the
expert's action for that robot in the same state.

Usage: python results/generalist/stage-k/actions_at.py POLICY START STOP D
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.metrics import EpisodeFacts
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

spec, start, stop, D = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4])
sc = get_suite("dynamic-v0").scenario
eps = run_episodes(sc, resolve_policy(spec, sc).controller, list(range(start, stop)))
for ep in eps:
    if not EpisodeFacts(ep).collided:
        continue
    tc, i = (int(v) for v in np.argwhere(ep.collided)[0])
    rows = []
    for s in range(max(tc - int(round(D / sc.dt)), 0), tc + 1, 2):
        pol = resolve_policy(spec, sc).controller
        exp = resolve_policy("vcs", sc).controller
        seen = {}

        def act(world, obs, s=s, i=i, pol=pol, exp=exp, seen=seen):
            a, e = pol(world, obs), exp(world, obs)
            if int(world.steps[0]) == s:
                seen["p"], seen["e"], seen["v"] = a[0, i].copy(), e[0, i].copy(), float(world.speed[0, i])
            return a

        run_episodes(sc, act, [ep.seed], max_steps=s + 1)
        p, e, v = seen["p"], seen["e"], seen["v"]
        rows.append(f"t-{(tc - s) * sc.dt:.1f}s v{v:.2f} pol({p[0]:+.2f},{p[1]:+.2f}) vcs({e[0]:+.2f},{e[1]:+.2f})")
    print(ep.seed, i, tc, " | ".join(rows), flush=True)
