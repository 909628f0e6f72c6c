"""The at-fault obstacle contacts on `dynamic-v0` (the first contact of an episode, the robot drove into an
obstacle, vcs_env.contacts): was the obstacle's path predictable from its velocity a second earlier?

    python results/generalist/stage-n/obstacle_contacts.py policies/generalist/model.zip vcs --seeds 9000:10000

For each such contact at step s, with the obstacle's velocity estimated over the step before s - LOOK
(obstacles turn at a random rate, redrawn every 2 s): "predicted miss" is the smallest gap [m] between the
robot's actual path over the last LOOK seconds and the obstacle moved on at that velocity; a gap above 0
means the obstacle's turn after that moment brought it into the robot's path. Also the obstacle's heading
change over those LOOK seconds [rad], the robot's speed at the contact [m/s], where the obstacle came
from in the robot's frame (front: within 45 deg of the heading, behind: beyond 135 deg, else side), when
(first 2 s: the robot starting among obstacles that spawned around it) and how far from its goal.

Last column, over all episodes: the 10th percentile of every robot's smallest surface gap to any obstacle
while it drives [m] (how close the policy's ordinary passes are).
"""

from __future__ import annotations

import argparse

import numpy as np
from contacts import first_contact  # this directory's contacts.py

from agents.policies import resolve_policy
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite

LOOK = 1.0  # [s]


def describe(ep, c) -> dict:
    s, i, k = c.step, c.robot, c.other
    look = max(1, round(LOOK / ep.dt))
    s0 = max(1, s - look)
    v0 = (ep.obs_pos[s0, k] - ep.obs_pos[s0 - 1, k]) / ep.dt  # [m/s]
    t = np.arange(s0, s + 1)
    predicted = ep.obs_pos[s0, k] + (t - s0)[:, None] * ep.dt * v0
    gap = np.linalg.norm(ep.pos[t, i] - predicted, axis=-1) - ep.radius[i] - ep.obs_radius[k]
    d_before = ep.obs_pos[s0, k] - ep.obs_pos[s0 - 1, k]
    d_now = ep.obs_pos[s + 1, k] - ep.obs_pos[s, k] if s + 1 < len(ep.obs_pos) else d_before
    turn = abs(np.angle(complex(*d_now) / complex(*d_before))) if np.any(d_before) and np.any(d_now) else 0.0
    rel = ep.obs_pos[s, k] - ep.pos[s, i]
    bearing = abs(np.angle(complex(*rel) * np.exp(-1j * ep.heading[s, i])))
    side = "front" if bearing < np.pi / 4 else "behind" if bearing > 3 * np.pi / 4 else "side"
    return {
        "miss": float(gap.min()), "turn": float(turn), "speed": float(ep.speed[s, i]), "side": side,
        "time": s * ep.dt, "goal": float(np.linalg.norm(ep.pos[s, i] - ep.goal[i])),
    }  # fmt: skip


def smallest_gaps(ep) -> np.ndarray:
    """Every robot's smallest surface gap to any obstacle while it drives ``(n,)`` [m] (inf: never drove)."""
    gap = np.linalg.norm(ep.pos[:, :, None] - ep.obs_pos[:, None], axis=-1) - ep.radius[:, None] - ep.obs_radius
    driving = np.concatenate((ep.acted, np.zeros((1, ep.acted.shape[1]), dtype=bool)))
    return np.where(driving[:, :, None], gap, np.inf).min(axis=(0, 2))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("policies", nargs="+", help="planner names or checkpoint paths")
    p.add_argument("--seeds", default="9000:10000", help="LO:HI, seeds LO..HI-1")
    a = p.parse_args()
    lo, hi = (int(x) for x in a.seeds.split(":"))
    scenario = get_suite("dynamic-v0").scenario
    print(f"dynamic-v0 scenario, seeds {lo}-{hi - 1}; first contacts that are at-fault obstacle contacts, {LOOK=} s")
    head = (
        "policy",
        "contacts",
        "predicted miss > 0",
        "median predicted miss [m]",
        "median turn [rad]",
        "median speed [m/s]",
        "front / side / behind",
        "first 2 s",
        "within 1 m of the goal",
        "p10 smallest gap [m]",
    )
    print("| " + " | ".join(head) + " |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for spec in a.policies:
        controller = resolve_policy(spec, scenario).controller
        rows, gaps = [], []
        for ep in run_episodes(scenario, controller, range(lo, hi), batch_size=250):
            gaps.append(smallest_gaps(ep))
            first = first_contact(ep)
            if first is not None and first.kind == "obstacle" and first.at_fault:
                rows.append(describe(ep, first) | {"seed": ep.seed})
        gaps = np.concatenate(gaps)
        p10 = np.percentile(gaps[np.isfinite(gaps)], 10)
        if not rows:
            print(f"| {spec} | 0 | | | | | | | | {p10:.3f} |")
            continue
        miss = np.array([r["miss"] for r in rows])
        sides = [sum(r["side"] == x for r in rows) for x in ("front", "side", "behind")]
        print(
            f"| {spec} | {len(rows)} | {int((miss > 0).sum())} | {np.median(miss):.2f} | "
            f"{np.median([r['turn'] for r in rows]):.2f} | {np.median([r['speed'] for r in rows]):.2f} | "
            f"{' / '.join(map(str, sides))} | {sum(r['time'] < 2.0 for r in rows)} | "
            f"{sum(r['goal'] < 1.0 for r in rows)} | {p10:.3f} |"
        )
        for r in rows:
            print(
                f"    seed {r['seed']}: at {r['time']:.1f} s, {r['goal']:.2f} m from the goal, "
                f"miss {r['miss']:.2f} m, turn {r['turn']:.2f} rad, speed {r['speed']:.2f} m/s, {r['side']}"
            )


if __name__ == "__main__":
    main()
