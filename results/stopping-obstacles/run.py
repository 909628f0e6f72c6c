"""VCS with and without ``stopping_obstacles`` (vcs-method §2.4): the crowd suites' layouts with
obstacles that stop and go (seeds 20000-20099, no suite uses them), and the suites themselves.

    python results/stopping-obstacles/run.py > results/stopping-obstacles/results.txt
"""

import vcs_env
from agents.evaluate import evaluate
from baselines.vcs.planner import VCSPlanner
from vcs_env.suites import SUITES, Suite

CASES = [
    (
        f"{b} stop_and_go",
        Suite(b, vcs_env.make_scenario(SUITES[b].scenario, obstacle_motion="stop_and_go"), tuple(range(20000, 20100))),
    )
    for b in ("crowd-5-v0", "crowd-10-v0", "crowd-20-v0")
] + [(b, SUITES[b]) for b in ("crowd-5-v0", "crowd-10-v0", "crowd-20-v0", "dynamic-v0", "random-dense-v0")]
KEYS = ("success", "collision", "at_fault_collision", "deadlock", "timeout", "time_to_goal")

print("| episodes | stopping_obstacles | " + " | ".join(KEYS) + " |")
print("|---|---|" + "---|" * len(KEYS))
for name, suite in CASES:
    for on in (False, True):
        r = evaluate(VCSPlanner(stopping_obstacles=on), suite, progress=False).summary
        print(
            f"| {name} | {'on' if on else 'off'} | " + " | ".join(f"{r[k]['mean']:.2f}" for k in KEYS) + " |",
            flush=True,
        )
