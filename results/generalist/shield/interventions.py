"""How often the released generalist's shield replaces the network's action: per suite, the share of the
decisions of active robots (one robot, one step) where it stepped in, and the episodes where it did at all.

    python results/generalist/shield/interventions.py 2> /dev/null > results/generalist/shield/interventions.txt
"""

from __future__ import annotations

import numpy as np

from agents.checkpoint import read_metadata
from agents.policies import load_checkpoint
from agents.shield import shield_from_record
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

POLICY = "policies/generalist/model.zip"
SUITES = ("circle-8-v0", "circle-16-v0", "circle-24-v0", "swap-v0", "crossing-v0", "crowd-5-v0", "crowd-10-v0",
          "crowd-20-v0", "dynamic-v0", "random-dense-v0")  # fmt: skip


def interventions(name: str, shield) -> tuple[int, int, int, int]:
    """(decisions it stepped in, decisions, episodes where it did, episodes) on suite ``name``."""
    suite = get_suite(name)
    network = load_checkpoint(POLICY, suite.scenario, shield=False)
    count = {"decisions": 0, "stepped": 0}
    touched: set[int] = set()

    def control(world, obs):
        B, n, D = obs.shape
        actions = network.predict(obs.reshape(B * n, D), deterministic=True)[0].reshape(B, n, 2)
        safe, stepped = shield.filter(obs, actions, suite.scenario.n_neighbors)
        stepped &= world.active
        count["decisions"] += int(world.active.sum())
        count["stepped"] += int(stepped.sum())
        touched.update(np.flatnonzero(stepped.any(1)).tolist())  # world b plays suite.seeds[b]
        return np.where(world.active[..., None], safe, 0.0)

    run_episodes(suite.scenario, control, suite.seeds)  # all seeds in one batch
    return count["stepped"], count["decisions"], len(touched), suite.n_episodes


def main() -> None:
    shield = shield_from_record(read_metadata(POLICY))
    print(f"# {POLICY}, shield {shield}")
    print("| suite | decisions it stepped in | episodes where it did |")
    print("|---|---|---|")
    for name in SUITES:
        stepped, decisions, touched, episodes = interventions(name, shield)
        print(f"| {name} | {stepped / decisions:.4f} ({stepped} of {decisions}) | {touched} of {episodes} |")


if __name__ == "__main__":
    main()
