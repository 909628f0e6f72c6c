"""The VCS point search finds the cheapest admissible point that is clear along the way.

The kernel's search (:func:`baselines.vcs.kernel.search.search_point`) prunes: grid rows whose lower
bound cannot beat the best extra point are never costed, the grid is swept in bands of its
neighbour-free lower bound, and the check along the way is made for the winner only (again for the
next if it fails). The oracle here costs every candidate of the same window (grid and extra points)
with the stage functions one by one, no pruning: the search's point must be admissible, clear along
the way, and within rounding as cheap as the oracle's least, on states of rollouts that cover
robots, crowds, walls and holonomic robots, with and without the check along the way (the circle
of 16 holds states whose cheapest admissible point is not clear along the way).
"""

import math

import numpy as np
import pytest
from numba import njit

from baselines.vcs import VCSPlanner
from baselines.vcs.kernel.cost import admissible, cost, ramp_clear, relevant, wall_ramp_clear
from baselines.vcs.kernel.neighbours import work
from baselines.vcs.kernel.records import INF
from baselines.vcs.kernel.scalar import reach_steps
from baselines.vcs.kernel.search import grid_work, prepare_robot, search_point
from baselines.vcs.kernel.window import candidate, goal_step, threats, window
from vcs_env.engine import NavEngine
from vcs_env.scenario import make_scenario

SCENARIOS = {
    "circle-16": ("circle", {"n_robots": 16, "jitter": 0.1, "on_collision": "continue"}),
    "random-dense": ("random", {"n_robots": 10, "arena_half_size": 3.5, "on_collision": "continue"}),
    "crowd": ("crowd", {"n_obstacles": 10, "on_collision": "continue"}),
    "doorway": ("doorway", {"on_collision": "continue"}),
    "holonomic": ("random", {"n_robots": 8, "arena_half_size": 3.0, "robot": {"holonomic": True}}),
}
TOL = 1e-9
"""Rounding between the search's separable costs and :func:`~baselines.vcs.kernel.cost.cost`."""


@njit
def compare(world, inputs, st, out):
    """For every active robot of world 0: the search's (dv, dth, J) and the oracle's least J, the
    search point's admissibility and clearance along the way and its J by the oracle's formula,
    into ``out`` rows; returns the number of rows."""
    p = st.prm[0]
    n = world.pos.shape[1]
    g = grid_work(p)
    wk = work(n, world.obs_pos.shape[1], world.seg_present.shape[1], p)
    rows = 0
    for i in range(n):
        if not world.active[0, i]:
            continue
        count = prepare_robot(0, i, world, inputs, st, p, wk)
        r = wk.robot[0]
        nbs = wk.nbs
        found, fdv, fdth = search_point(nbs, count, r, p, wk, g)[:3]
        # the oracle: every candidate of the same window, costed one by one
        tstar = threats(nbs, count)[0]
        win = window(r, p, tstar)
        g1v, g1th = goal_step(r)
        na, nj = relevant(nbs, wk.order, count, r.tau_s, wk.adm, wk.js)
        least = INF
        ngrid = win.nv * win.nth
        for c in range(ngrid + 3):
            dv, dth = candidate(c, win, r, g1v, g1th)
            steps = reach_steps(dv, dth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r)
            if c < ngrid and r.holo and steps > win.k:
                continue  # outside the holonomic window's disc
            s = r.v_r + dv
            vx, vy = s * math.cos(r.th + dth), s * math.sin(r.th + dth)
            if admissible(nbs, wk.adm, na, vx, vy) and ramp_clear(nbs, count, r, dv, dth):
                least = min(least, cost(nbs, wk.js, nj, r, dv, dth, vx, vy, steps))
        s = r.v_r + fdv
        vx, vy = s * math.cos(r.th + fdth), s * math.sin(r.th + fdth)
        steps = reach_steps(fdv, fdth, r.dv1, r.dth1, r.holo, r.vrx, r.vry, r.th, r.v_r)
        out[rows, 0] = found
        out[rows, 1] = least
        out[rows, 2] = admissible(nbs, wk.adm, na, vx, vy) and ramp_clear(nbs, count, r, fdv, fdth)
        out[rows, 3] = cost(nbs, wk.js, nj, r, fdv, fdth, vx, vy, steps)
        rows += 1
    return rows


def _states(kind: str, overrides: dict, planner: VCSPlanner, steps: int, every: int, seed: int):
    """Every ``every`` steps of a VCS rollout (one world, reset with ``seed``): the world and the
    kernels' inputs of its state, with the planner's memory of that state."""
    eng = NavEngine(make_scenario(kind, **overrides), 1)
    eng.reset([seed])
    for step in range(steps):
        world = eng.world
        if step % every == 0:
            planner.plan(world)  # the memory of this state
            kworld = planner._kernel_world(world)
            own, comm, detour = planner._inputs(world, kworld)
            planned = np.ones((1, world.n_robots), dtype=bool)
            yield world, planner._kernel_inputs(world, kworld, own, comm, detour, planned)
        eng.step(planner.act(world))


def _rows(kind: str, overrides: dict, planner: VCSPlanner, steps: int = 80, every: int = 4) -> np.ndarray:
    """Rows of :func:`compare` over states of a VCS rollout (one world)."""
    rows = []
    for world, args in _states(kind, overrides, planner, steps, every, seed=3):
        out = np.zeros((world.n_robots, 4))
        rows.append(out[: compare(*args, out)])
    return np.concatenate(rows)


@pytest.mark.parametrize("ramp_check", [True, False])
@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_search_finds_the_cheapest_admissible_point(name, ramp_check):
    kind, overrides = SCENARIOS[name]
    rows = _rows(kind, overrides, VCSPlanner(ramp_check=ramp_check))
    found, least, ok, again = rows.T
    assert len(rows) >= 10
    none = np.isinf(least)
    assert np.array_equal(np.isinf(found), none), "the search and the oracle disagree on whether a point is admissible"
    assert ok[~none].all(), "the search returned a point that is not admissible or not clear along the way"
    gap = found[~none] - least[~none]
    assert np.all(np.abs(gap) <= TOL * (1.0 + least[~none])), f"search above the least cost by up to {gap.max():.3g}"
    assert np.allclose(again[~none], found[~none], rtol=TOL, atol=TOL)
    assert (~none).sum() > 0.5 * len(rows)


@njit
def ramp_answers(world, inputs, st, rng_keys, out):
    """For every active robot of world 0 and every candidate of its window (visited in the order of
    ``rng_keys``): the test along the way and the fallback's wall test asked with no hint
    (``ramp_hint`` -1), and whether the answers with the hint earlier refusals left, and with each
    record as the hint, all equal those: rows ``(fresh, same, wall fresh, wall same, refused by one
    record alone)`` (the last: the candidate's ramp is refused, and some record is the only one that
    breaks it); returns the number of rows."""
    p = st.prm[0]
    n = world.pos.shape[1]
    wk = work(n, world.obs_pos.shape[1], world.seg_present.shape[1], p)
    rows = 0
    for i in range(n):
        if not world.active[0, i]:
            continue
        count = prepare_robot(0, i, world, inputs, st, p, wk)
        r = wk.robot[0]
        nbs = wk.nbs
        win = window(r, p, threats(nbs, count)[0])
        g1v, g1th = goal_step(r)
        total = win.nv * win.nth + 3
        carried = -1
        for c in np.argsort(rng_keys[:total]):
            dv, dth = candidate(c, win, r, g1v, g1th)
            r.ramp_hint = -1
            fresh = ramp_clear(nbs, count, r, dv, dth)
            r.ramp_hint = -1
            wall = wall_ramp_clear(nbs, count, r, dv, dth)
            r.ramp_hint = carried
            same = ramp_clear(nbs, count, r, dv, dth) == fresh
            carried = r.ramp_hint
            r.ramp_hint = carried
            wall_same = wall_ramp_clear(nbs, count, r, dv, dth) == wall
            alone = False
            for q in range(count):
                r.ramp_hint = q
                same = same and ramp_clear(nbs, count, r, dv, dth) == fresh
                r.ramp_hint = q
                wall_same = wall_same and wall_ramp_clear(nbs, count, r, dv, dth) == wall
                if not fresh:  # is q the only record that breaks this ramp? (walk it without q)
                    other = nbs[q].overlap
                    nbs[q].overlap = True  # ramp_breaks skips an overlap record
                    r.ramp_hint = -1
                    alone = alone or ramp_clear(nbs, count, r, dv, dth)
                    nbs[q].overlap = other
            out[rows, 0], out[rows, 1], out[rows, 2], out[rows, 3], out[rows, 4] = fresh, same, wall, wall_same, alone
            rows += 1
    return rows


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_the_ramp_hint_never_changes_an_answer(name):
    """The ramp test walks the record that broke the robot's last refused ramp first (a speed-up):
    for the test along the way and the fallback's wall test, the answers with the hint left by
    earlier refusals (candidates in random order) and with every record as the hint equal those
    with none, on rollout states of each scenario, among them ramps that one record alone refuses."""
    kind, overrides = SCENARIOS[name]
    rng = np.random.default_rng(0)
    rows = []
    for world, args in _states(kind, overrides, VCSPlanner(), steps=60, every=6, seed=5):
        out = np.zeros((world.n_robots * 2000, 5), dtype=np.bool_)
        rows.append(out[: ramp_answers(*args, rng.random(2000), out)])
    fresh, same, wall, wall_same, alone = np.concatenate(rows).T
    assert same.all() and wall_same.all(), "a hint changed the answer of the ramp test"
    assert alone.sum() > 10, "too few ramps refused by one record alone to test the hint"
    if name == "doorway":
        assert (~wall).sum() > 10, "too few wall refusals to test the hint"


def test_the_search_counts_in_periods_of_at_most_plan_steps_to_cross_the_velocity_space():
    """A world step far finer than a robot's limits (``a_max dt`` of 1e-4 m/s here, 1e-6 at the allowed least) made
    the search walk its window, reach steps and ramps one world step at a time: seconds to minutes per decision. Such a
    robot's search counts in periods of several world steps (``planning_period``), set by its own limits alone (a
    sluggish robot in one world does not change another world's plans); every suite's robots plan in its own step.
    The sluggish robots still pass each other untouched, commanded every world step."""
    from baselines.vcs.kernel import PLAN_STEPS
    from baselines.vcs.planner import CoarseStepWarning, planning_period
    from vcs_env import RobotSpec, Simulator

    for name in ("circle-16-v0", "crowdnav-circle-v0", "random-dense-holonomic-v0", "corridor-narrow-v0"):
        engine = NavEngine(make_scenario(name), 1)
        engine.reset([0])
        assert (planning_period(engine.world) == engine.world.dt).all()
    engine = NavEngine(make_scenario("crowd", n_robots=4), 2)
    engine.reset([0, 1])
    world = engine.world
    world.a_max[1, 3] = 0.001  # 1 / (0.001 * 0.1) = 10^4 steps to top speed: periods of 10 steps for this robot
    assert planning_period(world)[1, 3] == 1.0 and (planning_period(world)[0] == 0.1).all()
    with pytest.warns(CoarseStepWarning, match=r"plans in periods of 1 s \(dt = 0.1 s\)"):
        planned = VCSPlanner().plan(world)[0]
    np.testing.assert_array_equal(planned, VCSPlanner().plan(world.world(0))[0])

    scenario = make_scenario("circle", n_robots=8, robot=RobotSpec(a_max=0.01), dt=0.005, initial_speed=0.5)
    sim = Simulator(scenario)
    sim.reset([0])
    assert (planning_period(sim.world) == 0.1).all()  # 1 / (0.01 * 0.005) = 20000 steps: periods of 20 steps
    planner = VCSPlanner()
    for _ in range(int(40.0 / scenario.dt)):
        sim.step(planner.act(sim.world))
        assert planner.last["k"].max() <= PLAN_STEPS
        if not sim.world.active.any():
            break
    assert sim.world.reached.all() and not sim.world.collided.any()
