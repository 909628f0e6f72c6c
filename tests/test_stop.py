"""``on_collision="terminate"``: a robot that touches anything stops where it first touched
(:mod:`vcs_env.stop_kernels`), never on or beyond a wall nor inside another robot, whatever
``dt`` and speed; the kernel against a scalar twin that samples the step finely."""

import dataclasses

import numpy as np
import pytest

from vcs_env import kernels
from vcs_env.scenario import CustomLayout, ObstacleTrajectory, RobotSpec, Scenario
from vcs_env.sim import Simulator

TOL = 1e-6  # [m]


def one_robot_at_a_wall(dt, speed):
    """The issue's case: a robot at ``speed`` [m/s] 1 m before a thin wall at x = 0."""
    layout = CustomLayout(start=[(-1, 0)], goal=[(3, 3)], heading=[0.0], speed=[speed], walls=[((0, -1), (0, 1))])
    robot = RobotSpec(v_max=speed, a_max=1.0)
    return Scenario(kind="custom", n_robots=1, dt=dt, on_collision="terminate", robot=robot, custom=layout)


@pytest.mark.parametrize("dt, speed", [(0.5, 3.0), (0.1, 1.0), (1.0, 2.5), (1.0, 3.0)])
def test_robot_stops_at_the_wall_not_through_it(dt, speed):
    sim = Simulator(one_robot_at_a_wall(dt, speed))
    sim.reset([0])
    for _ in range(int(np.ceil(1.0 / (speed * dt))) + 1):
        ev = sim.step(np.zeros((1, 1, 2)))
        if ev.collided[0, 0]:
            break
    assert ev.collided[0, 0] and ev.wall_hits[0, 0, 0] and not sim.world.active[0, 0]
    np.testing.assert_allclose(sim.world.pos[0, 0], (-0.25, 0.0), atol=TOL)  # touching, on its own side
    assert ev.min_separation[0, 0] == pytest.approx(0.0, abs=TOL)
    sim.step(np.zeros((1, 1, 2)))
    np.testing.assert_allclose(sim.world.pos[0, 0], (-0.25, 0.0), atol=TOL)  # and parked there


def test_head_on_robots_and_an_obstacle_stop_touching():
    # Two robots at 3 m/s head-on 2 m apart, dt = 1: they meet after 0.25 s, each 0.75 m on;
    # a third runs into a standing obstacle 1 m ahead: it stops 0.5 m before the centre.
    obstacle = ObstacleTrajectory(times=(0.0, 10.0), positions=((0.0, 5.0), (0.0, 5.0)), radius=0.25)
    layout = CustomLayout(
        start=[(-1, 0), (1, 0), (-1, 5)], goal=[(9, 0), (-9, 0), (9, 5)], heading=[0.0, np.pi, 0.0],
        speed=[3.0, 3.0, 3.0], obstacles=(obstacle,),
    )  # fmt: skip
    s = Scenario(
        kind="custom", n_robots=3, n_obstacles=1, dt=1.0, robot=RobotSpec(v_max=3.0), custom=layout,
        on_collision="terminate", arena_half_size=12.0,
    )  # fmt: skip
    sim = Simulator(s)
    sim.reset([0])
    ev = sim.step(np.zeros((1, 3, 2)))
    assert ev.collided[0].all() and ev.robot_hits[0, 0, 1] and ev.robot_hits[0, 1, 0] and ev.obstacle_hits[0, 2, 0]
    np.testing.assert_allclose(sim.world.pos[0], [(-0.25, 0.0), (0.25, 0.0), (-0.5, 5.0)], atol=TOL)


def test_continue_mode_is_unchanged():
    s = one_robot_at_a_wall(0.5, 3.0)
    sim = Simulator(dataclasses.replace(s, on_collision="continue"))
    sim.reset([0])
    ev = sim.step(np.zeros((1, 1, 2)))
    assert ev.collided[0, 0]
    np.testing.assert_allclose(sim.world.pos[0, 0], (0.5, 0.0))  # through the wall, as documented for continue


def crossed(p, q, a, b):
    """Scalar: does the motion [p, q] cross the segment [a, b] (strictly)?"""

    def side(u, v, w):
        return (v[0] - u[0]) * (w[1] - u[1]) - (v[1] - u[1]) * (w[0] - u[0])

    return side(a, b, p) * side(a, b, q) < 0 and side(p, q, a) * side(p, q, b) < 0


def point_to_segment(p, a, b):
    """Scalar distance [m] from the point ``p`` to the segment [a, b]."""
    ab = b - a
    u = min(max(float((p - a) @ ab / (ab @ ab)), 0.0), 1.0)
    return float(np.linalg.norm(p - (a + u * ab)))


@pytest.mark.parametrize("kind", ["walls", "corridor", "random"])
@pytest.mark.parametrize("dt", [0.1, 0.5, 1.0])
def test_no_robot_ever_parks_in_a_wall_or_another_robot(kind, dt):
    """The oracle, in plain loops: after every step of fast robots driven at random, no present
    robot is closer than its radius to a wall, crossed one during the step, or overlaps another
    robot; a robot that crashed touches what it hit (robot or wall). Obstacles never stop, so one
    may drive on through a parked robot; the contact with it is checked by the sampled twin."""
    s = Scenario(
        kind=kind, n_robots=8, n_obstacles=4 if kind == "random" else 0, dt=dt, on_collision="terminate",
        robot=RobotSpec(v_max=3.0, a_max=6.0), obstacle_motion="constant" if kind == "random" else "static",
        obstacle_speed=(1.0, 3.0), max_steps=50,
    )  # fmt: skip
    sim = Simulator(s, 2, action_mode="absolute")
    sim.reset([11, 12])
    rng = np.random.default_rng(3)
    w, crashes = sim.world, 0
    for _ in range(30):
        before = w.pos.copy()
        ev = sim.step(rng.uniform(-1, 1, (2, s.n_robots, 2)))
        for b in range(2):
            walls = [(w.seg_a[b, k], w.seg_b[b, k]) for k in range(w.n_segments) if w.seg_present[b, k]]
            for i in range(s.n_robots):
                if not w.present[b, i]:
                    continue
                r = w.radius[b, i]
                for a, c in walls:
                    assert point_to_segment(w.pos[b, i], a, c) >= r - TOL
                    assert not crossed(before[b, i], w.pos[b, i], a, c)
                for j in range(i + 1, s.n_robots):
                    if w.present[b, j]:
                        assert np.linalg.norm(w.pos[b, i] - w.pos[b, j]) >= r + w.radius[b, j] - TOL
                for j in np.flatnonzero(ev.robot_hits[b, i]):
                    assert np.linalg.norm(w.pos[b, i] - w.pos[b, j]) - r - w.radius[b, j] == pytest.approx(0, abs=TOL)
                for k in np.flatnonzero(ev.wall_hits[b, i]):
                    assert point_to_segment(w.pos[b, i], w.seg_a[b, k], w.seg_b[b, k]) == pytest.approx(r, abs=TOL)
                crashes += int(ev.collided[b, i])
    assert crashes >= 4  # the check saw crashes


def sampled_stops(pos, new_pos, radius, obs_pos, new_obs, obs_radius, walls, samples=4000):
    """Scalar twin of :func:`kernels.stop_at_contact` for one world: step time forward in
    ``samples`` ticks; a moving robot closer than the sum of radii to anything at a tick stops
    at that tick (with the moving robot it touched)."""
    n = len(radius)
    stop, moving = np.ones(n), np.ones(n, dtype=bool)

    def at(i, t):
        return pos[i] + min(t, stop[i]) * (new_pos[i] - pos[i])

    for tick in range(1, samples + 1):
        t = tick / samples
        hit = []
        for i in np.flatnonzero(moving):
            p = at(i, t)
            touched = [j for j in range(n) if j != i and np.linalg.norm(at(j, t) - p) < radius[i] + radius[j]]
            o = obs_pos + t * (new_obs - obs_pos)
            near = any(np.linalg.norm(o[k] - p) < radius[i] + obs_radius[k] for k in range(len(obs_radius)))
            near |= any(point_to_segment(p, a, c) < radius[i] for a, c in walls)
            if touched or near:
                hit += [i] + [j for j in touched if moving[j]]
        for i in hit:
            stop[i], moving[i] = t, False
    return stop


@pytest.mark.slow
def test_stop_kernel_matches_sampled_twin():
    rng = np.random.default_rng(0)
    compared = stopped = 0
    while compared < 12:
        n, m = 4, 2
        pos = rng.uniform(-2, 2, (n, 2))
        obs_pos = rng.uniform(-2, 2, (m, 2))
        radius, obs_radius = rng.uniform(0.1, 0.3, n), rng.uniform(0.1, 0.3, m)
        walls = [(rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)) for _ in range(2)]
        centres = np.concatenate((pos, obs_pos))
        radii = np.concatenate((radius, obs_radius))
        gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1) - radii[:, None] - radii[None]
        clear = all(point_to_segment(p, a, c) > r for p, r in zip(pos, radius) for a, c in walls)
        if not (clear and (gaps + 10 * np.eye(n + m) > 0).all()):
            continue  # starts must be apart
        new_pos, new_obs = pos + rng.uniform(-2.5, 2.5, (n, 2)), obs_pos + rng.uniform(-1.5, 1.5, (m, 2))
        seg_a, seg_b = np.array([[a for a, _ in walls]]), np.array([[c for _, c in walls]])
        stop, hits, collided, _ = kernels.stop_at_contact(
            pos[None], new_pos[None], radius[None], np.ones((1, n), bool), np.ones((1, n), bool), obs_pos[None],
            new_obs[None], obs_radius[None], seg_a, seg_b, np.ones((1, 2), bool), np.ones(1, bool),
        )  # fmt: skip
        want = sampled_stops(pos, new_pos, radius, obs_pos, new_obs, obs_radius, walls)
        np.testing.assert_allclose(stop[0], want, atol=2.0 / 4000)
        assert (collided[0] == (want < 1)).all() and (hits[0].any(axis=1) == collided[0]).all()
        compared += 1
        stopped += int(collided.sum())
    assert stopped >= 10  # contacts were exercised


def test_batched_worlds_equal_one_by_one_with_crashes():
    s = Scenario(
        kind="walls", n_robots=6, dt=0.5, on_collision="terminate", robot=RobotSpec(v_max=3.0, a_max=6.0), max_steps=40
    )
    together, alone = Simulator(s, 3, "absolute"), [Simulator(s, 1, "absolute") for _ in range(3)]
    together.reset([4, 5, 6])
    for b, sim in enumerate(alone):
        sim.reset([4 + b])
    rng = np.random.default_rng(1)
    crashes = 0
    for _ in range(20):
        actions = rng.uniform(-1, 1, (3, s.n_robots, 2))
        ev = together.step(actions)
        crashes += int(ev.collided.sum())
        for b, sim in enumerate(alone):
            one = sim.step(actions[b : b + 1])
            np.testing.assert_array_equal(together.world.pos[b], sim.world.pos[0])
            for name in ("collided", "robot_hits", "wall_hits", "min_separation", "reached"):
                np.testing.assert_array_equal(getattr(ev, name)[b], getattr(one, name)[0], err_msg=name)
    assert crashes >= 3
