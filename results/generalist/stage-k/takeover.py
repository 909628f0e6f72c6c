"""Takeover test on dynamic-v0: for each episode the policy loses to a contact at step t_c, replay it with
the policy until t_c - D/dt and the VCS expert for every robot afterwards; does the expert still avoid it?

Usage: python results/generalist/stage-k/takeover.py POLICY START STOP D[,D...]
(seeds START..STOP-1, D in seconds; the expert is called every step so its memory follows the episode).
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.metrics import EpisodeFacts
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

spec, start, stop = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
sc = get_suite("dynamic-v0").scenario
eps = run_episodes(sc, resolve_policy(spec, sc).controller, list(range(start, stop)))
bad = [(ep.seed, int(np.argwhere(ep.collided)[0][0])) for ep in eps if EpisodeFacts(ep).collided]
print(f"{len(bad)} of {len(eps)} with contact; seeds/steps {bad}", flush=True)
for D in (float(x) for x in sys.argv[4].split(",")):
    saved = 0
    rows = []
    for seed, tc in bad:
        switch = max(tc - int(round(D / sc.dt)), 0)
        pol = resolve_policy(spec, sc).controller
        exp = resolve_policy("vcs", sc).controller

        def act(world, obs, switch=switch, pol=pol, exp=exp):
            a, e = pol(world, obs), exp(world, obs)
            return np.where((np.asarray(world.steps) >= switch)[:, None, None], e, a)

        ep = run_episodes(sc, act, [seed])[0]
        f = EpisodeFacts(ep)
        saved += not f.collided
        rows.append(f"{seed}:{'ok' if not f.collided else 'hit'}")
    print(f"D={D} s: expert takes over, avoids {saved} of {len(bad)}  {' '.join(rows)}", flush=True)
