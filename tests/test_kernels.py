"""The compiled step kernels (vcs_env.kernels) against the readable numpy geometry they replace.

Each kernel is checked on random inputs against its numpy oracle: dynamics.integrate,
geometry.closest_approach / point_segment_distance, observations.reference_observe. Both compute
the same float operations in the same order, so results are compared exactly; the one exception
is atan2 (holonomic heading), where numpy's vectorized arctan2 and the C library differ by at
most an ulp, bounded below.
"""

import dataclasses

import numpy as np
import pytest

import vcs_env
from vcs_env import kernels
from vcs_env.dynamics import integrate, stop_at_goal
from vcs_env.geometry import closest_approach, point_segment_distance, unit
from vcs_env.observations import observation_layout, observe, reference_observe
from vcs_env.obstacles import Arbitrary
from vcs_env.sim import Simulator, StepEvents
from vcs_env.state import WorldState


def random_world(rng, B=3, n=6, m=5, holonomic=False, spread=4.0):
    """A world state with random robots and obstacles, some robots finished or gone."""
    active = rng.random((B, n)) < 0.8
    present = active | (rng.random((B, n)) < 0.5)
    return WorldState(
        time=rng.uniform(0, 10, B),
        steps=rng.integers(0, 100, B),
        key=rng.integers(0, 2**63, B).astype(np.uint64),
        pos=rng.uniform(-spread, spread, (B, n, 2)),
        heading=rng.uniform(-np.pi, np.pi, (B, n)),
        speed=rng.uniform(0, 1.5, (B, n)) * (rng.random((B, n)) < 0.9),
        radius=rng.uniform(0.1, 0.5, (B, n)),
        goal=rng.uniform(-spread, spread, (B, n, 2)),
        v_max=rng.uniform(0.5, 2.0, (B, n)),
        a_max=rng.uniform(0.5, 4.0, (B, n)),
        omega_max=rng.uniform(0.5, 4.0, (B, n)),
        active=active,
        present=present,
        reached=np.zeros((B, n), dtype=bool),
        collided=np.zeros((B, n), dtype=bool),
        obs_pos=rng.uniform(-spread, spread, (B, m, 2)),
        obs_vel=rng.uniform(-1, 1, (B, m, 2)),
        obs_radius=rng.uniform(0.1, 0.6, (B, m)),
        dt=0.1,
        r_goal=0.3,
        r_ca=3.0,
        holonomic=holonomic,
    )


def reference_integrate(w, actions, mode):
    """The simulator's numpy phase 1: dynamics.integrate, then robots that did not act stay put."""
    speed, heading, pos = integrate(w, actions, mode)
    acted = w.active
    return (
        np.where(acted, speed, 0.0),
        np.where(acted, heading, w.heading),
        np.where(acted[..., None], pos, w.pos),
    )


def run_integrate(w, actions, mode):
    return kernels.integrate(
        w.pos, w.heading, w.speed, w.v_max, w.a_max, w.omega_max, w.active, actions, w.dt, w.holonomic,
        mode == "absolute",
    )  # fmt: skip


@pytest.mark.parametrize("mode", ["delta", "absolute"])
def test_integrate_unicycle_equals_numpy_bit_for_bit(mode):
    rng = np.random.default_rng(1)
    for _ in range(20):
        w = random_world(rng)
        actions = rng.uniform(-1.5, 1.5, (*w.speed.shape, 2))  # some beyond the clip
        for got, want in zip(run_integrate(w, actions, mode), reference_integrate(w, actions, mode)):
            np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("mode", ["delta", "absolute"])
def test_integrate_holonomic_equals_numpy_up_to_atan2_rounding(mode):
    rng = np.random.default_rng(2)
    for _ in range(20):
        w = random_world(rng, holonomic=True)
        actions = rng.uniform(-1.5, 1.5, (*w.speed.shape, 2))
        (speed, heading, pos), (r_speed, r_heading, r_pos) = (
            run_integrate(w, actions, mode),
            reference_integrate(w, actions, mode),
        )
        np.testing.assert_array_equal(speed, r_speed)
        np.testing.assert_array_max_ulp(heading, r_heading, maxulp=2)  # atan2: C library vs numpy
        np.testing.assert_allclose(pos, r_pos, rtol=0, atol=1e-14)


def reference_events(w, new_pos, new_obs):
    """The simulator's numpy phase 2 (swept checks), as it was before the kernels."""
    n = w.n_robots
    acted, present, old_pos = w.active, w.present, w.pos
    rr_gap = closest_approach(
        old_pos[:, None, :, :] - old_pos[:, :, None, :], new_pos[:, None, :, :] - new_pos[:, :, None, :]
    ) - (w.radius[:, :, None] + w.radius[:, None, :])
    pair_ok = present[:, :, None] & present[:, None, :] & ~np.eye(n, dtype=bool)
    rr_gap = np.where(pair_ok, rr_gap, np.inf)
    ro_gap = closest_approach(
        w.obs_pos[:, None, :, :] - old_pos[:, :, None, :], new_obs[:, None, :, :] - new_pos[:, :, None, :]
    ) - (w.radius[:, :, None] + w.obs_radius[:, None, :])
    ro_gap = np.where(present[:, :, None], ro_gap, np.inf)
    robot_hits = (rr_gap < 0.0) & acted[:, :, None]
    obstacle_hits = (ro_gap < 0.0) & acted[:, :, None]
    min_sep = np.minimum(rr_gap.min(axis=2, initial=np.inf), ro_gap.min(axis=2, initial=np.inf))
    return (
        robot_hits,
        obstacle_hits,
        robot_hits.any(axis=2) | obstacle_hits.any(axis=2),
        acted & (point_segment_distance(w.goal, old_pos, new_pos) <= w.r_goal),
        np.where(acted, min_sep, np.inf),
        np.linalg.norm(w.goal - old_pos, axis=-1),
        np.linalg.norm(w.goal - new_pos, axis=-1),
    )


def test_swept_events_equal_numpy_bit_for_bit():
    rng = np.random.default_rng(3)
    hits = 0
    for _ in range(30):
        w = random_world(rng, spread=2.0)
        # Long random motions (some robots stand still) so that many segments cross.
        new_pos = w.pos + rng.uniform(-1.5, 1.5, w.pos.shape) * (rng.random((*w.speed.shape, 1)) < 0.8)
        new_obs = w.obs_pos + rng.uniform(-1.0, 1.0, w.obs_pos.shape)
        w.goal[:, 0] = (w.pos[:, 0] + new_pos[:, 0]) / 2  # a goal on the path: reached
        got = kernels.swept_events(
            w.pos, new_pos, w.radius, w.present, w.active, w.goal, w.obs_pos, new_obs, w.obs_radius, w.r_goal
        )
        want = reference_events(w, new_pos, new_obs)
        for g, r in zip(got, want):
            assert g.dtype == r.dtype
            np.testing.assert_array_equal(g, r)
        hits += int(got[0].sum() + got[1].sum())
    assert hits > 50  # the inputs exercised the collision branches


def test_stop_at_goal_equals_numpy_bit_for_bit():
    rng = np.random.default_rng(11)
    stops = 0
    for _ in range(30):
        w = random_world(rng, spread=2.0)
        new_pos = w.pos + rng.uniform(-1.5, 1.5, w.pos.shape) * (rng.random((*w.speed.shape, 1)) < 0.9)
        # Goals near the path, some passed through and left, some ending inside the disc.
        w.goal[:] = w.pos + rng.uniform(0.0, 1.3, w.speed.shape)[..., None] * (new_pos - w.pos)
        w.goal += rng.uniform(-w.r_goal, w.r_goal, w.goal.shape)
        want_pos, want = stop_at_goal(w.pos, new_pos, w.goal, w.active, w.r_goal)
        got_pos = new_pos.copy()
        got = kernels.stop_at_goal(w.pos, got_pos, w.goal, w.active, w.r_goal)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(got_pos, want_pos)
        assert not (got & ~w.active).any()
        np.testing.assert_array_equal(got_pos[~got], new_pos[~got])  # the others end where they would
        assert (np.linalg.norm(got_pos[got] - w.goal[got], axis=-1) <= w.r_goal + 1e-12).all()
        stops += int(got.sum())
    assert stops > 50  # the inputs exercised the cut


@pytest.mark.parametrize("k", [1, 3, 6, 20])
def test_observe_equals_numpy_bit_for_bit(k):
    rng = np.random.default_rng(4 + k)
    scenario = vcs_env.make_scenario("dynamic", n_neighbors=k)
    for trial in range(20):
        w = random_world(rng, n=7, m=6 if trial % 4 else 0, spread=3.0)
        if trial % 5 == 0:
            w.goal[:, 0] = w.pos[:, 0]  # at the goal: bearing (1, 0)
        got, want = observe(w, scenario), reference_observe(w, scenario)
        assert got.dtype == want.dtype == np.float32 and got.shape == want.shape
        np.testing.assert_array_equal(got, want)


def test_observe_breaks_gap_ties_by_index_robots_first():
    """Two objects at the same gap: the lower index (robots before obstacles) comes first."""
    scenario = vcs_env.make_scenario("dynamic", n_neighbors=2)
    w = random_world(np.random.default_rng(5), B=1, n=2, m=2)
    w.present[:] = True
    w.heading[:] = 0.0
    w.pos[0] = [[0.0, 0.0], [0.0, 1.0]]
    w.radius[0] = 0.25
    w.obs_pos[0] = [[0.0, -1.0], [1.0, 0.0]]  # same distance and radius as robot_1
    w.obs_radius[0] = 0.25
    first, second = observation_layout(scenario).read(observe(w, scenario), "neighbors")[0, 0]
    assert first[7] == 1.0 and first[2] > 0  # robot_1 (left), first
    assert second[7] == 0.0 and second[2] < 0  # obstacle_0 (right) before obstacle_1 (ahead)


def reference_obstacle_velocity(sim):
    """Simulator._obstacle_velocity as it was in numpy, with Arbitrary.velocity's numpy formula."""
    s, w, params = sim.scenario, sim.world, sim.motion_params
    if s.n_obstacles == 0:
        return np.zeros_like(w.obs_pos)
    if isinstance(sim.motion, Arbitrary):
        rates = params["rates"]
        k = np.floor(w.time[:, None] / params["period"] + 1e-9).astype(np.int64)
        k = np.clip(k, 0, rates.shape[-1] - 1)
        rate = np.take_along_axis(rates, k[..., None], axis=-1)[..., 0]
        params["heading"] = params["heading"] + rate * s.dt
        vel = unit(params["heading"]) * params["speed"][..., None]
    else:
        vel = sim.motion.velocity(params, w.time, w.obs_pos, s.dt)
    if s.bounce:
        half = s.arena_half_size
        nxt = w.obs_pos + vel * s.dt
        r = w.obs_radius[..., None]
        flip = ((nxt + r > half) & (vel > 0)) | ((nxt - r < -half) & (vel < 0))
        if np.any(flip):
            vel = np.where(flip, -vel, vel)
            sim.motion.reflect(params, flip)
    return vel


def reference_step(sim, actions):
    """Simulator.step as it was in numpy, on a copy of ``sim`` (oracle of the kernel path)."""
    s, w = sim.scenario, sim.world
    acted = w.active.copy()
    speed, heading, new_pos = reference_integrate(w, actions, sim.action_mode)
    new_pos, at_goal = stop_at_goal(w.pos, new_pos, w.goal, acted, w.r_goal)
    obs_vel = reference_obstacle_velocity(sim)
    new_obs = w.obs_pos + obs_vel * s.dt
    robot_hits, obstacle_hits, collided, reached, min_sep, before, after = reference_events(w, new_pos, new_obs)
    reached |= at_goal
    if s.on_collision == "terminate" and collided.any():  # crashed robots stop where they touched (test_stop.py)
        redo = collided.any(axis=1)
        stop, hits, crashed, sep = kernels.stop_at_contact(
            w.pos, new_pos, w.radius, w.present, acted, w.obs_pos, new_obs, w.obs_radius, w.seg_a, w.seg_b,
            w.seg_present, redo,
        )  # fmt: skip
        n = s.n_robots
        robot_hits[redo], obstacle_hits[redo] = hits[redo, :, :n], hits[redo, :, n:]
        collided[redo], min_sep[redo] = crashed[redo], sep[redo]
        short = stop < 1.0
        new_pos = np.where(short[..., None], w.pos + stop[..., None] * (new_pos - w.pos), new_pos)
        reached = np.where(short, point_segment_distance(w.goal, w.pos, new_pos) <= w.r_goal, reached)
        after = np.linalg.norm(w.goal - new_pos, axis=-1)
    w.pos, w.speed, w.heading, w.obs_pos, w.obs_vel = new_pos, speed, heading, new_obs, obs_vel
    w.reached |= reached
    w.collided |= collided
    stopped = reached | (collided if s.on_collision == "terminate" else np.zeros_like(collided))
    w.active &= ~stopped
    w.speed = np.where(w.active, w.speed, 0.0)
    if not s.park_finished:
        w.present &= ~stopped
    w.steps = w.steps + 1
    w.time = w.steps * s.dt
    return StepEvents(acted, reached, collided, robot_hits, obstacle_hits, min_sep, before, after)


@pytest.mark.parametrize(
    "scenario, overrides",
    [
        ("dynamic", {"on_collision": "continue"}),
        ("crowd", {}),
        ("circle", {"park_finished": False}),
        ("random", {"obstacle_motion": "patrol"}),
        ("random", {"obstacle_motion": "constant", "n_obstacles": 6}),
        ("dynamic", {"on_collision": "continue", "arena_half_size": 3.0, "n_obstacles": 8}),  # many bounces
    ],
)
@pytest.mark.parametrize("mode", ["delta", "absolute"])
def test_simulator_rollout_equals_numpy_path(scenario, overrides, mode):
    """Whole rollouts, observations included: the kernel path equals the old numpy path exactly."""
    s = vcs_env.make_scenario(scenario, **overrides)
    fast, slow = Simulator(s, 2, mode), Simulator(s, 2, mode)
    fast.reset([5, 6])
    slow.reset([5, 6])
    rng = np.random.default_rng(7)
    for _ in range(80):
        actions = rng.uniform(-1.2, 1.2, (2, s.n_robots, 2))
        ev_fast, ev_slow = fast.step(actions), reference_step(slow, actions)
        for f in dataclasses.fields(StepEvents):
            np.testing.assert_array_equal(getattr(ev_fast, f.name), getattr(ev_slow, f.name), err_msg=f.name)
        for f in dataclasses.fields(WorldState):
            np.testing.assert_array_equal(getattr(fast.world, f.name), getattr(slow.world, f.name), err_msg=f.name)
        np.testing.assert_array_equal(observe(fast.world, s), reference_observe(slow.world, s))
        if fast.done.all():
            break
