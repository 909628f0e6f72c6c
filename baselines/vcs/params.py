"""Every parameter of the VCS planner, documented against ``docs/vcs-method.md``.

Tags as in docs/vcs-method.md: [paper] from the seed paper, [standard] from the VO/RVO/HRVO/DWA
literature, [reconstructed] our choice (the paper's formula is unknown).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vcs_env.checks import check_choice, check_int, check_positive, check_range
from vcs_env.stall import DETOUR_JITTER, DETOUR_TIME, PROGRESS_WINDOW, STALL_SPEED, STALL_TIME

HORIZONS = ("adaptive", "infinite")
WINDOWS = ("multi_step", "one_step")
COSTS = ("full", "goal_only")
RECIPROCITIES = ("hrvo", "rvo", "vo")
GOAL_METRICS = ("vcs", "velocity")
FALLBACKS = ("least_harm", "penalty")


@dataclass(frozen=True)
class VCSParams:
    """VCS planner parameters (vcs-method §2.16 defaults)."""

    # --- size regulation (vcs-method §2.6) [paper concept, formula reconstructed]
    delta_min: float = 0.05
    """Always-on safety buffer added to the combined radius [m]."""
    delta_s: float = 0.15
    """Extra buffer at full collision-time or collision-distance factor [m]."""
    fit_clearance: float | None = 0.01
    """Buffers fit the free space (vcs-method §2.6), on by default since 2026-11-27
    (vcs-calibration §7: with ``give_way``, ``corridor-narrow-v0`` 0.12 -> 1.00,
    ``intersection-v0`` 0.96 -> 0.98 on its seeds and 0.96 -> 0.94 on fresh ones; None turns it
    off): where the surface gap ``g`` between a static disc (a parked robot, a standing obstacle) and a wall
    lets the robot's disc (radius ``r``) through with ``c`` on both sides (``g >= 2 (r + c)``),
    the buffer of each of the two beyond its physical radius (``r_eff - r_0``: regulated, or
    ``delta_min`` for the wall) is at most ``max(c, (g - 2 r) / 4)``: half the spare room
    ``g - 2 r`` is buffer, half a lane to drive in. ``c`` is this clearance [m] or the robot's
    braking distance ``v^2 / (2 a_max)`` if larger, so a buffer only shrinks for a robot slow
    enough to stop within it. None: the buffers of vcs-method §2.6 and vcs-method §2.18 alone [ours]."""
    eps_overlap: float = 1e-3
    """Cone kept defined when the buffered disc already contains the robot: r_eff = d - eps [m]."""
    t_max: float = 5.0
    """T_max: collision-time factor scale and the largest avoidance horizon [s]."""
    # --- avoidance horizon (vcs-method §2.7) [reconstructed]
    t_margin: float = 1.0
    """T_m: horizon = time needed to leave the cone + this margin [s], for obstacles (vcs-method §2.7)."""
    t_margin_robots: float = 2.0
    """T_m for other (active) robots [s]. With the reconstruction's 1 s, dense circles (20-24 robots)
    ran into states where no candidate was admissible and collided; 2 s solved them, while
    obstacles keep 1 s, which the un-conservative tests need (``docs/vcs-calibration.md``)
    [reconstructed]."""
    horizon: str | float = "adaptive"
    """``"adaptive"`` (T_h = min(T_max, T_need + T_m)), ``"infinite"`` (classic conservative VO:
    the foil of the un-conservative claim) or a number (a fixed horizon T [s])."""
    # --- window (vcs-method §2.10) [paper: multi-step window; rule reconstructed]
    window: str = "multi_step"
    """``"multi_step"``: window sized by the time to the first threat (foresighted);
    ``"one_step"``: only the one-step window (the shortsighted foil)."""
    window_margin_steps: int = 2
    """Steps kept in hand before the first threat when sizing the window (0 to 1000)."""
    holonomic_window_fit: bool = True
    """A holonomic robot's window grid spans the bounds of its disc of reachable velocities (speeds
    within ``k a_max dt`` of its own, directions within ``asin(k a_max dt / v_R)`` of its heading
    while the disc leaves out the origin) instead of every speed and direction, so a small window
    close to a threat keeps lateral candidates (False: the whole domain, of which the disc keeps a
    few points along the heading, the ablation; vcs-method §2.10) [ours]."""
    # --- point search (vcs-method §2.11) [reconstructed]
    n_v: int = 21
    """Grid values of the speed change over the window (endpoints included)."""
    n_theta: int = 41
    """Grid values of the direction change over a partial window (endpoints included)."""
    n_theta_full: int = 72
    """Direction values when the window covers the full circle, over [-pi, pi)."""
    coarse_n_v: int = 21
    """Coarse grid over the whole VCS domain for T_need (vcs-method §2.7), speed values."""
    coarse_n_theta: int = 72
    """... direction values."""
    # --- cost (vcs-method §2.12) [reconstructed]
    cost: str = "full"
    """``"full"`` multi-objective cost; ``"goal_only"``: closest to the preferred velocity (the
    RVO/HRVO ClearPath selection, the foil of the multi-objective claim)."""
    goal_metric: str = "velocity"
    """Where the goal term J_g is measured: ``"vcs"`` (distance to the goal point G in the VCS,
    speed / v_max and direction / pi) or ``"velocity"`` (|v - v_pref| / (2 v_max), the reconstruction's
    vcs-method §2.12 choice, the default). In velocity space a stopped unicycle gains nothing by turning
    (every direction change maps to the zero velocity); the stall detour handles that case.
    The VCS metric prices braking higher than turning and was less safe in dense circles
    (``docs/vcs-calibration.md``); vcs-method §5 open question 3 [reconstructed]."""
    w_goal: float = 1.0
    """Weight of the goal term J_g."""
    w_safety: float = 0.2
    """Weight of the soft safety band just beyond the horizon."""
    w_change: float = 0.2
    """Weight of the size of the velocity change."""
    w_reach: float = 0.1
    """Weight of the time needed to reach the candidate."""
    w_hysteresis: float = 0.2
    """Weight of the distance to last period's target."""
    w_bias: float = 0.0
    """Weight of the keep-right bias max(0, dtheta) / pi."""
    tau_s: float = 1.0
    """Width of the soft safety band beyond the horizon [s]."""
    kappa: float = 5.0
    """Fallback penalty kappa / t_c when no candidate is admissible [s] (vcs-method §2.13)."""
    fallback: str = "least_harm"
    """``"least_harm"``: with no admissible candidate, prefer separating from what the robot
    already touches and never speed up toward a threat (vcs-method §2.13); ``"penalty"``: the plain
    RVO-style penalty kappa / t_c + J_g (the ablation) [reconstructed]."""
    fallback_clearance: float | None = 0.025
    """While the robot is already inside a body's regulated buffer (where every buffered time to
    collision is ~0 and cannot rank), the least-harm fallback measures time to contact with the
    combined physical radius plus this clearance [m] (at most r_eff); ``None``: always the
    regulated radius r_eff (the ablation; vcs-method §2.13) [ours]."""
    fit_discs: bool = True
    """With ``fit_clearance``, buffers also fit the gate between two static discs (parked robots, standing
    obstacles) that the robot's preferred velocity runs through between their bodies, the same way as a
    disc and a wall (vcs-method §2.6) [ours]. On by default since 2026-12-01 (vcs-calibration §7): it lets
    robots through the 0.7 m between two rows of parked robots (fresh seeds: ``intersection-v0`` with 12
    robots 0.20 -> 0.68, ``corridor-v0`` with 10 robots 0.52 -> 0.85; holonomic robots on ``corridor-v0``
    0.90 -> 1.00), and every suite ends with the same success and at-fault counts. False: the buffers of
    vcs-method §2.6 between discs (the ablation); ``fit_clearance=None`` turns all fitting off, this
    included."""
    fallback_contact: float | None = 20.0
    """With nothing admissible, the least-harm fallback (``fallback="least_harm"``) also plays each
    candidate out against the moving obstacles (the robot ramping to it and holding it, each
    obstacle at its planned velocity, up to ``t_max``): a candidate that meets one (contact radius
    r0 + ``fallback_clearance``, r0 with None), first after t_m [s], while driving toward the centre
    of one it meets at up to v_t [m/s], costs this weight [s] times ``1 / t_m + v_t`` more (t_m in s,
    v_t in units of 1 m/s): the least-bad escape meets a mover late and not head on (what matters
    against movers faster than the robot). Robots, driving, arriving or parked, and static bodies
    are not played out. ``None``: off (the ablation; vcs-method §2.13) [ours]."""
    # --- safety against what does not get out of the way [reconstructed]
    # (vcs-method §2.4, vcs-method §2.7, vcs-method §2.15)
    arriving_non_reactive: bool = True
    """A robot within braking distance of its goal (communicated preferred speed below its
    v_max) is about to park: take full responsibility for it, as for an obstacle, instead of
    sharing the avoidance (False: every active robot is reciprocal, the ablation)."""
    arriving_goal_twin: bool = True
    """An arriving robot parks at its goal, dead, at whatever speed it has (the simulator parks it
    on arrival): it also gets a static twin there, which the robot can tell from the communicated
    preferred velocity (its direction, and its speed ``min(v_max, d / dt, sqrt(2 a_max d))`` at
    goal distance ``d``), with a margin that covers the robot's stopping time, as a static body's
    (vcs-method §2.7). A robot following or crossing an arriving one thus keeps its braking
    distance from where that one will stop, not from where it is. Only for an arriving robot faster
    than it can brake to its goal (one step of braking over its preferred speed), and only in
    worlds without walls, where the preferred velocity points at the goal (False: the twin where it
    is only, the ablation; see vcs-method §2.4) [ours]."""
    stopping_obstacles: bool = False
    """A moving obstacle may stop at any moment (``stop_and_go`` obstacles do): it also gets a
    static twin at its current position, as an arriving robot does, whose margin covers the
    robot's stopping time, so the robot does not follow it closer than it can brake (False, the
    default: obstacles keep their velocity) [ours]."""
    mirror_bounces: bool = True
    """Where obstacles reflect off the arena's edges (``Scenario.bounce``), the robot also plans
    against each obstacle's mirror image in the edge it moves toward (a straight motion reflected
    off a line is the straight motion of its image), so it sees the obstacle coming back before it
    turns (False: obstacles keep their velocity, the ablation) [ours]."""
    mover_turn_lead: float | None = 0.2
    """Movers that turn: each obstacle's velocity is taken turned by its turn over the last period
    (at most :data:`~baselines.vcs.planner.MAX_TURN_RATE`; a faster change of heading is a jump,
    a bounce or a push, not a turn) scaled to this lead [s], the heading it will have ``lead``
    from now at its current turn rate; a straight line of that heading is the chord of its arc
    over twice the lead. ``None``: obstacles keep their velocity (the ablation) [ours]."""
    no_follow: bool = True
    """Inside a non-reactive mover's regulated buffer (a moving obstacle's, an arriving robot's),
    the robot closes on it no faster than it could brake within the surface gap g,
    ``sqrt(2 a_max g)``, even while the mover recedes (it may stop or turn): the velocity
    obstacle's apex keeps at most that much of the mover's receding speed (False: the apex is
    the mover's velocity, and the robot may ride a receding mover at any gap, the ablation;
    vcs-method §2.4) [ours]."""
    stop_margin: bool = True
    """The margin of a static object (parked robot, standing obstacle) covers the robot's own
    stopping time: max(T_m, v_R / a_max) (False: T_m)."""
    joint_escape: bool = True
    """T_need counts only escapes that no non-reactive object closes within T_max, so the
    horizon grows where a crowd closes the nearby escapes (False: each object alone)."""
    crowd_margin: bool = True
    """The margin of a moving obstacle is T_m per *contesting* mover (a non-reactive mover that
    can reach the robot within T_max, counted as ``crowd_reach`` says), and its horizon T_need
    + that margin is not capped at T_max: a lone mover keeps the un-conservative T_m, a crowd
    is watched further ahead, towards the classic VO (False: T_m for each, capped)."""
    crowd_reach: bool = True
    """Under the crowd margin, a mover contests the robot's escapes if the robot could meet it
    within T_max at any velocity it may pick (gap <= (v_max + the mover's approach speed) T_max),
    not only if it closes on the robot's current velocity: a slow or stopped robot in a crowd
    looks as far ahead as a fast one. When no candidate is admissible under this count, the
    search is run again with the closing count before falling back (False: the closing count
    only, the ablation; vcs-method §2.7)."""
    ramp_check: bool = True
    """A candidate is admissible only if the ramp that reaches it keeps clear of non-reactive
    objects, and out of contact with driving robots that take the mirror of the change (the
    reciprocal assumption) (False: only its end velocity is judged, the ablation)."""
    step_split: bool = True
    """Simultaneous steps (vcs-method §2.15): every robot moves for a whole period on the velocity
    it picks, from the same snapshot, while the velocity obstacles predict the other robot's
    velocity (the mirror of one's change, or the current one). A candidate's first step may
    advance towards another active robot (along the line of their centres) by at most
    ``max(g / 2, g - U_j, 0)``: ``g`` the surface gap less ``STEP_GAP``, ``U_j`` the farthest the
    other can advance towards it in one step within its limits. Two robots that both keep the
    rule cannot touch within the step, whatever each of them picks (False: the ablation)."""
    wall_brake: bool = True
    """Near a wall, a ramp must leave the robot able to stop: from every state along it, braking
    straight at a_max keeps clear of the wall; and with no admissible candidate, the fallback
    counts a ramp that sweeps into a wall as hard as a wall (vcs-method §2.18) (False: the ramp's
    positions only, the ablation)."""
    # --- interaction (vcs-method §2.4) [paper: interactive velocity rule; default HRVO]
    reciprocity: str = "hrvo"
    """Robot-robot rule: ``"hrvo"``, ``"rvo"``, or ``"vo"`` (treat robots as passive movers)."""
    # --- preferred velocity and deadlocks (vcs-method §2.5, vcs-method §2.13)
    perturbation: float = 0.01
    """Symmetry-breaking noise on v_pref as a fraction of v_max (multi-robot only)."""
    stall_speed: float = STALL_SPEED
    """A robot slower than this fraction of v_max ..."""
    stall_goal_margin: float = 0.0
    """... farther than r_goal + this from its goal [m] (the reconstruction's 0.3 m, with r_goal 0.1 m,
    left robots stopped 0.1-0.3 m short of their goal for good) ..."""
    stall_time: float = STALL_TIME
    """... for this long [s] starts a detour ..."""
    progress_window: float = PROGRESS_WINDOW
    """A robot that has not come closer to its goal by ``stall_speed * v_max * progress_window``
    over this window [s] is stalled too, whatever its speed (creeping sideways, circling);
    0 turns the progress test off."""
    detour_time: float = DETOUR_TIME
    """... of this duration [s] ..."""
    detour_angle: float = -math.pi / 4
    """... with v_pref rotated by this angle [rad] (negative: keep right) and w_safety = 0
    (vcs-method §2.13); the smoothness weights w_change, w_reach, w_hysteresis are also 0 during a
    detour, so a robot stopped with its goal behind it turns around, and the size-regulation
    buffer shrinks to delta_min, so a gap the full buffer closed opens [reconstructed]."""
    stall_turn: bool = True
    """A robot that detours from rest measures its goal term in the VCS (vcs-method §2.12, the rule
    of vcs-method §2.13), so it turns in place toward the detour's direction: in the velocity
    metric every heading at zero speed costs the same, and a unicycle at rest beside a body, whose
    every way of starting off closes on that body (the ramp check), stood there for good. False:
    only beside a wall (the rule of vcs-method §2.18), the ablation [ours]."""
    free_turn: bool = True
    """A robot that turns in place from rest (``stall_turn``, or beside a wall) aims at the heading nearest its
    goal's along which it can start off (the first step's speed admissible), instead of the goal's own: a unicycle
    stopped against a wall with its route past the wall's end faces the route, every start refused, and stood there
    for good (vcs-method §2.13). False: toward the goal's heading, the ablation [ours]."""
    detour_escalate: bool = True
    """A detour that began without progress since the last one turns further: the k-th
    consecutive detour rotates v_pref by k times detour_angle (at most a half turn; after four,
    from one again), so a robot wedged where keeping right stays blocked (between two parked
    robots) backs out. Only in worlds without walls: on the maps robots that queue in a corridor
    or give way at a junction stall for good reasons, and backing out cost `intersection-v0` 9
    points and `corridor-v0` 7 (time-outs). False: every detour turns by detour_angle, the
    ablation [ours]."""
    detour_jitter: float = DETOUR_JITTER
    """On a map with walls, each detour lasts detour_time times a factor uniform in
    [1 - detour_jitter, 1 + detour_jitter] (the world's counter-based noise): a head-on pair
    in a door one robot wide otherwise stalls, detours and comes back in step (0: every detour
    lasts detour_time, the ablation; without walls it always does)."""
    detour_off_walls: bool = True
    """A detour keeps left instead when keeping right would run into a wall within t_margin at
    v_max and keeping left would not (vcs-method §2.18) (False: always detour_angle, the
    ablation)."""
    # --- give way at crossing routes (vcs-method §2.19) [ours]
    give_way: bool = True
    """On a map with walls, a robot gives way to a driving robot whose next route leg crosses its
    own from the right (priority to the right, decided from the state alone): it slows down to stop
    short of the crossing, and never stops inside the lane of another robot about to cross
    (vcs-method §2.19). ``intersection-v0`` 0.75 -> 0.96 (vcs-calibration §7). False: the ablation;
    without walls it never acts."""
    give_way_angle: float = math.pi / 6
    """Two legs cross when their directions differ by more than this angle [rad] (and by less than
    pi minus it: head-on and same-way traffic is left to the velocity obstacles)."""
    give_way_margin: float = 0.3
    """Gap kept between the two discs at the crossing [m]: a lane is the combined radius plus this,
    over the sine of the crossing angle, on each side of the crossing point."""
    give_way_speed: float = 0.2
    """Only robots faster than this fraction of their v_max are given way to (one that waits does
    not hold anyone up)."""
    give_way_range: float = 4.0
    """Crossings farther than this along either leg [m] are not considered yet."""
    give_way_slack: float = 1.0
    """The other robot is given way to if it reaches its lane no later than this [s] after the robot
    would have cleared it at v_max."""
    give_way_stop: float = 0.1
    """The robot stops this far [m] before the lane it gives way to."""
    # --- one at a time through a narrow passage (vcs-method §2.20) [ours]
    narrow_pass: bool = False
    """On a map with walls, of two robots head-on at a passage too narrow for both side by side (a door), the one that
    would reach it later stops ``r_i + r_j + give_way_margin`` before it and lets the other come out first
    (vcs-method §2.20; off by default: it costs ``walls-v0`` two episodes). Without walls it never acts."""
    narrow_pass_margin: float = 0.1
    """A passage is narrow where the walls on its two sides are less than ``2 (r_i + r_j)`` plus this [m] apart."""
    r_ca: float | None = None
    """Sensing radius [m]; None uses the world's."""

    def __post_init__(self) -> None:
        for name in (
            "delta_min",
            "delta_s",
            "eps_overlap",
            "t_margin",
            "t_margin_robots",
            "stall_goal_margin",
            "stall_time",
            "progress_window",
            "detour_time",
            "detour_jitter",
            "give_way_margin",
            "give_way_slack",
            "give_way_stop",
            "narrow_pass_margin",
            "w_goal",
            "w_safety",
            "w_change",
            "w_reach",
            "w_hysteresis",
            "w_bias",
        ):
            check_positive(f"VCSParams.{name}", getattr(self, name), allow_zero=True)
        check_range("VCSParams.detour_jitter", self.detour_jitter, 0.0, 1.0, hi_open=True)
        for name in ("perturbation", "stall_speed", "give_way_speed"):  # fractions of v_max
            check_range(f"VCSParams.{name} (a fraction of v_max)", getattr(self, name), 0.0, 1.0)
        check_range("VCSParams.give_way_angle [rad]", self.give_way_angle, 0.0, math.pi / 2, lo_open=True)
        check_positive("VCSParams.give_way_range", self.give_way_range)
        for name in ("t_max", "kappa", "tau_s"):  # tau_s divides the safety term's time to contact
            check_positive(f"VCSParams.{name}", getattr(self, name))
        if isinstance(self.horizon, str):
            check_choice("VCSParams.horizon (or a number of seconds)", self.horizon, HORIZONS)
        else:
            check_positive("VCSParams.horizon", self.horizon)
        for name in (
            "arriving_non_reactive",
            "arriving_goal_twin",
            "stopping_obstacles",
            "mirror_bounces",
            "no_follow",
            "stop_margin",
            "joint_escape",
            "crowd_margin",
            "crowd_reach",
            "ramp_check",
            "step_split",
            "wall_brake",
            "detour_off_walls",
            "detour_escalate",
            "stall_turn",
            "free_turn",
            "give_way",
            "narrow_pass",
            "holonomic_window_fit",
            "fit_discs",
        ):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"VCSParams.{name} must be a bool, got {getattr(self, name)!r}")
        for name, choices in (
            ("fallback", FALLBACKS),
            ("window", WINDOWS),
            ("cost", COSTS),
            ("reciprocity", RECIPROCITIES),
            ("goal_metric", GOAL_METRICS),
        ):
            check_choice(f"VCSParams.{name}", getattr(self, name), choices)
        for name in ("n_v", "n_theta", "n_theta_full", "coarse_n_v", "coarse_n_theta"):
            check_int(f"VCSParams.{name}", getattr(self, name), 2, 1000)
        check_int("VCSParams.window_margin_steps", self.window_margin_steps, 0, 1000)
        check_range("VCSParams.detour_angle [rad]", self.detour_angle, -math.pi, math.pi)
        if self.r_ca is not None:
            check_positive("VCSParams.r_ca", self.r_ca)
        if self.fit_clearance is not None:
            check_positive("VCSParams.fit_clearance", self.fit_clearance)
        if self.fallback_clearance is not None:
            check_positive("VCSParams.fallback_clearance", self.fallback_clearance, allow_zero=True)
        if self.fallback_contact is not None:
            check_positive("VCSParams.fallback_contact [s]", self.fallback_contact)
        if self.mover_turn_lead is not None:
            check_positive("VCSParams.mover_turn_lead [s]", self.mover_turn_lead)

    @property
    def weights(self) -> tuple[float, float, float, float, float, float]:
        """(w_goal, w_safety, w_change, w_reach, w_hysteresis, w_bias) after the ``cost`` switch."""
        if self.cost == "goal_only":
            return (self.w_goal, 0.0, 0.0, 0.0, 0.0, 0.0)
        return (self.w_goal, self.w_safety, self.w_change, self.w_reach, self.w_hysteresis, self.w_bias)

    @property
    def horizon_value(self) -> float:
        """-1 for adaptive, inf for infinite, else the fixed horizon [s] (kernel encoding)."""
        if self.horizon == "adaptive":
            return -1.0
        if self.horizon == "infinite":
            return math.inf
        return float(self.horizon)
