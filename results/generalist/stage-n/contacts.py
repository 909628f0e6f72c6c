"""Where the released generalist's `dynamic-v0` failures come from: every episode with a contact,
classified by its first contact (vcs_env.contacts), beside the VCS expert on the same episodes.

    python results/generalist/stage-n/contacts.py policies/generalist/model.zip vcs --seeds 9000:10000

"parked, just arrived": the other robot arrived (and stopped dead, as every arriving robot does)
at most ARRIVED_WITHIN seconds before the contact. "first 2 s": the contact starts within 2 s of
the episode's start (obstacles spawn at random around robots standing still).
"""

from __future__ import annotations

import argparse
from collections import Counter

from agents.policies import resolve_policy
from vcs_env.contacts import contact_events
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

ARRIVED_WITHIN = 0.5  # [s]
EARLY = 2.0  # [s]


def first_contact(ep):
    """The episode's first contact (``vcs_env.contacts.Contact``; the at-fault side of a tie first), or None."""
    events = contact_events(ep)
    return min(events, key=lambda c: (c.step, not c.at_fault)) if events else None


def classify(ep) -> tuple[str, bool, bool] | None:
    """(class, at fault, first 2 s) of the episode's first contact, or None without contacts."""
    first = first_contact(ep)
    if first is None:
        return None
    kind = first.kind
    if kind == "parked":
        arrived = ep.reached_step[first.other]
        just = arrived >= 0 and (first.step - arrived) * ep.dt <= ARRIVED_WITHIN + 1e-9
        kind = "parked, just arrived" if just else "parked, earlier"
    return kind, first.at_fault, first.step * ep.dt < EARLY


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("policies", nargs="+", help="planner names or checkpoint paths")
    p.add_argument("--seeds", default="9000:10000", help="LO:HI, seeds LO..HI-1")
    a = p.parse_args()
    lo, hi = (int(x) for x in a.seeds.split(":"))
    scenario = get_suite("dynamic-v0").scenario
    failed: dict[str, set[int]] = {}
    kinds = ("obstacle", "parked, just arrived", "parked, earlier", "robot")
    print(f"dynamic-v0 scenario, seeds {lo}-{hi - 1}; episodes whose first contact is of each class (at fault)")
    print("| policy | episodes with a contact | " + " | ".join(kinds) + " | first 2 s |")
    print("|---|---|" + "---|" * (len(kinds) + 1))
    for spec in a.policies:
        controller = resolve_policy(spec, scenario).controller
        episodes = run_episodes(scenario, controller, range(lo, hi), batch_size=250)
        rows = {ep.seed: classify(ep) for ep in episodes}
        rows = {s: r for s, r in rows.items() if r is not None}
        failed[spec] = set(rows)
        count = Counter(r[0] for r in rows.values())
        fault = Counter(r[0] for r in rows.values() if r[1])
        early = sum(r[2] for r in rows.values())
        cells = " | ".join(f"{count[k]} ({fault[k]})" for k in kinds)
        print(f"| {spec} | {len(rows)} | {cells} | {early} |")
    if len(a.policies) == 2:
        x, y = a.policies
        print(f"episodes with a contact under both: {len(failed[x] & failed[y])}")


if __name__ == "__main__":
    main()
