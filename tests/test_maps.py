"""Map scenario kinds (corridor, doorway, room, intersection, random walls) and the route layer."""

import math

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import vcs_env
from baselines.common import preferred_velocity
from vcs_env.layouts import KINDS, generate
from vcs_env.routes import Roadmap, route_direction, waypoints
from vcs_env.scenario import MAPS, CustomLayout, Scenario, make_scenario
from vcs_env.sim import Simulator
from vcs_env.walls import clearance


@pytest.mark.parametrize("name", sorted(MAPS))
def test_map_layouts_are_clear_of_walls_and_routed(name):
    s = make_scenario(name, n_obstacles=2)
    for seed in range(3):
        lay = generate(s, np.random.default_rng(seed))
        assert 0 < len(lay.segments) <= KINDS[s.kind].n_segments(s)
        r = s.robot.radius
        assert np.all(clearance(lay.start, lay.segments) - r >= s.min_separation)
        assert np.all(clearance(lay.goal, lay.segments) - r >= s.min_separation)
        assert np.all(clearance(lay.obs_pos, lay.segments) - lay.obs_radius >= s.min_separation)
        rm = Roadmap(lay.segments, r)
        for i in range(s.n_robots):
            length = rm.route_length(lay.start[i], lay.goal[i])
            assert np.linalg.norm(lay.goal[i] - lay.start[i]) - 1e-9 <= length < math.inf


@pytest.mark.parametrize("name", sorted(MAPS))
def test_map_presets_pass_the_pettingzoo_api_test(name):
    parallel_api_test(vcs_env.parallel_env(scenario=name, max_steps=30), num_cycles=30)


def test_random_walls_differ_by_seed():
    s = make_scenario("walls")
    a, b = (generate(s, np.random.default_rng(seed)).segments for seed in (0, 1))
    assert a.shape == b.shape == (4 + s.n_walls, 2, 2) and not np.array_equal(a, b)


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"kind": "doorway", "door_width": 0.4}, "no route"),  # narrower than a robot
        ({"kind": "corridor", "corridor_width": 0.6}, "passage"),
        ({"kind": "room", "door_width": 7.0}, "door_width"),
        ({"kind": "doorway", "layout_radius": 0.3}, "from a wall"),
        # Robots outside the arena's walls (they drove round the outside of the box).
        ({"kind": "doorway", "arena_half_size": 2.0, "layout_radius": 3.0}, "outside the arena's walls"),
        ({"kind": "doorway", "n_robots": 30, "arena_half_size": 4.0, "layout_radius": 2.22}, "outside the arena"),
        # Robots that would start in contact with each other (they collided at the first step, doing nothing).
        ({"kind": "corridor", "lane_spacing": 0.49}, "starts of robots 0 and 1 are 0.490 m apart, need >= 0.800"),
        ({"kind": "doorway", "lane_spacing": 0.7}, "starts of robots 0 and 1"),
        ({"kind": "corridor", "layout_radius": 0.2}, "starts of robots 0 and 2"),
        ({"kind": "intersection", "layout_radius": 0.3}, "starts of robots 0 and 2"),  # the two groups meet
        ({"kind": "corridor", "n_robots": 8, "corridor_width": 4.0, "lane_spacing": 0.9, "jitter": 0.1}, "2 jitter"),
        ({"kind": "room", "jitter": 1.0}, "2 jitter\\); increase layout_radius, or reduce n_robots, or reduce jitter"),
        ({"kind": "intersection", "layout_radius": 0.3, "jitter": 0.0}, "min_separation\\); increase [^;]*radius$"),
        # Random walls too dense to draw a layout for every seed: refused here, not at some reset.
        (
            {"kind": "walls", "n_walls": 30, "wall_length": (3, 5), "arena_half_size": 4.0, "n_robots": 6},
            "trial layouts",
        ),
        # Obstacles between the walls that no trial layout can place (the arena's area alone allows them).
        ({"kind": "room", "n_obstacles": 28, "obstacle_radius": (0.7, 0.7)}, "room: trial layout 0 .* n_obstacles"),
    ],
)
def test_bad_maps_are_refused_with_a_clear_error(overrides, message):
    with pytest.raises(ValueError, match=message):
        Scenario(**{"n_robots": 4, **overrides})


def test_dense_obstacles_that_pass_the_construction_check_place_at_every_reset():
    """Sequential placement can wedge itself where a fresh draw fits: the obstacles start over instead of
    failing the reset (doorway, 3 robots, 30 obstacles: seeds 0, 4, 27 and 30 of 0-39 failed at reset)."""
    s = make_scenario("doorway", n_robots=3, n_obstacles=30)
    sim = Simulator(s)
    for seed in range(40):
        sim.reset(seed)


def door_world():
    """A wall at x = 0 with a 1 m door centred at y = 1; robot from (-2, 0) to (2, 0)."""
    walls = (((0.0, -4.0), (0.0, 0.5)), ((0.0, 1.5), (0.0, 4.0)))
    s = Scenario(kind="custom", n_robots=1, custom=CustomLayout(start=((-2.0, 0.0),), goal=((2.0, 0.0),), walls=walls))
    return s, Simulator(s).reset(0)


def test_route_goes_through_the_door():
    s, w = door_world()
    target, length = waypoints(w)
    r = s.robot.radius
    # The shortest route bends around the door's lower edge (0, 0.5), kept r + margin away.
    straight_around_edge = 2 * math.hypot(2.0, 0.5 + r)
    assert straight_around_edge - 0.05 < length[0, 0] < straight_around_edge + 0.3
    assert target[0, 0, 0] < 0.0 and target[0, 0, 1] > 0.5 + r  # a node left of the wall, above the edge
    e, d = route_direction(w)
    np.testing.assert_allclose(np.linalg.norm(e, axis=-1), d)


def test_a_route_runs_along_a_wall_at_any_angle():
    # A lone wall in the open, end to end between start and goal: the route goes around one end.
    # With nodes in eight fixed world directions, walls near 22.5 deg (mod 45) had no route at all.
    r, half = 0.25, 1.5
    for deg in np.arange(0.0, 180.0, 2.5):
        d = np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
        length = Roadmap(np.array([[-half * d, half * d]]), r).route_length(-(half + 1) * d, (half + 1) * d)
        straight = 2 * (half + 1)
        assert straight < length < straight + 1.0, (deg, length)


def test_following_the_route_reaches_the_goal_without_contact():
    s, _ = door_world()
    planner = vcs_env.make_planner("straight")
    engine = vcs_env.NavEngine(s)
    engine.reset(0)
    for _ in range(s.max_steps):
        res = engine.step(planner.act(engine.world))
        assert not res.events.collided.any()
        if not engine.world.active.any():
            break
    assert engine.world.reached.all()


def test_without_walls_the_route_is_the_goal_and_preferred_velocity_unchanged():
    w = Simulator(make_scenario("circle", n_robots=5)).reset(3)
    target, length = waypoints(w)
    np.testing.assert_array_equal(target, w.goal)
    e = w.goal - w.pos
    np.testing.assert_array_equal(route_direction(w)[0], e)
    # preferred_velocity of a world with walls that never block equals the wall-free one
    # along the same direction (the route is the straight line).
    far = make_scenario(
        "custom",
        custom=CustomLayout(start=((-2.0, 0.0),), goal=((2.0, 0.0),), walls=(((-5.0, 9.0), (5.0, 9.0)),)),
        n_robots=1,
        n_obstacles=0,
    )
    wf = Simulator(far).reset(0)
    bare = Simulator(
        make_scenario(
            "custom", custom=CustomLayout(start=((-2.0, 0.0),), goal=((2.0, 0.0),)), n_robots=1, n_obstacles=0
        )
    ).reset(0)
    np.testing.assert_array_equal(preferred_velocity(wf), preferred_velocity(bare))


def facing_wall_world(holonomic=True):
    """One robot at the origin moving at 1 m/s along +x, a long wall at x = 0.6."""
    s = Scenario(
        kind="custom",
        n_robots=1,
        custom=CustomLayout(
            start=((0.0, 0.0),), goal=((0.0, 3.0),), heading=(0.0,), speed=(1.0,), walls=(((0.6, -5.0), (0.6, 5.0)),)
        ),
        robot=vcs_env.RobotSpec(holonomic=holonomic),
    )
    return Simulator(s).reset(0)


@pytest.mark.parametrize("name", ["vo", "hrvo", "orca"])
def test_local_avoidance_sees_walls(name, monkeypatch):
    """With the preferred velocity forced straight into the wall, the chosen velocity keeps off it."""
    import baselines.orca
    import baselines.vo
    from baselines.capsule import capsule_tau

    module = baselines.orca if name == "orca" else baselines.vo
    monkeypatch.setattr(module, "preferred_velocity", lambda world: np.array([[[1.0, 0.0]]]))
    w = facing_wall_world()
    v = vcs_env.make_planner(name).desired_velocity(w)[0, 0]
    assert capsule_tau(0.6, -5.0, 0.6, 5.0, v[0], v[1], 0.25) >= 1.5  # (1, 0) would touch it after 0.35 s
    w.seg_present[:] = False  # the same world without its wall: straight ahead
    np.testing.assert_allclose(vcs_env.make_planner(name).desired_velocity(w)[0, 0], [1.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("name", ["vo", "hrvo"])
def test_vo_family_touches_no_wall_on_room_and_walls_maps(name):
    from vcs_env.contacts import contact_events
    from vcs_env.rollout import planner_controller, run_episodes

    for preset in ("room", "walls"):
        s = make_scenario(preset, on_collision="continue")
        episodes = run_episodes(s, planner_controller(vcs_env.make_planner(name)), range(3))
        assert not any(c.kind == "wall" for e in episodes for c in contact_events(e))
        assert np.mean([e.reached_step >= 0 for e in episodes]) >= 0.9


def test_renderers_draw_the_walls():
    from vcs_env.render import WALL_COLOR, Renderer, ansi

    s = make_scenario("doorway")
    w = Simulator(s).reset(0)
    renderer = Renderer(s.view_extent, size=200)
    frame = renderer.draw(w)
    mid = renderer._px(np.array([0.0, -2.0])).astype(int)
    assert tuple(frame[mid[1], mid[0]]) == WALL_COLOR  # the wall x = 0 below the door
    assert "walls=6" in ansi(w)


def test_nearest_wall_points_block_is_optional_and_matches_a_scalar_twin():
    import dataclasses

    from vcs_env.observations import (
        EGO_DIM,
        NEIGHBOR_DIM,
        SENSE_REF,
        observation_bounds,
        observation_config,
        observation_dim,
        observe,
        reference_observe,
        sensors_of,
    )

    base = make_scenario("room", n_robots=4)
    assert base.n_wall_points == 0 and "n_wall_points" not in observation_config(base)
    assert observation_dim(base) == EGO_DIM + base.n_neighbors * NEIGHBOR_DIM  # the default is unchanged
    k = 40  # more than the room has segments: no tie at the cut
    s = dataclasses.replace(base, n_wall_points=k)
    world = Simulator(s, batch_size=2).reset(3)
    world.heading[:] = np.random.default_rng(0).uniform(-np.pi, np.pi, world.heading.shape)
    obs = observe(world, s)
    np.testing.assert_array_equal(obs, reference_observe(world, s))
    low, high = observation_bounds(s)
    assert obs.shape[-1] == observation_dim(s) == low.shape[0] and (obs >= low).all() and (obs <= high).all()
    np.testing.assert_array_equal(obs[..., : observation_dim(base)], observe(world, base))
    block = obs[..., observation_dim(base) :].reshape(2, 4, k, 3)
    # With wall_segments each point also gives its wall segment: direction (turned ahead) and extent either side.
    s7 = dataclasses.replace(s, wall_segments=True)
    obs7 = observe(world, s7)
    np.testing.assert_array_equal(obs7, reference_observe(world, s7))
    low, high = observation_bounds(s7)
    assert obs7.shape[-1] == observation_dim(s7) == observation_dim(s) + 4 * k == low.shape[0]
    assert (obs7 >= low).all() and (obs7 <= high).all()
    assert sensors_of(observation_config(s7))["wall_segments"]
    assert not sensors_of(observation_config(s))["wall_segments"]
    seg = obs7[..., observation_dim(base) :].reshape(2, 4, k, 7)
    assert ((seg[..., 5] == 0) & (seg[..., 0] == 1)).any() and (seg[..., 5:] > 0).all(-1).any()  # ends and feet
    for b in range(2):
        for i in range(4):
            p, th = world.pos[b, i], world.heading[b, i]
            c, sn = np.cos(th), np.sin(th)
            near = []
            for a, e, ok in zip(world.seg_a[b], world.seg_b[b], world.seg_present[b]):
                t = min(max(float((p - a) @ (e - a) / ((e - a) @ (e - a))), 0.0), 1.0)
                q = a + t * (e - a) - p
                if ok and np.hypot(*q) <= world.r_ca:
                    x, y = q[0] * c + q[1] * sn, -q[0] * sn + q[1] * c
                    d = (e - a) / np.hypot(*(e - a))  # from a to b, then in the robot frame, turned ahead
                    tx, ty = d[0] * c + d[1] * sn, -d[0] * sn + d[1] * c
                    to_a, to_b = t * np.hypot(*(e - a)), (1 - t) * np.hypot(*(e - a))
                    if tx < 0 or (tx == 0 and ty < 0):
                        tx, ty, to_a, to_b = -tx, -ty, to_b, to_a
                    near.append((np.hypot(*q), x, y, tx, ty, to_a, to_b))
            near.sort()
            want = np.zeros((k, 7))
            for j, (_, x, y, tx, ty, back, ahead) in enumerate(near[:k]):
                want[j] = (1.0, *np.clip((x / SENSE_REF, y / SENSE_REF), -1, 1), tx, ty,
                           *np.clip((back / SENSE_REF, ahead / SENSE_REF), 0, 1))  # fmt: skip
            # nearest first; points at equal distance (symmetric corners) may come in either order
            np.testing.assert_allclose(np.sort(block[b, i], axis=0), np.sort(want[:, :3], axis=0), atol=1e-6)
            got = seg[b, i][np.lexsort(np.round(seg[b, i], 4).T[::-1])]
            np.testing.assert_allclose(got, want[np.lexsort(np.round(want, 4).T[::-1])], atol=1e-6)
            gaps = [row[0] for row in near[:k]]
            got = np.hypot(block[b, i, :, 1], block[b, i, :, 2])[: len(gaps)] * SENSE_REF
            np.testing.assert_allclose(got, gaps, atol=1e-5)
            assert block[b, i, :, 0].sum() == min(k, len(near)) >= 4  # the room's walls are in range


def test_a_dense_random_wall_map_that_passes_construction_resets_on_every_seed():
    """60 walls among 4 robots passed the trial layouts, then 3 resets in 20 failed (50 draws of the walls ran out)."""
    env = vcs_env.parallel_env(scenario=vcs_env.Scenario(kind="walls", n_robots=4, n_walls=60))
    for seed in (5000, 5011, 5014):
        env.reset(seed=seed)


def _waypoints_one_world_at_a_time(world):
    """The oracle of :func:`waypoints`: each world's robots routed alone, per robot radius."""
    from vcs_env.routes import roadmap, walled

    target, length = world.goal.copy(), np.linalg.norm(world.goal - world.pos, axis=-1)
    if not walled(world):
        return target, length
    for b in range(world.batch_size):
        if not world.seg_present[b].any():
            continue
        active = np.flatnonzero(world.active[b])
        for r in np.unique(world.radius[b, active]):
            idx = active[world.radius[b, active] == r]
            wp, total = roadmap(world, b, r).next_waypoints(world.pos[b, idx], world.goal[b, idx])
            found = np.isfinite(total)
            target[b, idx[found]], length[b, idx[found]] = wp[found], total[found]
    return target, length


def test_waypoints_of_one_world_are_the_oracles():
    sim = Simulator(make_scenario("walls"), 1)
    sim.reset(11)
    rng = np.random.default_rng(1)
    for _ in range(30):
        sim.step(rng.uniform(-1, 1, (1, sim.scenario.n_robots, 2)))
        got, want = waypoints(sim.world), _waypoints_one_world_at_a_time(sim.world)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])


@pytest.mark.parametrize("name", ["doorway", "walls"])
def test_waypoints_of_a_batch_are_those_of_each_world_alone(name):
    # Worlds that share their walls are routed together: the same waypoints and lengths as one world at a time,
    # with worlds of other walls, worlds without walls, robots that are done and robots of another radius mixed in.
    sim = Simulator(make_scenario(name), 12)
    sim.reset(3)
    rng = np.random.default_rng(0)
    for t in range(40):
        sim.step(rng.uniform(-1, 1, (12, sim.scenario.n_robots, 2)))
        w = sim.world
        if t == 10:
            w.seg_a[[2, 5]], w.seg_b[[2, 5]] = w.seg_a[[0, 0]], w.seg_b[[0, 0]]  # walls of world 0 in 2 and 5 too
            w.seg_present[[2, 5]] = w.seg_present[[0, 0]]
            w.seg_present[7] = False  # no walls
            w.radius[:, 0] = 0.3  # another radius
            w.active[4, 1:] = False
        got, want = waypoints(w), _waypoints_one_world_at_a_time(w)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        for _ in range(2):  # the caller's copy: the same state asked again is answered as before
            got[0][:], got[1][:] = 0.0, 0.0
            got = waypoints(w)
            np.testing.assert_array_equal(got[0], want[0])
            np.testing.assert_array_equal(got[1], want[1])
    routed = got[1] != np.linalg.norm(w.goal - w.pos, axis=-1)
    assert routed.any()  # some robot was routed around a wall
    b = int(np.flatnonzero(routed.any(1))[0])
    ref = _waypoints_one_world_at_a_time(w)
    changes = {
        "pos": lambda x: x + 0.05,
        "goal": lambda x: x + 0.3,
        "active": lambda x: ~x,
        "radius": lambda x: 0.6 * x,
    }
    changes["seg_present"] = lambda x: np.zeros_like(x)
    changes["seg_a"] = changes["seg_b"] = lambda x: x + 1.0
    for field, change in changes.items():
        waypoints(w)  # the state before the change is the last one asked
        arr = getattr(w, field)  # any change of what it reads is a new state
        before = arr.copy()
        arr[b] = change(arr[b])
        got, want = waypoints(w), _waypoints_one_world_at_a_time(w)
        assert not np.array_equal(want[1], ref[1]), field  # the change moves some route
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        arr[:] = before


def test_walls_whose_obstacles_find_no_room_are_drawn_again():
    """A walls layout whose obstacles found no room among its walls failed the reset (seeds 10 and 42 here, after the
    trial layouts passed); the walls are drawn again, as when a robot finds no place or route."""
    env = vcs_env.parallel_env(scenario="walls", n_robots=2, n_walls=4, arena_half_size=2.6, n_obstacles=8)
    for seed in (10, 42):
        env.reset(seed=seed)
        assert len(env.engine.world.obs_pos[0]) == 8


def test_route_kernels_compile_once_for_every_source_of_walls():
    """The roadmaps cached by their walls' bytes held read-only walls, the others writable ones, and numba compiled
    every route kernel a second time for them (about 2 s at a process's first map with a cold cache)."""
    from vcs_env import routes

    seg = np.array([[[0.0, -1.0], [0.0, 1.0]], [[2.0, -1.0], [2.0, 3.0]]])
    start, goal = np.array([[-1.0, 0.0]]), np.array([[3.0, 0.0]])
    for rm in (Roadmap(seg, 0.25), routes._cached(seg.tobytes(), 2, 0.25)):
        assert rm.segments.flags.writeable
        rm.next_waypoints(start, goal)
    for kernel in (routes._visible, routes._visible_pairs, routes._clearance, routes._next_waypoints):
        assert len(kernel.signatures) == 1, kernel.signatures
