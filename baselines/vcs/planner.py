"""The VCS planner: the expert policy and reward shaper (vcs-method §2)."""

from __future__ import annotations

import dataclasses
import operator
import warnings

import numpy as np

from vcs_env.checks import check_int
from vcs_env.geometry import rotate
from vcs_env.planning import Planner, robots_mask
from vcs_env.routes import route_direction
from vcs_env.stall import goal_distances
from vcs_env.state import WorldState

from ..capsule import reference_capsule_tau
from ..common import preferred_velocity
from . import kernel
from .kernel.records import STATIC_SPEED
from .params import VCSParams
from .passage import narrow_pass, stop_within

COARSE_DT = 0.25
"""[s] The longest step the expert is measured at (every suite: 0.1 s, CrowdNav's 0.25 s); a longer one warns."""


class CoarseStepWarning(UserWarning):
    """The world's step is longer than :data:`COARSE_DT`: the expert's velocity obstacles assume velocities held
    from now on, a robot holds its command for a whole step, and robots collide that would not at shorter steps
    (vcs-calibration §5, "Coarse control steps"). Also when a robot's planning period is longer than
    :data:`COARSE_DT` (:func:`planning_period`: a world step far finer than its limits): its search then counts in
    steps that coarse."""


def planning_period(world: WorldState) -> np.ndarray:
    """The period [s] each robot's search counts its steps in ``(B, n)`` (vcs-method §2.10): the world's ``dt``, or,
    for a robot that would need more than :data:`~.kernel.PLAN_STEPS` steps of it to cross its velocity space (its top
    speed at ``a_max``, a half turn at ``omega_max``), the fewest whole world steps that bring it within them. Each
    robot's own limits set its period, and it is commanded every world step either way: the first step toward the point
    found."""
    dt = float(world.dt)
    return dt * kernel.robot_planning_steps(world.v_max, world.a_max, world.omega_max, dt, bool(world.holonomic))


@dataclasses.dataclass
class _Memory:
    """Per-robot memory across periods (:data:`~.kernel.Memory`), kept idempotent: ``inp`` is what
    the plan at step ``step`` uses, ``out`` what it leaves for step ``step + 1``."""

    step: np.ndarray  # (B,) int
    key: np.ndarray  # (B,) uint64
    inp: kernel.Memory
    out: kernel.Memory

    @classmethod
    def empty(cls, B: int, n: int) -> _Memory:
        def zeros() -> kernel.Memory:
            z1 = [np.zeros((B, n)) for _ in range(5)]
            return kernel.Memory(np.zeros((B, n, 2)), np.zeros((B, n), dtype=bool), *z1)

        return cls(np.full(B, -1, dtype=np.int64), np.zeros(B, dtype=np.uint64), zeros(), zeros())

    def sync(self, world: WorldState) -> None:
        """Move last period's output into this period's input, or clear it on a new episode."""
        kernel.sync_memory(world.steps, world.key, self.step, self.key, self.inp, self.out)


@dataclasses.dataclass
class _MoverMemory:
    """Every obstacle's velocity at the last period seen and at the one before, per world (for
    ``VCSParams.mover_turn_lead``); planning the same step again changes nothing."""

    step: np.ndarray  # (B,) int
    key: np.ndarray  # (B,) uint64
    now: np.ndarray  # (B, m, 2) [m/s]
    before: np.ndarray  # (B, m, 2) [m/s]
    has: np.ndarray  # (B,) bool: ``before`` is the period just before ``now``

    @classmethod
    def empty(cls, B: int, m: int) -> _MoverMemory:
        z = np.zeros((B, m, 2))
        return cls(np.full(B, -1, dtype=np.int64), np.zeros(B, dtype=np.uint64), z, z.copy(), np.zeros(B, dtype=bool))

    def update(self, world: WorldState) -> None:
        kernel.remember_movers(
            world.steps, world.key, self.step, self.key, self.before, self.now, self.has, world.obs_vel
        )


class VCSPlanner(Planner):
    """Velocity Change Space planner (Zhong, Zhong and Peng), batched over worlds and robots.

    Each robot, every period, maps its goal, the (size-regulated, time-truncated) velocity
    obstacles of what it senses within ``r_ca`` and its multi-step reachable window into the
    plane of (speed change, direction change), searches a grid of that window for the
    admissible point of least multi-objective cost, and steers toward it at its maximal
    per-step rates. Decentralised: a robot uses only what it senses, and the communicated
    preferred velocity of other robots (HRVO side choice).

    Args:
        params: a :class:`VCSParams`; keyword arguments replace its fields
            (``VCSPlanner(horizon="infinite")`` is the classic-VO foil).

    After each call, ``last`` holds per-robot diagnostics ``(B, n)``: ``fallback`` (no
    admissible candidate), ``k`` (window steps, of the robot's :func:`planning_period`: the world's
    step at ordinary limits), ``t_star`` (first threat time [s]), ``threats``, ``target`` (dv*,
    dtheta*) ``(B, n, 2)``, ``goal_point`` G and ``goal_step`` (G clipped to the one-period window)
    ``(B, n, 2)``, ``cost`` and ``detour``.

    The planner keeps memory from period to period (J_h's residual, the stall and detour state, the
    movers' last velocities) per batch row, matched by the world's episode ``key`` and ``steps``: a
    world one step on continues it, a new episode or a jump clears it, and the same step planned
    again starts from the same memory, so a robot left out of a replan (``plan_for``) keeps its own.
    Another state planned at the same step of the same episode (a what-if copy of the world, or
    another env at the same seed) takes the first's place for the next period: plan such states
    with a copy of the planner (``copy.deepcopy(planner)`` continues bit for bit).
    """

    name = "vcs"

    def __init__(self, params: VCSParams | None = None, **overrides):
        base = params if params is not None else VCSParams()
        if not isinstance(base, VCSParams):
            raise ValueError(f"params must be a VCSParams, got {type(base).__name__}")
        self.params = dataclasses.replace(base, **overrides) if overrides else base
        self._mem: _Memory | None = None
        self._movers: _MoverMemory | None = None
        self._cache_key: tuple | None = None
        self._cache_target: np.ndarray | None = None
        self._coarse_told = False
        self.last: dict[str, np.ndarray] = {}

    @property
    def params(self) -> VCSParams:
        """The settings; a new ``VCSParams`` may be set (the compiled record follows it, the memory stays)."""
        return self._params

    @params.setter
    def params(self, value: VCSParams) -> None:
        if not isinstance(value, VCSParams):
            raise ValueError(f"params must be a VCSParams, got {type(value).__name__}")
        self._params, self._prm = value, kernel.params_record(value)  # the kernels read the record
        self._cache_key = self._cache_target = None  # a plan of the old settings is not this one's

    # ------------------------------------------------------------------ inputs
    def _inputs(self, world: WorldState, kworld: kernel.World):
        """Preferred velocities (perturbed, and detour-rotated) and communicated ones
        ``(B, n, 2)`` [m/s], and the robots that detour ``(B, n)``; the memory for the next period
        (``kworld``: the world as the kernels read it)."""
        p = self.params
        mem = self._mem
        route, leg = None, None
        B, n = world.batch_size, world.n_robots
        if world.n_segments:  # (next leg scaled to the remaining length [m], that length [m]); the leg's length [m]
            scaled, length, leg = route_direction(world, with_leg=True)
            route = (scaled, length)
            d_goal = length
        else:
            d_goal = goal_distances(world)  # as the stall clock measures it
        pref = route_pref = preferred_velocity(world, route=route)
        if p.give_way and world.n_segments and n > 1:
            # Give way at crossing routes (vcs-method §2.19): priority to the right.
            pref = self._give_way(world, pref, leg)
        if p.narrow_pass and world.n_segments and n > 1:
            pref = narrow_pass(world, p, route_pref, pref)  # one at a time through a door (vcs-method §2.20)
        # Stall handling (vcs-method §2.13), and the direction psi of the symmetry-breaking push.
        psi, detour = np.empty((B, n)), np.empty((B, n), dtype=bool)
        rules = kernel.StallRules(
            float(world.dt), float(world.r_goal), p.stall_goal_margin, p.stall_speed, p.stall_time,
            p.progress_window, p.detour_time, p.detour_jitter, bool(p.detour_jitter > 0 and world.n_segments),
        )  # fmt: skip
        kernel.stall_rules(
            world.key, world.steps, kworld.speed, kworld.v_max, kworld.active, rules, d_goal, mem.inp, mem.out, psi,
            detour,
        )  # fmt: skip
        if n > 1 and p.perturbation > 0:
            # Symmetry breaking (vcs-method §2.5): a small random push, from the world's counter-based noise.
            own = np.empty((B, n, 2))
            kernel.push(pref, world.v_max, d_goal, float(world.r_goal), p.perturbation, np.cos(psi), np.sin(psi), own)
        else:
            own = pref.copy()
        if detour.any():
            angle = np.full((B, n), p.detour_angle)
            if p.detour_off_walls and world.n_segments:
                angle = self._detour_side(world, own, angle, detour)
            if p.detour_escalate and not world.n_segments:
                # The k-th detour without progress turns k times as far, up to a half turn, then again.
                k = (np.maximum(mem.out.tries, 1.0) - 1.0) % ESCALATION + 1.0
                angle = np.sign(angle) * np.minimum(np.abs(angle) * k, np.pi)
            own = np.where(detour[..., None], rotate(own, angle), own)
        return own, pref, detour

    def _give_way(self, world: WorldState, pref: np.ndarray, leg: np.ndarray) -> np.ndarray:
        """Preferred velocities ``(B, n, 2)`` [m/s] after giving way at crossing routes
        (``VCSParams.give_way``, vcs-method §2.19), from the preferred velocities ``pref`` ``(B, n, 2)``
        [m/s] (along each robot's next route leg) and the lengths of those legs ``leg`` ``(B, n)`` [m].

        Robot i's leg crosses robot j's when their directions ``u_i``, ``u_j`` differ by more than
        ``give_way_angle`` (either way) and the crossing point lies on both legs: ``s_i`` [m] ahead
        of i and ``t_j`` [m] ahead of j, with ``p_i + s_i u_i = p_j + t_j u_j``. j's *lane* on i's
        leg is ``s_i +- c`` with ``c = (r_i + r_j + give_way_margin) / |sin|`` of the crossing
        angle. i gives way to j when j comes from i's right (``det(u_i, u_j) > 0``), drives (faster
        than ``give_way_speed v_max``, not yet through: ``t_j > -c``), reaches its lane no later
        than ``give_way_slack`` after i would have cleared it at v_max, and i's disc is not in j's
        way yet (``s_i |sin| >= r_i + r_j``, s_i signed): i's preferred speed is capped to stop
        ``give_way_stop`` before the lane (``min(d / dt, sqrt(2 a_max d))``, as at a goal). Its
        stopping point is then moved back before the lane of any other robot about to cross
        where it would stop (a robot does not wait in the middle of a crossing)."""
        p = self.params
        sp = np.sqrt(np.einsum("...i,...i->...", pref, pref))  # (B, n) [m/s]
        u = pref / np.maximum(sp, 1e-12)[..., None]
        ui, uj = u[:, :, None, :], u[:, None, :, :]  # (B, n, 1, 2), (B, 1, n, 2)
        cross = ui[..., 0] * uj[..., 1] - ui[..., 1] * uj[..., 0]  # det(u_i, u_j) (B, n, n)
        sin_min = np.sin(p.give_way_angle)
        crossing = np.abs(cross) > sin_min
        c = np.where(crossing, cross, 1.0)
        q = world.pos[:, None, :, :] - world.pos[:, :, None, :]  # p_j - p_i (B, n, n, 2) [m]
        s_i = (q[..., 0] * uj[..., 1] - q[..., 1] * uj[..., 0]) / c  # along i's leg [m]
        t_j = (q[..., 0] * ui[..., 1] - q[..., 1] * ui[..., 0]) / c  # along j's leg [m]
        r2 = world.radius[:, :, None] + world.radius[:, None, :]  # (B, n, n) [m]
        lane = (r2 + p.give_way_margin) / np.abs(c)  # half width of j's lane along i's leg [m]
        going = world.active & (sp > 0)
        driving = going & (world.speed > p.give_way_speed * world.v_max)
        ahead = (
            crossing
            & going[:, :, None]
            & driving[:, None, :]
            & (t_j > -lane)
            & (s_i + lane <= leg[:, :, None])
            & (t_j + lane <= leg[:, None, :])
            & (s_i - lane <= p.give_way_range)
            & (t_j - lane <= p.give_way_range)
            & (s_i * np.abs(c) >= r2)
        )  # (B, n, n): j is about to cross i's leg, and i is not in j's way yet
        soon = (t_j - lane) / np.maximum(world.speed, 1e-9)[:, None, :] <= (s_i + lane) / world.v_max[
            ..., None
        ] + p.give_way_slack
        before, after = s_i - lane - p.give_way_stop, s_i + lane
        stop = np.where(ahead & soon & (cross > 0), before, np.inf).min(axis=-1)  # (B, n) [m]
        for _ in range(world.n_robots):  # not inside the lane of another robot about to cross
            inside = ahead & (before < stop[..., None]) & (stop[..., None] < after)
            stop = np.minimum(stop, np.where(inside, before, np.inf).min(axis=-1))
        return stop_within(world, pref, stop)

    def _detour_side(self, world: WorldState, own: np.ndarray, angle: np.ndarray, detour: np.ndarray) -> np.ndarray:
        """The detour's rotation ``(B, n)`` [rad] (vcs-method §2.13, vcs-method §2.18): keep right, unless the
        rotated preferred direction runs into a wall within ``t_margin`` at v_max (the capsule of
        r + delta_min) and the other side does not; then keep left. A robot stopped facing a wall
        with its route along it otherwise turned toward the wall on every detour, for good."""
        p = self.params
        a = world.seg_a[:, None, :, :] - world.pos[:, :, None, :]  # (B, n, S, 2) [m]
        b = world.seg_b[:, None, :, :] - world.pos[:, :, None, :]
        present = world.seg_present[:, None, :] & detour[..., None]
        r = np.broadcast_to((world.radius + p.delta_min)[..., None], present.shape)
        heading = np.arctan2(own[..., 1], own[..., 0])

        def blocked(turn):
            w = world.v_max[..., None] * np.stack((np.cos(heading + turn), np.sin(heading + turn)), -1)
            w = np.broadcast_to(w[:, :, None, :], a.shape)
            with np.errstate(divide="ignore", invalid="ignore"):
                tau = reference_capsule_tau(
                    np.where(present[..., None], a, 0.0), np.where(present[..., None], b, 1.0), w, r
                )
            return (present & (tau <= p.t_margin)).any(axis=-1)

        flip = blocked(angle) & ~blocked(-angle)
        return np.where(flip, -angle, angle)

    def _kernel_world(self, world: WorldState) -> kernel.World:
        """The world arrays as the kernels read them: the obstacles with the velocities of
        :meth:`obstacle_velocities`, with ``mirror_bounces`` followed by their mirror images
        (:func:`bounce_images`)."""
        images = self.params.mirror_bounces and world.bounce_half is not None and world.n_obstacles
        obs = self._obstacles(world, 4 if images else 1)
        return kernel.World(
            world.pos, world.heading, world.speed, world.radius, world.v_max, world.a_max, world.omega_max,
            world.active, world.present, *obs, world.seg_a, world.seg_b, world.seg_present,
        )  # fmt: skip

    def _obstacles(self, world: WorldState, images: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions ``(B, images m, 2)`` [m], velocities [m/s] and radii ``(B, images m)`` [m] of the
        obstacles as the planner plans with them (:meth:`obstacle_velocities`), with ``images`` = 4
        followed by their mirror images (:func:`bounce_images`; one compiled call for both)."""
        lead = self.params.mover_turn_lead
        B, m = world.batch_size, world.n_obstacles
        turn = lead is not None and m > 0
        if turn:
            mem = self._movers
            if mem is None or mem.now.shape != world.obs_vel.shape:
                mem = self._movers = _MoverMemory.empty(B, m)
            mem.update(world)
            angle = turn_angles(mem.before, mem.now, mem.has, float(world.dt), lead)
            cos_t, sin_t = np.cos(angle), np.sin(angle)
        else:
            cos_t = sin_t = world.obs_radius  # not read
        out = np.empty((B, images * m, 2)), np.empty((B, images * m, 2)), np.empty((B, images * m))
        half = -1.0 if world.bounce_half is None else float(world.bounce_half)
        kernel.mover_images(world.obs_pos, world.obs_vel, turn, cos_t, sin_t, world.obs_radius, half, FAR, *out)
        return out

    def obstacle_velocities(self, world: WorldState) -> np.ndarray:
        """The obstacle velocities ``(B, m, 2)`` [m/s] the planner plans with in this state: the
        sensed ones, turned a lead ahead with ``mover_turn_lead`` (:func:`turned_velocities`; the
        planner remembers the last period's, so asking again in the same state changes nothing)."""
        if self.params.mover_turn_lead is None or not world.n_obstacles:
            return world.obs_vel
        return self._obstacles(world, 1)[1]

    def _kernel_inputs(self, world: WorldState, kworld, own, comm, detour, planned) -> tuple:
        """The world, preferred velocities, memory and the robots to plan ``(B, n)`` bool, and the
        setting, as the kernels' records."""
        mem = self._mem.inp
        r_ca = world.r_ca if self.params.r_ca is None else self.params.r_ca
        return (
            kworld,
            kernel.Inputs(own, comm, detour, mem.prev, mem.has_prev, planned),
            kernel.Setting(self._prm, float(r_ca), float(world.dt), bool(world.holonomic)),
        )

    # -------------------------------------------------------------------- plan
    def plan(self, world: WorldState, robots: np.ndarray | None = None) -> np.ndarray:
        """Targets ``(B, n, 2)`` (speed [m/s], heading [rad]) of every robot, or only of ``robots`` ``(n,)`` bool (the
        others' rows keep their speed and heading, and their ``last`` entries are those of a robot
        that is done; the robots planned get the same targets either way)."""
        world.check_shapes()  # the kernels index every field by the sizes of pos, obs_pos and seg_present
        world.check_limits()  # and divide by dt and the robots' limits
        if not self._coarse_told:
            dt, holo = float(world.dt), bool(world.holonomic)
            steps = kernel.robot_planning_steps(world.v_max, world.a_max, world.omega_max, dt, holo)
            steps = int(steps[world.active].max(initial=0))  # the longest period among the robots that drive
            said = f"steps of dt = {dt:g} s" if dt > COARSE_DT else f"in periods of {dt * steps:g} s (dt = {dt:g} s)"
            if max(dt, dt * steps) > COARSE_DT:
                self._coarse_told = True
                warnings.warn(
                    f"the VCS expert plans {said}; it is measured at dt <= {COARSE_DT:g} s, and at coarser "
                    "steps robots collide that would not at shorter ones (vcs-calibration §5, 'Coarse control steps'"
                    "; vcs-method §2.10 for planning periods)",
                    CoarseStepWarning,
                    stacklevel=2,
                )
        if robots is not None:
            robots = robots_mask(world, robots)
        # The same state asked again (the env's expert action, then a policy that follows it) is planned once:
        # every field of the state is in the key (goals, limits, walls, obstacle velocities, dt, ...), so a plan
        # is never reused for another world that happens to share positions, speeds and episode key.
        key = (None if robots is None else robots.tobytes(), *[_bytes(v) for v in STATE_FIELDS(world)])
        if key == self._cache_key:
            return self._cache_target.copy()
        B, n = world.batch_size, world.n_robots
        if self._mem is None or self._mem.inp.stall.shape != (B, n):
            self._mem = _Memory.empty(B, n)
        mem = self._mem
        mem.sync(world)
        kworld = self._kernel_world(world)
        own, comm, detour = self._inputs(world, kworld)
        own_angle = np.arctan2(own[..., 1], own[..., 0])  # direction of the goal point G [rad]
        out = kernel.Outputs(
            np.zeros((B, n, 2)),
            np.zeros((B, n)),
            np.zeros((B, n), dtype=np.bool_),
            np.zeros((B, n), dtype=np.int64),
            np.zeros((B, n)),
            np.zeros((B, n), dtype=np.int64),
            np.zeros((B, n, 2)),
        )
        planned = np.ones((B, n), dtype=bool) if robots is None else np.repeat(robots[None], B, axis=0)
        kernel.plan_batch(*self._kernel_inputs(world, kworld, own, comm, detour, planned), out)
        # The polar targets, and the residual of the target after this period's saturated command
        # (for J_h next period).
        target, cost, goal_point = np.empty((B, n, 2)), np.empty((B, n)), np.empty((B, n, 2))
        cap = sum(self.params.weights) + 1.0
        kernel.finish(
            world.speed, world.heading, world.active, world.a_max, world.omega_max, bool(world.holonomic),
            float(world.dt), planned, own, own_angle, out, cap, target, mem.out.prev, mem.out.has_prev, cost,
            goal_point,
        )  # fmt: skip
        self.last = {
            "target": out.target,
            "cost": cost,
            "fallback": out.fallback,
            "k": out.k,
            "t_star": out.t_star,
            "threats": out.threats,
            "goal_step": out.goal_step,
            "goal_point": goal_point,
            "detour": detour,
        }
        self._cache_key, self._cache_target = key, target
        return target.copy()

    def plan_for(self, world: WorldState, robots: np.ndarray) -> np.ndarray:
        """:meth:`plan` of ``robots`` ``(n,)`` bool only: the others are not planned."""
        return self.plan(world, robots)

    def potential(self, world: WorldState) -> np.ndarray:
        """Minus the expert's optimal cost J of the state ``(B, n)``, in
        ``[potential_floor, 0]`` (0 for robots that are done); used by ``vcs_potential`` shaping."""
        self.plan(world)
        return np.where(world.active, -self.last["cost"], 0.0)

    @property
    def potential_floor(self) -> float:
        """The lowest potential, ``-(sum of the cost weights + 1)``: a state where no velocity
        change is admissible (the fallback's cost is capped there). Shaping gives it to a
        collision that ends a robot's episode."""
        return -(float(sum(self.params.weights)) + 1.0)

    def evaluate(self, world: WorldState, b: int, i: int, dv: np.ndarray, dth: np.ndarray):
        """Admissibility and cost of arbitrary VCS points of robot ``i`` in world ``b`` at this
        state (same inputs as :meth:`plan`); for tests and plots.

        Args:
            world, b, i: the state, a world ``0 <= b < B`` and a robot ``0 <= i < n`` of it.
            dv, dth: the VCS points, changes of speed [m/s] and of heading [rad], ``(k,)`` each (or any one shape,
                read flat).

        Returns:
            ``admissible`` (k,) bool, ``cost`` (k,), ``horizon`` (2 n + m + s,) [s] per sensed object:
            robots, obstacles, the static twin of each arriving robot, then wall segments (inf: not sensed;
            the twins of ``stopping_obstacles`` are not reported).
        """
        check_int("b (a world of the batch)", b, 0, world.batch_size - 1)
        check_int("i (a robot of the world)", i, 0, world.n_robots - 1)
        if np.shape(dv) != np.shape(dth):
            raise ValueError(f"dv and dth must have one shape (one point each), got {np.shape(dv)} and {np.shape(dth)}")
        self.plan(world)  # memory and inputs of this state
        kworld = self._kernel_world(world)
        own, comm, detour = self._inputs(world, kworld)
        dv = np.ascontiguousarray(dv, dtype=np.float64).ravel()
        dth = np.ascontiguousarray(dth, dtype=np.float64).ravel()
        ok = np.zeros(dv.shape[0], dtype=np.bool_)
        cost = np.zeros(dv.shape[0])
        m = kworld.obs_pos.shape[1]  # the obstacles and their mirror images
        horizon = np.zeros(2 * world.n_robots + m + world.n_segments)
        planned = np.ones((world.batch_size, world.n_robots), dtype=bool)
        kernel.evaluate_points(
            b, i, *self._kernel_inputs(world, kworld, own, comm, detour, planned), dv, dth, ok, cost, horizon
        )
        n, m0 = world.n_robots, world.n_obstacles
        return ok, cost, np.concatenate((horizon[: n + m0], horizon[n + m : n + m + n], horizon[2 * n + m :]))


STATE_FIELDS = operator.attrgetter(*(f.name for f in dataclasses.fields(WorldState)))
"""Every field of a world state (the key of :meth:`VCSPlanner.plan`'s cache of its last plan)."""


def _bytes(value):
    """An array's bytes (a field of :data:`STATE_FIELDS` in the cache key), any other value as it is."""
    return value.tobytes() if type(value) is np.ndarray else value


MAX_TURN_RATE = 2.0
"""[rad/s] fastest change of an obstacle's heading that ``VCSParams.mover_turn_lead`` reads as a
turn; a faster one (a bounce off an edge, a push) is a jump, and the obstacle keeps its velocity."""


def turn_angles(before: np.ndarray, now: np.ndarray, has: np.ndarray, dt: float, lead: float) -> np.ndarray:
    """The angles ``(B, m)`` [rad] by which :func:`turned_velocities` turns the velocities ``now``."""
    out = np.empty(now.shape[:-1])
    a0 = np.arctan2(before[..., 1], before[..., 0])  # numpy's arctan2 (kernel.period's module docstring)
    a1 = np.arctan2(now[..., 1], now[..., 0])
    kernel.turn_leads(a0, a1, before, now, has, dt, lead, STATIC_SPEED, MAX_TURN_RATE * dt, out)
    return out


def turned_velocities(before: np.ndarray, now: np.ndarray, has: np.ndarray, dt: float, lead: float) -> np.ndarray:
    """Obstacle velocities ``now`` ``(B, m, 2)`` [m/s] turned by their turn since ``before`` (one
    period ``dt`` [s] earlier; worlds where ``has`` ``(B,)`` is False have no such period) times
    ``lead / dt``: the heading each will have ``lead`` [s] from now at its current turn rate
    (``VCSParams.mover_turn_lead``). Obstacles at rest (below the kernel's ``STATIC_SPEED``), or that
    turned faster than :data:`MAX_TURN_RATE`, keep their velocity."""
    return rotate(now, turn_angles(before, now, has, dt, lead))


ESCALATION = 4
"""Detour angles of the escalation (``VCSParams.detour_escalate``): 1 to this many times
``detour_angle``, each at most a half turn, then from 1 again."""

FAR = 1e9
"""[m] where :func:`bounce_images` puts an image that is not needed (beyond any sensing radius)."""


def bounce_images(pos: np.ndarray, vel: np.ndarray, radius: np.ndarray, half: float):
    """Obstacles that reflect off the arena's edges, followed by their mirror images
    (``VCSParams.mirror_bounces``, vcs-method §2.4): ``(B, 4 m, 2)`` positions [m] and velocities
    [m/s] and ``(B, 4 m)`` radii [m]. An obstacle of radius r turns where its centre meets
    ``+-(half - r)``; its image in the edge it moves toward (in x, in y, and in both, the corner)
    moves straight along the path the obstacle takes after it bounces, and is outside the arena
    until then, so a robot that plans against the images plans against the bounce. An axis the
    obstacle does not move along has no image there (put at :data:`FAR`)."""
    B, m = radius.shape
    out = np.empty((B, 4 * m, 2)), np.empty((B, 4 * m, 2)), np.empty((B, 4 * m))
    kernel.mover_images(pos, vel, False, radius, radius, radius, float(half), FAR, *out)
    return out
