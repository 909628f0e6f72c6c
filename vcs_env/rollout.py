"""Run whole episodes, many worlds at once, and record them.

:func:`run_episodes` steps one batched :class:`~vcs_env.engine.NavEngine` with one world per
seed; a controller maps the state (and observations) of all worlds to actions in one call.
Finished worlds idle until the slowest one ends. Each episode comes back as an
:class:`Episode` of plain arrays, from which :mod:`vcs_env.metrics` computes the metrics.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .engine import NavEngine
from .scenario import Scenario
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
    actions: np.ndarray  # (T, n, 2), as applied (zeros for robots that were not active)
    acted: np.ndarray  # (T, n) bool
    collided: np.ndarray  # (T, n) bool, robot touched something in that step
    robot_contact: np.ndarray  # (T, n) bool, ... a robot
    obstacle_contact: np.ndarray  # (T, n) bool, ... an obstacle
    min_separation: np.ndarray  # (T, n) smallest swept gap in that step [m] (inf if not acting)
    reached_step: np.ndarray  # (n,) int, step count at arrival (-1: never)
    straight_time: np.ndarray  # (n,) time a robot at v_max would need for the straight line [s]
    compute_time: float = 0.0  # controller wall time for this episode's share [s]
    decisions: int = 0  # robot decisions made (active robot-steps)
    frames: list = field(default_factory=list)  # rendered frames, if requested

    @property
    def steps(self) -> int:
        return len(self.actions)

    @property
    def n_robots(self) -> int:
        return self.pos.shape[1]


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
) -> list[Episode]:
    """Run one episode per seed and record them.

    Args:
        scenario: the episode family.
        controller: maps (world, observations) of all worlds to actions.
        seeds: one seed per episode.
        action_mode: action units the controller returns.
        max_steps: overrides ``scenario.max_steps``.
        render_worlds: indices (into ``seeds``) of the episodes to render into ``frames``.
        render_size: frame side [px].
        batch_size: worlds stepped together (default: all seeds at once).
        progress: called with the number of finished episodes after each batch.

    Returns:
        Episodes, in the order of ``seeds``.
    """
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds must not be empty")
    bs = len(seeds) if batch_size is None else max(1, min(int(batch_size), len(seeds)))
    out: list[Episode] = []
    for start in range(0, len(seeds), bs):
        chunk = seeds[start : start + bs]
        rend = [i - start for i in render_worlds if start <= i < start + len(chunk)]
        out.extend(_run_batch(scenario, controller, chunk, action_mode, max_steps, rend, render_size))
        if progress is not None:
            progress(len(out))
    return out


def _run_batch(scenario, controller, seeds, action_mode, max_steps, render_worlds, render_size) -> list[Episode]:
    engine = NavEngine(scenario, len(seeds), action_mode, max_steps=max_steps)
    obs = engine.reset(seeds)
    w = engine.world
    B, n = w.batch_size, w.n_robots
    renderers = {}
    if render_worlds:
        from .render import Renderer

        renderers = {b: Renderer(scenario.view_extent, size=render_size) for b in render_worlds}
    frames = {b: [] for b in render_worlds}
    radius, goal, obs_radius = w.radius.copy(), w.goal.copy(), w.obs_radius.copy()
    start_pos = w.pos.copy()
    rec = {k: [getattr(w, k).copy()] for k in ("pos", "heading", "speed", "obs_pos")}
    steps: dict[str, list[np.ndarray]] = {
        k: [] for k in ("actions", "acted", "collided", "robot_contact", "obstacle_contact", "min_separation")
    }
    reached_step = np.full((B, n), -1, dtype=np.int64)
    end_step = np.zeros(B, dtype=np.int64)
    compute = np.zeros(B)
    decisions = np.zeros(B, dtype=np.int64)
    running = np.ones(B, dtype=bool)

    def render():
        for b, r in renderers.items():
            if running[b] or not frames[b]:
                frames[b].append(r.draw(w.world(b)))

    render()
    while running.any():
        active = w.active.copy()
        t0 = time.perf_counter()
        actions = np.asarray(controller(w, obs), dtype=np.float64)
        dt_wall = time.perf_counter() - t0
        n_active = active.sum(axis=1)
        # Share the batched controller time among worlds by their active robots.
        compute += dt_wall * n_active / max(1, n_active.sum())
        decisions += n_active
        res = engine.step(actions)
        obs = res.obs
        ev = res.events
        steps["actions"].append(np.where(active[..., None], np.clip(actions, -1, 1), 0.0))
        steps["acted"].append(ev.acted)
        steps["collided"].append(ev.collided)
        steps["robot_contact"].append(ev.robot_hits.any(axis=2))
        steps["obstacle_contact"].append(ev.obstacle_hits.any(axis=2))
        steps["min_separation"].append(ev.min_separation)
        for k in rec:
            rec[k].append(getattr(w, k).copy())
        reached_step = np.where(ev.reached & (reached_step < 0), w.steps[:, None], reached_step)
        finished = running & (~w.active.any(axis=1) | (w.steps >= engine.max_steps))
        end_step[finished] = w.steps[finished]
        render()
        running &= ~finished
    arrays = {k: np.stack(v, axis=1) for k, v in rec.items()}  # (B, T+1, ...)
    step_arrays = {k: np.stack(v, axis=1) for k, v in steps.items()}  # (B, T, ...)
    straight = np.linalg.norm(goal - start_pos, axis=-1) / w.v_max
    episodes = []
    for b, seed in enumerate(seeds):
        t_end = int(end_step[b])
        episodes.append(
            Episode(
                seed=seed,
                dt=scenario.dt,
                radius=radius[b],
                goal=goal[b],
                obs_radius=obs_radius[b],
                **{k: np.ascontiguousarray(v[b, : t_end + 1]) for k, v in arrays.items()},
                **{k: np.ascontiguousarray(v[b, :t_end]) for k, v in step_arrays.items()},
                reached_step=reached_step[b],
                straight_time=straight[b],
                compute_time=float(compute[b]),
                decisions=int(decisions[b]),
                frames=frames.get(b, []),
            )
        )
    return episodes


def planner_controller(planner, action_mode: str = "delta") -> Controller:
    """A controller from a :class:`~vcs_env.planning.Planner` (privileged state)."""

    def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
        return planner.act(world, action_mode)

    return control
