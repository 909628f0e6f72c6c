"""Static walls: segment geometry, the swept wall kernel against its numpy oracle, tunnelling,
custom maps from arrays and their validation, wall contacts in episodes."""

import numpy as np
import pytest

from vcs_env import kernels
from vcs_env.contacts import contact_events
from vcs_env.rollout import run_episodes
from vcs_env.scenario import CustomLayout, RobotSpec, Scenario
from vcs_env.sim import Simulator
from vcs_env.walls import box_segments, polygon_segments, reference_wall_events, segment_distance


def scalar_segment_distance(p, q, a, b):
    """Slow twin: the distance from a point of [p, q] to [a, b] is convex along [p, q];
    ternary search on it, each point's distance to [a, b] by projection."""

    def to_ab(x):
        ab = b - a
        u = min(max(float((x - a) @ ab / (ab @ ab)), 0.0), 1.0)
        return float(np.linalg.norm(x - (a + u * ab)))

    lo, hi = 0.0, 1.0
    for _ in range(200):
        m1, m2 = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        if to_ab(p + m1 * (q - p)) <= to_ab(p + m2 * (q - p)):
            hi = m2
        else:
            lo = m1
    return min(to_ab(p), to_ab(q), to_ab(p + lo * (q - p)))


@pytest.mark.slow
def test_segment_distance_matches_scalar_twin():
    rng = np.random.default_rng(0)
    p, q, a, b = (rng.uniform(-2, 2, (400, 2)) for _ in range(4))
    got = segment_distance(p, q, a, b)
    want = np.array([scalar_segment_distance(*x) for x in zip(p, q, a, b)])
    np.testing.assert_allclose(got, want, atol=1e-9)
    assert (got == 0).sum() > 40 and (got > 0.1).sum() > 100  # crossings and clear pairs both exercised


def test_segment_distance_by_hand():
    a, b = np.array([0.0, -1.0]), np.array([0.0, 1.0])
    assert segment_distance(np.array([-1.0, 0.0]), np.array([1.0, 0.0]), a, b) == 0.0  # crossing
    assert segment_distance(np.array([-2.0, 0.0]), np.array([-0.5, 0.0]), a, b) == 0.5
    assert segment_distance(np.array([1.0, 2.0]), np.array([1.0, 5.0]), a, b) == pytest.approx(np.sqrt(2.0))


def test_wall_kernel_equals_numpy_oracle_bit_for_bit():
    rng = np.random.default_rng(1)
    hits = 0
    for trial in range(30):
        B, n, s = 3, 5, 7
        spread = 3.0 if trial % 2 else 10.0  # wide worlds exercise the broad phase's skips
        pos = rng.uniform(-spread, spread, (B, n, 2))
        new_pos = pos + rng.uniform(-1.5, 1.5, (B, n, 2))
        radius = rng.uniform(0.1, 0.5, (B, n))
        present, acted = rng.random((B, n)) < 0.9, rng.random((B, n)) < 0.8
        seg_a = rng.uniform(-spread, spread, (B, s, 2))
        seg_b = seg_a + rng.uniform(-2, 2, (B, s, 2))
        seg_present = rng.random((B, s)) < 0.8
        # The smallest gap so far (to robots and obstacles): some inf, some below the walls' gaps.
        sep = np.where(rng.random((B, n)) < 0.5, np.inf, rng.uniform(-0.2, 1.0, (B, n)))
        collided = rng.random((B, n)) < 0.2
        got = kernels.wall_events(pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided)
        want = reference_wall_events(pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
        hits += int(got[0].sum())
    assert hits > 50


def test_cached_wall_kernel_equals_numpy_oracle_over_many_steps():
    """The per-robot wall candidates kept from step to step (``wall_events_cached``) against the
    oracle: random walks that mostly stay in their balls (candidates reused), some jumps out of
    them, radii that grow and shrink, robots that stop acting, a world emptied as a reset would."""
    rng = np.random.default_rng(2)
    B, n, s = 4, 6, 9
    for trial in range(12):
        seg_a = rng.uniform(-4, 4, (B, s, 2))
        seg_b = seg_a + rng.uniform(-2, 2, (B, s, 2))
        seg_present = rng.random((B, s)) < 0.85
        pos = rng.uniform(-4, 4, (B, n, 2))
        radius = rng.uniform(0.1, 0.4, (B, n))
        cache = kernels.wall_cache(B, n, s)
        reach = (0.05, 0.3, 1.0, 3.0)[trial % 4]
        reused = hits = 0
        for step in range(60):
            new_pos = pos + rng.normal(0.0, 0.04, (B, n, 2)) * rng.choice((0.1, 1.0, 5.0), (B, n, 1))
            jump = rng.random((B, n)) < 0.03  # teleports (a robot set by hand)
            new_pos[jump] = rng.uniform(-4, 4, (int(jump.sum()), 2))
            radius = np.where(rng.random((B, n)) < 0.05, rng.uniform(0.1, 0.5, (B, n)), radius)
            present, acted = rng.random((B, n)) < 0.95, rng.random((B, n)) < 0.9
            sep = np.where(rng.random((B, n)) < 0.5, np.inf, rng.uniform(-0.2, 1.5, (B, n)))
            collided = rng.random((B, n)) < 0.1
            args = (pos, new_pos, radius, present, acted, seg_a, seg_b, seg_present, sep, collided)
            before = cache[0].copy()
            got = kernels.wall_events_cached(*args, *cache, reach)
            want = reference_wall_events(*args)
            for g, w in zip(got, want):
                np.testing.assert_array_equal(g, w)
            reused += int((acted & present & (cache[0] == before).all(axis=2) & (before[..., 2] >= 0)).sum())
            hits += int(got[0].sum())
            if step == 30:  # world 1 gets new walls: its cache is emptied, as Simulator.reset does
                seg_a[1] = rng.uniform(-4, 4, (s, 2))
                seg_b[1] = seg_a[1] + rng.uniform(-2, 2, (s, 2))
                cache[0][1, :, 2] = -1.0
            pos = new_pos
        assert reused > 200 and hits > 0


def test_simulator_wall_events_equal_the_oracle_across_resets(monkeypatch):
    """The simulator's persistent wall candidates give the oracle's events at every step, also
    after worlds are reset onto new random maps (autoreset with different walls), and when a
    reset world's robots are put back by hand where they were on the old map (their old
    candidates would still cover their motion)."""
    from vcs_env.engine import NavEngine
    from vcs_env.scenario import make_scenario

    cached, checked = kernels.wall_events_cached, [0]

    def check(*args):
        got = cached(*args)
        for g, w in zip(got, reference_wall_events(*(a.copy() for a in args[:10]))):
            np.testing.assert_array_equal(g, w)
        checked[0] += 1
        return got

    monkeypatch.setattr(kernels, "wall_events_cached", check)
    s = make_scenario("walls", n_robots=4, n_walls=12, on_collision="continue", max_steps=25)
    eng = NavEngine(s, batch_size=3)
    eng.reset([0, 1, 2])
    actions = np.random.default_rng(0).uniform(-1, 1, (80, 3, 4, 2))
    segments = eng.world.seg_a.copy()
    for t, a in enumerate(actions):
        eng.step(a, autoreset=True)
        if t % 10 == 5:
            pos = eng.world.pos.copy()
            eng.reset([100 + t], worlds=[t % 3])
            eng.world.pos[t % 3] = pos[t % 3]
    assert checked[0] == 80 and not np.array_equal(segments, eng.world.seg_a)


def wall_scenario(start, goal, walls, **kw):
    return Scenario(
        kind="custom",
        n_robots=len(start),
        custom=CustomLayout(start=start, goal=goal, walls=walls),
        on_collision="continue",
        **kw,
    )


def test_fast_robot_cannot_tunnel_through_a_thin_wall():
    """3 m/s for 0.3 s is 0.9 m: from x = -0.4 to x = 0.5, both ends clear of the wall at x = 0."""
    fast = RobotSpec(radius=0.1, v_max=3.0, a_max=10.0, holonomic=True)
    walls = (((0.0, -3.0), (0.0, 3.0)),)
    s = wall_scenario(((-0.4, 0.0),), ((3.0, 0.0),), walls, robot=fast, initial_speed=3.0, dt=0.3)
    sim = Simulator(s)
    sim.reset(0)
    ev = sim.step(np.zeros((1, 1, 2)))  # holonomic delta 0: keep 3 m/s along +x
    assert sim.world.pos[0, 0, 0] == pytest.approx(0.5)
    assert ev.wall_hits[0, 0, 0] and ev.collided[0, 0] and ev.min_separation[0, 0] == pytest.approx(-0.1)
    # The same motion through a door in the wall touches nothing.
    door = (((0.0, -3.0), (0.0, -0.3)), ((0.0, 0.3), (0.0, 3.0)))
    sim = Simulator(wall_scenario(((-0.4, 0.0),), ((3.0, 0.0),), door, robot=fast, initial_speed=3.0, dt=0.3))
    sim.reset(0)
    ev = sim.step(np.zeros((1, 1, 2)))
    assert not ev.collided[0, 0] and ev.min_separation[0, 0] == pytest.approx(0.2)


def test_walls_are_per_world_arrays_with_a_mask():
    s = wall_scenario(((-2.0, 0.0),), ((2.0, 0.0),), box_segments(4.0))
    sim = Simulator(s, batch_size=3)
    w = sim.reset(0)
    assert w.seg_a.shape == (3, 4, 2) and w.seg_present.all()
    np.testing.assert_array_equal(w.world(1).seg_b[0], box_segments(4.0)[:, 1])


def test_no_walls_gives_empty_arrays():
    w = Simulator(Scenario(kind="swap", n_robots=2), batch_size=2).reset(0)
    assert w.seg_a.shape == (2, 0, 2) and w.n_segments == 0


@pytest.mark.parametrize(
    "walls, start, message",
    [
        ((((0.0, 0.0), (0.0, 0.0)),), ((-2.0, 0.0),), "degenerate"),
        ((((0.0, 0.0), (0.0, np.nan)),), ((-2.0, 0.0),), "finite"),
        ((((0.0, 0.0), (1.0, 0.0), (2.0, 0.0)),), ((-2.0, 0.0),), "shape"),
        ((((-2.1, -1.0), (-2.1, 1.0)),), ((-2.0, 0.0),), "start 0"),
        (tuple(map(tuple, box_segments(1.0).tolist())), ((0.0, 0.0),), "no route"),
        ({"x": 1}, ((-2.0, 0.0),), "or a list of such arrays, got dict"),  # was numpy's TypeError
    ],
)
def test_bad_custom_walls_are_refused_with_a_clear_error(walls, start, message):
    with pytest.raises(ValueError, match=message):
        wall_scenario(start, ((2.0, 0.0),), walls)


def test_walls_may_be_a_list_of_polygons():
    # One segment array per polygon, of different lengths (numpy's "inhomogeneous shape" before).
    tri = polygon_segments(((0.5, 0.5), (1.5, 0.5), (0.5, 1.5)))
    s = wall_scenario(((-2.0, -2.0),), ((2.0, -2.0),), [tri, box_segments(3.0)])
    np.testing.assert_array_equal(Simulator(s).reset(0).seg_a[0, :7], np.concatenate((tri, box_segments(3.0)))[:, 0])


def test_polygon_is_a_closed_chain():
    seg = polygon_segments(((0, 0), (1, 0), (0, 1)))
    np.testing.assert_array_equal(seg[-1], [[0, 1], [0, 0]])
    with pytest.raises(ValueError, match="3 vertices"):
        polygon_segments(((0, 0), (1, 0)))


def test_wall_contacts_are_recorded_and_explained():
    """A robot driven straight into a wall: an obstacle-like contact of kind "wall", at fault."""
    s = wall_scenario(((-1.0, 0.0),), ((1.0, 0.0),), (((0.0, -1.0), (0.0, 1.0)),), max_steps=40)
    full = np.array([[[1.0, 0.0]]])

    def control(world, obs):
        return full

    (ep,) = run_episodes(s, control, seeds=[0])
    assert ep.wall_hits.shape[-1] == 1 and ep.wall_hits.any() and ep.obstacle_contact.any()
    first = contact_events(ep)[0]
    assert first.kind == "wall" and first.other == 0 and first.at_fault


def test_line_of_sight_skips_only_walls_out_of_reach():
    # routes._clear_line skips a wall whose bounding box lies beyond r of the line's, or whose ends lie on one side
    # of the line's carrier beyond r; its answers must be those of the segment distance to every wall, also for
    # walls within 1e-9 m of r either way.
    from vcs_env.kernels import _segment_distance
    from vcs_env.routes import _clear_line

    rng = np.random.default_rng(5)
    boxed = sided = 0
    for _ in range(6000):
        p, q = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        r = rng.uniform(0.1, 0.6)
        seg = rng.uniform(-4, 4, (4, 2, 2))
        tie = rng.choice([-1e-9, 0.0, 1e-9, 2e-9, 1e-6])
        # one wall parallel to an axis, its box r + tiny from the line's box (ties with the skip's margin)
        x0 = max(p[0], q[0]) + r + tie
        seg[0] = ((x0, rng.uniform(-3, 3)), (x0, rng.uniform(-3, 3)))
        # one wall beside the line, its ends r + tiny from the carrier on one side, along the line's extent
        u = (q - p) / np.linalg.norm(q - p)
        off = np.array([-u[1], u[0]]) * (r + tie + rng.choice([0.0, 0.3]) * rng.random())
        seg[1] = (p + off + 0.2 * (q - p), q + off - 0.2 * (q - p))
        want = all(_segment_distance(*p, *q, *w[0], *w[1]) >= r for w in seg)
        assert _clear_line(*p, *q, seg, r) == want
        boxed += want and seg[0, :, 0].min() - max(p[0], q[0]) > r + 1e-9
        sided += want and tie > 1e-9
    assert boxed > 100 and sided > 100  # both skips were taken


def test_nearly_collinear_segments_far_apart_do_not_cross():
    # Two segments on one line (up to rounding), apart along it: the side tests of the crossing check round to
    # either sign there; the distance is the gap along the line, never a crossing (0), for the kernel, its numpy
    # oracle, the swept wall kernel and the lines of sight (routes._clear_line skips such walls by their boxes).
    from vcs_env.kernels import _segment_distance
    from vcs_env.routes import _clear_line
    from vcs_env.wall_kernels import _swept_wall_distance

    rng = np.random.default_rng(0)
    spurious_before = 0
    for _ in range(20000):
        th = rng.uniform(0, 2 * np.pi)
        d, o = np.array([np.cos(th), np.sin(th)]), rng.uniform(-5, 5, 2)
        t = np.sort(rng.uniform(-6, 6, 4))
        a, b, p, q = (o + s * d for s in t)
        gap = t[2] - t[1]
        want = segment_distance(p, q, a, b)
        got = _segment_distance(*p, *q, *a, *b)
        m, h = (p + q) / 2, np.linalg.norm(q - p) / 2
        swept = _swept_wall_distance(*p, *q, *a, *b, *m, h)
        assert got == want == swept
        assert got >= gap - 1e-9
        assert _clear_line(*p, *q, np.array([[a, b]]), 0.5 * gap) == (got >= 0.5 * gap)

        def det(u, v):
            return u[0] * v[1] - u[1] * v[0]

        ab, pq = b - a, q - p
        spurious_before += det(ab, p - a) * det(ab, q - a) < 0 and det(pq, a - p) * det(pq, b - p) < 0
    assert spurious_before > 0  # the side tests alone read crossings here: the case is exercised


def test_box_segments_refuses_a_half_size_that_is_not_positive():
    """box_segments(-1.0) drew the box of half size 1 (its corners in another order)."""
    from vcs_env.walls import box_segments

    for args in ((-1.0,), (2.0, -0.5), (0.0,)):
        with pytest.raises(ValueError, match="must be > 0"):
            box_segments(*args)


def test_a_wall_square_to_the_heading_reads_the_same_at_any_heading():
    """Two robots in the same situation mirrored through the origin (headings 0 and pi, a wall with a door square to
    both) read their wall segments differently: cos(pi / 2) is 6e-17, so the tie at tx = 0 went by rounding."""
    import math

    import vcs_env
    from vcs_env import observations
    from vcs_env.scenario import CustomLayout, Scenario

    walls = (((0.0, 0.6), (0.0, 4.0)), ((0.0, -4.0), (0.0, -0.6)))
    layout = CustomLayout(
        start=((-2.0, 1.5), (2.0, -1.5)), goal=((-2.0, 2.5), (2.0, -2.5)), heading=(0.0, math.pi), walls=walls
    )
    s = Scenario(kind="custom", n_robots=2, custom=layout, n_wall_points=2, wall_segments=True, n_neighbors=1)
    obs, _ = vcs_env.parallel_env(scenario=s).reset(seed=0)
    read = observations.observation_layout(s).read
    a, b = (read(obs[f"robot_{i}"], "wall_points") for i in (0, 1))
    np.testing.assert_allclose(
        a, b, rtol=0, atol=1e-12
    )  # ty was +1 for one and -1 for the other, back and ahead swapped
    assert a[0, 4] == b[0, 4] == 1.0 and a[0, 3] == b[0, 3] == 0.0  # the wall ahead: ty = +1, tx exactly 0
