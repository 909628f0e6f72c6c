"""Plane geometry: hand-computed cases and vectorized == scalar twin on random inputs."""

import math

import numpy as np
import pytest

from vcs_env.geometry import closest_approach, point_segment_distance, rotate, time_to_collision, unit, wrap_angle


def scalar_closest_approach(r0, r1, samples=20001):
    """Brute force: sample the relative position along the step."""
    best = math.inf
    for k in range(samples):
        s = k / (samples - 1)
        x = r0[0] + s * (r1[0] - r0[0])
        y = r0[1] + s * (r1[1] - r0[1])
        best = min(best, math.hypot(x, y))
    return best


def scalar_ttc(p, w, r, t_max=60.0, dt=1e-4):
    """Brute force: march in time until the gap closes."""
    if math.hypot(*p) <= r:
        return 0.0
    t = 0.0
    while t < t_max:
        if math.hypot(p[0] - w[0] * t, p[1] - w[1] * t) <= r:
            return t
        t += dt
    return math.inf


def test_wrap_angle_range_and_values():
    a = np.array([0.0, math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 2 * math.pi, 7.0, -7.0])
    w = wrap_angle(a)
    assert np.all(w > -math.pi) and np.all(w <= math.pi)
    assert w[1] == pytest.approx(math.pi) and w[2] == pytest.approx(math.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)


def test_rotate_and_unit():
    v = rotate(np.array([1.0, 0.0]), np.array(math.pi / 2))
    np.testing.assert_allclose(v, [0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(unit(np.array([0.0, math.pi])), [[1, 0], [-1, 0]], atol=1e-15)


def test_closest_approach_hand_cases():
    # Head-on through each other: relative position goes from (1, 0) to (-1, 0): touches 0.
    assert closest_approach(np.array([1.0, 0.0]), np.array([-1.0, 0.0])) == pytest.approx(0.0)
    # Passing at lateral offset 0.3.
    assert closest_approach(np.array([1.0, 0.3]), np.array([-1.0, 0.3])) == pytest.approx(0.3)
    # Moving apart: closest at the start.
    assert closest_approach(np.array([1.0, 0.0]), np.array([2.0, 0.0])) == pytest.approx(1.0)
    # No motion.
    assert closest_approach(np.array([0.0, 2.0]), np.array([0.0, 2.0])) == pytest.approx(2.0)


def test_closest_approach_matches_scalar_twin(rng):
    r0 = rng.uniform(-3, 3, size=(200, 2))
    r1 = rng.uniform(-3, 3, size=(200, 2))
    vec = closest_approach(r0, r1)
    for k in range(0, 200, 5):
        assert vec[k] == pytest.approx(scalar_closest_approach(r0[k], r1[k]), abs=2e-4)


def test_point_segment_distance():
    d = point_segment_distance(np.array([0.0, 1.0]), np.array([-1.0, 0.0]), np.array([1.0, 0.0]))
    assert d == pytest.approx(1.0)
    d = point_segment_distance(np.array([3.0, 0.0]), np.array([-1.0, 0.0]), np.array([1.0, 0.0]))
    assert d == pytest.approx(2.0)


def test_time_to_collision_hand_cases():
    # Head-on: gap 2 - 0.5 = 1.5 m closing at 1 m/s.
    assert time_to_collision(np.array([2.0, 0.0]), np.array([1.0, 0.0]), 0.5) == pytest.approx(1.5)
    # Moving away, miss, or standing still: never.
    assert time_to_collision(np.array([2.0, 0.0]), np.array([-1.0, 0.0]), 0.5) == math.inf
    assert time_to_collision(np.array([2.0, 0.0]), np.array([0.0, 1.0]), 0.5) == math.inf
    assert time_to_collision(np.array([2.0, 0.0]), np.array([0.0, 0.0]), 0.5) == math.inf
    # Overlapping: 0.
    assert time_to_collision(np.array([0.2, 0.0]), np.array([-1.0, 0.0]), 0.5) == 0.0


@pytest.mark.slow
def test_time_to_collision_matches_brute_force(rng):
    """Spec U1: tau agrees with a brute-force search within 2e-3 s, or both are inf."""
    p = rng.uniform(-4, 4, size=(120, 2))
    w = rng.uniform(-1.5, 1.5, size=(120, 2))
    r = rng.uniform(0.2, 1.0, size=120)
    tau = time_to_collision(p, w, r)
    for k in range(120):
        ref = scalar_ttc(p[k], w[k], r[k], t_max=30.0, dt=5e-4)
        if math.isinf(ref):
            assert math.isinf(tau[k]) or tau[k] > 29.0
        else:
            assert tau[k] == pytest.approx(ref, abs=2e-3)
