"""Pedestrians: obstacles that walk to goals and avoid each other, and the robots if they see them.

:class:`PedestrianSpec` (the Scenario field ``pedestrians``, with ``obstacle_motion="pedestrians"``)
says how they walk; :class:`vcs_env.obstacles.Pedestrians` is the motion model that steps them,
every world in one call. Two models of how a pedestrian chooses its velocity:

* ``"orca"``: ORCA (:mod:`vcs_env.orca_kernel`), reciprocal among pedestrians, as CrowdNav
  simulates its humans (``crowd_sim/envs/policy/orca.py``: neighbour distance 10 m, 10
  neighbours, time horizon 5 s, radius + 0.01 m, max speed = preferred speed).
* ``"social_force"``: the social force model of Helbing and Molnar (Phys. Rev. E 51, 1995),
  :func:`social_force`, with the parameters of the reference implementation
  ``svenkreiss/socialforce`` (``potentials.py``, ``simulator.py``, ``fieldofview.py``):
  relaxation time ``tau = 0.5 s``; pedestrian repulsion ``V0 = 2.1 m^2/s^2``, ``sigma = 0.3 m``
  on the elliptic distance ``b`` with step ``0.4 s``; field of view 200 degrees, forces from
  behind weighted 0.5; top speed 1.3 times the preferred speed.

Goals (``goal_policy``): ``"circle"`` walks to the layout's second point of each obstacle
(the ``crowd`` kind: the antipode, CrowdNav's circle crossing) and stays there; ``"square"``
re-places every pedestrian as CrowdNav's square crossing does (start on a random half of the
square ``[-arena_half_size, arena_half_size]^2``, goal on the other half) and stays at the goal;
``"wander"`` walks to the layout's point, then to random goals in the arena, a new one on each
arrival. Every random draw happens at reset, from the world's generator.

Pedestrians are holonomic and see no walls (the layout must keep them out of walls; a
pedestrian placed inside one is a ``ValueError`` at reset). With ``sees_robots=False``
(CrowdNav's "invisible" robot) the robots do not exist for them; with True they avoid the robots
as they avoid each other (ORCA: reciprocally, so they expect the robot to take half).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import check_choice, check_int, check_range

PEDESTRIAN_MODELS = ("orca", "social_force")
GOAL_POLICIES = ("circle", "square", "wander")

SF_TAU = 0.5
"""Social force relaxation time [s] (Helbing & Molnar 1995; socialforce ``tau``)."""
SF_V0 = 2.1
"""Pedestrian repulsion strength [m^2/s^2] (Helbing & Molnar 1995; socialforce ``PedPedPotential.v0``)."""
SF_SIGMA = 0.3
"""Pedestrian repulsion range [m] (socialforce ``PedPedPotential.sigma``)."""
SF_STEP = 0.4
"""Step [s] in the elliptic distance ``b`` (socialforce ``Simulator.delta_t``)."""
SF_FOV_COS = math.cos(math.radians(100.0))
"""Cosine of half the field of view (200 degrees, socialforce ``FieldOfView.twophi``)."""
SF_OUT_OF_VIEW = 0.5
"""Weight of forces from outside the field of view (socialforce ``out_of_view_factor``)."""
SF_MAX_SPEED = 1.3
"""Top speed as a multiple of the preferred speed (socialforce ``MAX_SPEED_MULTIPLIER``)."""
TOP_SPEED_LIMIT = 3.0
"""Fastest a pedestrian may walk [m/s]: ``vcs_env.scenario.V_REF``, the speed limit of every obstacle (the
observation's velocity scale)."""
ARRIVAL_TIME = 1.0
"""A pedestrian walks at its preferred speed until it is this time [s] from its goal, then at
``distance / ARRIVAL_TIME`` (CrowdNav: ``pref_vel = velocity / speed if speed > 1 else velocity``)."""


@dataclass(frozen=True)
class PedestrianSpec:
    """How the obstacles of a scenario walk (with ``obstacle_motion="pedestrians"``)."""

    model: str = "orca"
    """``"orca"`` or ``"social_force"`` (module docstring)."""
    v_pref: float = 1.0
    """Preferred speed [m/s], in [0, 3]; ORCA's max speed is the same (CrowdNav), social force's
    ``SF_MAX_SPEED`` times it, so at most 3 / 1.3 = 2.31 m/s there (:attr:`top_speed`)."""
    goal_policy: str = "circle"
    """``"circle"``, ``"square"`` or ``"wander"`` (module docstring)."""
    sees_robots: bool = False
    """Pedestrians avoid the robots (CrowdNav "visible" robot); False: they ignore them ("invisible")."""
    time_horizon: float = 5.0
    """ORCA time horizon [s], > 0 (CrowdNav: 5)."""
    neighbor_dist: float = 10.0
    """ORCA neighbour distance [m], > 0 (CrowdNav: 10)."""
    max_neighbors: int = 10
    """ORCA half-planes per pedestrian, in [1, 512] (CrowdNav: 10)."""
    radius_margin: float = 0.01
    """Added to every body's radius in ORCA [m], in [0, 1] (CrowdNav: 0.01)."""

    def __post_init__(self) -> None:
        check_choice("pedestrians.model", self.model, PEDESTRIAN_MODELS)
        check_range("pedestrians.v_pref", self.v_pref, 0.0, TOP_SPEED_LIMIT)
        if self.top_speed > TOP_SPEED_LIMIT:
            raise ValueError(
                f"pedestrians.v_pref of social force pedestrians must be at most {TOP_SPEED_LIMIT / SF_MAX_SPEED:.3f} "
                f"m/s: they walk up to {SF_MAX_SPEED} times it, and no obstacle may be faster than "
                f"{TOP_SPEED_LIMIT} m/s; got {self.v_pref}"
            )
        check_choice("pedestrians.goal_policy", self.goal_policy, GOAL_POLICIES)
        if not isinstance(self.sees_robots, bool):
            raise ValueError(f"pedestrians.sees_robots must be a bool, got {self.sees_robots!r}")
        check_range("pedestrians.time_horizon", self.time_horizon, 0.0, 1e3, lo_open=True)
        check_range("pedestrians.neighbor_dist", self.neighbor_dist, 0.0, 1e4, lo_open=True)
        check_int("pedestrians.max_neighbors", self.max_neighbors, 1, 512)
        check_range("pedestrians.radius_margin", self.radius_margin, 0.0, 1.0)

    @property
    def top_speed(self) -> float:
        """Fastest the pedestrians walk [m/s]: ``v_pref`` (ORCA), ``SF_MAX_SPEED v_pref`` (social force)."""
        return self.v_pref * (SF_MAX_SPEED if self.model == "social_force" else 1.0)


def preferred_velocity(pos: np.ndarray, goal: np.ndarray, v_pref: np.ndarray) -> np.ndarray:
    """Toward the goal at ``v_pref``, slowing within ``v_pref * ARRIVAL_TIME`` of it.

    ``pos``, ``goal`` ``(..., 2)`` [m], ``v_pref`` ``(...)`` [m/s] -> ``(..., 2)`` [m/s].
    """
    d = goal - pos
    dist = np.linalg.norm(d, axis=-1)
    speed = np.minimum(v_pref, dist / ARRIVAL_TIME)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(dist[..., None] > 0.0, d / dist[..., None] * speed[..., None], 0.0)


def social_force(
    pos: np.ndarray,
    vel: np.ndarray,
    pref: np.ndarray,
    present: np.ndarray,
    n_walking: int,
) -> np.ndarray:
    """Social force on the first ``n_walking`` agents of every world [m/s^2].

    Helbing & Molnar: ``F_a = (v_pref_a - v_a) / tau + sum_b w(e_a, f_ab) f_ab`` with
    ``f_ab = -grad V(b_ab)``, ``V(b) = V0 exp(-b / sigma)``, and the elliptic distance
    ``2 b = sqrt((|r| + |r - s e_b|)^2 - s^2)``, ``r = r_a - r_b``, ``s = |v_b| SF_STEP``, ``e_b``
    the direction agent b wants to walk (its preferred velocity's, as the reference's ``PedPedPotential``;
    for an agent that does not walk, a robot, the direction it drives). Bodies have no size here, as in the
    reference: the repulsion acts on centres, and pedestrians can overlap in dense crossings. ``w`` is 1 when
    ``f_ab`` pushes against a's walking direction within the field of view, :data:`SF_OUT_OF_VIEW` otherwise.

    Args:
        pos: ``(B, a, 2)`` [m] (walking agents first, then whatever they see).
        vel: ``(B, a, 2)`` current velocities [m/s].
        pref: ``(B, n_walking, 2)`` preferred velocities [m/s] (their directions are ``e_a``).
        present: ``(B, a)`` bool.
        n_walking: agents that feel the force.

    Returns:
        ``(B, n_walking, 2)`` [m/s^2].
    """
    r = pos[:, :n_walking, None, :] - pos[:, None, :, :]  # (B, w, a, 2): from b to a
    speed_b = np.linalg.norm(vel, axis=-1)  # (B, a)
    wish = np.concatenate((pref, vel[:, n_walking:]), axis=1)  # where each agent wants to go (a robot: its drive)
    wish_norm = np.linalg.norm(wish, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        e_b = np.where(wish_norm[..., None] > 0.0, wish / wish_norm[..., None], 0.0)
    s = (speed_b * SF_STEP)[:, None, :]  # (B, 1, a) [m]
    r2 = r - s[..., None] * e_b[:, None, :, :]  # where b will be, seen from a
    n1 = np.linalg.norm(r, axis=-1)
    n2 = np.linalg.norm(r2, axis=-1)
    b = 0.5 * np.sqrt(np.maximum((n1 + n2) ** 2 - s**2, 1e-16))
    # -dV/dr = V0 / sigma exp(-b / sigma) db/dr, db/dr = (n1 + n2) / (4 b) (r / n1 + r2 / n2).
    with np.errstate(invalid="ignore", divide="ignore"):
        u1 = np.where(n1[..., None] > 0.0, r / n1[..., None], 0.0)
        u2 = np.where(n2[..., None] > 0.0, r2 / n2[..., None], 0.0)
    mag = SF_V0 / SF_SIGMA * np.exp(-b / SF_SIGMA) * (n1 + n2) / (4.0 * b)
    f = mag[..., None] * (u1 + u2)  # (B, w, a, 2)
    others = present[:, None, :] & ~np.eye(n_walking, pos.shape[1], dtype=bool)[None]
    # Field of view: a force that pushes against the walking direction comes from ahead.
    speed_pref = np.linalg.norm(pref, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        e_a = np.where(speed_pref[..., None] > 0.0, pref / speed_pref[..., None], 0.0)
    f_norm = np.linalg.norm(f, axis=-1)
    ahead = np.einsum("bwd,bwad->bwa", e_a, -f) > f_norm * SF_FOV_COS
    weight = np.where(ahead, 1.0, SF_OUT_OF_VIEW) * others
    drive = (pref - vel[:, :n_walking]) / SF_TAU
    return drive + np.sum(weight[..., None] * f, axis=2)
