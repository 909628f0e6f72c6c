"""``orca``: Optimal Reciprocal Collision Avoidance through the real RVO2 library (``pyrvo``).

ORCA (van den Berg, Guy, Lin and Manocha, ISRR 2009) runs in RVO2 2.0.3 through the ``pyrvo``
wheel (optional extra: ``pip install -e '.[orca]'``); nothing of ORCA is reimplemented here.

How the world is handed to RVO2 (one call plans every robot of every world):

* every step and every world gets a fresh ``RVOSimulator`` with time step ``world.dt``, holding
  one agent per present robot and per obstacle, each at its current position and velocity;
* robots that plan: radius = body radius + ``radius_margin`` (default 0.01 m), max speed =
  ``v_max``, preferred velocity = :func:`baselines.common.preferred_velocity` (as for every
  planner), neighbour distance = ``r_ca`` (a robot only reacts to what it senses), every sensed
  object counted (``max_neighbors = n + m``), time horizon ``time_horizon`` (default 5 s, the
  horizon CrowdNav uses for ORCA);
* obstacles and parked robots are agents that keep their current velocity (parked: 0); they see
  nothing (neighbour distance 0), and what RVO2 computes for them is discarded;
* walls (:mod:`vcs_env.walls`) are RVO2 obstacles, each segment a 2-vertex obstacle (avoided
  from both sides, fully: RVO2 handles obstacle edges first as hard constraints), with the
  obstacle time horizon ``time_horizon_obst`` (default 2 s);
* one ``do_step`` computes every agent's new velocity from the same snapshot (RVO2 computes all
  ORCA velocities before it moves anybody), and each robot's new velocity is read back as its
  desired velocity; the simulator is then dropped (no state is kept between calls).

Known limits, inherent to ORCA:

* RVO2 assumes that every agent is reciprocal (each side takes half of the avoidance,
  ``u / 2``); only polygonal obstacles are avoided fully. Passive obstacles and parked robots
  are therefore avoided with half effort, the other half comes from re-planning every step.
* ORCA has no acceleration or turn-rate limits; the robot tracks the ORCA velocity as fast as
  its limits allow (:func:`~vcs_env.dynamics.target_to_action`), so the guarantee is lost.
* Perfectly symmetric encounters (the ``circle`` preset without jitter) stay symmetric: the
  ORCA velocity is the vertex of a symmetric constraint polygon, which small pushes of the
  preferred velocity (the RVO2 examples perturb it by 1e-4 m/s) do not move, so the robots
  creep to the centre and stop (deadlock).
* The ORCA velocity is as close as possible to the preferred one, so agents pass each other at
  exactly the combined radius; RVO2 computes in float32, and with ``radius_margin = 0`` the
  gap at a pass is 0 up to rounding (about 1e-8 m) and is reported as a contact. The default
  margin of 1 cm (what CrowdNav adds to ORCA's radius) keeps a real gap.
"""

from __future__ import annotations

import numpy as np

from vcs_env.checks import check_positive, install_hint
from vcs_env.state import WorldState

from .common import VelocityPlanner, preferred_velocity

TIME_HORIZON = 5.0
"""Default ORCA time horizon for other agents [s]."""
TIME_HORIZON_OBST = 2.0
"""Default ORCA time horizon for walls (RVO2 obstacles) [s]."""


def import_pyrvo():
    """The ``pyrvo`` module, or an ImportError that names the extra to install."""
    try:
        import pyrvo
    except ImportError as e:
        raise ImportError(f"the 'orca' planner needs the RVO2 bindings pyrvo: {install_hint('orca')}") from e
    return pyrvo


class OrcaPlanner(VelocityPlanner):
    """ORCA (RVO2 2.0.3 via ``pyrvo``) over what each robot senses (module docstring).

    Args:
        time_horizon: ORCA time horizon tau for other agents [s], > 0.
        r_ca: neighbour distance [m]; None uses ``world.r_ca``.
        radius_margin: added to the ORCA radius of every robot that plans [m], >= 0 (CrowdNav adds
            0.01).
        time_horizon_obst: ORCA time horizon for walls [s], > 0.

    Raises:
        ImportError: when ``pyrvo`` is not installed (``pip install -e '.[orca]'``).
    """

    name = "orca"

    def __init__(
        self,
        time_horizon: float = TIME_HORIZON,
        r_ca: float | None = None,
        radius_margin: float = 0.01,
        time_horizon_obst: float = TIME_HORIZON_OBST,
    ):
        check_positive("time_horizon [s]", time_horizon)
        check_positive("time_horizon_obst [s]", time_horizon_obst)
        if r_ca is not None:
            check_positive("r_ca [m]", r_ca)
        check_positive("radius_margin [m]", radius_margin, allow_zero=True)
        import_pyrvo()  # fail early, with the install hint
        self.time_horizon = float(time_horizon)
        self.r_ca = r_ca
        self.radius_margin = float(radius_margin)
        self.time_horizon_obst = float(time_horizon_obst)

    def desired_velocity(self, world: WorldState) -> np.ndarray:
        """Each active robot's new ORCA velocity ``(B, n, 2)`` [m/s] (0 for inactive robots)."""
        rvo = import_pyrvo()
        B, n, m = world.batch_size, world.n_robots, world.n_obstacles
        pref = preferred_velocity(world)
        vel = world.vel
        r_ca = float(world.r_ca if self.r_ca is None else self.r_ca)
        out = np.zeros((B, n, 2))
        for b in range(B):
            if not world.active[b].any():
                continue
            sim = rvo.RVOSimulator()
            sim.set_time_step(float(world.dt))
            for k in np.flatnonzero(world.seg_present[b]):
                sim.add_obstacle([tuple(map(float, world.seg_a[b, k])), tuple(map(float, world.seg_b[b, k]))])
            if world.seg_present[b].any():
                sim.process_obstacles()
            ids = {}
            for i in range(n):
                if not world.present[b, i]:
                    continue
                planning = bool(world.active[b, i])
                v = (float(vel[b, i, 0]), float(vel[b, i, 1])) if planning else (0.0, 0.0)
                ids[i] = sim.add_agent(
                    (float(world.pos[b, i, 0]), float(world.pos[b, i, 1])),
                    r_ca if planning else 0.0,  # neighbour distance [m]: parked robots plan nothing
                    n + m,  # max neighbours: everything sensed
                    self.time_horizon,
                    self.time_horizon_obst,
                    float(world.radius[b, i]) + (self.radius_margin if planning else 0.0),
                    float(world.v_max[b, i]),
                    v,
                )
                sim.set_agent_pref_velocity(ids[i], (float(pref[b, i, 0]), float(pref[b, i, 1])) if planning else v)
            for k in range(m):
                v = (float(world.obs_vel[b, k, 0]), float(world.obs_vel[b, k, 1]))
                a = sim.add_agent(
                    (float(world.obs_pos[b, k, 0]), float(world.obs_pos[b, k, 1])),
                    0.0,
                    n + m,
                    self.time_horizon,
                    self.time_horizon_obst,
                    float(world.obs_radius[b, k]),
                    float(np.hypot(*v)) + 1e-3,
                    v,
                )
                sim.set_agent_pref_velocity(a, v)
            sim.do_step()
            for i, a in ids.items():
                if world.active[b, i]:
                    out[b, i] = sim.get_agent_velocity(a).to_tuple()
        return out
