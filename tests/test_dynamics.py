"""Kinematics: hand-computed motion, clipping, action modes, and the batched step == scalar twin."""

import dataclasses
import math

import numpy as np
import pytest

import vcs_env
from vcs_env.dynamics import check_actions, integrate, target_to_action
from vcs_env.engine import NavEngine
from vcs_env.scenario import CustomLayout


def one_robot(speed=0.0, heading=0.0, holonomic=False, **robot):
    scenario = vcs_env.make_scenario(
        "custom",
        n_robots=1,
        n_obstacles=0,
        max_steps=1000,
        r_goal=0.05,
        custom=CustomLayout(start=((0.0, 0.0),), goal=((100.0, 0.0),), heading=(heading,), speed=(speed,)),
    )
    scenario = scenario.with_robot(holonomic=holonomic, **robot)
    engine = NavEngine(scenario)
    engine.reset([0])
    return engine


def scalar_unicycle_step(x, y, th, v, a0, a1, dt, a_max, w_max, v_max):
    """The obvious one-robot version of dynamics.integrate (delta mode)."""
    a0 = min(max(a0, -1.0), 1.0)
    a1 = min(max(a1, -1.0), 1.0)
    v = min(max(v + a0 * a_max * dt, 0.0), v_max)
    th = math.atan2(math.sin(th + a1 * w_max * dt), math.cos(th + a1 * w_max * dt))
    return x + v * dt * math.cos(th), y + v * dt * math.sin(th), th, v


def test_constant_speed_for_two_seconds_moves_two_meters():
    eng = one_robot(speed=1.0)
    for _ in range(20):
        eng.step(np.zeros((1, 1, 2)))
    np.testing.assert_allclose(eng.world.pos[0, 0], [2.0, 0.0], atol=1e-12)
    assert eng.world.time[0] == pytest.approx(2.0)


def test_full_acceleration_from_rest():
    # a_max = 0.5 m/s^2, dt = 0.1: speed after k steps is 0.05 k; x = sum 0.005 k = 0.005 k(k+1)/2.
    eng = one_robot()
    for _ in range(20):
        eng.step(np.array([[[1.0, 0.0]]]))
    assert eng.world.speed[0, 0] == pytest.approx(1.0)
    assert eng.world.pos[0, 0, 0] == pytest.approx(0.005 * 20 * 21 / 2)
    # Speed saturates at v_max.
    for _ in range(10):
        eng.step(np.array([[[1.0, 0.0]]]))
    assert eng.world.speed[0, 0] == pytest.approx(1.0)


def test_turn_rate_and_out_of_range_clipping():
    eng = one_robot(speed=0.5)
    eng.step(np.array([[[0.0, 5.0]]]))  # clipped to +1: one-step turn omega_max dt
    assert eng.world.heading[0, 0] == pytest.approx(math.pi / 2 * 0.1)
    eng.step(np.array([[[-7.0, -1.0]]]))  # clipped to -1 on speed; turn back
    assert eng.world.speed[0, 0] == pytest.approx(0.45)
    assert eng.world.heading[0, 0] == pytest.approx(0.0, abs=1e-15)


def test_no_reversing():
    eng = one_robot(speed=0.02)
    eng.step(np.array([[[-1.0, 0.0]]]))
    assert eng.world.speed[0, 0] == 0.0


def test_turning_in_place_full_circle():
    eng = one_robot()
    for _ in range(40):  # pi/2 rad/s for 4 s
        eng.step(np.array([[[0.0, 1.0]]]))
    np.testing.assert_allclose(eng.world.pos[0, 0], [0.0, 0.0])
    assert math.cos(eng.world.heading[0, 0]) == pytest.approx(1.0)


def test_absolute_mode_tracks_command_within_limits():
    scenario = vcs_env.make_scenario(
        "custom",
        n_robots=1,
        n_obstacles=0,
        custom=CustomLayout(start=((0.0, 0.0),), goal=((50.0, 0.0),), heading=(0.0,)),
    )
    eng = NavEngine(scenario, action_mode="absolute")
    eng.reset([0])
    # Target speed v_max and heading pi/2: speed ramps by a_max dt, heading by omega_max dt.
    eng.step(np.array([[[1.0, 0.5]]]))
    assert eng.world.speed[0, 0] == pytest.approx(0.05)
    assert eng.world.heading[0, 0] == pytest.approx(math.pi / 2 * 0.1)
    for _ in range(30):
        eng.step(np.array([[[1.0, 0.5]]]))
    assert eng.world.heading[0, 0] == pytest.approx(math.pi / 2)
    # Command (-1, .) is a target speed of 0.
    for _ in range(40):
        eng.step(np.array([[[-1.0, 0.5]]]))
    assert eng.world.speed[0, 0] == 0.0


def test_holonomic_velocity_change_is_a_disc():
    eng = one_robot(holonomic=True, speed=0.5)
    # (1, 1) is clipped to the unit disc: |dv| = a_max dt.
    eng.step(np.array([[[1.0, 1.0]]]))
    v = eng.world.vel[0, 0]
    dv = v - np.array([0.5, 0.0])
    assert np.linalg.norm(dv) == pytest.approx(0.05)
    assert dv[0] == pytest.approx(dv[1])
    # Heading is the direction of motion.
    assert eng.world.heading[0, 0] == pytest.approx(math.atan2(v[1], v[0]))


def test_integrate_matches_scalar_twin(rng):
    scenario = vcs_env.make_scenario("circle", n_robots=7)
    eng = NavEngine(scenario, batch_size=3)
    eng.reset([1, 2, 3])
    w = eng.world
    w.speed[:] = rng.uniform(0, 1, size=w.speed.shape)
    w.heading[:] = rng.uniform(-math.pi, math.pi, size=w.heading.shape)
    acts = rng.uniform(-1.5, 1.5, size=(3, 7, 2))
    speed, heading, pos = integrate(w, acts)
    for b in range(3):
        for i in range(7):
            x, y, th, v = scalar_unicycle_step(
                w.pos[b, i, 0],
                w.pos[b, i, 1],
                w.heading[b, i],
                w.speed[b, i],
                acts[b, i, 0],
                acts[b, i, 1],
                w.dt,
                w.a_max[b, i],
                w.omega_max[b, i],
                w.v_max[b, i],
            )
            assert pos[b, i] == pytest.approx([x, y], abs=1e-12)
            assert heading[b, i] == pytest.approx(th, abs=1e-12)
            assert speed[b, i] == pytest.approx(v, abs=1e-12)


@pytest.mark.parametrize("holonomic", [False, True])
@pytest.mark.parametrize("mode", ["delta", "absolute"])
def test_target_to_action_reaches_reachable_targets(holonomic, mode, rng):
    """A target within one step is reached exactly by the action target_to_action gives."""
    scenario = vcs_env.make_scenario("circle", n_robots=5).with_robot(holonomic=holonomic)
    eng = NavEngine(scenario, action_mode=mode)
    eng.reset([4])
    w = eng.world
    w.speed[:] = rng.uniform(0.2, 0.8, size=w.speed.shape)
    if holonomic:
        dv = rng.uniform(-0.03, 0.03, size=w.speed.shape)
        dth = rng.uniform(-0.03, 0.03, size=w.speed.shape)
    else:
        dv = rng.uniform(-0.05, 0.05, size=w.speed.shape)
        dth = rng.uniform(-0.15, 0.15, size=w.speed.shape)
    target = np.stack((w.speed + dv, w.heading + dth), axis=-1)
    act = target_to_action(w, target, mode)
    assert act.dtype == np.float32 and np.all(np.abs(act) <= 1.0)
    speed, heading, _ = integrate(w, act.astype(np.float64), mode)
    np.testing.assert_allclose(speed, target[..., 0], atol=1e-5)
    np.testing.assert_allclose(np.cos(heading - target[..., 1]), 1.0, atol=1e-8)


def test_check_actions_rejects_bad_input():
    with pytest.raises(ValueError, match="shape"):
        check_actions(np.zeros((1, 2, 3)), (1, 2, 2))
    with pytest.raises(ValueError, match="finite"):
        check_actions(np.array([[[np.nan, 0.0]]]), (1, 1, 2))
    with pytest.raises(ValueError, match="finite"):
        check_actions(np.array([[[np.inf, 0.0]]]), (1, 1, 2))
    with pytest.raises(ValueError):
        check_actions([["a", "b"]], (1, 2))


def test_robot_spec_limits_are_validated():
    with pytest.raises(ValueError, match="robot.v_max"):
        dataclasses.replace(vcs_env.RobotSpec(), v_max=0.0)
    with pytest.raises(ValueError, match="robot.a_max"):
        vcs_env.RobotSpec(a_max=-1.0)
    with pytest.raises(ValueError, match="robot.omega_max"):
        vcs_env.RobotSpec(omega_max=float("nan"))
    for name in ("a_max", "omega_max"):  # a step of 1e-9 made each of the expert's decisions take seconds
        with pytest.raises(ValueError, match=rf"robot.{name} must be a finite number in \[0.001, "):
            vcs_env.RobotSpec(**{name: 1e-8})
        vcs_env.RobotSpec(**{name: 1e-3})


def test_numpy_bools_are_bools_and_other_flags_are_refused():
    """A robot kind given as numpy's bool was refused while the scenario's flags took it, and kept it, so the run
    record's JSON failed on it; an engine step with autoreset="yes" auto-reset."""
    import json

    robot = vcs_env.RobotSpec(holonomic=np.bool_(True))
    scenario = vcs_env.make_scenario("walls", n_wall_points=2, stall_clock=np.bool_(True), robot=robot)
    assert type(scenario.robot.holonomic) is bool and type(scenario.stall_clock) is bool
    json.dumps(dataclasses.asdict(scenario))
    engine = NavEngine(vcs_env.make_scenario("circle", n_robots=2), 1)
    engine.reset(0)
    with pytest.raises(ValueError, match="autoreset must be True or False, got 'yes'"):
        engine.step(np.zeros((1, 2, 2)), autoreset="yes")
