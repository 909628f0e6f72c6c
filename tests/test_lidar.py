"""Lidar (vcs_env.lidar): ranges against an analytic scalar twin on random scenes, noise, the
optional observation block."""

import math

import numpy as np
import pytest
from numba import njit

import vcs_env
from vcs_env.lidar import LidarSpec, _ray_disc, _ray_segment, cast, cast_into, scan
from vcs_env.observations import observation_bounds, observation_dim
from vcs_env.scenario import CustomLayout, Scenario
from vcs_env.sim import Simulator


def twin_range(origin, angle, discs, segments, max_range):
    """Slow twin: the first hit of the ray origin + t (cos, sin) solved in closed form, object by
    object: |o + t d - c|^2 = rho^2 for a disc (the smaller root), o + t d = a + u (b - a) for a
    segment (Cramer's rule on the 2x2 system)."""
    o = np.asarray(origin, dtype=float)
    d = np.array([math.cos(angle), math.sin(angle)])
    best = max_range
    for c, rho in discs:
        f = o - np.asarray(c)
        if f @ f <= rho * rho:
            return 0.0
        # t^2 + 2 (f.d) t + |f|^2 - rho^2 = 0
        half_b, cc = f @ d, f @ f - rho * rho
        disc = half_b * half_b - cc
        if disc >= 0.0:
            t = -half_b - math.sqrt(disc)
            if t >= 0.0:
                best = min(best, t)
    for a, b in segments:
        a, b = np.asarray(a), np.asarray(b)
        m = np.array([[d[0], a[0] - b[0]], [d[1], a[1] - b[1]]])
        det = np.linalg.det(m)
        if abs(det) < 1e-12:  # parallel: on the segment's line the nearer end ahead is hit
            off = a - o
            if abs(off[0] * d[1] - off[1] * d[0]) <= 1e-9:
                ta, tb = off @ d, (b - o) @ d
                if max(ta, tb) >= 0.0:  # an end ahead; 0 from a point on the segment
                    best = min(best, max(0.0, min(ta, tb)))
            continue
        t, u = np.linalg.solve(m, a - o)
        if t >= 0.0 and 0.0 <= u <= 1.0:
            best = min(best, t)
    return best


def test_ranges_match_the_analytic_twin_on_random_scenes():
    rng = np.random.default_rng(0)
    spec = LidarSpec(n_beams=24, fov=5.0, max_range=5.0)
    hits = 0
    for _ in range(15):
        B, n, m, s = 2, 4, 3, 5
        pos = rng.uniform(-4, 4, (B, n, 2))
        heading = rng.uniform(-np.pi, np.pi, (B, n))
        present = rng.random((B, n)) < 0.8
        radius = rng.uniform(0.1, 0.4, (B, n))
        obs_pos, obs_radius = rng.uniform(-4, 4, (B, m, 2)), rng.uniform(0.2, 0.6, (B, m))
        seg_a = rng.uniform(-4, 4, (B, s, 2))
        seg_b = seg_a + rng.uniform(-3, 3, (B, s, 2))
        seg_present = rng.random((B, s)) < 0.8
        got = cast(pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present, spec.offsets, 5.0)
        for b in range(B):
            for i in range(n):
                if not present[b, i]:
                    assert np.all(got[b, i] == 5.0)
                    continue
                discs = [(pos[b, j], radius[b, j]) for j in range(n) if j != i and present[b, j]]
                discs += [(obs_pos[b, j], obs_radius[b, j]) for j in range(m)]
                segs = [(seg_a[b, j], seg_b[b, j]) for j in range(s) if seg_present[b, j]]
                for q, off in enumerate(spec.offsets):
                    want = twin_range(pos[b, i], heading[b, i] + off, discs, segs, 5.0)
                    assert got[b, i, q] == pytest.approx(want, abs=1e-9)
                    hits += want < 5.0
    assert hits > 300


def test_beams_by_hand():
    """A robot at the origin facing +x: a wall at x = 2, an obstacle of radius 0.5 at (0, 3)."""
    s = Scenario(
        kind="custom",
        n_robots=1,
        n_obstacles=1,
        custom=CustomLayout(
            start=((0.0, 0.0),),
            goal=((0.0, -2.0),),
            heading=(0.0,),
            walls=(((2.0, -5.0), (2.0, 5.0)),),
            obstacles=(vcs_env.ObstacleTrajectory(times=(0.0,), positions=((0.0, 3.0),), radius=0.5),),
        ),
        lidar=LidarSpec(n_beams=4, fov=2 * math.pi, max_range=10.0),
    )
    w = Simulator(s).reset(0)
    # Beams at -135, -45, 45, 135 degrees from +x.
    r = scan(w, s.lidar)[0, 0]
    assert r[1] == pytest.approx(2.0 * math.sqrt(2.0)) and r[2] == pytest.approx(2.0 * math.sqrt(2.0))
    assert r[0] == 10.0 and r[3] == 10.0
    s2 = Scenario(**{**s.__dict__, "lidar": LidarSpec(n_beams=1, fov=0.5, max_range=10.0)})
    w.heading[:] = math.pi / 2  # straight at the obstacle
    assert scan(w, s2.lidar)[0, 0, 0] == pytest.approx(2.5)


@pytest.mark.parametrize(
    "heading, wall, want",
    [
        (0.0, ((2.0, 0.0), (3.0, 0.0)), 2.0),
        (math.pi, ((-3.0, 0.0), (-2.0, 0.0)), 2.0),
        (math.pi / 2, ((0.0, 0.6), (0.0, 3.0)), 0.6),  # in a door, looking along its jamb
        (-math.pi / 2, ((0.0, -3.0), (0.0, -0.6)), 0.6),
        (math.pi / 4, ((1.0, 1.0), (2.0, 2.0)), math.sqrt(2.0)),
    ],
)
def test_a_wall_seen_end_on_is_hit_at_its_nearer_end(heading, wall, want):
    """A beam along a wall's own line reads the distance to the wall's nearer end; it read max
    range (the beam and the wall are parallel, or parallel within rounding)."""
    s = Scenario(
        kind="custom",
        n_robots=1,
        custom=CustomLayout(start=((0.0, 0.0),), goal=((-1.0, 1.0),), heading=(heading,), walls=(wall,)),
        lidar=LidarSpec(n_beams=3, fov=0.3, max_range=4.0),
    )
    r = scan(Simulator(s).reset(0), s.lidar)[0, 0]
    assert r[1] == pytest.approx(want, abs=1e-9) and r[0] == 4.0 and r[2] == 4.0


def test_noise_is_seeded_by_the_world_and_clipped():
    spec = LidarSpec(n_beams=32, max_range=3.0, noise=0.05)
    s = vcs_env.make_scenario("doorway", lidar=spec)
    a = Simulator(s).reset(5)
    b = Simulator(s).reset(5)
    clean = scan(a, LidarSpec(n_beams=32, max_range=3.0))
    np.testing.assert_array_equal(scan(a, spec), scan(b, spec))  # same world state, same scan
    diff = scan(a, spec) - clean
    assert 0.02 < diff[clean < 2.5].std() < 0.08 and np.all(scan(a, spec) <= 3.0) and np.all(scan(a, spec) >= 0.0)


def test_lidar_is_an_optional_observation_block():
    base = vcs_env.make_scenario("doorway")
    with_lidar = vcs_env.make_scenario("doorway", lidar=LidarSpec(n_beams=12, max_range=4.0))
    assert observation_dim(with_lidar) == observation_dim(base) + 12
    low, high = observation_bounds(with_lidar)
    assert np.all(low[-12:] == 0.0) and np.all(high[-12:] == 1.0)
    env = vcs_env.parallel_env(scenario=with_lidar)
    obs, _ = env.reset(seed=0)
    o = obs["robot_0"]
    plain, _ = vcs_env.parallel_env(scenario=base).reset(seed=0)
    np.testing.assert_array_equal(o[:-12], plain["robot_0"])  # the default observation is unchanged
    w = env.engine.world
    np.testing.assert_allclose(o[-12:], scan(w, with_lidar.lidar)[0, 0] / 4.0, rtol=1e-6)
    assert env.observation_space("robot_0").contains(o)


def test_bad_lidar_specs_are_refused():
    for kw, field in (({"n_beams": 0}, "n_beams"), ({"fov": 7.0}, "fov"), ({"max_range": -1.0}, "max_range")):
        with pytest.raises(ValueError, match=field):
            LidarSpec(**kw)
    with pytest.raises(ValueError, match="lidar"):
        vcs_env.make_scenario("circle", lidar="yes")


@njit
def brute_cast(pos, heading, present, radius, obs_pos, obs_radius, seg_a, seg_b, seg_present, offsets, max_range):
    """Oracle of the pruned :func:`cast`: every beam of every robot against every body."""
    B, n = radius.shape
    out = np.full((B, n, offsets.shape[0]), max_range)
    for b in range(B):
        for i in range(n):
            if not present[b, i]:
                continue
            ox, oy = pos[b, i, 0], pos[b, i, 1]
            for q in range(offsets.shape[0]):
                c, s, co, so = (
                    math.cos(heading[b, i]),
                    math.sin(heading[b, i]),
                    math.cos(offsets[q]),
                    math.sin(offsets[q]),
                )
                dx, dy = c * co - s * so, s * co + c * so  # the beam's robot-frame direction, rotated
                best = max_range
                for j in range(n):
                    if j != i and present[b, j]:
                        best = min(best, _ray_disc(ox, oy, dx, dy, pos[b, j, 0], pos[b, j, 1], radius[b, j]))
                for j in range(obs_radius.shape[1]):
                    best = min(best, _ray_disc(ox, oy, dx, dy, obs_pos[b, j, 0], obs_pos[b, j, 1], obs_radius[b, j]))
                for j in range(seg_present.shape[1]):
                    if seg_present[b, j]:
                        ax, ay, bx, by = seg_a[b, j, 0], seg_a[b, j, 1], seg_b[b, j, 0], seg_b[b, j, 1]
                        best = min(best, _ray_segment(ox, oy, dx, dy, ax, ay, bx, by))
                out[b, i, q] = best
    return out


@pytest.mark.parametrize("max_range", [0.5, 2.0, 5.0, 30.0])
def test_pruned_cast_equals_the_brute_force_bit_for_bit(max_range):
    """Pruning by range keeps every range (short ranges prune most bodies); the serial and the
    parallel twin alike, across blocks of worlds."""
    rng = np.random.default_rng(int(max_range * 10))
    B, n, m, s = 37, 6, 8, 12
    pos = rng.uniform(-5, 5, (B, n, 2))
    args = (
        pos, rng.uniform(-np.pi, np.pi, (B, n)), rng.random((B, n)) < 0.85, rng.uniform(0.1, 0.4, (B, n)),
        rng.uniform(-5, 5, (B, m, 2)), rng.uniform(0.1, 0.6, (B, m)),
        rng.uniform(-6, 6, (B, s, 2)), rng.uniform(-6, 6, (B, s, 2)), rng.random((B, s)) < 0.8,
        LidarSpec(n_beams=64).offsets, max_range,
    )  # fmt: skip
    want = brute_cast(*args)
    assert 0 < (want < max_range).mean() < 1
    for kernel in (cast_into.serial, cast_into.parallel):
        got = np.empty_like(want)
        kernel(*args, got, 1.0)
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(cast(*args), want)
