"""Run whole episodes, many worlds at once: the one episode loop, with hooks.

:func:`play` steps one batched :class:`~vcs_env.engine.NavEngine` with one world per seed until
every world's episode ended (finished worlds idle until the slowest one ends). A *controller*
maps the state (and observations) of all worlds to actions in one call; *hooks* watch every
step (:class:`Hook`): they record episodes (:class:`EpisodeRecorder`, what :func:`run_episodes`
returns), render frames (:class:`FrameRecorder`), or label states with the expert's action
for imitation learning. Each episode comes back as an :class:`Episode` of plain arrays, from
which :mod:`vcs_env.metrics` computes the metrics.

Only the controller call is timed (``Step.compute_time``): rendering happens after the batch,
from state snapshots, and :func:`warm_up` runs a controller once so that compilation and cache
loading do not count as decision time.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .checks import check_int
from .engine import NavEngine, StepResult
from .planning import make_planner
from .scenario import Scenario
from .start_states import StartStates
from .state import WorldState

Controller = Callable[[WorldState, np.ndarray], np.ndarray]
"""``controller(world, obs (B, n, D)) -> actions (B, n, 2)`` in the engine's action units."""


@dataclass
class Episode:
    """One recorded episode. ``T`` steps; index 0 of the state arrays is the initial state."""

    seed: int
    dt: float  # [s]
    radius: np.ndarray  # (n,) [m]
    goal: np.ndarray  # (n, 2) [m]
    obs_radius: np.ndarray  # (m,) [m]
    pos: np.ndarray  # (T+1, n, 2) [m]
    heading: np.ndarray  # (T+1, n) [rad]
    speed: np.ndarray  # (T+1, n) [m/s]
    obs_pos: np.ndarray  # (T+1, m, 2) [m]
    actions: np.ndarray  # (T, n, 2), as applied, in the run's action units (vcs_env.dynamics; 0 for inactive robots)
    acted: np.ndarray  # (T, n) bool
    collided: np.ndarray  # (T, n) bool, robot touched something in that step
    robot_contact: np.ndarray  # (T, n) bool, ... a robot
    obstacle_contact: np.ndarray  # (T, n) bool, ... an obstacle or a wall
    min_separation: np.ndarray  # (T, n) smallest swept gap in that step [m] (inf if not acting)
    reached_step: np.ndarray  # (n,) int, step count at arrival (-1: never)
    straight_time: np.ndarray  # (n,) time a robot at v_max would need for the straight line [s]
    compute_time: float = 0.0  # controller wall time for this episode's share [s]
    decisions: int = 0  # robot decisions made (active robot-steps)
    frames: list = field(default_factory=list)  # rendered frames, if requested
    robot_hits: np.ndarray | None = None  # (T, n, n) bool, robot i touched robot j in that step
    obstacle_hits: np.ndarray | None = None  # (T, n, m) bool, robot i touched obstacle k
    wall_hits: np.ndarray | None = None  # (T, n, s) bool, robot i touched wall segment k
    segments: np.ndarray | None = None  # (s, 2, 2) the world's wall segments [m] (absent ones are NaN)

    @property
    def steps(self) -> int:
        return len(self.actions)

    @property
    def n_robots(self) -> int:
        return self.pos.shape[1]

    def check(self) -> None:
        """A ``ValueError`` naming the first array whose shape disagrees with the episode's ``T`` steps, ``n`` robots
        and ``m`` obstacles (from ``actions``, ``pos`` and ``obs_radius``), or a step ``dt`` that is not > 0, as a
        hand-made episode may; the metrics and the contacts check it first (a mismatch failed deep in numpy, or gave
        a wrong value silently)."""
        if not (isinstance(self.dt, (int, float, np.integer, np.floating)) and self.dt > 0 and np.isfinite(self.dt)):
            raise ValueError(f"Episode.dt must be a step length > 0 [s], got {self.dt!r}")
        T, n, m = len(self.actions), (np.shape(self.pos) + (-1, -1))[1], len(self.obs_radius)
        s = None if self.segments is None else len(self.segments)
        want = {"pos": (T + 1, n, 2), "radius": (n,), "goal": (n, 2), "heading": (T + 1, n), "speed": (T + 1, n),
                "obs_pos": (T + 1, m, 2), "actions": (T, n, 2), "acted": (T, n), "collided": (T, n),
                "robot_contact": (T, n), "obstacle_contact": (T, n), "min_separation": (T, n), "reached_step": (n,),
                "straight_time": (n,), "robot_hits": (T, n, n), "obstacle_hits": (T, n, m),
                "wall_hits": (T, n, s)}  # fmt: skip
        for name, shape in want.items():
            value = getattr(self, name)
            if value is None or (name == "wall_hits" and s is None and np.shape(value)[:2] == (T, n)):
                continue
            if np.shape(value) != shape:
                raise ValueError(
                    f"Episode.{name} has shape {np.shape(value)}, expected {shape} (T={T} steps from actions, "
                    f"n={n} robots from pos, m={m} obstacles from obs_radius)"
                )


@dataclass
class Step:
    """What a hook sees after each step of :func:`play` (``B`` worlds, ``n`` robots)."""

    engine: NavEngine
    """The engine, already stepped (``engine.world`` is the state after the step)."""
    obs: np.ndarray
    """``(B, n, D)`` observations the controller saw."""
    actions: np.ndarray
    """``(B, n, 2)`` the controller's actions."""
    result: StepResult
    """The engine's step result (rewards, events, terminations, next observations)."""
    acting: np.ndarray
    """``(B, n)`` bool: robots active before the step, in worlds still running."""
    steps: np.ndarray
    """``(B,)`` step count of each world before the step."""
    running: np.ndarray
    """``(B,)`` bool: worlds whose episode was still running in this step."""
    finished: np.ndarray
    """``(B,)`` bool: worlds whose episode ended with this step."""
    compute_time: float
    """Wall time of the controller call [s]."""


class Hook:
    """Watches :func:`play`. Subclasses override what they need; the defaults do nothing."""

    def begin(self, engine: NavEngine, seeds: Sequence[int], first: int) -> None:
        """A batch starts: ``engine`` was reset with ``seeds``; ``first`` is the index of
        ``seeds[0]`` in the whole run (batches of :func:`run_episodes` follow each other)."""

    def step(self, step: Step) -> None:
        """Called after every step of the batch."""

    def end(self) -> None:
        """The batch ended (every world finished)."""


def play(
    scenario: Scenario,
    controller: Controller,
    seeds: Sequence[int],
    hooks: Iterable[Hook] = (),
    action_mode: str = "delta",
    max_steps: int | None = None,
    expert=None,
    first: int = 0,
    start_states: StartStates | None = None,
) -> None:
    """Play one episode per seed, all worlds in one engine, calling ``hooks`` (module docstring).

    Args:
        scenario: the episode family.
        controller: maps (world, observations) of all worlds to actions.
        seeds: one reset seed per world.
        hooks: see :class:`Hook`.
        action_mode: action units the controller returns.
        max_steps: overrides ``scenario.max_steps``.
        expert: planner (or name) attached to the engine (``engine.expert_action``).
        first: index of ``seeds[0]`` in the caller's whole list (passed to ``Hook.begin``).
        start_states: pools of saved states a world may start from (:mod:`vcs_env.start_states`; for
            training data only, never for scoring).
    """
    hooks = list(hooks)
    engine = NavEngine(scenario, len(seeds), action_mode, expert=expert, max_steps=max_steps, start_states=start_states)
    obs = engine.reset([int(s) for s in seeds])
    w = engine.world
    for h in hooks:
        h.begin(engine, seeds, first)
    running = np.ones(w.batch_size, dtype=bool)
    while running.any():
        acting = w.active & running[:, None]
        steps = w.steps.copy()
        t0 = time.perf_counter()
        actions = np.asarray(controller(w, obs), dtype=np.float64)
        compute = time.perf_counter() - t0
        res = engine.step(actions)
        finished = running & (~w.active.any(axis=1) | (w.steps >= engine.max_steps))
        step = Step(engine, obs, actions, res, acting, steps, running.copy(), finished, compute)
        for h in hooks:
            h.step(step)
        obs = res.obs
        running &= ~finished
    for h in hooks:
        h.end()


def warm_up(scenario: Scenario, controller: Controller, seed: int, action_mode: str = "delta") -> None:
    """Run ``controller`` for two steps of one world, untimed, so that JIT compilation, cache
    loading and lazy imports do not count as decision time afterwards."""
    play(scenario, controller, [seed], action_mode=action_mode, max_steps=2)


class EpisodeRecorder(Hook):
    """Records every world of every batch as an :class:`Episode` (into ``episodes``).

    The controller time of a step is shared among the worlds still running, by their acting
    robots; ``decisions`` counts acting robot-steps.
    """

    def __init__(self) -> None:
        self.episodes: list[Episode] = []

    def begin(self, engine: NavEngine, seeds: Sequence[int], first: int) -> None:
        w = engine.world
        B, n = w.batch_size, w.n_robots
        self.dt, self.seeds = engine.scenario.dt, [int(s) for s in seeds]
        self.w = w
        self.radius, self.goal, self.obs_radius = w.radius.copy(), w.goal.copy(), w.obs_radius.copy()
        self.segments = np.where(w.seg_present[..., None, None], np.stack((w.seg_a, w.seg_b), axis=2), np.nan)
        self.straight = np.linalg.norm(w.goal - w.pos, axis=-1) / w.v_max
        self.states = {k: [getattr(w, k).copy()] for k in ("pos", "heading", "speed", "obs_pos")}
        self.per_step: dict[str, list[np.ndarray]] = {
            k: []
            for k in (
                "actions",
                "acted",
                "collided",
                "min_separation",
                "robot_hits",
                "obstacle_hits",
                "wall_hits",
            )
        }
        self.reached_step = np.full((B, n), -1, dtype=np.int64)
        self.end_step = np.zeros(B, dtype=np.int64)
        self.compute = np.zeros(B)
        self.decisions = np.zeros(B, dtype=np.int64)

    def step(self, s: Step) -> None:
        w, ev = self.w, s.result.events
        n_acting = s.acting.sum(axis=1)
        self.compute += s.compute_time * n_acting / max(1, n_acting.sum())
        self.decisions += n_acting
        self.per_step["actions"].append(np.where(s.acting[..., None], np.clip(s.actions, -1, 1), 0.0))
        self.per_step["acted"].append(ev.acted)
        self.per_step["collided"].append(ev.collided)
        self.per_step["min_separation"].append(ev.min_separation)
        self.per_step["robot_hits"].append(ev.robot_hits.copy())
        self.per_step["obstacle_hits"].append(ev.obstacle_hits.copy())
        self.per_step["wall_hits"].append(ev.wall_hits.copy())
        for k, v in self.states.items():
            v.append(getattr(w, k).copy())
        self.reached_step = np.where(ev.reached & (self.reached_step < 0), w.steps[:, None], self.reached_step)
        self.end_step[s.finished] = w.steps[s.finished]

    def end(self) -> None:
        states = {k: np.stack(v, axis=1) for k, v in self.states.items()}  # (B, T+1, ...)
        per_step = {k: np.stack(v, axis=1) for k, v in self.per_step.items()}  # (B, T, ...)
        # Who touched anything, derived once from who touched whom.
        per_step["robot_contact"] = per_step["robot_hits"].any(axis=3)
        per_step["obstacle_contact"] = per_step["obstacle_hits"].any(axis=3) | per_step["wall_hits"].any(axis=3)
        for b, seed in enumerate(self.seeds):
            t_end = int(self.end_step[b])
            self.episodes.append(
                Episode(
                    seed=seed,
                    dt=self.dt,
                    radius=self.radius[b],
                    goal=self.goal[b],
                    obs_radius=self.obs_radius[b],
                    segments=self.segments[b],
                    **{k: np.ascontiguousarray(v[b, : t_end + 1]) for k, v in states.items()},
                    **{k: np.ascontiguousarray(v[b, :t_end]) for k, v in per_step.items()},
                    reached_step=self.reached_step[b],
                    straight_time=self.straight[b],
                    compute_time=float(self.compute[b]),
                    decisions=int(self.decisions[b]),
                )
            )


class Frames(Sequence):
    """The rendered frames of one episode ``(H, W, 3)`` uint8, drawn from its state snapshots when read (frame ``k``
    with the trails of the states before it), never all held at once: ``rollout --gif`` of 10 episodes held
    about 1 GB of frames. Slices are frames too (``ep.frames[::3]``)."""

    def __init__(self, snapshots: list, extent: float, size: int, picks: range | None = None) -> None:
        self.snapshots, self.extent, self.size = snapshots, extent, size
        self.picks = range(len(snapshots)) if picks is None else picks

    def __len__(self) -> int:
        return len(self.picks)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return Frames(self.snapshots, self.extent, self.size, self.picks[i])
        return self._draw(self._renderer(), self.picks[i])

    def __iter__(self):
        r = self._renderer()
        return (self._draw(r, k) for k in self.picks)

    def _renderer(self):
        from .render import Renderer

        return Renderer(self.extent, size=self.size)

    def _draw(self, r, k: int) -> np.ndarray:
        r.trails = [w.pos[0] for w in self.snapshots[:k]]  # the trail of the states before (draw adds its own)
        return r.draw(self.snapshots[k])


class FrameRecorder(Hook):
    """Renders chosen worlds into ``frames[index]`` (index into the whole seed list, :class:`Frames`): the initial
    state and the state after every step of the episode. During the run it only keeps state snapshots; they are
    drawn when the frames are read, after the run, outside the timed controller calls."""

    def __init__(self, extent: float, worlds: Iterable[int], size: int = 400) -> None:
        from .render import Renderer

        Renderer(extent, size=size)._pygame()  # a missing render extra fails here, before the run
        self.extent, self.size = extent, size
        self.frames: dict[int, Frames | list] = {int(i): [] for i in worlds}

    def begin(self, engine: NavEngine, seeds: Sequence[int], first: int) -> None:
        self.w = engine.world
        self.local = {i - first: i for i in self.frames if first <= i < first + len(seeds)}
        self.snapshots: dict[int, list[WorldState]] = {b: [self.w.world(b)] for b in self.local}

    def step(self, s: Step) -> None:
        for b, snaps in self.snapshots.items():
            if s.running[b]:
                snaps.append(self.w.world(b))

    def end(self) -> None:
        for b, snaps in self.snapshots.items():
            self.frames[self.local[b]] = Frames(snaps, self.extent, self.size)


def run_episodes(
    scenario: Scenario,
    controller: Controller,
    seeds: Sequence[int],
    action_mode: str = "delta",
    max_steps: int | None = None,
    render_worlds: Sequence[int] = (),
    render_size: int = 400,
    batch_size: int | None = None,
    progress: Callable[[int], None] | None = None,
    hooks: Iterable[Hook] = (),
) -> list[Episode]:
    """Run one episode per seed and record them.

    Args:
        scenario: the episode family.
        controller: maps (world, observations) of all worlds to actions.
        seeds: one seed per episode.
        action_mode: action units the controller returns.
        max_steps: overrides ``scenario.max_steps``.
        render_worlds: indices (into ``seeds``) of the episodes to render into ``Episode.frames``.
        render_size: frame side [px].
        batch_size: worlds stepped together (default: all seeds at once).
        progress: called with the number of finished episodes after each batch.
        hooks: more :class:`Hook` objects called at every step.

    Returns:
        Episodes, in the order of ``seeds``.
    """
    if isinstance(seeds, (str, bytes)) or not isinstance(seeds, Iterable):
        raise ValueError(f"seeds must be a sequence of integers, one per episode, got {seeds!r}")
    seeds = list(seeds)
    if not seeds:
        raise ValueError("seeds must not be empty")
    for s in seeds:
        check_int("each seed", s, 0, 2**63 - 1)
    seeds = [int(s) for s in seeds]
    if batch_size is not None:
        check_int("batch_size", batch_size, 1, 2**31)
    bs = len(seeds) if batch_size is None else min(int(batch_size), len(seeds))
    for i in render_worlds:
        check_int("each of render_worlds (an index into seeds)", i, 0, len(seeds) - 1)
    if len(render_worlds):
        check_int("render_size [px]", render_size, 1, 16384)
    recorder = EpisodeRecorder()
    frames = FrameRecorder(scenario.view_extent, render_worlds, render_size) if len(render_worlds) else None
    all_hooks = [recorder, *([frames] if frames else []), *hooks]
    for start in range(0, len(seeds), bs):
        play(scenario, controller, seeds[start : start + bs], all_hooks, action_mode, max_steps, first=start)
        if progress is not None:
            progress(len(recorder.episodes))
    if frames is not None:
        for i, f in frames.frames.items():
            recorder.episodes[i].frames = f
    return recorder.episodes


def planner_controller(planner, action_mode: str = "delta") -> Controller:
    """A controller from a :class:`~vcs_env.planning.Planner` (privileged state), or a planner's name
    (:func:`vcs_env.planning.make_planner`)."""
    if isinstance(planner, str):
        planner = make_planner(planner)
    elif not callable(getattr(planner, "act", None)):
        raise TypeError(f"planner must be a Planner or a planner's name, got {type(planner).__name__}")

    def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
        return planner.act(world, action_mode)

    return control
