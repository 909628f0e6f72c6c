"""Pedestrians (vcs_env.pedestrians, the ``pedestrians`` obstacle motion): ORCA against the RVO2
library, the social force against a hand computation and a scalar twin, batching, determinism,
visibility and bad input."""

import dataclasses
import math

import numpy as np
import pytest

import vcs_env
from vcs_env.engine import NavEngine
from vcs_env.obstacles import Pedestrians
from vcs_env.orca_kernel import orca_velocities
from vcs_env.pedestrians import SF_OUT_OF_VIEW, SF_SIGMA, SF_V0, PedestrianSpec, social_force
from vcs_env.placement import Layout
from vcs_env.scenario import make_scenario
from vcs_env.sim import Simulator


def crowd(model="orca", sees_robots=False, goal_policy="circle", **kw):
    spec = PedestrianSpec(model=model, sees_robots=sees_robots, goal_policy=goal_policy)
    return make_scenario(
        "crowd", obstacle_motion="pedestrians", pedestrians=spec, dt=0.25, max_steps=40, arena_half_size=5.0, **kw
    )


# --------------------------------------------------------------------------- ORCA == RVO2
def test_orca_equals_rvo2_on_random_states():
    pyrvo = pytest.importorskip("pyrvo")
    rng = np.random.default_rng(0)
    tau, dt, neighbor_dist, max_neighbors = 5.0, 0.25, 10.0, 10
    worst = 0.0
    for _ in range(100):
        a = int(rng.integers(2, 9))
        pos, vel = rng.uniform(-3, 3, (a, 2)), rng.uniform(-1, 1, (a, 2))
        radius, max_speed, pref = rng.uniform(0.2, 0.4, a), rng.uniform(0.8, 1.5, a), rng.uniform(-1.2, 1.2, (a, 2))
        ours = orca_velocities(
            pos[None], vel[None], radius[None], max_speed[None], pref[None], np.ones((1, a), bool), a,
            tau, dt, neighbor_dist, max_neighbors,
        )[0]  # fmt: skip
        sim = pyrvo.RVOSimulator()
        sim.set_time_step(dt)
        for k in range(a):
            i = sim.add_agent(
                tuple(pos[k]), neighbor_dist, max_neighbors, tau, tau, float(radius[k]), float(max_speed[k]),
                tuple(vel[k]),
            )  # fmt: skip
            sim.set_agent_pref_velocity(i, tuple(pref[k]))
        sim.do_step()
        rvo2 = np.array([sim.get_agent_velocity(k).to_tuple() for k in range(a)])
        worst = max(worst, float(np.abs(ours - rvo2).max()))
    assert worst < 2e-4  # RVO2 computes in float32, we in float64


def test_orca_head_on_pair_turns_aside_symmetrically():
    pos = np.array([[[-2.0, 0.0], [2.0, 0.0]]])
    vel = np.array([[[1.0, 0.0], [-1.0, 0.0]]])
    out = orca_velocities(pos, vel, np.full((1, 2), 0.31), np.ones((1, 2)), vel, np.ones((1, 2), bool), 2, 5.0, 0.25,
                          10.0, 10)[0]  # fmt: skip
    np.testing.assert_allclose(out[0], -out[1], atol=1e-12)  # reciprocal: each takes half
    assert abs(out[0, 1]) > 0.05 and out[0, 0] < 1.0


# --------------------------------------------------------------------------- social force
def scalar_social_force(pos, vel, pref, present, n_walking):
    """One world, loops: the force on each walking agent [m/s^2] (Helbing & Molnar, module docstring)."""
    out = np.zeros((n_walking, 2))
    for a in range(n_walking):
        force = (pref[a] - vel[a]) / 0.5
        e_a = pref[a] / np.linalg.norm(pref[a]) if np.linalg.norm(pref[a]) > 0 else np.zeros(2)
        for b in range(len(pos)):
            if b == a or not present[b]:
                continue
            r = pos[a] - pos[b]
            speed = np.linalg.norm(vel[b])
            wish = pref[b] if b < n_walking else vel[b]  # b's preferred direction; a robot's, its drive
            e_b = wish / np.linalg.norm(wish) if np.linalg.norm(wish) > 0 else np.zeros(2)
            s = speed * 0.4
            r2 = r - s * e_b
            n1, n2 = np.linalg.norm(r), np.linalg.norm(r2)
            bb = 0.5 * math.sqrt(max((n1 + n2) ** 2 - s * s, 1e-16))
            f = 2.1 / 0.3 * math.exp(-bb / 0.3) * (n1 + n2) / (4 * bb) * (r / n1 + r2 / n2)
            ahead = np.dot(e_a, -f) > np.linalg.norm(f) * math.cos(math.radians(100))
            force += (1.0 if ahead else 0.5) * f
        out[a] = force
    return out


def test_social_force_by_hand():
    # a walks along +x at its preferred velocity toward b, standing 1 m ahead: no drive, and b
    # pushes a back with V0 / sigma exp(-1 m / sigma) (b = |r| for a standing b).
    pos = np.array([[[0.0, 0.0], [1.0, 0.0]]])
    vel = np.array([[[1.0, 0.0], [0.0, 0.0]]])
    f = social_force(pos, vel, vel[:, :1], np.ones((1, 2), bool), 1)[0, 0]
    push = SF_V0 / SF_SIGMA * math.exp(-1.0 / SF_SIGMA)
    np.testing.assert_allclose(f, [-push, 0.0], rtol=1e-12)
    assert push == pytest.approx(0.249717, abs=1e-6)
    # b behind a: outside the field of view, half the force.
    f = social_force(pos, -vel, -vel[:, :1], np.ones((1, 2), bool), 1)[0, 0]
    np.testing.assert_allclose(f, [-SF_OUT_OF_VIEW * push, 0.0], rtol=1e-12)


def test_social_force_equals_scalar_twin():
    rng = np.random.default_rng(1)
    B, a, w = 3, 6, 4
    pos, vel = rng.uniform(-3, 3, (B, a, 2)), rng.uniform(-1, 1, (B, a, 2))
    pref = rng.uniform(-1, 1, (B, w, 2))
    present = rng.random((B, a)) < 0.8
    batched = social_force(pos, vel, pref, present, w)
    for b in range(B):
        np.testing.assert_allclose(batched[b], scalar_social_force(pos[b], vel[b], pref[b], present[b], w), rtol=1e-10)


# --------------------------------------------------------------------------- in the engine
def rollout(scenario, seeds, steps=30, robot_action=None):
    engine = NavEngine(scenario, len(seeds))
    engine.reset(list(seeds))
    action = np.zeros((len(seeds), scenario.n_robots, 2)) if robot_action is None else robot_action
    out = [engine.world.obs_pos.copy()]
    for _ in range(steps):
        engine.step(np.broadcast_to(action, (len(seeds), scenario.n_robots, 2)))
        out.append(engine.world.obs_pos.copy())
    return np.stack(out, axis=1)  # (B, T+1, m, 2)


@pytest.mark.parametrize("model", ["orca", "social_force"])
@pytest.mark.parametrize("goal_policy", ["circle", "square", "wander"])
def test_batched_equals_one_by_one_and_seeds_decide(model, goal_policy):
    s = crowd(model, sees_robots=True, goal_policy=goal_policy)
    seeds = [3, 4, 5]
    batched = rollout(s, seeds, robot_action=np.array([1.0, 0.0]))
    for i, seed in enumerate(seeds):
        assert np.array_equal(batched[i], rollout(s, [seed], robot_action=np.array([1.0, 0.0]))[0])
    assert np.array_equal(batched, rollout(s, seeds, robot_action=np.array([1.0, 0.0])))
    assert not np.array_equal(batched[0], batched[1])
    assert np.abs(batched[:, -1] - batched[:, 0]).max() > 1.0  # they walk


@pytest.mark.parametrize("model", ["orca", "social_force"])
def test_invisible_robots_are_ignored(model):
    go, stay = np.array([1.0, 0.0]), np.array([-1.0, 0.0])  # accelerate or brake
    hidden = crowd(model, n_robots=1, n_obstacles=5)
    assert np.array_equal(rollout(hidden, [0, 1], robot_action=go), rollout(hidden, [0, 1], robot_action=stay))
    seen = crowd(model, sees_robots=True, n_robots=1, n_obstacles=5)
    assert not np.array_equal(rollout(seen, [0, 1], robot_action=go), rollout(seen, [0, 1], robot_action=stay))


def test_square_crossing_geometry():
    s = crowd(goal_policy="square", n_obstacles=5)
    engine = NavEngine(s, 1)
    engine.reset(0)
    params = engine.sim.motion_params
    start, goal = engine.world.obs_pos[0], params["goals"][0, :, 0]
    assert np.all(np.abs(start) <= 5.0) and np.all(np.abs(goal) <= 5.0)
    assert np.all(np.sign(start[:, 0]) == -np.sign(goal[:, 0]))  # from one half of the square to the other


# --------------------------------------------------------------------------- bad input
def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="pedestrians.model must be one of"):
        PedestrianSpec(model="boids")
    with pytest.raises(ValueError, match="pedestrians.v_pref"):
        PedestrianSpec(v_pref=-0.5)
    with pytest.raises(ValueError, match="pedestrians.goal_policy"):
        PedestrianSpec(goal_policy="dance")
    with pytest.raises(ValueError, match="social force pedestrians must be at most 2.308 m/s"):
        PedestrianSpec(model="social_force", v_pref=3.0)  # they would walk at 3.9 m/s
    with pytest.raises(ValueError, match="pedestrians needs obstacle_motion='pedestrians'"):
        make_scenario("crowd", pedestrians=PedestrianSpec())
    lay = Layout(
        start=np.zeros((1, 2)), goal=np.ones((1, 2)), heading=np.zeros(1), speed=np.zeros(1),
        obs_pos=np.array([[3.0, 0.1]]), obs_target=np.array([[-3.0, 0.0]]), obs_radius=np.array([0.3]),
        segments=np.array([[[3.0, -1.0], [3.0, 1.0]]]),
    )  # fmt: skip
    with pytest.raises(ValueError, match="pedestrians: obstacle 0 at \\[3.0, 0.1\\] is inside a wall"):
        Pedestrians().place(np.random.default_rng(0), crowd(), lay)


def test_a_pedestrians_object_given_to_an_env_is_its_scenario_fields():
    """A Pedestrians(spec) object is the scenario's obstacle_motion and pedestrians, checked as such: given as an
    object the env's scenario said "constant" (its square-crossing room check skipped), and pedestrians= beside it
    was refused as if the motion were "constant"."""
    spec = PedestrianSpec(goal_policy="square", v_pref=0.8)
    env = vcs_env.parallel_env(scenario="crowd", obstacle_motion=Pedestrians(spec))
    named = vcs_env.parallel_env(scenario="crowd", obstacle_motion="pedestrians", pedestrians=spec)
    assert env.scenario == named.scenario and env.scenario.pedestrians == spec
    env.reset(seed=3)
    named.reset(seed=3)
    assert np.array_equal(env.engine.world.obs_pos, named.engine.world.obs_pos)
    both = vcs_env.parallel_env(scenario="crowd", obstacle_motion=Pedestrians(spec), pedestrians=spec)
    assert both.scenario == named.scenario
    with pytest.raises(ValueError, match="pedestrians= and the Pedestrians object given as obstacle_motion differ"):
        vcs_env.parallel_env(scenario="crowd", obstacle_motion=Pedestrians(spec), pedestrians=PedestrianSpec())
    with pytest.raises(ValueError, match="found no place for them"):  # the scenario's room check, now applied
        vcs_env.parallel_env(scenario="crowd", n_obstacles=200, obstacle_motion=Pedestrians(spec))


def test_no_pedestrian_is_faster_than_any_obstacle_may_be():
    """Social force pedestrians walk up to SF_MAX_SPEED times their preferred speed: the fastest spec allowed
    stays within the obstacles' speed limit V_REF (the observation's velocity scale)."""
    from vcs_env.pedestrians import SF_MAX_SPEED, TOP_SPEED_LIMIT
    from vcs_env.scenario import V_REF

    assert TOP_SPEED_LIMIT == V_REF
    spec = PedestrianSpec(model="social_force", v_pref=V_REF / SF_MAX_SPEED)
    assert spec.top_speed <= V_REF and PedestrianSpec(v_pref=V_REF).top_speed == V_REF
    scen = make_scenario("crowd", n_obstacles=10, layout_radius=6.0, obstacle_motion="pedestrians", pedestrians=spec)
    env = vcs_env.parallel_env(scenario=scen)
    env.reset(seed=0)
    top = 0.0
    while env.agents:
        env.step({a: np.zeros(2) for a in env.agents})
        top = max(top, float(np.linalg.norm(env.engine.world.obs_vel, axis=-1).max()))
    assert spec.v_pref < top <= V_REF + 1e-9  # faster than preferred when pushed, never above the limit


# --------------------------------------------------------------------------- conformance
def test_pettingzoo_and_gymnasium_conformance_with_pedestrians():
    import pickle

    from gymnasium.utils.env_checker import check_env
    from pettingzoo.test import parallel_api_test, parallel_seed_test

    import vcs_env
    from vcs_env.gym_env import VcsNavEnv

    s = crowd(sees_robots=True, n_robots=2, n_obstacles=4)
    parallel_api_test(vcs_env.parallel_env(scenario=s, max_cycles=40), num_cycles=60)
    parallel_seed_test(lambda: vcs_env.parallel_env(scenario=s), num_cycles=30)
    check_env(VcsNavEnv(scenario=crowd(goal_policy="wander")))
    env = vcs_env.parallel_env(scenario=s)
    env.reset(seed=0)
    assert pickle.loads(pickle.dumps(env)).scenario == s


def test_preferred_velocity_equals_scalar_twin():
    from vcs_env.pedestrians import ARRIVAL_TIME, preferred_velocity

    rng = np.random.default_rng(2)
    pos, goal, v_pref = rng.uniform(-3, 3, (50, 2)), rng.uniform(-3, 3, (50, 2)), rng.uniform(0, 2, 50)
    goal[:5] = pos[:5]  # at the goal
    goal[5:10] = pos[5:10] + 0.1  # slowing down
    for i, v in enumerate(preferred_velocity(pos, goal, v_pref)):
        d = goal[i] - pos[i]
        dist = math.hypot(*d)
        speed = min(v_pref[i], dist / ARRIVAL_TIME)
        np.testing.assert_allclose(v, d / dist * speed if dist > 0 else (0.0, 0.0), rtol=1e-12, atol=1e-15)


def test_wanderers_take_new_goals_and_the_others_stay():
    for policy, moves_on in (("wander", True), ("circle", False)):
        engine = NavEngine(dataclasses.replace(crowd(goal_policy=policy), max_steps=200), 2)
        engine.reset([0, 1])
        for _ in range(200):
            engine.step(np.zeros((2, engine.scenario.n_robots, 2)))
        params = engine.sim.motion_params
        assert (params["goal_idx"] > 0).any() == moves_on, policy
        if not moves_on:  # arrived and standing at the antipode
            np.testing.assert_allclose(engine.world.obs_pos, params["goals"][:, :, 0], atol=0.05)


@pytest.mark.parametrize("kind", ["room", "intersection", "walls"])
def test_square_crossing_pedestrians_start_and_walk_to_points_clear_of_walls(kind):
    """The square placement ignored walls: on map kinds about half the resets failed (a pedestrian inside a wall)."""
    from vcs_env.walls import clearance

    s = vcs_env.make_scenario(
        kind, n_obstacles=4, obstacle_motion="pedestrians", pedestrians=PedestrianSpec(goal_policy="square")
    )
    sim = Simulator(s, 1)
    for seed in range(20):
        sim.reset(seed)
        w = sim.world
        segments = np.stack((w.seg_a[0], w.seg_b[0]), axis=1)[w.seg_present[0]]
        goals = sim.motion_params["goals"][0, :, 0]
        for points in (w.obs_pos[0], goals):
            assert (clearance(points, segments) >= w.obs_radius[0] + s.min_separation - 1e-9).all()


def test_square_crossers_need_no_room_on_the_crowd_ring_and_are_drawn_where_they_walk():
    """The crowd ring's capacity refused a 16th pedestrian crossing the square (their ring places are replaced);
    the drawn area was the ring's, leaving square and wander pedestrians out of frame. Layouts that fitted before
    draw as before (the suites' resets hashed unchanged when this changed)."""
    env = vcs_env.parallel_env(scenario="crowdnav-square-v0", n_obstacles=16)
    env.reset(seed=0)
    pos, h = env.engine.world.obs_pos[0], env.scenario.arena_half_size
    assert pos.shape == (16, 2) and np.all(np.abs(pos) <= h)
    with pytest.raises(ValueError, match="crowd circle"):  # pedestrians that cross the circle still need its room
        vcs_env.parallel_env(scenario="crowdnav-circle-v0", n_obstacles=16)
    for policy in ("square", "wander"):
        s = vcs_env.make_scenario("crowdnav-square-v0", arena_half_size=7.0)
        s = dataclasses.replace(s, pedestrians=dataclasses.replace(s.pedestrians, goal_policy=policy))
        assert s.view_extent >= 7.0 + s.robot.radius
    with pytest.raises(ValueError, match="pedestrians crossing the square: trial layout . of 8 found no place"):
        vcs_env.make_scenario("crowdnav-square-v0", arena_half_size=1.0)  # refused here, not at some reset
    circle = vcs_env.make_scenario("crowdnav-circle-v0", arena_half_size=7.0)
    assert circle.view_extent < 7.0  # circle crossers stay near their ring
    default = vcs_env.make_scenario("crowd", obstacle_motion="pedestrians", arena_half_size=7.0)
    assert default.pedestrians is None and default.view_extent < 7.0  # PedestrianSpec()'s cross the circle too
