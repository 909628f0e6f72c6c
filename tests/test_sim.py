"""Simulator semantics: swept collisions, arrival, parking, collision modes, obstacle motion."""

import dataclasses
import math
import warnings

import numpy as np
import pytest

import vcs_env
from vcs_env.engine import NavEngine
from vcs_env.observations import EGO_DIM, GOAL_REF, SENSE_REF, observation_layout, observe
from vcs_env.obstacles import MOTION_MODELS, ObstacleMotion, Trajectory
from vcs_env.pedestrians import PedestrianSpec
from vcs_env.scenario import CustomLayout, ObstacleTrajectory
from vcs_env.sim import Simulator


def custom(starts, goals, headings=None, speeds=None, obstacles=(), **kw):
    layout = CustomLayout(start=starts, goal=goals, heading=headings, speed=speeds, obstacles=obstacles)
    return vcs_env.make_scenario("custom", n_robots=len(starts), n_obstacles=len(obstacles), custom=layout, **kw)


def test_discs_passing_through_each_other_within_one_step_collide():
    # Two fast robots 0.6 m apart head-on at 3 m/s each, dt = 0.2: they swap sides within one
    # step, and their end positions are 0.6 m apart again (no overlap at either end).
    fast = vcs_env.RobotSpec(v_max=3.0, radius=0.2)
    # (With on_collision="terminate" they would stop touching: tests/test_stop.py.)
    s = custom(
        ((-0.3, 0.0), (0.3, 0.0)), ((10.0, 0.0), (-10.0, 0.0)), speeds=(3.0, 3.0), dt=0.2, robot=fast,
        on_collision="continue",
    )  # fmt: skip
    sim = Simulator(s)
    sim.reset([0])
    ev = sim.step(np.zeros((1, 2, 2)))
    assert np.linalg.norm(sim.world.pos[0, 0] - sim.world.pos[0, 1]) == pytest.approx(0.6)
    assert ev.collided.all()
    assert ev.robot_hits[0, 0, 1] and ev.robot_hits[0, 1, 0]
    assert ev.min_separation[0, 0] == pytest.approx(-0.4)


def test_near_miss_is_not_a_collision():
    # Same crossing with a lateral offset of radius sum + 1 cm.
    fast = vcs_env.RobotSpec(v_max=3.0, radius=0.2)
    s = custom(((-0.3, 0.0), (0.3, 0.41)), ((10.0, 0.0), (-10.0, 0.41)), speeds=(3.0, 3.0), dt=0.2, robot=fast)
    sim = Simulator(s)
    sim.reset([0])
    ev = sim.step(np.zeros((1, 2, 2)))
    assert not ev.collided.any()
    assert ev.min_separation[0, 0] == pytest.approx(0.01)


def test_robot_obstacle_swept_collision_and_names():
    obstacle = ObstacleTrajectory(times=(0.0, 1.0), positions=((1.0, -1.0), (1.0, 1.0)), radius=0.2)
    s = custom(((0.0, 0.0),), ((5.0, 0.0),), speeds=(1.0,), obstacles=(obstacle,))
    env = vcs_env.parallel_env(scenario=s)
    env.reset(seed=0)
    hit = None
    for _ in range(20):
        _, rew, term, _, info = env.step({"robot_0": np.zeros(2)})
        if info["robot_0"]["collided_with"]:
            hit = info["robot_0"]
            break
    assert hit is not None and hit["collided_with"] == ["obstacle_0"]
    assert hit["reward_terms"]["collision"] == -1.0
    assert term["robot_0"] and not env.agents  # terminate mode ends the robot's episode


def test_continue_mode_keeps_driving_and_reports_every_contact_step():
    # Robot 0 at 1 m/s runs into robot 1, 2 cm away and standing.
    s = custom(((0.0, 0.0), (0.52, 0.0)), ((5.0, 0.0), (0.52, 5.0)), speeds=(1.0, 0.0), on_collision="continue")
    eng = NavEngine(s)
    eng.reset([0])
    for _ in range(3):
        res = eng.step(np.zeros((1, 2, 2)))
        assert res.events.collided.all() and not res.terminated.any()
        assert res.terms["collision"][0].tolist() == [-1.0, -1.0]
    assert eng.world.active.all() and eng.world.collided.all()
    assert eng.world.pos[0, 0, 0] == pytest.approx(0.3)


def test_arrival_is_swept_and_robot_parks():
    # 1 m/s straight at a goal at x = 1.05: the 10th step passes within r_goal = 0.1 of it.
    s = custom(((0.0, 0.0), (-3.0, 2.0)), ((1.05, 0.0), (3.0, 2.0)), speeds=(1.0, 0.0), r_goal=0.1)
    eng = NavEngine(s)
    eng.reset([0])
    steps = 0
    while steps < 15:
        res = eng.step(np.zeros((1, 2, 2)))
        steps += 1
        if res.terminated[0, 0]:
            break
    assert steps == 10 and res.events.reached[0, 0] and res.terms["arrival"][0, 0] == 1.0
    parked = eng.world.pos[0, 0].copy()
    res = eng.step(np.ones((1, 2, 2)))  # actions of a finished robot are ignored
    np.testing.assert_array_equal(eng.world.pos[0, 0], parked)
    assert eng.world.speed[0, 0] == 0.0 and not res.terminated[0, 0] and res.reward[0, 0] == 0.0
    assert eng.world.present[0, 0]  # still an obstacle for the others


@pytest.mark.parametrize("on_collision", ["continue", "terminate"])
def test_a_step_through_the_goal_disc_stops_at_the_goal(on_collision):
    # 3 m/s with dt = 0.5 s: the first step (1.5 m) passes 0.05 m from the goal 1 m ahead and would end
    # 0.5 m beyond it, 0.1 m into a thin wall 0.6 m behind it. The robot arrives and stops at the step's
    # point nearest its goal: no contact with the wall, a positive progress, parked inside the disc.
    layout = CustomLayout(
        start=[(0.0, 0.0)], goal=[(1.0, 0.05)], heading=[0.0], speed=[3.0], walls=[((1.6, -1.0), (1.6, 1.0))]
    )
    robot = vcs_env.RobotSpec(v_max=3.0, radius=0.2)
    s = vcs_env.make_scenario(
        "custom", n_robots=1, n_obstacles=0, custom=layout, dt=0.5, r_goal=0.1, robot=robot, on_collision=on_collision
    )
    eng = NavEngine(s)
    eng.reset([0])
    res = eng.step(np.zeros((1, 1, 2)))
    assert res.events.reached[0, 0] and res.terminated[0, 0] and not res.events.collided[0, 0]
    assert res.terms["arrival"][0, 0] == 1.0 and res.terms["collision"][0, 0] == 0.0
    assert res.terms["progress"][0, 0] > 0.0
    np.testing.assert_allclose(eng.world.pos[0, 0], (1.0, 0.0), atol=1e-12)  # nearest to (1, 0.05): 0.05 away
    assert res.events.goal_dist_after[0, 0] == pytest.approx(0.05)
    eng.step(np.zeros((1, 1, 2)))
    np.testing.assert_allclose(eng.world.pos[0, 0], (1.0, 0.0), atol=1e-12)  # and parked there


def test_a_step_that_ends_inside_the_goal_disc_is_not_cut():
    # 1 m/s, dt = 0.1: the 10th step runs through the goal and ends 0.03 m past it, inside r_goal: it ends
    # where it ends (the 9th ended 0.07 m short, outside).
    s = custom(((0.0, 0.0),), ((0.97, 0.0),), speeds=(1.0,), r_goal=0.04)
    eng = NavEngine(s)
    eng.reset([0])
    for k in range(10):
        res = eng.step(np.zeros((1, 1, 2)))
        assert res.events.reached[0, 0] == (k == 9)
    assert eng.world.pos[0, 0, 0] == pytest.approx(1.0)


def test_park_finished_false_removes_arrived_robots():
    s = custom(((0.0, 0.0), (2.0, 0.0)), ((0.5, 0.0), (-3.0, 0.0)), speeds=(1.0, 0.0), park_finished=False)
    eng = NavEngine(s)
    eng.reset([0])
    for _ in range(6):
        eng.step(np.zeros((1, 2, 2)))
    assert eng.world.reached[0, 0] and not eng.world.present[0, 0]
    # Robot 1 drives through where robot 0 stopped without a collision.
    for _ in range(40):
        res = eng.step(np.array([[[0.0, 0.0], [1.0, 0.0]]]))
        assert not res.events.collided[0, 1]


def test_truncation_at_max_steps():
    s = custom(((0.0, 0.0),), ((50.0, 0.0),), max_steps=7)
    eng = NavEngine(s)
    eng.reset([0])
    for k in range(7):
        res = eng.step(np.zeros((1, 1, 2)))
        assert res.truncated[0, 0] == (k == 6)


def test_step_before_reset_and_bad_actions_raise():
    sim = Simulator(vcs_env.make_scenario("swap"))
    with pytest.raises(RuntimeError, match="reset"):
        sim.step(np.zeros((1, 2, 2)))
    sim.reset([0])
    with pytest.raises(ValueError, match="shape"):
        sim.step(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="finite"):
        sim.step(np.full((1, 2, 2), np.nan))


# --------------------------------------------------------------------------- obstacles
def run_obstacles(scenario, steps, seed=0):
    sim = Simulator(scenario)
    sim.reset([seed])
    out = [sim.world.obs_pos[0].copy()]
    vel = []
    for _ in range(steps):
        sim.step(np.zeros((1, scenario.n_robots, 2)))
        out.append(sim.world.obs_pos[0].copy())
        vel.append(sim.world.obs_vel[0].copy())
    return np.array(out), np.array(vel), sim


def test_motion_models_are_registered():
    assert set(MOTION_MODELS) == {"static", "constant", "patrol", "arbitrary", "stop_and_go", "pedestrians"}


def test_static_and_constant_velocity_obstacles():
    s = vcs_env.make_scenario("random", n_robots=2, n_obstacles=4, obstacle_motion="static")
    pos, _, _ = run_obstacles(s, 10)
    np.testing.assert_array_equal(pos[0], pos[-1])
    s = vcs_env.make_scenario(
        "random", n_robots=2, n_obstacles=4, obstacle_motion="constant", obstacle_speed=(0.3, 0.6)
    )
    pos, vel, _ = run_obstacles(s, 10)
    speed = np.linalg.norm(vel, axis=-1)
    assert np.all((speed >= 0.3 - 1e-12) & (speed <= 0.6 + 1e-12))
    np.testing.assert_allclose(pos[-1] - pos[0], 10 * 0.1 * vel[0], atol=1e-12)


def test_patrol_lands_on_its_waypoints_and_turns_back():
    s = vcs_env.make_scenario("random", n_robots=1, n_obstacles=3, obstacle_motion="patrol", obstacle_speed=(0.5, 0.5))
    pos, vel, sim = run_obstacles(s, 400)
    wp = sim.motion_params["waypoints"][0]  # (m, 2, 2): start, target
    for k in range(3):
        d_target = np.linalg.norm(pos[:, k] - wp[k, 1], axis=-1)
        d_start = np.linalg.norm(pos[1:, k] - wp[k, 0], axis=-1)
        assert d_target.min() < 1e-9 and d_start.min() < 1e-9  # went there and came back
    assert np.all(np.linalg.norm(vel, axis=-1) <= 0.5 + 1e-9)


def test_arbitrary_motion_keeps_speed_and_bounded_turn_rate():
    s = vcs_env.make_scenario("dynamic", bounce=False, turn_rate=0.6, turn_period=2.0)
    _, vel, _ = run_obstacles(s, 100)
    speed = np.linalg.norm(vel, axis=-1)
    np.testing.assert_allclose(speed, speed[0][None].repeat(len(speed), 0), atol=1e-12)
    ang = np.unwrap(np.arctan2(vel[..., 1], vel[..., 0]), axis=0)
    rate = np.abs(np.diff(ang, axis=0)) / 0.1
    assert rate.max() <= 0.6 + 1e-9
    # Piecewise constant: the rate changes at most once every 2 s (20 steps).
    changes = np.abs(np.diff(np.diff(ang, axis=0), axis=0)) > 1e-9
    assert changes.sum(axis=0).max() <= 100 // 20 + 1


def test_stop_and_go_alternates():
    s = vcs_env.make_scenario(
        "random",
        n_robots=1,
        n_obstacles=2,
        obstacle_motion="stop_and_go",
        go_time=(1.0, 1.0),
        stop_time=(0.5, 0.5),
        obstacle_speed=(0.4, 0.4),
    )
    _, vel, _ = run_obstacles(s, 30)
    moving = np.linalg.norm(vel, axis=-1) > 0
    # 1 s moving (10 steps), 0.5 s stopped (5 steps), ...
    np.testing.assert_array_equal(moving[:, 0], ([True] * 10 + [False] * 5) * 2)


def test_bounce_keeps_obstacles_in_the_arena():
    s = vcs_env.make_scenario(
        "dynamic", n_obstacles=8, arena_half_size=4.0, obstacle_speed=(0.8, 1.0), n_robots=2, max_steps=600
    )
    pos, _, sim = run_obstacles(s, 600)
    r = sim.world.obs_radius[0]
    assert np.all(np.abs(pos) <= 4.0 - r[None, :, None] + 1e-9)
    # Steps long against the arena: as long as the room from the centre to the edge, the obstacles stay in; longer,
    # a reversed step would carry them out through the opposite edge (they reached 3.98 m in a 2 m arena): refused.
    kw = dict(n_robots=1, n_obstacles=3, arena_half_size=2.0, obstacle_radius=(0.4, 0.4), dt=1.0)
    for motion in ("constant", "arbitrary"):
        s = vcs_env.make_scenario("dynamic", obstacle_motion=motion, obstacle_speed=(1.6, 1.6), **kw)
        for seed in range(4):
            pos, _, _ = run_obstacles(s, 60, seed)
            assert np.all(np.abs(pos) <= 1.6 + 1e-9)
    with pytest.raises(ValueError, match="bouncing obstacles at up to 1.7 m/s move 1.7 m in a step"):
        vcs_env.make_scenario("dynamic", obstacle_speed=(1.7, 1.7), **kw)
    # Bouncing obstacles start inside the arena: a crowd ring beyond it is refused (its obstacles started up to 2.8 m
    # out, held there by the bounce), and square-crossing pedestrians keep their discs inside it (they overhung).
    for ring in ({"scenario": "crowd", "layout_radius": 8.0}, {"scenario": "crowd-20-v0"}):
        with pytest.raises(ValueError, match="reach beyond the arena they bounce in"):
            vcs_env.parallel_env(**ring, bounce=True, obstacle_motion="arbitrary")
    walkers = vcs_env.make_scenario(
        "dynamic", obstacle_motion="pedestrians", pedestrians=PedestrianSpec(goal_policy="square")
    )
    sim = Simulator(walkers, 50)
    sim.reset(list(range(50)))
    assert (np.abs(sim.world.obs_pos) + sim.world.obs_radius[..., None] <= walkers.arena_half_size + 1e-12).all()
    s = vcs_env.make_scenario("dynamic", obstacle_speed=(1.6, 1.6), **kw)
    env = vcs_env.parallel_env(scenario=s, obstacle_motion=_Drift(lambda pos: np.where(pos > 0, -2.0, 2.0)))
    env.reset(seed=0)
    with pytest.raises(
        ValueError, match="obstacle motion _Drift left an obstacle beyond an arena edge after its bounce"
    ):
        for _ in range(20):
            env.step({a: np.zeros(2, np.float32) for a in env.agents})


def test_scripted_trajectory_hits_its_waypoints():
    traj = ObstacleTrajectory(times=(0.0, 2.0, 3.0), positions=((0.0, 5.0), (2.0, 5.0), (2.0, 4.0)))
    s = custom(((0.0, 0.0),), ((9.0, 0.0),), obstacles=(traj,))
    assert isinstance(vcs_env.obstacles.make_motion(s), Trajectory)
    pos, _, _ = run_obstacles(s, 40)
    np.testing.assert_allclose(pos[10, 0], [1.0, 5.0], atol=1e-12)
    np.testing.assert_allclose(pos[20, 0], [2.0, 5.0], atol=1e-12)
    np.testing.assert_allclose(pos[25, 0], [2.0, 4.5], atol=1e-12)
    np.testing.assert_allclose(pos[40, 0], [2.0, 4.0], atol=1e-12)  # held after the last waypoint


def test_observation_sees_nearest_objects_in_robot_frame():
    # Robot at the origin facing +y; a robot 1 m ahead, an obstacle 2 m to its right, a robot
    # out of sensing range.
    obstacle = ObstacleTrajectory(times=(0.0,), positions=((2.0, 0.0),), radius=0.3)
    s = custom(
        ((0.0, 0.0), (0.0, 1.0), (0.0, -9.0)),
        ((0.0, 5.0), (0.0, 6.0), (0.0, -15.0)),
        headings=(math.pi / 2, 0.0, 0.0),
        obstacles=(obstacle,),
        r_ca=6.0,
        n_neighbors=3,
    )
    env = vcs_env.parallel_env(scenario=s)
    obs, _ = env.reset(seed=0)
    o = obs["robot_0"]
    assert env.observation_space("robot_0").contains(o)
    nb = observation_layout(s).read(o, "neighbors")
    assert nb.shape == (3, 9) and not nb[..., 8].any()  # nobody has parked yet
    assert nb[0, 0] == 1 and nb[0, 7] == 1  # nearest: the robot ahead
    np.testing.assert_allclose(nb[0, 1:3], [1.0 / SENSE_REF, 0.0], atol=1e-6)  # +x of the robot frame
    assert nb[1, 0] == 1 and nb[1, 7] == 0  # then the obstacle
    np.testing.assert_allclose(nb[1, 1:3], [0.0, -2.0 / SENSE_REF], atol=1e-6)  # to the right
    assert nb[2, 0] == 0 and np.all(nb[2] == 0)  # padding: the third robot is out of range
    np.testing.assert_allclose(o[2:4], [1.0, 0.0], atol=1e-6)  # goal straight ahead


def test_a_robot_parked_at_its_goal_reads_parked_in_v2_and_v1_has_no_such_field():
    """Observation v2's parked flag: robot_1 arrives on its first step and stays; robot_0, driving,
    reads it as a parked robot (1) while it was a robot like any other (0) before; v1 slots have 8 floats."""
    s = custom(((0.0, 0.0), (1.5, 0.0)), ((8.0, 5.0), (1.55, 0.0)), n_neighbors=2)
    sim = Simulator(s)
    sim.reset([0])
    before = observation_layout(s).read(observe(sim.world, s), "neighbors")[0, 0]
    sim.step(np.zeros((1, 2, 2)))
    assert sim.world.present[0, 1] and not sim.world.active[0, 1] and sim.world.active[0, 0]
    after = observation_layout(s).read(observe(sim.world, s), "neighbors")[0, 0]
    assert before[0, 7] == after[0, 7] == 1.0  # a robot
    assert before[0, 8] == 0.0 and after[0, 8] == 1.0  # parked once it arrived
    v1 = dataclasses.replace(s, observation=1)
    assert observation_layout(v1).read(observe(sim.world, v1), "neighbors").shape == (1, 2, 2, 8)
    np.testing.assert_array_equal(
        observe(sim.world, v1)[0, 0, : EGO_DIM + 8], observe(sim.world, s)[0, 0, : EGO_DIM + 8]
    )


def test_same_local_situation_gives_the_same_observation_whatever_the_rest_of_the_world():
    """Fixed physical scales (observation v1): robot_0 with the same goal and the same neighbour
    reads the same numbers when far-away robots are added, the arena grows or the layout kind
    changes (v0 divided the goal distance by a scale that grew with the world)."""
    near = (((0.0, 0.0), (1.5, 0.0)), ((0.0, 7.0), (1.5, -3.0)))
    far_robots = tuple((40.0 + 2.0 * i, 30.0) for i in range(10)), tuple((-40.0 + 2.0 * i, -30.0) for i in range(10))
    small = custom(*near, headings=(math.pi / 2, 0.0), arena_half_size=6.0)
    big = custom(near[0] + far_robots[0], near[1] + far_robots[1], headings=(math.pi / 2,) + (0.0,) * 11)
    bigger_arena = custom(*near, headings=(math.pi / 2, 0.0), arena_half_size=80.0)
    assert small.world_extent < big.world_extent
    rows = []
    for s in (small, big, bigger_arena):
        env = vcs_env.parallel_env(scenario=s)
        obs, _ = env.reset(seed=0)
        rows.append(obs["robot_0"])
    np.testing.assert_array_equal(rows[0], rows[1])
    np.testing.assert_array_equal(rows[0], rows[2])
    assert rows[0][1] == pytest.approx(7.0 / GOAL_REF)  # goal 7 m ahead
    np.testing.assert_allclose(rows[0][8:11], [6.0 / SENSE_REF, 0.1 / 2.0, 0.1])  # r_ca, r_goal, dt features


def test_scenario_parameters_a_policy_needs_are_explicit_features():
    base = custom(((0.0, 0.0),), ((0.0, 5.0),))
    changed = custom(((0.0, 0.0),), ((0.0, 5.0),), r_ca=4.0, r_goal=0.3, dt=0.2)
    o0 = vcs_env.parallel_env(scenario=base).reset(seed=0)[0]["robot_0"]
    o1 = vcs_env.parallel_env(scenario=changed).reset(seed=0)[0]["robot_0"]
    np.testing.assert_allclose(o1[8:11] - o0[8:11], [-2.0 / SENSE_REF, 0.2 / 2.0, 0.1], atol=1e-6)
    np.testing.assert_array_equal(o0[:8], o1[:8])


class _Drift(ObstacleMotion):
    """An obstacle motion of one's own: ``self.out(pos)`` as the velocity, a scalar parameter from init."""

    name = "drift"

    def __init__(self, out):
        self.out = out

    def init(self, rng, scenario, pos, target):
        return {"gain": 0.5}  # a scalar, not an (m,) array

    def velocity(self, params, t, pos, dt):
        return self.out(pos)


def test_an_obstacle_motion_of_ones_own_is_checked_by_name():
    """Velocities of another shape failed inside numba or numpy, NaN ones made the obstacles vanish from every
    collision check, speeds above V_REF were clipped in the observations, and a scalar parameter failed in reset."""
    s = vcs_env.make_scenario("dynamic", n_robots=2, n_obstacles=3)
    env = vcs_env.parallel_env(scenario=s, obstacle_motion=_Drift(lambda pos: 0.5 * np.ones_like(pos)))
    env.reset(seed=0)
    env.step({a: np.zeros(2, np.float32) for a in env.agents})  # fine as it is
    for said, out in {
        r"must have shape \(1, 3, 2\), got \(1, 3\)": lambda pos: np.ones(pos.shape[:2]),
        "must be finite": lambda pos: np.full(pos.shape, np.nan),
        "reached 4.243 m/s, above the 3.0 m/s that observations scale velocities by": lambda pos: np.full(
            pos.shape, 3.0
        ),
    }.items():
        env = vcs_env.parallel_env(scenario=s, obstacle_motion=_Drift(out))
        with pytest.raises(ValueError, match="the velocity of obstacle motion _Drift " + said):
            env.reset(seed=0)
            env.step({a: np.zeros(2, np.float32) for a in env.agents})
    env = vcs_env.parallel_env(scenario=s, obstacle_motion=_Drift(lambda pos: np.ones(pos.shape).tolist()))
    env.reset(seed=0)
    env.step({a: np.zeros(2, np.float32) for a in env.agents})  # a nested list of numbers is taken


class _Spin(ObstacleMotion):
    """Turning at a per-world speed: ``init`` gives that speed as one number (documented: one value for all)."""

    def __init__(self, init=None):
        self.given = init

    def init(self, rng, scenario, pos, target):
        if self.given is not None:
            return self.given(pos)
        return {"speed": rng.uniform(0.2, 0.6), "phase": rng.uniform(-np.pi, np.pi, len(pos))}

    def velocity(self, params, t, pos, dt):
        a = params["phase"] + 0.5 * t[:, None]
        return np.stack((np.cos(a), np.sin(a)), -1) * params["speed"][..., None]


def test_obstacle_motion_parameters_are_one_row_per_obstacle():
    """A number from ``init`` is one value for every obstacle: stored per world it broadcast against (B, m, 2) where
    B = m, and 6 batched worlds moved their obstacles up to 0.18 m off the same worlds one by one. Parameters of
    another leading size, or no dict, are refused by name (a TypeError or numpy's broadcast error)."""
    s = vcs_env.make_scenario("dynamic", n_robots=1, n_obstacles=6)
    sim = Simulator(s, 6, obstacle_motion=_Spin())
    sim.reset(list(range(6)))
    for _ in range(10):
        sim.step(np.zeros((6, 1, 2)))
    for b in range(6):
        one = Simulator(s, 1, obstacle_motion=_Spin())
        one.reset([b])
        for _ in range(10):
            one.step(np.zeros((1, 1, 2)))
        np.testing.assert_allclose(one.world.obs_pos[0], sim.world.obs_pos[b], atol=1e-12)
    for init, said in (
        (lambda pos: None, "_Spin.init must return a dict of parameter arrays"),
        (lambda pos: {"x": np.zeros(len(pos) + 1)}, r"_Spin.init gave 'x' of shape \(7,\): parameters have leading"),
    ):
        with pytest.raises(ValueError, match=f"obstacle motion {said}"):
            Simulator(s, 1, obstacle_motion=_Spin(init)).reset([0])


def test_reset_takes_distinct_world_indices_in_range():
    """An index past the batch was an IndexError; -1 reset the last world and 0.5 the first."""
    sim = Simulator(vcs_env.make_scenario("circle", n_robots=2), 2)
    for worlds in ([5], [-1], [0.5], [True], [0, 0], 3):
        with pytest.raises(ValueError, match=r"worlds must be distinct integer indices in \[0, 2\)"):
            sim.reset(0, worlds=worlds)
    sim.reset([7], worlds=np.array([1]))  # numpy integers are indices
    sim.reset(0, worlds=[])  # nothing to reset


def test_long_episodes_draw_a_bounded_obstacle_script():
    """A tiny turn period or a very long episode drew the turn rates (stop-and-go phases) of the whole episode at
    reset: hundreds of MB to GB per world. Bounded, and said so (the obstacles changed their ways late in long
    episodes without a word)."""
    from vcs_env.obstacles import MAX_PERIODS, ShortScriptWarning

    for overrides in ({"turn_period": 1e-4}, {"max_steps": 10**7, "dt": 1.0}):
        sim = Simulator(vcs_env.make_scenario("dynamic", **overrides), 1)
        with pytest.warns(ShortScriptWarning, match="after that each keeps its last turn rate"):
            sim.reset(0)
        assert sim.motion_params["rates"].shape[-1] == MAX_PERIODS
        sim.step(np.zeros((1, sim.scenario.n_robots, 2)))
    sim = Simulator(
        vcs_env.make_scenario("dynamic", obstacle_motion="stop_and_go", go_time=(1e-3, 1e-3), stop_time=(0, 0))
    )
    with pytest.warns(ShortScriptWarning, match="they may keep moving without stopping"):
        sim.reset(0)
    assert sim.motion_params["switch"].shape[-1] == MAX_PERIODS
    with warnings.catch_warnings():
        warnings.simplefilter("error", ShortScriptWarning)  # a suite's episodes are covered: no warning
        Simulator(vcs_env.make_scenario("dynamic-fast-v0")).reset(0)


def test_a_world_field_replaced_with_another_shape_is_named_not_read_past_its_end():
    """Robots may be moved by hand between steps (WorldState's docstring); a field given another shape was read by the
    kernels past its end (a robot stepped to 1e-322, or planned from a goal it does not have)."""
    from baselines.vcs import VCSPlanner

    sim = Simulator(vcs_env.make_scenario("swap"))
    sim.reset(0)
    sim.world.check_shapes()  # a world as the simulator makes it fits
    good = sim.world.copy()
    sim.world.pos = sim.world.pos[:, :1].copy()  # one robot of two
    with pytest.raises(ValueError, match=r"WorldState.heading must be an array of shape \(1, 1\), got shape \(1, 2\)"):
        sim.step(np.zeros((1, 2, 2)))
    wrong_goal = dataclasses.replace(good, goal=good.goal[:, :1].copy())
    with pytest.raises(ValueError, match=r"WorldState.goal must be an array of shape \(1, 2, 2\), got shape \(1, 1, 2"):
        VCSPlanner().plan(wrong_goal)
    with pytest.raises(ValueError, match=r"WorldState.speed must be an array of shape \(1, 2\), got a list"):
        dataclasses.replace(good, speed=[0.0, 0.0]).check_shapes()
    with pytest.raises(ValueError, match=r"WorldState.obs_pos must be an array of shape \(B, m, 2\), got shape \(3,\)"):
        dataclasses.replace(good, obs_pos=np.zeros(3)).check_shapes()
