"""The VCS expert and walls (vcs-method §2.18): a wall record's forbidden set is the capsule's
velocity obstacle (against the numpy oracle), a door head-on, a wall between a robot and its
goal, the ablation with the walls hidden from the kernel, and giving way at a junction."""

import dataclasses

import numpy as np
import pytest

from baselines.capsule import reference_capsule_tau, segment_range
from baselines.vcs import VCSPlanner
from baselines.vcs.kernel.neighbours import fit_disc_pairs
from baselines.vcs.kernel.records import K_STATIC, NEIGHBOUR
from vcs_env.contacts import contact_events
from vcs_env.rollout import planner_controller, run_episodes
from vcs_env.scenario import CustomLayout, RobotSpec, Scenario
from vcs_env.sim import Simulator
from vcs_env.suites import SUITES


class WallBlindVCS(VCSPlanner):
    """The ablation: the kernel sees no wall (the route layer still aims around them)."""

    def _kernel_inputs(self, world, *args):
        w, inputs, setting = super()._kernel_inputs(world, *args)
        B = world.batch_size
        no_walls = {"seg_a": np.zeros((B, 0, 2)), "seg_b": np.zeros((B, 0, 2)), "seg_present": np.zeros((B, 0), bool)}
        return w._replace(**no_walls), inputs, setting


def _wall_contacts(episodes) -> int:
    return sum(c.kind == "wall" for e in episodes for c in contact_events(e))


def _custom(start, goal, walls, heading=None, speed=None, **kw) -> Scenario:
    layout = CustomLayout(start=start, goal=goal, walls=walls, heading=heading, speed=speed)
    return Scenario(kind="custom", n_robots=len(start), custom=layout, on_collision="continue", **kw)


@pytest.mark.parametrize("holonomic", [False, True])
def test_wall_forbidden_set_is_the_capsule_velocity_obstacle(holonomic):
    """Alone beside a wall, a candidate is admissible iff the centre does not enter the capsule
    of radius r + delta_min within the wall's horizon (ramp check off: end velocities only)."""
    rng = np.random.default_rng(3)
    planner = VCSPlanner(ramp_check=False)
    checked = forbidden = 0
    for _trial in range(8):
        a = rng.uniform(-2.5, 2.5, 2)
        b = a + rng.uniform(-2.0, 2.0, 2)
        heading = [rng.uniform(-np.pi, np.pi)]
        s = _custom([(-6.0, 6.0)], [(6.0, 6.0)], [(tuple(a), tuple(b))], heading, robot=RobotSpec(holonomic=holonomic))
        world = Simulator(s).reset(0)
        world.pos[0, 0] = rng.uniform(-2.0, 2.0, 2)
        world.speed[0, 0] = rng.uniform(0.0, 1.0)
        r = world.radius[0, 0] + planner.params.delta_min
        if segment_range(*(a - world.pos[0, 0]), *(b - world.pos[0, 0])) <= r + 0.05:
            continue  # only robots clear of the buffer (inside it r_eff shrinks)
        dv = rng.uniform(-world.speed[0, 0], 1.0 - world.speed[0, 0], 300)
        dth = rng.uniform(-np.pi, np.pi, 300)
        ok, _cost, horizon = planner.evaluate(world, 0, 0, dv, dth)
        t_h = horizon[2 + world.n_obstacles]  # robots, twins, then the wall
        assert np.isfinite(t_h) and 0 < t_h <= planner.params.t_max
        v = (world.speed[0, 0] + dv)[:, None] * np.stack(
            (np.cos(world.heading[0, 0] + dth), np.sin(world.heading[0, 0] + dth)), -1
        )
        tau = reference_capsule_tau(a - world.pos[0, 0], b - world.pos[0, 0], v, np.full(300, r))
        clear = np.abs(tau - t_h) > 1e-6
        np.testing.assert_array_equal(ok[clear], (tau > t_h)[clear])
        checked += 1
        forbidden += int((~ok).sum())
    assert checked >= 4 and forbidden > 50  # both sides of the boundary exercised


def test_door_head_on_both_arrive_without_contact():
    """Two robots head-on through a door one robot diameter + 0.2 m wide: no deadlock, no contact."""
    suite = SUITES["door-headon-v0"]
    assert suite.scenario.door_width == pytest.approx(2 * suite.scenario.robot.radius + 0.2)
    episodes = run_episodes(suite.scenario, planner_controller(VCSPlanner()), list(suite.seeds)[:3])
    for e in episodes:
        assert (e.reached_step >= 0).all(), f"seed {e.seed}: not every robot arrived"
        assert not contact_events(e), f"seed {e.seed}: {contact_events(e)}"


def test_wall_between_robot_and_goal_is_passed_by_the_route():
    """A wall across the way, open at both ends: the robot goes around it and arrives."""
    s = _custom([(-2.0, 0.0)], [(2.0, 0.0)], [((0.0, -1.5), (0.0, 1.5))], max_steps=400)
    (e,) = run_episodes(s, planner_controller(VCSPlanner()), [0])
    assert e.reached_step[0] >= 0 and not contact_events(e)
    assert np.abs(e.pos[:, 0, 1]).max() > 1.5  # around an end, not through the wall


@pytest.mark.slow
def test_walls_hidden_from_the_kernel_collide():
    """The ablation: the same doorway episodes with the walls hidden from the kernel touch walls;
    with them seen, none does."""
    suite = SUITES["doorway-v0"]
    seeds = list(suite.seeds)[:4]
    seen = run_episodes(suite.scenario, planner_controller(VCSPlanner()), seeds)
    blind = run_episodes(suite.scenario, planner_controller(WallBlindVCS()), seeds)
    assert _wall_contacts(seen) == 0
    assert _wall_contacts(blind) >= 2


def test_plot_masks_of_walls_agree_with_the_kernel():
    """The numpy reference of the picture (``object_forbidden_masks``) forbids what the kernel
    refuses, for a robot alone among walls (ramp check on)."""
    from baselines.vcs import geometry as G
    from baselines.vcs.plot import object_forbidden_masks

    rng = np.random.default_rng(5)
    planner = VCSPlanner()
    walls = [((-1.0, 0.6), (1.5, 0.6)), ((0.8, -2.0), (0.8, 0.2)), ((-1.5, -0.8), (-0.2, -1.4))]
    s = _custom([(-6.0, 6.0)], [(6.0, 6.0)], walls, [0.3])
    world = Simulator(s).reset(0)
    agree = refused = 0
    for _trial in range(6):
        world.pos[0, 0] = rng.uniform(-0.5, 0.3, 2)
        world.heading[0, 0] = rng.uniform(-np.pi, np.pi)
        world.speed[0, 0] = rng.uniform(0.0, 0.8)
        planner = VCSPlanner()
        dv = rng.uniform(-world.speed[0, 0], 1.0 - world.speed[0, 0], 400)
        dth = rng.uniform(-3.1, 3.1, 400)
        ok, _cost, horizon = planner.evaluate(world, 0, 0, dv, dth)
        vel = G.vcs_to_velocity(dv, dth, world.speed[0, 0], world.heading[0, 0])
        masks = object_forbidden_masks(world, planner, 0, 0, vel, horizon)
        assert set(masks) <= {2 + k for k in range(3)}
        forbidden = np.any([m for m in masks.values()], axis=0)
        agree += int((forbidden == ~ok).sum())
        refused += int((~ok).sum())
    assert agree >= 0.995 * 6 * 400 and refused > 100


def _episodes(suite: str, seeds, **kw):
    return run_episodes(SUITES[suite].scenario, planner_controller(VCSPlanner(**kw)), list(seeds))


def test_wall_brake_keeps_a_turning_robot_off_the_wall():
    """corridor-v0 seed 1092: a robot at 0.84 m/s starts a U-turn toward a goal behind it, the
    shorter way round, through the wall 0.56 m away. Without ``wall_brake`` (the ramp's
    positions only, and a fallback blind to ramps) it touches the wall; with it, every state of
    the ramp can brake straight to a stop clear of the wall, and nothing touches it."""
    assert _wall_contacts(_episodes("corridor-v0", [1092], wall_brake=False)) == 1
    (e,) = _episodes("corridor-v0", [1092])
    assert not contact_events(e) and (e.reached_step >= 0).all()


def test_fallback_brakes_clear_of_a_wall_rather_than_turn_through_it():
    """corridor-v0, fresh seeds: a robot that overshot its goal beside a parked robot comes back along the wall, closing
    on it at 0.3 m/s, 0.12 m away, with nothing admissible. Its fallback turned toward the goal, away from the wall in
    the end but through it on the way, where braking straight would have stopped it short: every such episode touched
    the wall (0.005-0.027 m deep). A candidate that cannot stop clear now ranks below one whose end velocity only lies
    in the wall's velocity obstacle (vcs-method §2.18), and none does."""
    assert not _wall_contacts(_episodes("corridor-v0", [5082, 5104, 5289, 5340]))


@pytest.mark.slow
def test_detour_keeps_off_the_wall():
    """A robot stopped facing a wall, its route along it: a detour that keeps right turned it
    into the wall on every try (door-headon-v0 seed 1007, robot 1, alone after the other passed;
    intersection-v0, robots pushed into the wrong branch). Keeping left there frees it."""
    kw = dict(wall_brake=False, detour_jitter=0.0, free_turn=False)  # the rule alone
    (stuck,) = _episodes("door-headon-v0", [1007], detour_off_walls=False, **kw)
    (free,) = _episodes("door-headon-v0", [1007], **kw)
    assert (stuck.reached_step < 0).any() and (free.reached_step >= 0).all()
    seeds = list(SUITES["intersection-v0"].seeds)[:8]
    arrived_off = sum(
        int((e.reached_step >= 0).all())
        for e in _episodes("intersection-v0", seeds, detour_off_walls=False, free_turn=False)
    )
    arrived_on = sum(int((e.reached_step >= 0).all()) for e in _episodes("intersection-v0", seeds, free_turn=False))
    assert arrived_on >= arrived_off + 3


def test_free_turn_starts_a_robot_stopped_against_a_wall():
    """A unicycle at rest 3 mm from a wall (the walls around robot 2 of walls-v0 seed 1074 with ``narrow_pass``),
    facing its route past the wall's end: every way of starting off along that heading closes on the wall, and
    turning in place toward the route gains nothing, so the ablation stands there, detour after detour. With
    ``free_turn`` it turns toward the nearest heading it can start along (vcs-method §2.13) and arrives."""
    walls = [((-0.33, -2.24), (0.59, -1.05)), ((0.83, -1.64), (2.23, -1.52)), ((-0.79, -1.05), (0.47, 1.33))]
    s = _custom([(0.22, -1.115)], [(4.2, 1.2)], walls, heading=[0.35], max_steps=300, min_separation=0.001)
    (stuck,) = run_episodes(s, planner_controller(VCSPlanner(free_turn=False)), [0])
    (free,) = run_episodes(s, planner_controller(VCSPlanner()), [0])
    assert (stuck.reached_step < 0).all() and np.ptp(stuck.pos[:, 0], axis=0).max() < 0.01
    assert (free.reached_step >= 0).all() and not contact_events(free)


def test_detour_jitter_breaks_the_door_head_on():
    """door-headon-v0: with detours of one length the pair of seed 1011 stalls, detours and comes
    back in step until the time runs out; detours of different lengths let one through first."""
    (same,) = _episodes("door-headon-v0", [1011], detour_jitter=0.0)
    (jittered,) = _episodes("door-headon-v0", [1011])
    assert (same.reached_step < 0).any()
    assert (jittered.reached_step >= 0).all() and not contact_events(jittered)


def test_narrow_pass_lets_one_through_first():
    """vcs-method §2.20, against its ablation. A 0.9 m door with 4 robots (seed 7008): robots 1 and 2 reach it from its
    two sides together, both drive in and touch; with ``narrow_pass`` the later one waits and all arrive untouched.
    door-headon-v0 seed 1011 with detours of one length (which alone stalls there for good, the test above): the
    later robot (by index: the pair is symmetric) waits before the door, and both arrive."""
    door = Scenario(
        kind="doorway", n_robots=4, door_width=0.9, arena_half_size=3.5, layout_radius=2.0, jitter=0.1,
        max_steps=600, on_collision="continue",
    )  # fmt: skip
    (off,) = run_episodes(door, planner_controller(VCSPlanner()), [7008])
    (on,) = run_episodes(door, planner_controller(VCSPlanner(narrow_pass=True)), [7008])
    assert contact_events(off) and not contact_events(on) and (on.reached_step >= 0).all()
    (e,) = _episodes("door-headon-v0", [1011], detour_jitter=0.0, narrow_pass=True)
    assert (e.reached_step >= 0).all() and not contact_events(e)


def test_fitted_buffers_pass_a_robot_parked_in_a_narrow_corridor():
    """corridor-narrow-v0 seed 1000: the first robot of each column parks at its goal in the middle
    of the 1.7 m corridor, 0.6 m from each wall, which lets a robot through with 0.05 m on each
    side. Under the buffers of vcs-method §2.6 (``fit_clearance=None``) the robot behind it
    stalls there for good (two robots never arrive); with buffers fitted to the gap it slows
    down and passes, and nothing touches anything."""
    (blocked,) = _episodes("corridor-narrow-v0", [1000], fit_clearance=None)
    (fitted,) = _episodes("corridor-narrow-v0", [1000], fit_clearance=0.01)
    assert (blocked.reached_step < 0).sum() == 2 and not contact_events(blocked)
    assert (fitted.reached_step >= 0).all() and not contact_events(fitted)


def test_fitted_gate_between_parked_robots():
    """corridor-v0: the front robots of each lane park at their goals 1.2 m apart across the corridor, 0.7
    m between their bodies, and a robot bound for a goal beyond them must pass between the two (0.1 m to
    spare on each side). Under the buffers of vcs-method §2.6 that gate is closed: holonomic robots
    (seeds 1010, 1018) and ten unicycles (seeds 9002, 9003) leave robots short of their goals; with
    ``fit_discs`` the robot heading for the gate slows down and passes, and nothing touches anything."""
    base = SUITES["corridor-v0"].scenario
    holonomic = dataclasses.replace(base, robot=dataclasses.replace(base.robot, holonomic=True))
    cases = [(holonomic, [1010, 1018]), (dataclasses.replace(base, n_robots=10), [9002, 9003])]
    for scenario, seeds in cases:
        for fit in (False, True):
            episodes = run_episodes(scenario, planner_controller(VCSPlanner(fit_discs=fit)), seeds)
            for e in episodes:
                assert not contact_events(e)
                assert (e.reached_step >= 0).all() == fit
    # fit_clearance=None turns all fitting off, between discs too: the same episode either way.
    scenario, seeds = cases[1][0], cases[1][1][:1]
    off, discs_off = (
        run_episodes(scenario, planner_controller(VCSPlanner(fit_clearance=None, fit_discs=f)), seeds)[0]
        for f in (True, False)
    )
    np.testing.assert_array_equal(off.pos, discs_off.pos)


def test_fitted_gate_only_where_the_ray_runs_between_the_bodies():
    """``fit_disc_pairs`` on two parked discs (physical radii 0.25 m, buffers 0.2 m beyond) and a robot at
    the origin heading along +x: a ray that keeps out of both bodies up to where it crosses the segment
    between their centres fits both buffers to max(clearance, (g - 2 r) / 4) (0.05 m for discs 1.2 m
    apart); one that runs into a body first (the robot bound past a robot parked in its lane, the gate
    across the lane or slanted along it), or does not cross at all, leaves them regulated."""
    r_i, clearance, buffer = 0.25, 0.01, 0.2

    def buffers(a, c):
        nbs = np.zeros(2, dtype=NEIGHBOUR)
        for rec, (x, y) in zip(nbs, (a, c), strict=True):
            rec["kind"], rec["px"], rec["py"] = K_STATIC, x, y
            rec["d"], rec["r0"] = np.hypot(x, y), 2 * r_i
            rec["reff"] = rec["r0"] + buffer
        fit_disc_pairs(nbs, 2, r_i, clearance, 1.0, 0.0)
        return nbs["reff"] - nbs["r0"]

    fitted, regulated = [0.05, 0.05], [buffer, buffer]
    np.testing.assert_allclose(buffers((1, -0.6), (1, 0.6)), fitted)  # through the middle of the gate
    np.testing.assert_allclose(buffers((1, -0.3), (1, 0.9)), fitted)  # 0.3 m from the near centre: past its body
    np.testing.assert_allclose(buffers((1, -0.9), (1, 0.3)), fitted)  # the same by the other disc
    np.testing.assert_allclose(buffers((1, -0.1), (1, 1.1)), regulated)  # into the near body at the crossing
    np.testing.assert_allclose(buffers((1, -1.1), (1, 0.1)), regulated)  # into the other one
    np.testing.assert_allclose(buffers((1, -0.05), (2.5, 0.1)), regulated)  # into the near body before a slanted gate
    np.testing.assert_allclose(buffers((1, 0.1), (1, 1.3)), regulated)  # not between them at all


def _into_crossing_corridor(e) -> np.ndarray:
    """``(n,)`` [m]: how far each robot of an ``intersection`` episode got across its own
    corridor's axis (into the other corridor beyond 1.25 m, its half width)."""
    along_x = np.abs(e.goal[:, 0]) > np.abs(e.goal[:, 1])
    across = np.where(along_x, np.abs(e.pos[..., 1]), np.abs(e.pos[..., 0]))  # (T + 1, n)
    return across.max(axis=0)


@pytest.mark.slow
def test_give_way_keeps_robots_out_of_the_crossing_corridor():
    """intersection-v0 seeds 1014, 1022, 1029: the two groups reach the junction together. Without
    ``give_way`` a robot crosses in front of the other group's stream, is carried along it deep
    into the other corridor, beyond the robots parked there, and never arrives; giving way to the
    robots coming from the right (vcs-method §2.19), one group waits before the junction, every
    robot stays in its own corridor and arrives, and nothing touches anything."""
    seeds = [1014, 1022, 1029]
    alone = dict(fit_clearance=None, free_turn=False)  # the rule alone: fitted buffers let some of them through later
    for e in _episodes("intersection-v0", seeds, give_way=False, **alone):
        assert (e.reached_step < 0).any() and _into_crossing_corridor(e).max() > 5.0
    for e in _episodes("intersection-v0", seeds, **alone):
        assert (e.reached_step >= 0).all() and not contact_events(e)
        assert _into_crossing_corridor(e).max() < 1.25
