"""dynamic-v0 contacts of a policy: at each episode's first contact, what robot and obstacle were doing.

Usage: python results/generalist/stage-j/first_contacts.py POLICY START STOP [MOTION]
(seeds START..STOP-1; MOTION replaces the suite's obstacle motion, e.g. constant). Columns: robot and
obstacle speed [m/s] over the last 0.5 s, their closing speeds along the line between them [m/s], the
robot's slowest and mean speed over the 2 s before [m/s], its goal distance [m], and the bearings of the
obstacle and of the goal in the robot's frame [deg] (past 90 deg: behind the robot).
"""

import dataclasses
import sys

import numpy as np

from agents.policies import resolve_policy
from vcs_env.rollout import run_episodes
from vcs_env.suites import get_suite


def bearing(vec: np.ndarray, heading: float) -> float:
    """Angle of ``vec`` (2,) in a frame turned by ``heading`` [rad], in [-180, 180) [deg]."""
    return (np.degrees(np.arctan2(vec[1], vec[0]) - heading) + 180.0) % 360.0 - 180.0


spec, start, stop = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
motion = sys.argv[4] if len(sys.argv) > 4 else "arbitrary"
sc = dataclasses.replace(get_suite("dynamic-v0").scenario, obstacle_motion=motion)
eps = run_episodes(sc, resolve_policy(spec, sc).controller, list(range(start, stop)))
print(
    "seed step robot kind reached_step v_rob v_obs obs_closing rob_closing min_v_2s mean_v_2s"
    " goal_dist obs_deg goal_deg"
)
for ep in eps:
    if not ep.collided.any():
        continue
    t, i = np.argwhere(ep.collided)[0]
    t0 = max(t - 4, 0)
    v_rob = (ep.pos[t + 1, i] - ep.pos[t0, i]) / (ep.dt * (t + 1 - t0))
    head = f"{ep.seed} {t} {i}"
    if ep.robot_contact[t, i]:
        print(f"{head} robot {ep.reached_step[i]} {np.linalg.norm(v_rob):.2f}")
        continue
    k = int(np.argmax(ep.obstacle_hits[t, i]))  # the obstacle touched
    v_obs = (ep.obs_pos[t + 1, k] - ep.obs_pos[t0, k]) / (ep.dt * (t + 1 - t0))
    d = ep.pos[t + 1, i] - ep.obs_pos[t + 1, k]
    d /= np.linalg.norm(d) + 1e-9  # unit vector obstacle -> robot
    sp = ep.speed[max(t - 20, 0) : t + 1, i]
    h = ep.heading[t, i]
    cols = (
        np.linalg.norm(v_rob),
        np.linalg.norm(v_obs),
        v_obs @ d,
        -(v_rob @ d),
        sp.min(),
        sp.mean(),
        np.linalg.norm(ep.goal[i] - ep.pos[t, i]),
        bearing(ep.obs_pos[t, k] - ep.pos[t, i], h),
        bearing(ep.goal[i] - ep.pos[t, i], h),
    )
    print(f"{head} obstacle {ep.reached_step[i]} " + " ".join(f"{x:.2f}" for x in cols))
print(f"{sum(ep.collided.any() for ep in eps)} of {len(eps)} episodes with contact")
