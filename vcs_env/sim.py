"""The batched simulator core: ``B`` worlds of one scenario stepped in one numpy call.

No Gymnasium or PettingZoo types here; the API classes are thin adapters around
:class:`Simulator`. Each world owns its ``np.random.Generator`` (seeded at reset) and draws
everything random at reset, so one seed gives one trajectory, bit for bit, and stepping B
worlds together equals stepping them one by one.

A step has two phases: every robot's command comes from one frozen snapshot (the actions),
then all robots and obstacles move. Collisions are checked on the swept motion of the step;
with ``on_collision="terminate"`` a robot that touches anything stops at the point of first
contact (:mod:`vcs_env.stop_kernels`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import kernels, stall
from .dynamics import ACTION_MODES, check_actions
from .geometry import closest_approach
from .layouts import generate, segment_capacity
from .obstacles import ObstacleMotion, make_motion
from .scenario import V_REF, Scenario
from .start_states import StartStates, StatePool
from .state import WorldState


def _is_seed(x) -> bool:
    """A seed the worlds' generators take: a non-negative integer (not a bool)."""
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool) and x >= 0


@dataclass
class StepEvents:
    """What happened in one step, per world and robot. Robots that were not active at the start
    of the step have all-False events and ``min_separation = inf``."""

    acted: np.ndarray  # (B, n) bool: robots that were active at the start of the step
    reached: np.ndarray  # (B, n) bool: arrived during this step
    collided: np.ndarray  # (B, n) bool: touched something during this step
    robot_hits: np.ndarray  # (B, n, n) bool: [b, i, j] robot i touched robot j
    obstacle_hits: np.ndarray  # (B, n, m) bool: [b, i, k] robot i touched obstacle k
    min_separation: np.ndarray  # (B, n) smallest swept gap to any object or wall this step [m]
    goal_dist_before: np.ndarray  # (B, n) [m]
    goal_dist_after: np.ndarray  # (B, n) [m]
    wall_hits: np.ndarray | None = None  # (B, n, s) bool: [b, i, k] robot i touched wall segment k

    def __post_init__(self) -> None:
        if self.wall_hits is None:
            self.wall_hits = np.zeros((*self.acted.shape, 0), dtype=bool)


def world_indices(worlds, batch_size: int) -> list[int]:
    """``worlds`` as a list of world indices (None: all ``batch_size``), or a ``ValueError``: distinct integers in
    ``[0, batch_size)`` (a negative index, a float or a bool picked another world)."""
    if worlds is None:
        return list(range(batch_size))
    if isinstance(worlds, np.ndarray) and worlds.ndim == 1 and worlds.dtype.kind in "iu":  # autoreset's: one pass
        if worlds.size == 0 or (
            0 <= worlds.min() and worlds.max() < batch_size and np.unique(worlds).size == worlds.size
        ):
            return worlds.tolist()
    idx = list(worlds) if np.ndim(worlds) == 1 else None
    ok = idx is not None and all(isinstance(w, (int, np.integer)) and not isinstance(w, (bool, np.bool_)) for w in idx)
    if not ok or not all(0 <= w < batch_size for w in idx) or len(set(idx)) != len(idx):
        raise ValueError(f"worlds must be distinct integer indices in [0, {batch_size}), got {worlds!r}")
    return [int(w) for w in idx]


class Simulator:
    """``B`` worlds of one scenario.

    Args:
        scenario: the episode family.
        batch_size: number of worlds B.
        action_mode: ``"delta"`` (velocity-change window fractions) or ``"absolute"``
            (see :mod:`vcs_env.dynamics`).
        obstacle_motion: overrides the scenario's obstacle motion model.
        start_states: pools of saved states; a reset world of a scenario with a pool starts from
            one of its states with probability ``start_states.prob`` (:mod:`vcs_env.start_states`).
    """

    def __init__(
        self,
        scenario: Scenario,
        batch_size: int = 1,
        action_mode: str = "delta",
        obstacle_motion: ObstacleMotion | None = None,
        start_states: StartStates | None = None,
    ):
        if not isinstance(scenario, Scenario):
            raise ValueError(f"scenario must be a vcs_env.Scenario, got {type(scenario).__name__}")
        if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
            raise ValueError(f"batch_size must be an integer >= 1, got {batch_size!r}")
        if action_mode not in ACTION_MODES:
            raise ValueError(f"action_mode must be one of {ACTION_MODES}, got {action_mode!r}")
        self.scenario = scenario
        self.batch_size = int(batch_size)
        self.action_mode = action_mode
        if obstacle_motion is not None and not isinstance(obstacle_motion, ObstacleMotion):
            raise ValueError(
                f"obstacle_motion must be a vcs_env.obstacles.ObstacleMotion, got {type(obstacle_motion).__name__} "
                "(a model's name goes in the Scenario field obstacle_motion)"
            )
        self.motion = obstacle_motion if obstacle_motion is not None else make_motion(scenario)
        self.rngs: list[np.random.Generator] = [np.random.default_rng() for _ in range(self.batch_size)]
        self.world: WorldState = self._empty_world()
        self.motion_params: dict[str, np.ndarray] = {}
        self._needs_reset = np.ones(self.batch_size, dtype=bool)
        self._wall_cache: tuple = ()  # kernels.wall_events_cached's, for the segment arrays in _wall_cache_of
        self._wall_cache_of: tuple = ()
        self.start_pool: StatePool | None = None
        self.start_prob = 0.0
        if start_states is not None and (pool := start_states.pool(scenario)) is not None and len(pool):
            pool.check(self.world, self._name())
            self.start_pool, self.start_prob = pool, start_states.prob
        self.start_counts = np.zeros(2, dtype=np.int64)  # resets that started fresh, from the pool

    # ------------------------------------------------------------------ reset
    def _empty_world(self) -> WorldState:
        s, B, n, m = self.scenario, self.batch_size, self.scenario.n_robots, self.scenario.n_obstacles
        rs = s.robot
        n_seg = segment_capacity(s)
        return WorldState(
            time=np.zeros(B),
            steps=np.zeros(B, dtype=np.int64),
            key=np.zeros(B, dtype=np.uint64),
            pos=np.zeros((B, n, 2)),
            heading=np.zeros((B, n)),
            speed=np.zeros((B, n)),
            radius=np.full((B, n), rs.radius),
            goal=np.zeros((B, n, 2)),
            v_max=np.full((B, n), rs.v_max),
            a_max=np.full((B, n), rs.a_max),
            omega_max=np.full((B, n), rs.omega_max),
            active=np.zeros((B, n), dtype=bool),
            present=np.zeros((B, n), dtype=bool),
            reached=np.zeros((B, n), dtype=bool),
            collided=np.zeros((B, n), dtype=bool),
            obs_pos=np.zeros((B, m, 2)),
            obs_vel=np.zeros((B, m, 2)),
            obs_radius=np.zeros((B, m)),
            dt=s.dt,
            r_goal=s.r_goal,
            r_ca=s.r_ca,
            holonomic=rs.holonomic,
            bounce_half=s.arena_half_size if s.bounce else None,
            seg_a=np.zeros((B, n_seg, 2)),
            seg_b=np.zeros((B, n_seg, 2)),
            seg_present=np.zeros((B, n_seg), dtype=bool),
            clock=np.zeros((B, n, stall.CLOCK_DIM)) if s.stall_clock else None,
        )

    def reset(self, seeds: int | Sequence[int | None] | None = None, worlds: Sequence[int] | None = None) -> WorldState:
        """Start new episodes in ``worlds`` (default: all).

        Args:
            seeds: one seed per reset world, or one int (world ``i`` of the reset set gets
                ``seed + i``), or None (fresh entropy). A world's generator is re-seeded only
                when its seed is not None; otherwise it continues its stream.
            worlds: indices of the worlds to reset.

        Returns:
            The world state (a reference; copy it to keep a snapshot).
        """
        idx = world_indices(worlds, self.batch_size)
        if seeds is None or _is_seed(seeds):
            seed_list = [None if seeds is None else int(seeds) + i for i in range(len(idx))]
        else:
            if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__len__"):
                raise ValueError(f"seed must be a non-negative integer or one per world, got {seeds!r}")
            seed_list = list(seeds)
            if len(seed_list) != len(idx):
                raise ValueError(f"got {len(seed_list)} seeds for {len(idx)} worlds")
            bad = [s for s in seed_list if s is not None and not _is_seed(s)]
            if bad:
                raise ValueError(f"seeds must be non-negative integers or None, got {bad[0]!r}")
        w = self.world
        fresh, restored = [], []
        lays, params, keys = [], [], []
        for b, seed in zip(idx, seed_list):
            if seed is not None:
                self.rngs[b] = np.random.default_rng(seed)
            rng = self.rngs[b]
            lay = generate(self.scenario, rng)
            self.motion.place(rng, self.scenario, lay)
            lays.append(lay)
            params.append(self._motion_params(rng, lay))
            keys.append(rng.integers(0, np.iinfo(np.uint64).max, dtype=np.uint64, endpoint=True))
            if self.start_prob > 0 and rng.random() < self.start_prob:
                restored.append((b, int(rng.integers(len(self.start_pool)))))
            else:
                fresh.append(b)
        # Every world's draws above, in order; the arrays written once for all of them.
        if idx:
            w.time[idx] = 0.0
            w.steps[idx] = 0
            w.key[idx] = keys
            for field, name in (("pos", "start"), ("heading", "heading"), ("speed", "speed"), ("goal", "goal")):
                getattr(w, field)[idx] = np.stack([getattr(lay, name) for lay in lays])
            for field in ("active", "present"):
                getattr(w, field)[idx] = True
            for field in ("reached", "collided"):
                getattr(w, field)[idx] = False
            w.obs_pos[idx] = np.stack([lay.obs_pos for lay in lays])
            w.obs_radius[idx] = np.stack([lay.obs_radius for lay in lays])
            w.obs_vel[idx] = 0.0
            if w.n_segments:
                seg = np.zeros((len(idx), w.n_segments, 2, 2))
                present = np.zeros((len(idx), w.n_segments), dtype=bool)
                for i, lay in enumerate(lays):
                    seg[i, : len(lay.segments)] = lay.segments
                    present[i, : len(lay.segments)] = True
                w.seg_a[idx], w.seg_b[idx], w.seg_present[idx] = seg[:, :, 0], seg[:, :, 1], present
            if any(p.keys() != params[0].keys() for p in params):
                raise ValueError(
                    f"obstacle motion {type(self.motion).__name__}.init gave different parameter names in the worlds "
                    f"of one reset ({sorted(params[0])} and others): every world has the same parameters"
                )
            for key in params[0]:
                try:
                    value = np.stack([p[key] for p in params])
                except ValueError:
                    shapes = sorted({p[key].shape for p in params})
                    raise ValueError(
                        f"obstacle motion {type(self.motion).__name__}.init gave {key!r} of shapes {shapes} in the "
                        "worlds of one reset: a parameter has one shape in every world"
                    ) from None
                if key not in self.motion_params:
                    self.motion_params[key] = np.zeros((self.batch_size, *value.shape[1:]), dtype=value.dtype)
                self.motion_params[key][idx] = value
        self.start_counts += (len(fresh), len(restored))
        if restored:
            self.restore(self.start_pool, [i for _, i in restored], [b for b, _ in restored])
        if self._wall_cache:
            self._wall_cache[0][idx, :, 2] = -1.0  # new walls: no wall candidates
        # Obstacle velocities are what they will do over the coming step (for sensing).
        self._needs_reset[idx] = False
        self._preview_obstacle_velocity(fresh)  # restored worlds keep their saved obstacle velocities
        self._start_clock(fresh)
        return w

    def _motion_params(self, rng: np.random.Generator, lay) -> dict[str, np.ndarray]:
        """The obstacle motion's parameters of one world, checked: a dict of arrays with leading shape ``(m,)``, one
        row per obstacle; a number is one value for every obstacle (``np.full(m, value)``). A ``ValueError`` naming
        the model otherwise (a per-world number stored as ``(B,)`` broadcast against ``(B, m, 2)`` where B = m, and
        batched runs silently differed from one-by-one runs)."""
        name, m = type(self.motion).__name__, len(lay.obs_pos)
        params = self.motion.init(rng, self.scenario, lay.obs_pos, lay.obs_target)
        if not isinstance(params, dict):
            raise ValueError(f"obstacle motion {name}.init must return a dict of parameter arrays, got {params!r}")
        out = {}
        for key, value in params.items():
            arr = np.asarray(value)
            if arr.dtype.kind not in "biuf":
                raise ValueError(f"obstacle motion {name}.init gave {key!r} of dtype {arr.dtype}: it must be numbers")
            if arr.ndim == 0:
                arr = np.full(m, arr)
            elif arr.shape[0] != m:
                raise ValueError(
                    f"obstacle motion {name}.init gave {key!r} of shape {arr.shape}: parameters have leading shape "
                    f"(m,) = ({m},), one row per obstacle (or are one number for all)"
                )
            out[key] = arr
        return out

    def _start_clock(self, idx: Sequence[int]) -> None:
        """A new stall clock in worlds ``idx``, run on their current state (:mod:`vcs_env.stall`)."""
        if self.world.clock is not None and len(idx):
            self.world.clock[idx] = 0.0
            stall.tick(self.world, idx)

    def _name(self) -> str:
        s = self.scenario
        return f"scenario {s.kind} (n={s.n_robots}, m={s.n_obstacles})"

    def restore(self, pool: StatePool, states: Sequence[int], worlds: Sequence[int] | None = None) -> WorldState:
        """Put states ``states`` of ``pool`` (a pool of this scenario) into ``worlds`` (default: all,
        one state each): their bodies, obstacles and random draws then continue exactly as those of the worlds the
        states were taken from, their stall clocks start afresh (:mod:`vcs_env.start_states`). Their generators are
        not touched. Returns the world state. Behind a :class:`~vcs_env.engine.NavEngine` (expert, reward terms)
        pass ``start_states`` to it instead, so they see the restored worlds from their first step."""
        idx = world_indices(worlds, self.batch_size)
        states = [int(i) for i in states]
        if len(states) != len(idx):
            raise ValueError(f"got {len(states)} states for {len(idx)} worlds")
        if states and not 0 <= min(states) <= max(states) < len(pool):
            raise ValueError(f"state indices must be in [0, {len(pool)}), got {min(states)}..{max(states)}")
        pool.check(self.world, self._name())
        if not self.motion_params and pool.motion:  # never reset: make the motion arrays
            self.motion_params = {k: np.zeros((self.batch_size, *v.shape[1:]), v.dtype) for k, v in pool.motion.items()}
        if set(pool.motion) != set(self.motion_params):
            raise ValueError(
                f"the start-state pool has obstacle motion state {sorted(pool.motion)}, this scenario's motion "
                f"model {sorted(self.motion_params)}"
            )
        for field, values in pool.world.items():
            getattr(self.world, field)[idx] = values[states]
        for key, values in pool.motion.items():
            self.motion_params[key][idx] = values[states]
        if self._wall_cache:
            self._wall_cache[0][idx, :, 2] = -1.0  # new walls: no wall candidates
        self._needs_reset[idx] = False
        self._start_clock(idx)
        return self.world

    def _preview_obstacle_velocity(self, idx: list[int]) -> None:
        """Fill ``obs_vel`` of the reset worlds with the velocity of their first step, without
        advancing the motion model's state."""
        if self.scenario.n_obstacles == 0 or not idx:
            return
        params = {k: v[idx].copy() for k, v in self.motion_params.items()}
        worlds = dataclasses.replace(self.world, **{f: v[idx] for f, v in self.world.arrays().items()})
        self.world.obs_vel[idx] = self._motion_velocity(params, worlds)

    def _motion_velocity(self, params: dict, worlds: WorldState) -> np.ndarray:
        """The motion model's velocities ``(B, m, 2)`` [m/s] for ``worlds``, checked (a model of one's own that gives
        another shape is named; NaN obstacles escaped every collision check; speeds above ``V_REF`` were clipped in
        the observations, which scale velocities by it)."""
        vel = self.motion.world_velocity(params, worlds, self.scenario.dt)
        ok = isinstance(vel, np.ndarray) and vel.dtype == np.float64 and vel.shape == worlds.obs_pos.shape
        if not (ok and np.einsum("...i,...i->...", vel, vel).max(initial=0.0) <= V_REF**2 + 1e-9):
            what = f"the velocity of obstacle motion {type(self.motion).__name__}"
            vel = check_actions(vel, worlds.obs_pos.shape, what)
            fastest = float(np.linalg.norm(vel, axis=-1).max(initial=0.0))
            if fastest > V_REF + 1e-9:
                raise ValueError(
                    f"{what} reached {fastest:.3f} m/s, above the {V_REF} m/s that observations scale velocities by "
                    "(vcs_env.scenario.V_REF, as Scenario.obstacle_speed): keep obstacle speeds at or below it"
                )
        return vel

    # ------------------------------------------------------------------- step
    def step(self, actions: np.ndarray) -> StepEvents:
        """Advance every world by one step.

        Args:
            actions: ``(B, n, 2)`` in the simulator's action units; rows of robots that are not
                active are ignored. Values are clipped to [-1, 1]; NaN or inf raise.

        Returns:
            The events of the step. The state is updated in place (``self.world``).
        """
        if self._needs_reset.any():
            raise RuntimeError(f"worlds {np.flatnonzero(self._needs_reset).tolist()} must be reset before step()")
        s, w = self.scenario, self.world
        w.check_shapes()  # fields replaced by hand (WorldState's docstring)
        B, n = self.batch_size, s.n_robots
        actions = check_actions(actions, (B, n, 2))
        acted = w.active.copy()
        dt = s.dt

        # Phase 1: commands from the frozen snapshot (robots that did not act stay put).
        speed, heading, new_pos = kernels.integrate(
            w.pos, w.heading, w.speed, w.v_max, w.a_max, w.omega_max, acted, actions, dt,
            w.holonomic, self.action_mode == "absolute",
        )  # fmt: skip
        obs_vel = self._obstacle_velocity()
        new_obs = w.obs_pos + obs_vel * dt

        # A robot whose step passes through its goal disc and out again arrives, and stops, at the step's
        # point nearest its goal (in place on new_pos; the swept checks below see the shorter step).
        old_pos = w.pos
        at_goal = kernels.stop_at_goal(old_pos, new_pos, w.goal, acted, s.r_goal)

        # Phase 2: swept checks over the straight motions of the step.
        robot_hits, obstacle_hits, collided, reached, min_sep, goal_before, goal_after = kernels.swept_events(
            old_pos, new_pos, w.radius, w.present, acted, w.goal, w.obs_pos, new_obs, w.obs_radius, s.r_goal
        )
        reached |= at_goal  # its nearest point is within r_goal (exactly, not up to rounding on the shorter step)

        if w.n_segments:  # walls: contacts like obstacles, swept over the step (no tunnelling)
            wall_hits, min_sep, collided = kernels.wall_events_cached(
                old_pos, new_pos, w.radius, w.present, acted, w.seg_a, w.seg_b, w.seg_present, min_sep, collided,
                *self._wall_candidates(), kernels.WALL_REACH,
            )  # fmt: skip
        else:
            wall_hits = np.zeros((B, n, 0), dtype=bool)

        if s.on_collision == "terminate" and collided.any():
            # Crashed robots stop where they first touched, not where their step would have ended.
            redo = collided.any(axis=1)
            stop, hits, crashed, sep = kernels.stop_at_contact(
                old_pos, new_pos, w.radius, w.present, acted, w.obs_pos, new_obs, w.obs_radius,
                w.seg_a, w.seg_b, w.seg_present, redo,
            )  # fmt: skip
            m = w.obs_radius.shape[1]
            robot_hits[redo], obstacle_hits[redo] = hits[redo, :, :n], hits[redo, :, n : n + m]
            wall_hits[redo], collided[redo], min_sep[redo] = hits[redo, :, n + m :], crashed[redo], sep[redo]
            short = stop < 1.0
            new_pos = np.where(short[..., None], old_pos + stop[..., None] * (new_pos - old_pos), new_pos)
            passed = closest_approach(old_pos - w.goal, new_pos - w.goal) <= s.r_goal
            reached = np.where(short, passed, reached)
            goal_after = np.where(short, np.linalg.norm(w.goal - new_pos, axis=-1), goal_after)

        # Commit.
        w.pos, w.speed, w.heading = new_pos, speed, heading
        w.obs_pos, w.obs_vel = new_obs, obs_vel
        kernels.commit(
            w.active, w.present, w.reached, w.collided, w.speed, reached, collided,
            s.on_collision == "terminate", s.park_finished,
        )  # fmt: skip
        w.steps = w.steps + 1
        w.time = w.steps * dt  # multiplied out, not summed: a sum drifts (a turn period a step late after 34k steps)
        if w.clock is not None:
            stall.tick(w)
        return StepEvents(
            acted=acted,
            reached=reached,
            collided=collided,
            robot_hits=robot_hits,
            obstacle_hits=obstacle_hits,
            min_separation=min_sep,
            goal_dist_before=goal_before,
            goal_dist_after=goal_after,
            wall_hits=wall_hits,
        )

    def _wall_candidates(self) -> tuple:
        """The cache of :func:`kernels.wall_events_cached` for the world's walls: kept from step to
        step, emptied for the worlds :meth:`reset` resets and whenever the segment arrays are
        replaced. Walls are static between resets: segments changed in place must go through
        :meth:`reset`."""
        w, of = self.world, self._wall_cache_of
        if not (of and of[0] is w.seg_a and of[1] is w.seg_b and of[2] is w.seg_present):
            self._wall_cache = kernels.wall_cache(self.batch_size, w.n_robots, w.n_segments)
            self._wall_cache_of = (w.seg_a, w.seg_b, w.seg_present)
        return self._wall_cache

    def _obstacle_velocity(self) -> np.ndarray:
        """Velocities of all obstacles over the coming step, after wall bounces ``(B, m, 2)``."""
        s, w = self.scenario, self.world
        if s.n_obstacles == 0:
            return np.zeros_like(w.obs_pos)
        vel = self._motion_velocity(self.motion_params, w)
        if s.bounce:
            # Reverse a component that would carry the disc through a wall during the step.
            vel, flip = kernels.bounce(w.obs_pos, vel, w.obs_radius, s.arena_half_size, s.dt)
            if flip.any():
                out = flip & (np.abs(w.obs_pos + vel * s.dt) + w.obs_radius[..., None] > s.arena_half_size + 1e-9)
                if out.any():  # Scenario refuses such steps for the built-in motions; one's own motion is held here
                    raise ValueError(
                        f"obstacle motion {type(self.motion).__name__} left an obstacle beyond an arena edge after its "
                        f"bounce: it moved so far in one step (dt={s.dt:g} s) that the bounce off one edge carries it "
                        "out through the other, or it was already outside; reduce dt or the obstacles' speed, or "
                        "increase arena_half_size"
                    )
                params = self.motion_params
                before = {k: np.copy(v) for k, v in params.items()}
                self.motion.reflect(params, flip)
                calm = ~flip.any(axis=(1, 2))  # worlds without a bounce keep their parameters: batched = one by one
                B = len(calm)
                for k, v in before.items():  # the per-world ones (leading size B) that reflect kept
                    if calm.any() and v.ndim and len(v) == B and np.shape(params.get(k)) == v.shape:
                        params[k] = np.array(params[k])  # a new array: snapshots of params stay unchanged
                        params[k][calm] = v[calm]
        return vel

    # ---------------------------------------------------------------- queries
    @property
    def done(self) -> np.ndarray:
        """``(B,)`` bool: no robot is active any more."""
        return ~self.world.active.any(axis=1)
