"""VCS geometry, vcs-method §4.0 (U1-U7): vectorized reference functions against scalar twins and
brute force, and the numba planner kernel against the numpy reference."""

import dataclasses
import math

import numpy as np
import pytest

import vcs_env
from baselines.vcs import VCSPlanner, kernel
from baselines.vcs import geometry as G
from vcs_env.dynamics import integrate
from vcs_env.engine import NavEngine


def scalar_tau(px, py, wx, wy, r):
    """Scalar twin of the time to collision (vcs-method §2.2)."""
    c = px * px + py * py - r * r
    if c <= 0:
        return 0.0
    a, b = wx * wx + wy * wy, wx * px + wy * py
    d = b * b - a * c
    if a <= 0 or b <= 0 or d < 0:
        return math.inf
    return (b - math.sqrt(d)) / a


def random_pairs(rng, k):
    """Relative positions outside the combined radius, velocities, radii."""
    r = rng.uniform(0.3, 1.0, size=k)
    ang = rng.uniform(-math.pi, math.pi, size=k)
    d = r + rng.uniform(0.05, 5.0, size=k)
    p = d[:, None] * np.stack((np.cos(ang), np.sin(ang)), -1)
    w = rng.uniform(-2, 2, size=(k, 2))
    return p, w, r


def test_u1_tau_numba_and_numpy_match_the_scalar_twin(rng):
    p, w, r = random_pairs(rng, 2000)
    vec = G.time_to_collision(p, w, r)
    for k in range(2000):
        ref = scalar_tau(p[k, 0], p[k, 1], w[k, 0], w[k, 1], r[k])
        assert kernel.tau(p[k, 0], p[k, 1], w[k, 0], w[k, 1], r[k]) == ref
        assert (vec[k] == ref) or abs(vec[k] - ref) < 1e-12
        # tau_within(T) <=> tau <= T (finite)
        for horizon in (0.5, 2.0, math.inf):
            assert kernel.tau_within(p[k, 0], p[k, 1], w[k, 0], w[k, 1], r[k], horizon) == (
                math.isfinite(ref) and ref <= horizon
            )


def test_u2_cone_membership_equals_finite_tau(rng):
    """U2: the det-sign cone test agrees with finiteness of tau on 2000 random cases."""
    p, w, r = random_pairs(rng, 2000)
    _, alpha, n, l = G.cone(p, r)
    assert np.all((alpha > 0) & (alpha < math.pi / 2))
    inside = G.in_cone(w, n, l)
    finite = np.isfinite(G.time_to_collision(p, w, r))
    np.testing.assert_array_equal(inside, finite)
    assert 0.05 < inside.mean() < 0.95  # both outcomes are exercised


def test_u3_hrvo_apex_lies_on_both_side_lines(rng):
    """U3: the apex lies on the VO side line and on the RVO side line, both branches."""
    p, _, r = random_pairs(rng, 500)
    v_r = rng.uniform(-1, 1, size=(500, 2))
    v_j = rng.uniform(-1, 1, size=(500, 2))
    pref_r = rng.uniform(-1, 1, size=(500, 2))
    pref_j = rng.uniform(-1, 1, size=(500, 2))
    apex = G.hrvo_apex(p, r, v_r, v_j, pref_r, pref_j)
    _, _, n, l = G.cone(p, r)
    m = G.rvo_apex(v_r, v_j)
    left = G.det(p, pref_r - pref_j) > 0
    assert left.any() and (~left).any()
    # Passing left: right side from the VO (through v_j along n), left side from the RVO.
    vo_dir = np.where(left[:, None], n, l)
    rvo_dir = np.where(left[:, None], l, n)
    res_vo = np.abs(G.det(apex - v_j, vo_dir))
    res_rvo = np.abs(G.det(apex - m, rvo_dir))
    scale = 1 + np.abs(apex).max(axis=1)
    assert np.all(res_vo / scale < 1e-9) and np.all(res_rvo / scale < 1e-9)


def test_u3_snape_else_branch_sign_error_is_real(rng):
    """vcs-method §2.17: the reference code's `else` formula does not land on the RVO side line;
    our explicit intersection does (guards against porting it)."""
    p, _, r = random_pairs(rng, 200)
    v_r = rng.uniform(-1, 1, size=(200, 2))
    v_j = rng.uniform(-1, 1, size=(200, 2))
    _, alpha, n, l = G.cone(p, r)
    m = G.rvo_apex(v_r, v_j)
    s_code = 0.5 * G.det(v_r - v_j, n) / np.sin(2 * alpha)  # snape/HRVO `else` branch
    apex_code = v_j + s_code[:, None] * l
    off = np.abs(G.det(apex_code - m, n)) > 1e-6
    assert off.mean() > 0.9


def test_u4_static_closed_form_matches_tau(rng):
    """U4: t_c(s, delta) = (d cos(delta) - sqrt(r^2 - d^2 sin^2(delta))) / s vs tau."""
    for _ in range(300):
        d, r = rng.uniform(1.0, 5.0), rng.uniform(0.3, 0.9)
        phi = rng.uniform(-math.pi, math.pi)
        s, delta = rng.uniform(0.05, 2.0), rng.uniform(-math.pi, math.pi)
        p = d * np.array([math.cos(phi), math.sin(phi)])
        v = s * np.array([math.cos(phi + delta), math.sin(phi + delta)])
        ref = G.time_to_collision(p, v, r)
        got = G.static_collision_time(np.array(s), np.array(delta), d, r)
        assert (np.isinf(ref) and np.isinf(got)) or abs(got - ref) < 1e-9


def test_u5_column_speed_interval_matches_dense_sampling(rng):
    """U5: per direction, the speeds inside a translated cone form one interval."""
    speeds = np.linspace(0, 4, 4001)
    for _ in range(200):
        p, _, r = random_pairs(rng, 1)
        apex = rng.uniform(-1, 1, size=2)
        _, _, n, l = G.cone(p[0], r[0])
        th = rng.uniform(-math.pi, math.pi)
        u = np.array([math.cos(th), math.sin(th)])
        lo, hi = G.column_speed_interval(u, apex, n, l)
        inside = G.in_cone(speeds[:, None] * u - apex, n, l)
        if inside.any():
            assert float(lo) == pytest.approx(speeds[inside].min(), abs=0.02)
            top = speeds[inside].max()
            assert (top > 3.99 and float(hi) >= 3.99) or float(hi) == pytest.approx(top, abs=0.02)
        else:
            assert not float(lo) < float(hi) or float(lo) >= 3.99


def test_u6_vcs_maps_round_trip(rng):
    v_r = rng.uniform(0, 1, size=1000)
    th_r = rng.uniform(-math.pi, math.pi, size=1000)
    dv = rng.uniform(-1, 1, size=1000)
    dv = np.where(v_r + dv > 1e-3, dv, 0.5 - v_r)
    dth = rng.uniform(-math.pi + 1e-9, math.pi, size=1000)
    back_dv, back_dth = G.velocity_to_vcs(G.vcs_to_velocity(dv, dth, v_r, th_r), v_r, th_r)
    assert np.max(np.abs(back_dv - dv)) < 1e-12
    assert np.max(np.abs(G.wrap_angle(back_dth - dth))) < 1e-12


def test_u7_windows_are_rectangles_reached_by_the_saturated_ramp(rng):
    """U7: W_1 is the one-step rectangle; every point of W_k is reached in <= k steps."""
    s = vcs_env.make_scenario("circle", n_robots=1)
    eng = NavEngine(s)
    eng.reset([0])
    w = eng.world
    for _ in range(60):
        v0 = rng.uniform(0, 1)
        k = int(rng.integers(1, 8))
        lo, hi, half = G.window(k, v0, 1.0, 0.5, math.pi / 2, 0.1)
        if k == 1:
            assert (lo, hi, half) == (max(-v0, -0.05), min(1 - v0, 0.05), pytest.approx(math.pi / 20))
        dv, dth = rng.uniform(lo, hi), rng.uniform(-half, half)
        steps = int(G.reach_steps(np.array(dv), np.array(dth), 0.5, math.pi / 2, 0.1))
        assert steps <= k
        w.speed[:] = v0
        w.heading[:] = 0.0
        w.pos[:] = 0.0
        target = np.array([[[v0 + dv, dth]]])
        for _ in range(steps):  # the saturated per-step ramp toward the target
            act = vcs_env.dynamics.target_to_action(w, target)
            w.speed, w.heading, w.pos = integrate(w, act.astype(np.float64))
        # (actions are float32: reached up to their rounding)
        assert w.speed[0, 0] == pytest.approx(v0 + dv, abs=1e-6)
        assert w.heading[0, 0] == pytest.approx(dth, abs=1e-6)


@pytest.mark.parametrize("reciprocity", ["hrvo", "rvo", "vo"])
def test_kernel_admissibility_matches_numpy_reference(reciprocity):
    """The numba kernel's forbidden sets equal the numpy reference built from geometry.py
    (size regulation, HRVO/RVO/VO apexes, truncation at each object's horizon)."""
    scenario = vcs_env.make_scenario("dynamic", n_robots=6, n_obstacles=6, r_ca=6.0)
    eng = NavEngine(scenario)
    eng.reset([3])
    planner = VCSPlanner(reciprocity=reciprocity)
    for _ in range(25):
        eng.step(planner.act(eng.world))
    w = eng.world
    from baselines.vcs.plot import object_forbidden_masks

    rng = np.random.default_rng(0)
    checked = 0
    for i in np.flatnonzero(w.active[0]):
        dv = rng.uniform(-w.speed[0, i], 1 - w.speed[0, i], size=400)
        dth = rng.uniform(-math.pi, math.pi, size=400)
        ok, _, horizon = planner.evaluate(w, 0, i, dv, dth)
        v = G.vcs_to_velocity(dv, dth, w.speed[0, i], w.heading[0, i])
        masks = object_forbidden_masks(w, planner, 0, i, v, horizon)
        forbidden = np.any(list(masks.values()), axis=0) if masks else np.zeros(400, dtype=bool)
        np.testing.assert_array_equal(ok, ~forbidden)
        checked += len(masks)
    assert checked > 10


@pytest.mark.parametrize(
    "field, value",
    [
        ("t_max", True),  # a bool is not a number of seconds
        ("t_max", 0.0),
        ("kappa", float("nan")),
        ("w_safety", -1.0),
        ("horizon", "forever"),
        ("horizon", -2.0),
        ("detour_jitter", 1.0),
        ("detour_angle", 4.0),
        ("detour_angle", True),
        ("n_v", True),
        ("n_v", 1),
        ("window_margin_steps", -1),
        ("window_margin_steps", 2.5),
        ("reciprocity", "orca"),
        ("r_ca", 0.0),
        ("fallback_clearance", -0.1),
        ("tau_s", 0.0),  # accepted, then a ZeroDivisionError in the search near walls
        ("stall_speed", 1.5),  # fractions of v_max: accepted above 1, and every robot detoured for good
        ("perturbation", 5.0),
        ("give_way_speed", 5.0),
    ],
)
def test_vcs_params_reject_bad_values_naming_the_field(field, value):
    from baselines.vcs.params import VCSParams

    with pytest.raises(ValueError, match=f"VCSParams.{field}") as e:
        VCSParams(**{field: value})
    assert repr(value) in str(e.value)


def test_vcs_params_accept_the_edges_of_their_ranges():
    from baselines.vcs.params import HORIZONS, VCSParams

    VCSParams(w_safety=0.0, detour_jitter=0.0, detour_angle=-math.pi, window_margin_steps=0, horizon=3, n_v=2)
    VCSParams(perturbation=0.0, stall_speed=1.0, give_way_speed=0.0)
    for horizon in HORIZONS:
        assert VCSParams(horizon=horizon).horizon == horizon


def test_period_kernels_match_numpy_bit_for_bit(rng):
    """The compiled noise and angle wrap around the search (``kernel.period``) give numpy's bits:
    the counter-based noise of :mod:`vcs_env.noise` and :func:`vcs_env.geometry.wrap_angle`,
    edge angles included (plans stay bit for bit those of the numpy version)."""
    from baselines.vcs.kernel import period
    from vcs_env import noise
    from vcs_env.geometry import wrap_angle

    key = rng.integers(0, 2**63, size=3, dtype=np.uint64) * np.uint64(2) + np.uint64(1)
    steps = np.array([0, 7, 123456])
    for stream in (1, 2):
        ref = noise.uniform(key, steps, 5, stream=stream)
        got = [[period.uniform(key[b], steps[b], i, stream) for i in range(5)] for b in range(3)]
        assert np.array_equal(np.array(got), ref)
    edges = [math.pi, -math.pi, 2 * math.pi, -2 * math.pi, 3 * math.pi, 0.0, -0.0, 1e-300, math.pi - 1e-16]
    angles = np.concatenate((rng.uniform(-20.0, 20.0, 2000), rng.uniform(-math.pi, math.pi, 2000), edges))
    got = np.array([period.wrap_angle(a) for a in angles])
    assert np.array_equal(got.view(np.uint64), wrap_angle(angles).view(np.uint64))


def test_kernel_wrap_gives_the_bits_of_the_remainder_form(rng):
    """The search's angle wrap (``kernel.scalar.wrap``) takes one subtraction or addition of 2 pi
    within a turn either side instead of Python's float remainder: the same bits as the remainder
    form, at and around the edges of each branch (x = +-pi, +-3 pi) and far out."""
    from baselines.vcs.kernel.scalar import wrap

    def oracle(x):
        if -math.pi < x <= math.pi:
            return x
        y = (x + math.pi) % (2.0 * math.pi) - math.pi
        return y + 2.0 * math.pi if y <= -math.pi else y

    edges = [k * math.pi for k in (-5, -4, -3, -2, -1, 0, 1, 2, 3, 4, 5)] + [1e-300, -0.0, 1e6, -1e6]
    near = [x + d * math.ulp(x or 1.0) for x in edges for d in range(-3, 4)]
    angles = np.concatenate((rng.uniform(-4 * math.pi, 4 * math.pi, 3000), rng.uniform(-100.0, 100.0, 500), near))
    got = np.array([wrap(float(a)) for a in angles])
    want = np.array([oracle(float(a)) for a in angles])
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))


def test_bounce_images_move_along_the_reflected_path():
    """The mirror image of an obstacle in the arena edge it moves toward (``mirror_bounces``)
    moves straight along the path the simulator's bounce gives the obstacle after it reflects
    (within two steps' travel: the simulator reverses a component one step before it would carry
    the disc through the edge), in x, in y and in a corner, and an axis without
    motion has no image in reach."""
    from baselines.vcs.planner import FAR, bounce_images
    from vcs_env import kernels

    half, dt = 6.0, 0.1
    pos = np.array([[[5.0, 0.0], [0.0, -5.2], [5.3, 5.1], [1.0, 2.0]]])
    vel = np.array([[[1.5, 0.0], [0.3, -1.2], [1.0, 1.4], [0.0, 0.0]]])
    radius = np.array([[0.3, 0.4, 0.2, 0.3]])
    img_pos, img_vel, img_r = bounce_images(pos, vel, radius, half)
    assert img_pos.shape == (1, 16, 2) and img_r.shape == (1, 16)
    m = pos.shape[1]
    p, v = pos.copy(), vel.copy()
    for k in range(1, 21):
        v, _ = kernels.bounce(p, v, radius, half, dt)
        p = p + v * dt
        t = k * dt
        # After every bounce of an obstacle, one of its images is where the obstacle is.
        images = img_pos[0] + img_vel[0] * t  # (4 m, 2)
        for q in range(3):
            bounced = np.any(np.sign(v[0, q]) != np.sign(vel[0, q]))
            if bounced:
                gaps = np.linalg.norm(images[q::m] - p[0, q], axis=-1)
                assert gaps.min() <= 2 * np.linalg.norm(vel[0, q]) * dt + 1e-9, (q, t)
    assert np.all(np.abs(img_pos[0, 3::m][1:]).max(axis=-1) >= FAR / 2)  # the standing obstacle: no images


@pytest.mark.parametrize("motion", ["arbitrary", "stop_and_go"])
def test_the_planners_obstacles_are_the_numpy_oracles_bit_for_bit(motion):
    """The obstacles the search reads (compiled: movers turned a lead ahead, then the mirror images of
    bouncing ones) are, bit for bit, the readable numpy composition: each velocity turned by its turn
    over the last period times lead / dt (none for a jump, a mover at rest or a first period), then
    their images in the edges they move toward."""
    from baselines.vcs.kernel.records import STATIC_SPEED
    from baselines.vcs.planner import FAR, MAX_TURN_RATE, turned_velocities
    from vcs_env.geometry import rotate, wrap_angle
    from vcs_env.suites import SUITES

    def turned_oracle(before, now, has, dt, lead):
        turn = wrap_angle(np.arctan2(now[..., 1], now[..., 0]) - np.arctan2(before[..., 1], before[..., 0]))
        moving = (np.hypot(before[..., 0], before[..., 1]) > STATIC_SPEED) & (
            np.hypot(now[..., 0], now[..., 1]) > STATIC_SPEED
        )
        smooth = has[:, None] & moving & (np.abs(turn) <= MAX_TURN_RATE * dt)
        return rotate(now, np.where(smooth, turn * (lead / dt), 0.0))

    def images_oracle(pos, vel, radius, half):
        edge = np.sign(vel) * (half - radius)[..., None]
        moving = vel != 0.0
        mirrored, flipped = np.where(moving, 2.0 * edge - pos, FAR), np.where(moving, -vel, 0.0)
        img_x = np.stack((mirrored[..., 0], pos[..., 1]), -1), np.stack((flipped[..., 0], vel[..., 1]), -1)
        img_y = np.stack((pos[..., 0], mirrored[..., 1]), -1), np.stack((vel[..., 0], flipped[..., 1]), -1)
        return (
            np.concatenate((pos, img_x[0], img_y[0], mirrored), axis=1),
            np.concatenate((vel, img_x[1], img_y[1], flipped), axis=1),
            np.concatenate((radius,) * 4, axis=1),
        )

    # a start from rest within a turn's reach of heading 0 (atan2 of a standstill), a stop, a turn
    before = np.array([[[0.0, 0.0], [1.0, 0.0], [1.2, 0.05]]])
    now = np.array([[[1.0, 0.1], [0.0, 0.0], [1.2, 0.1]]])
    want = turned_oracle(before, now, np.array([True]), 0.1, 0.2)
    assert turned_velocities(before, now, np.array([True]), 0.1, 0.2).tobytes() == want.tobytes()
    assert want[0, 0].tobytes() == now[0, 0].tobytes() and want[0, 2].tobytes() != now[0, 2].tobytes()
    scenario = dataclasses.replace(SUITES["dynamic-fast-v0"].scenario, obstacle_motion=motion)
    eng = NavEngine(scenario, 3)
    eng.reset([1000, 1001, 1002])
    planner = VCSPlanner()
    before = None
    turned = resting = 0
    for step in range(60):
        world = eng.world
        kw = planner._kernel_world(world)
        now = world.obs_vel.copy()
        has = np.full(3, before is not None)
        vel = turned_oracle(before if before is not None else now, now, has, float(world.dt), 0.2)
        turned += int(np.any(vel != now))
        resting += int(np.any(np.hypot(now[..., 0], now[..., 1]) <= STATIC_SPEED))
        want = images_oracle(world.obs_pos, vel, world.obs_radius, world.bounce_half)
        for got, exp in zip((kw.obs_pos, kw.obs_vel, kw.obs_radius), want, strict=True):
            assert got.tobytes() == exp.tobytes(), step
        before = now
        eng.step(planner.act(world))
    if motion == "arbitrary":
        assert turned > 30  # the obstacles turn (and the rule turns their velocities) in most steps
    else:
        assert resting > 0  # movers at rest, and starting again (no turn is read from a standstill)


def test_evaluate_refuses_a_world_a_robot_or_points_that_are_not_there():
    from vcs_env.sim import Simulator

    sim = Simulator(vcs_env.make_scenario("swap"))
    sim.reset(0)
    planner = VCSPlanner()
    with pytest.raises(ValueError, match=r"b \(a world of the batch\) must be an integer in \[0, 0\], got 5"):
        planner.evaluate(sim.world, 5, 0, [0.0], [0.0])  # a ZeroDivisionError inside the kernel
    with pytest.raises(ValueError, match=r"i \(a robot of the world\) must be an integer in \[0, 1\], got 7"):
        planner.evaluate(sim.world, 0, 7, [0.0], [0.0])
    with pytest.raises(ValueError, match=r"dv and dth must have one shape \(one point each\), got \(3,\) and \(1,\)"):
        planner.evaluate(sim.world, 0, 0, [0.0, 0.1, 0.2], [0.0])  # read dth past its end
    ok, cost, _ = planner.evaluate(sim.world, 0, 1, [0.0, 0.1], [0.0, 0.0])
    assert ok.shape == cost.shape == (2,)
