"""Social navigation metrics of recorded episodes: how the robots treat the people around them.

The people are the episode's obstacles (pedestrians in the ``crowdnav-*`` suites; every moving
or static obstacle elsewhere). Each function returns one value per robot ``(n,)``, NaN where it
is undefined (no obstacle, a robot that never drove); :mod:`vcs_env.metrics` averages them over
the robots and lists them in ``METRICS``. Definitions and sources: ``docs/social-metrics.md``.

Distances are surface gaps (centre distance minus both radii) [m], so the proxemic zones are
measured from the body's edge, as people measure them from each other's.
"""

from __future__ import annotations

import numpy as np

from .rollout import Episode

INTIMATE_ZONE = 0.45
"""Hall's intimate distance [m]: closer than this is an intrusion into intimate space."""
PERSONAL_ZONE = 1.2
"""Hall's personal distance [m]: closer than this is an intrusion into personal space."""
TTC_CAP = 10.0
"""Times to collision are capped at this [s]: a robot never on a collision course scores it."""


def driving_states(ep: Episode) -> np.ndarray:
    """``(T+1, n)`` bool: states at the start or the end of a step the robot drove (``acted``)."""
    during = np.zeros(ep.pos.shape[:2], dtype=bool)
    during[:-1] |= ep.acted
    during[1:] |= ep.acted
    return during


def human_gaps(ep: Episode) -> np.ndarray:
    """Surface gap between every robot and every obstacle in every state ``(T+1, n, m)`` [m]."""
    d = np.linalg.norm(ep.pos[:, :, None, :] - ep.obs_pos[:, None, :, :], axis=-1)
    return d - ep.radius[None, :, None] - ep.obs_radius[None, None, :]


def nearest_gap(ep: Episode) -> np.ndarray:
    """Gap to the nearest obstacle in every state ``(T+1, n)`` [m] (inf without obstacles)."""
    gaps = human_gaps(ep)
    return gaps.min(axis=-1) if gaps.shape[-1] else np.full(ep.pos.shape[:2], np.inf)


def intrusion_share(ep: Episode, zone: float) -> np.ndarray:
    """Share of the robot's driving states in which some obstacle is closer than ``zone`` [m] ``(n,)``; ``zone`` a
    number > 0 (NaN or a negative zone read 0 everywhere)."""
    if isinstance(zone, bool) or not isinstance(zone, (int, float, np.number)) or not zone > 0:
        raise ValueError(f"intrusion_share: zone must be a number > 0 [m], got {zone!r}")
    during = driving_states(ep)
    inside = (nearest_gap(ep) < zone) & during
    with np.errstate(invalid="ignore", divide="ignore"):
        share = inside.sum(axis=0) / during.sum(axis=0)
    return np.where(during.any(axis=0) & (ep.obs_pos.shape[1] > 0), share, np.nan)


def min_human_gap(ep: Episode) -> np.ndarray:
    """Smallest gap to any obstacle over the robot's driving states ``(n,)`` [m]."""
    during = driving_states(ep)
    gap = np.where(during, nearest_gap(ep), np.inf).min(axis=0)
    return np.where(np.isfinite(gap), gap, np.nan)


def time_to_contact(dp: np.ndarray, dv: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Smallest ``t >= 0`` with ``|dp + dv t| <= reach``: 0 when already touching, inf when never.

    ``dp`` ``(..., 2)`` relative position [m], ``dv`` ``(..., 2)`` relative velocity [m/s],
    ``reach`` ``(...)`` sum of the radii [m] -> ``(...)`` [s].
    """
    a = np.sum(dv * dv, axis=-1)
    b = np.sum(dp * dv, axis=-1)
    c = np.sum(dp * dp, axis=-1) - reach**2
    disc = b * b - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-b - np.sqrt(np.maximum(disc, 0.0))) / a  # the first of the two touching times
    coming = (a > 0) & (disc >= 0) & (b < 0)  # approaching, and the lines pass within reach
    return np.where(c <= 0, 0.0, np.where(coming & (t >= 0), t, np.inf))


def min_time_to_collision(ep: Episode) -> np.ndarray:
    """Smallest time to collision with any obstacle over the steps the robot drove, capped at
    :data:`TTC_CAP` ``(n,)`` [s]. At the start of each step both move on at the velocity they had
    over that step (the recorded positions' differences)."""
    if ep.steps == 0 or ep.obs_pos.shape[1] == 0:
        return np.full(ep.n_robots, np.nan)
    v_robot = np.diff(ep.pos, axis=0) / ep.dt  # (T, n, 2)
    v_obs = np.diff(ep.obs_pos, axis=0) / ep.dt  # (T, m, 2)
    dp = ep.obs_pos[:-1, None] - ep.pos[:-1, :, None]  # (T, n, m, 2)
    dv = v_obs[:, None] - v_robot[:, :, None]
    ttc = time_to_contact(dp, dv, ep.radius[None, :, None] + ep.obs_radius[None, None, :]).min(axis=-1)
    ttc = np.where(ep.acted, ttc, np.inf).min(axis=0)
    return np.where(ep.acted.any(axis=0), np.minimum(ttc, TTC_CAP), np.nan)


def path_irregularity(ep: Episode, paths: np.ndarray) -> np.ndarray:
    """Turning beyond what facing the goal needs, per metre driven ``(n,)`` [rad/m] (Guzzi et al. 2013).

    ``paths`` ``(n,)`` [m]: the distance each robot drove. The needed turn is the initial angle
    between the heading and the direction to the goal.
    """
    turned = np.abs(np.diff(np.unwrap(ep.heading, axis=0), axis=0)).sum(axis=0)
    to_goal = ep.goal - ep.pos[0]
    need = np.abs(np.angle(np.exp(1j * (np.arctan2(to_goal[:, 1], to_goal[:, 0]) - ep.heading[0]))))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(paths > 0, np.maximum(turned - need, 0.0) / paths, np.nan)


def spl(ep: Episode, success: np.ndarray, paths: np.ndarray) -> np.ndarray:
    """Success weighted by path length (Anderson et al. 2018) per robot ``(n,)``:
    ``success * l / max(p, l)``, ``l`` the straight start-goal distance, ``p`` the distance driven [m]."""
    straight = np.linalg.norm(ep.goal - ep.pos[0], axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(straight > 0, straight / np.maximum(paths, straight), 1.0)
    return success * ratio
