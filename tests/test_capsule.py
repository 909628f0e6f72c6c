"""Velocity obstacle of a wall capsule (baselines.capsule) against its numpy oracle and a slow twin."""

import math

import numpy as np

from baselines.capsule import capsule_forbidden, capsule_tau, reference_capsule_tau

T_MAX = 20.0


def scalar_capsule_tau(a, b, w, r):
    """Slow twin: march the centre w t along t in steps of 1 ms until it is within r of [a, b],
    then bisect; None when the path only grazes the capsule (ambiguous at this resolution) or
    starts inside it (the half-plane rule, checked by hand below)."""

    def gap(t):
        """Gap(s) to the capsule at time(s) t: distance of w t to the nearest point of [a, b], minus r."""
        p = w * np.asarray(t, dtype=float)[..., None]
        ab = b - a
        u = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
        return np.linalg.norm(p - (a + u[..., None] * ab), axis=-1) - r

    ts = np.arange(0.0, T_MAX, 1e-3)
    gaps = gap(ts)
    if gaps[0] <= 0.0:
        return None
    if np.all(gaps > 1e-3):
        return math.inf
    if np.all(gaps > -1e-3):
        return None
    k = int(np.argmax(gaps <= 0.0))
    lo, hi = ts[k - 1], ts[k]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if gap(mid) <= 0.0 else (mid, hi)
    return hi


def test_capsule_tau_matches_numpy_oracle():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-4, 4, (2000, 2)), rng.uniform(-4, 4, (2000, 2))
    w, r = rng.uniform(-2, 2, (2000, 2)), rng.uniform(0.1, 0.8, 2000)
    got = np.array([capsule_tau(*a[i], *b[i], *w[i], r[i]) for i in range(2000)])
    want = reference_capsule_tau(a, b, w, r)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    assert np.isfinite(got).sum() > 400 and (got == 0).sum() > 20 and np.isinf(got).sum() > 400


def test_capsule_tau_matches_slow_twin():
    rng = np.random.default_rng(1)
    checked = 0
    for _ in range(60):
        a, b = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        w, r = rng.uniform(-1, 1, 2), rng.uniform(0.1, 0.6)
        twin = scalar_capsule_tau(a, b, w, r)
        if twin is None:
            continue
        got = capsule_tau(a[0], a[1], b[0], b[1], w[0], w[1], r)
        if math.isinf(twin):
            assert got >= T_MAX
        else:
            assert abs(got - twin) < 1e-6
        checked += 1
    assert checked > 40


def test_capsule_by_hand():
    # Wall x = 1 from y = -1 to 1; robot of radius 0.25 at the origin.
    a, b = (1.0, -1.0), (1.0, 1.0)
    assert capsule_tau(*a, *b, 1.0, 0.0, 0.25) == 0.75  # straight at the side
    assert math.isinf(capsule_tau(*a, *b, -1.0, 0.0, 0.25))  # away
    assert math.isinf(capsule_tau(*a, *b, 0.0, 1.0, 0.25))  # parallel
    # At the end disc around (1, 1): moving along y = 1 reaches it at x = 0.75.
    assert abs(capsule_tau(*a, *b, 1.0, 1.0, 0.25) - 0.75) < 1e-12  # (0.75, 0.75) is on the side
    assert capsule_forbidden(*a, *b, 1.0, 0.0, 0.25, 1.0) and not capsule_forbidden(*a, *b, 1.0, 0.0, 0.25, 0.5)
    # Inside the capsule: toward the wall collides now, away is free.
    assert capsule_tau(0.1, -1.0, 0.1, 1.0, 1.0, 0.0, 0.25) == 0.0
    assert math.isinf(capsule_tau(0.1, -1.0, 0.1, 1.0, -1.0, 0.0, 0.25))
