"""Diagnostic (run.sh): in training only, a robot counts as touching an obstacle once the gap between them is
below ``BUMPER`` [m] (environment variable), so the collision term and ``--on-collision terminate`` treat a
close pass as a contact. Replaces ``vcs_env.kernels.swept_events`` (called by ``vcs_env.sim``) with the same
kernel on obstacle radii grown by ``BUMPER``; the observation still reads the true radii. Robots and walls
are unchanged. Evaluation runs without the patch."""

import os

import vcs_env.kernels as K

BUMPER = float(os.environ["BUMPER"])  # [m]
_orig = K.swept_events


def swept_events(pos, new_pos, radius, present, acted, goal, obs_pos, new_obs, obs_radius, r_goal):
    return _orig(pos, new_pos, radius, present, acted, goal, obs_pos, new_obs, obs_radius + BUMPER, r_goal)


K.swept_events = swept_events
