"""The VCS planner: the expert policy and reward shaper (vcs-method §2)."""

from __future__ import annotations

import dataclasses

import numpy as np

from vcs_env import noise
from vcs_env.geometry import rotate, wrap_angle
from vcs_env.planning import Planner
from vcs_env.routes import route_direction
from vcs_env.state import WorldState

from ..capsule import reference_capsule_tau
from ..common import hold_inactive, preferred_velocity
from . import kernel
from .geometry import velocity_to_vcs
from .params import VCSParams


@dataclasses.dataclass
class _Memory:
    """Per-robot memory across periods, kept idempotent: ``inp`` is what the plan at step
    ``step`` uses, ``out`` what it leaves for step ``step + 1``."""

    step: np.ndarray  # (B,) int
    key: np.ndarray  # (B,) uint64
    prev_in: np.ndarray  # (B, n, 2) residual target (dv, dtheta) from the last period
    has_prev_in: np.ndarray  # (B, n) bool
    stall_in: np.ndarray  # (B, n) time spent stalled [s]
    detour_in: np.ndarray  # (B, n) detour time left [s]
    ref_in: np.ndarray  # (B, n) goal distance at the last progress mark [m] (0: unset)
    wait_in: np.ndarray  # (B, n) time since the last progress mark [s]
    prev_out: np.ndarray
    has_prev_out: np.ndarray
    stall_out: np.ndarray
    detour_out: np.ndarray
    ref_out: np.ndarray
    wait_out: np.ndarray

    @classmethod
    def empty(cls, B: int, n: int) -> _Memory:
        z2, z1, zb = np.zeros((B, n, 2)), np.zeros((B, n)), np.zeros((B, n), dtype=bool)
        return cls(
            np.full(B, -1, dtype=np.int64),
            np.zeros(B, dtype=np.uint64),
            z2,
            zb,
            z1,
            z1.copy(),
            z1.copy(),
            z1.copy(),
            z2.copy(),
            zb.copy(),
            z1.copy(),
            z1.copy(),
            z1.copy(),
            z1.copy(),
        )

    def sync(self, world: WorldState) -> None:
        """Move last period's output into this period's input, or clear it on a new episode."""
        fresh = (world.steps == 0) | (world.key != self.key)
        advance = ~fresh & (world.steps == self.step + 1)
        same = ~fresh & (world.steps == self.step)
        clear = ~(advance | same)
        every_advance, every_clear = advance.all(), clear.all()  # the usual cases, without masks
        for a, b in (
            (self.prev_in, self.prev_out),
            (self.has_prev_in, self.has_prev_out),
            (self.stall_in, self.stall_out),
            (self.detour_in, self.detour_out),
            (self.ref_in, self.ref_out),
            (self.wait_in, self.wait_out),
        ):
            if every_advance:
                a[...] = b
            elif every_clear:
                a[...] = 0
            else:
                a[advance] = b[advance]
                a[clear] = 0
        self.step = world.steps.copy()
        self.key = world.key.copy()


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
    admissible candidate), ``k`` (window steps), ``t_star`` (first threat time [s]),
    ``threats``, ``target`` (dv*, dtheta*) ``(B, n, 2)``, ``goal_point`` G and ``goal_step`` (G
    clipped to the one-step window) ``(B, n, 2)``, ``cost`` and ``detour``.
    """

    name = "vcs"

    def __init__(self, params: VCSParams | None = None, **overrides):
        base = params if params is not None else VCSParams()
        if not isinstance(base, VCSParams):
            raise ValueError(f"params must be a VCSParams, got {type(base).__name__}")
        self.params = dataclasses.replace(base, **overrides) if overrides else base
        self._prm = kernel.params_record(self.params)
        self._mem: _Memory | None = None
        self._cache_key: tuple | None = None
        self._cache_target: np.ndarray | None = None
        self.last: dict[str, np.ndarray] = {}

    # ------------------------------------------------------------------ inputs
    def _inputs(self, world: WorldState):
        """Preferred velocities (perturbed, and detour-rotated) and communicated ones."""
        p = self.params
        mem = self._mem
        route, leg = None, None
        if world.n_segments:  # (next leg scaled to the remaining length [m], that length [m]); the leg's length [m]
            scaled, length, leg = route_direction(world, with_leg=True)
            route = (scaled, length)
        pref = preferred_velocity(world, route=route)
        B, n = world.batch_size, world.n_robots
        if p.give_way and world.n_segments and n > 1:
            # Give way at crossing routes (vcs-method §2.19): priority to the right.
            pref = self._give_way(world, pref, leg)
        own = pref.copy()
        d_goal = np.linalg.norm(world.goal - world.pos, axis=-1) if route is None else route[1]
        if n > 1 and p.perturbation > 0:
            # Symmetry breaking (vcs-method §2.5): a small random push, from the world's counter-based noise.
            psi = 2.0 * np.pi * noise.uniform(world.key, world.steps, n, stream=1)
            push = p.perturbation * world.v_max[..., None] * np.stack((np.cos(psi), np.sin(psi)), -1)
            own = own + np.where((d_goal > world.r_goal)[..., None], push, 0.0)
        # Stall handling (vcs-method §2.13): after stall_time [s] slow and away from the goal, or after
        # progress_window [s] without gaining stall_speed * v_max * progress_window on the
        # goal (whatever the speed), detour.
        away = (d_goal > world.r_goal + p.stall_goal_margin) & world.active
        stalled = (world.speed < p.stall_speed * world.v_max) & away
        ref = np.where(mem.ref_in > 0, mem.ref_in, d_goal)
        progressed = ref - d_goal >= p.stall_speed * world.v_max * p.progress_window
        wait = np.where(progressed, 0.0, mem.wait_in + world.dt)
        no_progress = away & (p.progress_window > 0) & (wait >= p.progress_window - 1e-9)
        slow = stalled & (mem.stall_in + world.dt >= p.stall_time - 1e-9)
        start = (mem.detour_in <= 0) & (slow | no_progress)
        detour = (mem.detour_in > 0) | start
        angle = np.full((B, n), p.detour_angle)
        if p.detour_off_walls and world.n_segments and detour.any():
            angle = self._detour_side(world, own, angle, detour)
        own = np.where(detour[..., None], rotate(own, angle), own)
        length = p.detour_time
        if p.detour_jitter > 0 and world.n_segments and start.any():
            # Among walls a head-on pair in a door one robot wide stalls and detours in step;
            # detours of different lengths bring them back one after the other (vcs-method §2.13).
            length = p.detour_time * (
                1.0 + p.detour_jitter * (2.0 * noise.uniform(world.key, world.steps, n, stream=2) - 1.0)
            )
        mem.detour_out = np.where(detour, np.where(start, length, mem.detour_in) - world.dt, 0.0)
        mem.stall_out = np.where(stalled & ~detour, mem.stall_in + world.dt, 0.0)
        mark = progressed | start  # a new progress mark: progress made, or a detour begins
        mem.ref_out = np.where(mark, d_goal, ref)
        mem.wait_out = np.where(mark, 0.0, wait)
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
        way yet (``|s_i sin| >= r_i + r_j``): i's preferred speed is capped to stop
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
        room = np.maximum(stop, 0.0)
        cap = np.minimum(np.minimum(room / world.dt, np.sqrt(2.0 * world.a_max * room)), sp)
        scale = np.where(np.isfinite(stop), cap, sp) / np.maximum(sp, 1e-12)
        return pref * scale[..., None]

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

    def _kernel_inputs(self, world: WorldState, own, comm, detour, planned) -> tuple:
        """The world, preferred velocities, memory and the robots to plan ``(B, n)`` bool, and the
        setting, as the kernels' records."""
        mem = self._mem
        r_ca = world.r_ca if self.params.r_ca is None else self.params.r_ca
        return (
            kernel.World(
                world.pos, world.heading, world.speed, world.radius, world.v_max, world.a_max, world.omega_max,
                world.active, world.present, world.obs_pos, world.obs_vel, world.obs_radius,
                world.seg_a, world.seg_b, world.seg_present,
            ),
            kernel.Inputs(own, comm, detour, mem.prev_in, mem.has_prev_in, planned),
            kernel.Setting(self._prm, float(r_ca), float(world.dt), bool(world.holonomic)),
        )  # fmt: skip

    # -------------------------------------------------------------------- plan
    def plan(self, world: WorldState, robots: np.ndarray | None = None) -> np.ndarray:
        """Targets ``(B, n, 2)`` of every robot, or only of ``robots`` ``(n,)`` bool (the others'
        rows keep their speed and heading, and their ``last`` entries are those of a robot
        that is done; the robots planned get the same targets either way)."""
        if robots is not None:
            robots = np.asarray(robots, dtype=bool)
            if robots.shape != (world.n_robots,):
                raise ValueError(f"robots must be a bool mask of shape ({world.n_robots},), got shape {robots.shape}")
        key = (
            None if robots is None else robots.tobytes(),
            world.key.tobytes(),
            world.steps.tobytes(),
            world.pos.tobytes(),
            world.active.tobytes(),
            world.obs_pos.tobytes(),
            world.speed.tobytes(),
        )
        if key == self._cache_key:
            return self._cache_target.copy()
        B, n = world.batch_size, world.n_robots
        if self._mem is None or self._mem.prev_in.shape[:2] != (B, n):
            self._mem = _Memory.empty(B, n)
        mem = self._mem
        mem.sync(world)
        own, comm, detour = self._inputs(world)
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
        kernel.plan_batch(*self._kernel_inputs(world, own, comm, detour, planned), out)
        out_target = out.target
        # Residual of the target after this period's saturated command (for J_h next period).
        dv, dth = out_target[..., 0], out_target[..., 1]
        if world.holonomic:
            cmd_dv, cmd_dth = dv, dth  # the holonomic command reaches along the velocity change
            mem.prev_out = np.zeros((B, n, 2))
        else:
            dv1, dth1 = world.a_max * world.dt, world.omega_max * world.dt
            cmd_dv, cmd_dth = np.clip(dv, -dv1, dv1), np.clip(dth, -dth1, dth1)
            mem.prev_out = np.stack((dv - cmd_dv, wrap_angle(dth - cmd_dth)), axis=-1)
        mem.has_prev_out = world.active & planned
        # The heading target is this period's turn (|cmd_dth| < pi), not the planned point: a
        # planned half turn dth = -pi wraps to +pi, and the shortest-way turn toward it would
        # go the other way round from the one the plan checked (vcs-method §2.15).
        target = hold_inactive(world, np.stack((world.speed + dv, wrap_angle(world.heading + cmd_dth)), axis=-1))
        cap = sum(self.params.weights) + 1.0
        self.last = {
            "target": out_target,
            "cost": np.minimum(out.cost, cap),
            "fallback": out.fallback,
            "k": out.k,
            "t_star": out.t_star,
            "threats": out.threats,
            "goal_step": out.goal_step,
            "goal_point": np.stack(velocity_to_vcs(own, world.speed, world.heading), axis=-1),
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

        Returns:
            ``admissible`` (k,) bool, ``cost`` (k,), ``horizon`` (2 n + m + s,) [s] per sensed object:
            robots, obstacles, the static twin of each arriving robot, then wall segments (inf: not sensed;
            the twins of ``stopping_obstacles`` are not reported).
        """
        self.plan(world)  # memory and inputs of this state
        own, comm, detour = self._inputs(world)
        dv = np.ascontiguousarray(dv, dtype=np.float64).ravel()
        dth = np.ascontiguousarray(dth, dtype=np.float64).ravel()
        ok = np.zeros(dv.shape[0], dtype=np.bool_)
        cost = np.zeros(dv.shape[0])
        horizon = np.zeros(2 * world.n_robots + world.n_obstacles + world.n_segments)
        planned = np.ones((world.batch_size, world.n_robots), dtype=bool)
        kernel.evaluate_points(
            b, i, *self._kernel_inputs(world, own, comm, detour, planned), dv, dth, ok, cost, horizon
        )
        return ok, cost, horizon
