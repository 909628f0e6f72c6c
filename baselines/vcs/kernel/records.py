"""Named records of the VCS kernel: parameters, robot context, neighbour state, tolerances.

Parameters and neighbour records are numpy structured arrays (numba reads their fields as
``p.t_max``, ``nb.reff`` at the cost of a plain array access); the per-robot context and the
groups of arrays passed between stages are named tuples.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from vcs_env.stall import Rules

INF = np.inf

# ------------------------------------------------------------------ tolerances
STEP_SLACK = 1e-9
"""Slack of the step counts ``ceil(change / per-step change - slack)``: a change of exactly k
per-step changes takes k steps despite rounding."""
TINY = 1e-12
"""Guard of divisions by a distance [m] or a speed [m/s], and the threshold below which a
speed, a length or a determinant counts as zero."""
T_FLOOR = 1e-9
"""Smallest time to collision in the fallback's ``kappa / t_c`` [s]."""
ARRIVING_SLACK = 1e-6
"""Relative slack of "preferred speed below v_max" that marks a robot as arriving."""
STATIC_SPEED = 1e-6
"""Below this speed [m/s] a non-reactive object counts as static."""
WALL_COST = 1e6
"""Extra fallback cost of a candidate inside a wall's truncated velocity obstacle: walls do not
answer, so among inadmissible candidates those that keep off the walls come first."""
WALL_RAMP_GAP = 0.005
"""Gap [m] a ramp keeps from a wall (vcs-method §2.18): a wall never comes closer, so a robot
stopped a buffer delta_min from it may turn away while it starts moving."""
STEP_GAP = 0.005
"""Gap [m] two active robots keep within a step under ``VCSParams.step_split`` (vcs-method §2.15)."""
SPLIT_COST = 1e3
"""Extra fallback cost of a candidate whose first step oversteps its share of a gap to a robot
(``VCSParams.step_split``), plus as much again per ``STEP_GAP`` of overstep: below a wall's."""
SQRT_HALF = 0.7071067811865476
"""1 / sqrt(2): normalises a distance over the unit square of (dv / v_max, dtheta / pi)."""

# ------------------------------------------------------------------ codes
R_HRVO, R_RVO, R_VO = 0, 1, 2
"""Reciprocity codes (``VCSParams.reciprocity``)."""
K_RECIPROCAL, K_MOVER, K_STATIC = 0, 1, 2
"""Neighbour kinds (responsibility by kind): a driving robot shares the avoidance (reciprocity);
everything else (parked robots, robots arriving at their goal, obstacles) is non-reactive and
the robot takes full responsibility; a non-reactive object that does not move is static."""

# ------------------------------------------------------------------ parameters
PARAMS = np.dtype(
    [
        ("delta_min", "f8"),  # always-on buffer [m]
        ("delta_s", "f8"),  # extra regulated buffer [m]
        ("eps", "f8"),  # overlap margin of r_eff [m]
        ("t_max", "f8"),  # T_max [s]
        ("t_margin", "f8"),  # T_m of obstacles [s]
        ("t_margin_robots", "f8"),  # T_m of active robots [s]
        ("horizon", "f8"),  # -1 adaptive, inf classic VO, else fixed [s]
        ("tau_s", "f8"),  # safety band [s]
        ("kappa", "f8"),  # fallback penalty weight
        ("w_goal", "f8"),
        ("w_safety", "f8"),
        ("w_change", "f8"),
        ("w_reach", "f8"),
        ("w_hysteresis", "f8"),
        ("w_bias", "f8"),
        ("n_v", "i8"),  # window grid speeds
        ("n_theta", "i8"),  # window grid directions (partial window)
        ("n_theta_full", "i8"),  # window grid directions (full circle)
        ("coarse_n_v", "i8"),  # coarse grid of T_need
        ("coarse_n_theta", "i8"),
        ("window_margin", "f8"),  # steps kept before the first threat
        ("reciprocity", "i8"),  # R_HRVO, R_RVO or R_VO
        ("one_step", "?"),  # one-step window (the shortsighted foil)
        ("goal_vcs", "?"),  # goal term measured in the VCS (else in velocity space)
        ("stop_margin", "?"),
        ("joint_escape", "?"),
        ("ramp_check", "?"),
        ("step_split", "?"),  # a first step shares the gap to each active robot (vcs-method §2.15)
        ("wall_brake", "?"),
        ("arriving_non_reactive", "?"),
        ("arriving_goal_twin", "?"),  # arriving robots also get a static twin where they will park
        ("stopping_obstacles", "?"),  # moving obstacles also get a static twin (they may stop)
        ("least_harm", "?"),  # least-harm fallback (else the RVO penalty)
        ("crowd_margin", "?"),
        ("crowd_reach", "?"),  # contesting movers: any the robot could meet (else: closing ones)
        ("fallback_clearance", "f8"),  # least-harm fallback's contact radius r0 + this [m]; < 0: r_eff
        ("fallback_contact", "f8"),  # fallback weight of contact with a moving obstacle [s]; 0: off
        ("fit_clearance", "f8"),  # buffers fit passable gaps, down to this clearance [m]; < 0: off
        ("no_follow", "?"),  # inside a mover's buffer, do not close on it as it recedes
        ("stall_turn", "?"),  # a detouring robot at rest turns in place toward its goal (else: by walls only)
        ("holonomic_window_fit", "?"),  # a holonomic window grid spans its disc only
        ("fit_discs", "?"),  # fit_clearance also between two static discs, at a gate the robot heads through
        ("free_turn", "?"),  # a robot turning in place from rest aims at the nearest heading it can start off along
    ],
    align=True,
)
"""The kernel's parameters, one record (``VCSParams`` in kernel units, see :func:`params_record`)."""


def params_record(p) -> np.ndarray:
    """The kernel's parameter record ``(1,)`` of :data:`PARAMS` from a ``VCSParams``."""
    rec = np.zeros(1, dtype=PARAMS)
    wg, ws, wc, wr, wh, wb = p.weights
    values = {
        "delta_min": p.delta_min,
        "delta_s": p.delta_s,
        "eps": p.eps_overlap,
        "t_max": p.t_max,
        "t_margin": p.t_margin,
        "t_margin_robots": p.t_margin_robots,
        "horizon": p.horizon_value,
        "tau_s": p.tau_s,
        "kappa": p.kappa,
        "w_goal": wg,
        "w_safety": ws,
        "w_change": wc,
        "w_reach": wr,
        "w_hysteresis": wh,
        "w_bias": wb,
        "n_v": p.n_v,
        "n_theta": p.n_theta,
        "n_theta_full": p.n_theta_full,
        "coarse_n_v": p.coarse_n_v,
        "coarse_n_theta": p.coarse_n_theta,
        "window_margin": p.window_margin_steps,
        "reciprocity": {"hrvo": R_HRVO, "rvo": R_RVO, "vo": R_VO}[p.reciprocity],
        "one_step": p.window == "one_step",
        "goal_vcs": p.goal_metric == "vcs",
        "stop_margin": p.stop_margin,
        "joint_escape": p.joint_escape,
        "ramp_check": p.ramp_check,
        "step_split": p.step_split,
        "wall_brake": p.wall_brake,
        "arriving_non_reactive": p.arriving_non_reactive,
        "arriving_goal_twin": p.arriving_goal_twin,
        "stopping_obstacles": p.stopping_obstacles,
        "least_harm": p.fallback == "least_harm",
        "crowd_margin": p.crowd_margin,
        "crowd_reach": p.crowd_margin and p.crowd_reach and p.horizon == "adaptive",
        "fallback_clearance": -1.0 if p.fallback_clearance is None else p.fallback_clearance,
        "fallback_contact": 0.0 if p.fallback_contact is None else p.fallback_contact,
        "fit_clearance": -1.0 if p.fit_clearance is None else p.fit_clearance,
        "no_follow": p.no_follow,
        "stall_turn": p.stall_turn,
        "holonomic_window_fit": p.holonomic_window_fit,
        "fit_discs": p.fit_discs,
        "free_turn": p.free_turn,
    }
    for name, value in values.items():
        rec[name] = value
    return rec


# ------------------------------------------------------------------ neighbours
NEIGHBOUR = np.dtype(
    [
        ("px", "f8"),  # relative position p [m]
        ("py", "f8"),
        ("d", "f8"),  # centre distance |p| [m]
        ("r0", "f8"),  # combined physical radius [m]
        ("reff", "f8"),  # regulated radius r_eff [m]
        ("apx", "f8"),  # cone apex [m/s]
        ("apy", "f8"),
        ("scale", "f8"),  # relative velocity = scale (v - apex)
        ("jax", "f8"),  # apex of J_s's relative velocity [m/s]
        ("jay", "f8"),
        ("jscale", "f8"),
        ("hx", "f8"),  # overlap half-plane normal (unit p)
        ("hy", "f8"),
        ("tc0", "f8"),  # current-course time to collision [s]
        ("th", "f8"),  # horizon T_h [s]
        ("bound", "f8"),  # lower bound of tau over all candidates [s]
        ("jbound", "f8"),  # ... with J_s's relative velocity [s]
        ("vjx", "f8"),  # neighbour velocity [m/s]
        ("vjy", "f8"),
        ("stopk", "f8"),  # 1 / a_max of the robot when the stop margin applies [s^2/m]
        ("reach", "f8"),  # an active robot's farthest one-step advance towards the robot [m] (signed)
        ("idx", "i8"),  # robot index (< n), n + obstacle index, or 2 n + m + wall index
        ("kind", "i8"),  # K_RECIPROCAL, K_MOVER or K_STATIC
        ("overlap", "?"),  # true penetration: a half-plane instead of a cone
        ("mover", "?"),  # an active robot (whatever the reciprocity rule)
        ("twin", "?"),  # the static twin of an arriving robot or of a moving obstacle that may stop
        ("wall", "?"),  # a wall segment (vcs-method §2.18): p is its nearest point
        ("split", "?"),  # an active robot: the first step shares the gap with it (vcs-method §2.15)
        ("ax", "f8"),  # wall end points relative to the robot [m]
        ("ay", "f8"),
        ("bx", "f8"),
        ("by", "f8"),
    ],
    align=True,
)
"""One sensed object as robot i sees it (vcs-method §2.4, vcs-method §2.6, vcs-method §2.7, walls
vcs-method §2.18)."""

SENSED = np.dtype(
    [
        ("idx", "i8"),  # robot index (< n) or n + obstacle index
        ("px", "f8"),  # relative position p [m]
        ("py", "f8"),
        ("d", "f8"),  # centre distance |p| [m]
        ("r", "f8"),  # combined radius [m]
    ],
    align=True,
)
"""One object within the sensing radius (:func:`~.neighbours.sense`), shared by the VCS kernel
and the sampling VO planners."""

World = namedtuple(
    "World",
    "pos heading speed radius v_max a_max omega_max active present obs_pos obs_vel obs_radius seg_a seg_b seg_present",
)
"""The world arrays the kernel reads (:class:`~vcs_env.state.WorldState` fields; walls ``seg_*``)."""

Inputs = namedtuple("Inputs", "vpref pref_comm detour prev has_prev plan")
"""Per-robot planner inputs ``(B, n, ...)``: own preferred velocity [m/s], communicated
preferred velocity [m/s], detour flag, last period's residual target and whether it is set,
and whether to plan the robot (an unplanned robot is still sensed as it is; its outputs are
those of an inactive robot)."""

Setting = namedtuple("Setting", "prm r_ca dt holo")
"""Parameter record ``(1,)``, sensing radius [m], period [s], holonomic robots."""

Memory = namedtuple("Memory", "prev has_prev stall detour ref wait tries")
"""A robot's memory across periods ``(B, n, ...)``: the residual target (dv [m/s], dtheta [rad])
of the last period and whether it is set, the time spent stalled [s], the detour time left [s],
the goal distance at the last progress mark [m] (0: unset), the time since that mark [s] and the
detours begun since the robot last made progress."""

StallRules = Rules
"""The stall and detour rules (:data:`vcs_env.stall.Rules`, :func:`vcs_env.stall.stall_rules`)."""

Outputs = namedtuple("Outputs", "target cost fallback k t_star threats goal_step")
"""Per-robot results ``(B, n, ...)`` of :func:`~baselines.vcs.kernel.search.plan_batch`."""

ROBOT = np.dtype(
    [
        ("v_r", "f8"),  # speed [m/s]
        ("th", "f8"),  # heading [rad]
        ("vrx", "f8"),  # velocity [m/s]
        ("vry", "f8"),
        ("v_max", "f8"),  # top speed [m/s]
        ("dv1", "f8"),  # speed change per step [m/s]
        ("dth1", "f8"),  # direction change per step [rad] (pi: holonomic)
        ("kmax", "f8"),  # steps to cross the VCS domain
        ("pvx", "f8"),  # preferred velocity [m/s]
        ("pvy", "f8"),
        ("gv", "f8"),  # goal point G = (gv [m/s], gth [rad]) (vcs-method §2.9)
        ("gth", "f8"),
        ("wg", "f8"),  # cost weights (safety and smoothness 0 during a detour)
        ("ws", "f8"),
        ("wc", "f8"),
        ("wr", "f8"),
        ("wh", "f8"),
        ("wb", "f8"),
        ("pdv", "f8"),  # last period's residual target (dv [m/s], dtheta [rad])
        ("pdth", "f8"),
        ("tau_s", "f8"),  # safety band [s]
        ("dt", "f8"),  # period [s]
        ("ramp_gap", "f8"),  # gap kept along the way [m]
        ("ramp_hint", "i8"),  # the record that last broke a ramp of this robot's (-1: none; a speed-up only)
        ("has_prev", "?"),  # the residual target is set
        ("holo", "?"),  # holonomic robot
        ("goal_vcs", "?"),  # goal term measured in the VCS
        ("ramp", "?"),  # check admissibility along the way (vcs-method §2.15)
        ("split", "?"),  # the first step shares the gap to active robots (vcs-method §2.15)
        ("walls", "?"),  # senses a wall (vcs-method §2.18)
        ("wall_brake", "?"),  # a ramp near a wall must leave the robot able to stop (vcs-method §2.18)
    ],
    align=True,
)
"""Robot i's context as the search sees it, one record (:func:`~.cost.robot_context`)."""

Work = namedtuple("Work", "robot sensed nbs order key cspeed ccol cstep ccos csin pending need rows cols blk adm js")
"""Scratch arrays of the neighbour and horizon stages (:func:`~baselines.vcs.kernel.neighbours.work`)."""

Grid = namedtuple("Grid", "dv_row kv_row dth_col kt_col cth sth e_col g_col c_col h_col b_col cheap live")
"""Scratch arrays of the point search (:func:`~baselines.vcs.kernel.search.grid_work`); ``live``: the
rows whose ``cheap`` values are set (the others cannot win)."""

Window = namedtuple("Window", "k lo_v hi_v half full nv nth")
"""Window W_k of the search: k steps, speed-change range [m/s], half direction range [rad],
whether it covers the full circle, grid size."""
