"""Mean speed [m/s] at which robots reach their goals on 300 fresh dynamic-v0 episodes (seeds 9000-9299).

python results/generalist/stage-n/arrival-speed/arrival.py policies/generalist/model.zip vcs
"""

import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

scenario = get_suite("dynamic-v0").scenario
for spec in sys.argv[1:]:
    episodes = run_episodes(scenario, resolve_policy(spec, scenario).controller, range(9000, 9300), batch_size=300)
    speed = np.array([ep.speed[t - 1, i] for ep in episodes for i, t in enumerate(ep.reached_step) if t > 0])
    print(
        f"{spec}: arrival speed mean {speed.mean():.2f} m/s, median {np.median(speed):.2f}, above 0.8 m/s "
        f"{(speed > 0.8).mean():.2f} ({len(speed)} arrivals)"
    )
