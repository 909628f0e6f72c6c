"""Comparison planners (issue 4): ``vo``, ``rvo``, ``hrvo`` (sampling, RVO Library style) and
``orca`` (RVO2 through pyrvo), behind the same planner protocol as the VCS expert."""

import math
import re
import sys

import numpy as np
import pytest

import vcs_env
from baselines import PLANNERS, make_planner
from baselines.common import preferred_velocity
from vcs_env.checks import install_hint
from vcs_env.dynamics import target_to_action
from vcs_env.engine import NavEngine
from vcs_env.rollout import planner_controller, run_episodes
from vcs_env.scenario import make_scenario

SAMPLING = ("vo", "rvo", "hrvo")
COMPARISON = (*SAMPLING, "orca")


def test_registered():
    for name in COMPARISON:
        assert name in PLANNERS
        assert make_planner(name).name == name


@pytest.mark.parametrize("name", COMPARISON)
@pytest.mark.parametrize("scenario", sorted(vcs_env.SCENARIOS))
def test_runs_every_preset(name, scenario):
    planner = make_planner(name)
    engine = NavEngine(vcs_env.make_scenario(scenario), 2)
    engine.reset([3, 4])
    w = engine.world
    for _ in range(3):
        target = planner.plan(w)
        assert target.shape == (w.batch_size, w.n_robots, 2)
        assert np.all(np.isfinite(target))
        assert np.all(target[..., 0] >= 0.0) and np.all(target[..., 0] <= w.v_max + 1e-6)
        engine.step(planner.act(w))


def test_invalid_arguments():
    with pytest.raises(ValueError, match="n_samples"):
        make_planner("rvo", n_samples=0)
    with pytest.raises(ValueError, match="weight"):
        make_planner("vo", weight=-1.0)
    with pytest.raises(ValueError, match="time_horizon"):
        make_planner("orca", time_horizon=0.0)
    with pytest.raises(ValueError, match="planner 'hrvo' does not take the options \\['horizon'\\]"):
        make_planner("hrvo", horizon=3.0)
    from baselines.vcs import VCSPlanner

    with pytest.raises(ValueError, match="params must be a VCSParams"):
        VCSPlanner().params = {"horizon": 3.0}


@pytest.mark.parametrize("name", [*COMPARISON, "straight", "vcs"])
def test_bad_limits_in_a_world_are_named(name):
    """A world whose step or robot limits were set by hand out of a Scenario's ranges is refused by name, before the
    planner divides by them (dt 0 and a_max 0 ended in a ZeroDivisionError inside a kernel, NaN and negative limits
    in NaN actions or plans of the wrong sign)."""
    import dataclasses

    engine = NavEngine(vcs_env.make_scenario("crowd", n_robots=3), 2)
    engine.reset([0, 1])
    good = engine.world
    assert np.isfinite(make_planner(name).act(good)).all()
    cases = [(dataclasses.replace(good, dt=0.0), r"WorldState.dt \[s\] must be a finite number in \[0.001, 1.0\]")]
    for field, value, text in [
        ("a_max", 0.0, r"\[0.001, 10.0\], got 0.0"),
        ("a_max", -1.0, r"\[0.001, 10.0\], got -1.0"),
        ("omega_max", 1e-9, r"\[0.001, 6.28"),
        ("v_max", np.nan, r"\(0, 3.0\], got nan"),
        ("radius", 0.0, r"\(0, 2.0\], got 0.0"),
    ]:
        world = good.copy()
        getattr(world, field)[1, 2] = value
        cases.append((world, rf"WorldState.{field}\[1, 2\] must be a finite number in {text}"))
    for world, text in cases:
        with pytest.raises(ValueError, match=text):
            make_planner(name).act(world)


def test_new_params_set_on_a_planner_take_effect():
    """The compiled settings followed only the constructor's: params set afterwards were read by the Python parts
    and ignored by the kernels, so the planner planned with a mixture of the two."""
    import dataclasses

    from baselines.vcs import VCSPlanner

    engine = NavEngine(make_scenario("circle", n_robots=6), 1)
    engine.reset([0])
    changed, wanted, default = VCSPlanner(), VCSPlanner(horizon="infinite", cost="goal_only"), VCSPlanner()
    changed.params = dataclasses.replace(changed.params, horizon="infinite", cost="goal_only")
    differs = False
    for _ in range(40):
        world = engine.world
        target = changed.plan(world)
        assert np.array_equal(target, wanted.plan(world))
        differs |= not np.array_equal(target, default.plan(world))
        engine.step(target_to_action(world, target))
    assert differs  # the settings matter here


# ------------------------------------------------------------------ scalar twin of the penalty
def scalar_ttc(p, w, r):
    """Smallest t >= 0 with |p - w t| = r for a pair that does not overlap (textbook quadratic)."""
    a = w[0] ** 2 + w[1] ** 2
    b = -2.0 * (p[0] * w[0] + p[1] * w[1])
    c = p[0] ** 2 + p[1] ** 2 - r * r
    disc = b * b - 4.0 * a * c
    if a == 0.0 or disc < 0.0:
        return math.inf
    t = (-b - math.sqrt(disc)) / (2.0 * a)  # c > 0: both roots have the sign of -b
    return t if t >= 0.0 else math.inf


def scalar_hrvo_apex(p, r, v_i, v_j, pref_i, pref_j):
    """HRVO apex (vcs-method §2.4) with trigonometry and Cramer's rule."""
    d = math.hypot(p[0], p[1])
    phi, alpha = math.atan2(p[1], p[0]), math.asin(r / d)
    right = (math.cos(phi - alpha), math.sin(phi - alpha))
    left = (math.cos(phi + alpha), math.sin(phi + alpha))
    mid = (0.5 * (v_i[0] + v_j[0]), 0.5 * (v_i[1] + v_j[1]))
    rel = (pref_i[0] - pref_j[0], pref_i[1] - pref_j[1])
    if p[0] * rel[1] - p[1] * rel[0] > 0.0:  # pass on the left: VO right side, RVO left side
        d1, d2 = right, left
    else:
        d1, d2 = left, right
    den = d1[0] * d2[1] - d1[1] * d2[0]
    if abs(den) < 1e-12:
        return mid
    # v_j + s d1 = mid + t d2
    s = ((mid[0] - v_j[0]) * d2[1] - (mid[1] - v_j[1]) * d2[0]) / den
    return (v_j[0] + s * d1[0], v_j[1] + s * d1[1])


def scalar_penalty(world, b, i, v, method, weight=7.5):
    """w / t_c(v) + |v - v_pref| for robot i of world b, one neighbour at a time."""
    pref = preferred_velocity(world)
    n, m = world.n_robots, world.n_obstacles
    vel = world.vel
    v_i = tuple(vel[b, i])
    tc = math.inf
    for j in range(n + m):
        if j < n:
            if j == i or not world.present[b, j]:
                continue
            q, rj = world.pos[b, j], world.radius[b, j]
            v_j = tuple(vel[b, j]) if world.active[b, j] else (0.0, 0.0)
            reciprocal = bool(world.active[b, j]) and method != "vo"
        else:
            q, rj = world.obs_pos[b, j - n], world.obs_radius[b, j - n]
            v_j = tuple(world.obs_vel[b, j - n])
            reciprocal = False
        p = (q[0] - world.pos[b, i, 0], q[1] - world.pos[b, i, 1])
        r = world.radius[b, i] + rj
        d = math.hypot(*p)
        if d > world.r_ca:
            continue
        if d <= r:  # overlap: separate, or collide now
            a = (0.5 * (v_i[0] + v_j[0]), 0.5 * (v_i[1] + v_j[1])) if reciprocal else v_j
            t = math.inf if (v[0] - a[0]) * p[0] + (v[1] - a[1]) * p[1] < 0.0 else 0.0
        elif not reciprocal:
            t = scalar_ttc(p, (v[0] - v_j[0], v[1] - v_j[1]), r)
        elif method == "rvo":
            t = scalar_ttc(p, (2 * v[0] - v_i[0] - v_j[0], 2 * v[1] - v_i[1] - v_j[1]), r)
        else:
            a = scalar_hrvo_apex(p, r, v_i, v_j, pref[b, i], pref[b, j])
            t = scalar_ttc(p, (2 * (v[0] - a[0]), 2 * (v[1] - a[1])), r)
        tc = min(tc, t)
    return weight / max(tc, 1e-9) + math.hypot(v[0] - pref[b, i, 0], v[1] - pref[b, i, 1])


def random_world(seed):
    """A cluttered random state: overlaps, parked and absent robots, moving obstacles."""
    rng = np.random.default_rng(seed)
    engine = NavEngine(vcs_env.make_scenario("dynamic", n_robots=7, n_obstacles=4, r_ca=3.0), 2)
    engine.reset([seed, seed + 1])
    w = engine.world
    B, n, m = w.batch_size, w.n_robots, w.n_obstacles
    w.pos = rng.uniform(-2.5, 2.5, (B, n, 2))
    w.goal = rng.uniform(-4.0, 4.0, (B, n, 2))
    w.heading = rng.uniform(-np.pi, np.pi, (B, n))
    w.speed = rng.uniform(0.0, 1.0, (B, n))
    w.obs_pos = rng.uniform(-2.5, 2.5, (B, m, 2))
    w.obs_vel = rng.uniform(-0.7, 0.7, (B, m, 2))
    w.active[:, :2] = False  # parked
    w.present[:, 1] = False  # gone
    w.pos[1, 4] = w.pos[1, 3] + (0.3, 0.1)  # two active robots overlap
    w.pos[1, 0] = w.pos[1, 5] + (0.1, -0.3)  # an active robot overlaps a parked one
    w.speed = np.where(w.active, w.speed, 0.0)
    w.steps = w.steps + rng.integers(0, 100, B)
    return w


@pytest.mark.parametrize("method", SAMPLING)
def test_penalty_matches_scalar_twin(method):
    w = random_world(7)
    planner = make_planner(method, n_samples=40)
    cand, pen = planner.penalties(w)
    chosen = planner.desired_velocity(w)
    pref = preferred_velocity(w)
    B, n = w.batch_size, w.n_robots
    assert cand.shape == (B, n, 41, 2) and pen.shape == (B, n, 41)
    checked = 0
    for b in range(B):
        for i in range(n):
            if not w.active[b, i]:
                assert np.all(np.isnan(pen[b, i])) and np.all(chosen[b, i] == 0.0)
                continue
            np.testing.assert_array_equal(cand[b, i, 0], pref[b, i])  # candidate 0 is v_pref
            assert np.all(np.linalg.norm(cand[b, i, 1:], axis=-1) <= w.v_max[b, i] + 1e-12)
            twin = [scalar_penalty(w, b, i, cand[b, i, c], method) for c in range(41)]
            np.testing.assert_allclose(pen[b, i], twin, rtol=1e-6)
            # The fast path (early exits) picks the first least penalty.
            np.testing.assert_array_equal(chosen[b, i], cand[b, i, int(np.argmin(pen[b, i]))])
            checked += 1
    assert checked == B * (n - 2)


def test_overlap_moves_apart():
    """A robot inside a static obstacle picks a velocity that leaves it."""
    w = random_world(3)
    w.pos[0, 3] = (0.0, 0.0)
    w.goal[0, 3] = (0.0, 3.0)  # the goal is beside the obstacle: going there does not separate
    w.pos[0, 4:] += 100.0  # nothing else nearby
    w.obs_pos[0] = (0.2, 0.0) + 100.0 * np.arange(w.n_obstacles)[:, None]
    w.obs_vel[0] = 0.0
    w.obs_radius[0] = 0.3
    for method in SAMPLING:
        v = make_planner(method).desired_velocity(w)[0, 3]
        assert v[0] < 0.0


# ------------------------------------------------------------------ determinism and batching
@pytest.mark.parametrize("method", SAMPLING)
def test_same_state_same_targets(method):
    w = random_world(11)
    a = make_planner(method).plan(w)
    b = make_planner(method).plan(w.copy())
    c = make_planner(method).plan(w)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    # The samples change with the step count (they are keyed by world.key and world.steps).
    w2 = w.copy()
    w2.steps = w2.steps + 1
    cand1, _ = make_planner(method, n_samples=10).penalties(w)
    cand2, _ = make_planner(method, n_samples=10).penalties(w2)
    assert not np.array_equal(cand1[:, :, 1:], cand2[:, :, 1:])


@pytest.mark.parametrize("method", SAMPLING)
def test_batched_equals_one_by_one(method):
    scen = vcs_env.make_scenario("dynamic", on_collision="continue")
    ctrl = planner_controller(make_planner(method))
    together = run_episodes(scen, ctrl, seeds=[0, 1, 2], max_steps=40)
    alone = run_episodes(scen, ctrl, seeds=[0, 1, 2], max_steps=40, batch_size=1)
    for x, y in zip(together, alone):
        np.testing.assert_array_equal(x.pos, y.pos)
        np.testing.assert_array_equal(x.heading, y.heading)


@pytest.mark.parametrize("method", ["vcs", "straight"])
def test_plan_for_a_subset_gives_the_subsets_plans(method):
    """Planning only robots 1.. (what the Gymnasium env's `others` needs) gives them the targets of
    the full plan at every step, planner memory included, while robot_0 drives at random."""
    eng = NavEngine(vcs_env.make_scenario("dynamic", n_robots=4, on_collision="continue"), 3)
    eng.reset([0, 1, 2])
    full, some = make_planner(method), make_planner(method)
    others = np.array([False, True, True, True])
    rng = np.random.default_rng(0)
    for _ in range(60):
        a = full.act(eng.world)
        np.testing.assert_array_equal(some.act(eng.world, robots=others)[:, 1:], a[:, 1:])
        a[:, 0] = rng.uniform(-1.0, 1.0, (3, 2))
        eng.step(a)
    if method == "vcs":  # robot_0 was not planned: it has no window, as a robot that is done
        assert np.all(some.last["k"][:, 0] == 0) and np.any(full.last["k"][:, 0] > 0)
        with pytest.raises(ValueError, match="robots must be a bool mask of shape"):
            some.plan(eng.world, robots=np.ones(3, dtype=bool))


# ------------------------------------------------------------------ ORCA through pyrvo
def test_orca_swap_head_on():
    """Two robots swapping head-on pass each other without contact and both arrive."""
    pytest.importorskip("pyrvo")
    scen = vcs_env.make_scenario("swap", n_robots=2)
    (ep,) = run_episodes(scen, planner_controller(make_planner("orca")), seeds=[0])
    assert not ep.collided.any()
    assert np.all(ep.reached_step >= 0)
    # They really had to give way: the paths leave the straight line between start and goal.
    axis = (ep.goal - ep.pos[0]) / np.linalg.norm(ep.goal - ep.pos[0], axis=-1, keepdims=True)
    off = ep.pos - ep.pos[0]
    lateral = np.abs(axis[..., 0] * off[..., 1] - axis[..., 1] * off[..., 0])
    assert lateral.max() > 0.05


def test_orca_needs_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyrvo", None)  # import pyrvo now raises ImportError
    with pytest.raises(ImportError, match=re.escape(install_hint("orca"))):
        make_planner("orca")
