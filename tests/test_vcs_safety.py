"""The VCS expert against what does not get out of its way (issue: parked robots, static
obstacles, non-reactive crowds). Each rule is measured against its ablation on the same
episodes; the seeds are not any suite's, but where a test names one (crowd_reach: seed 1009)."""

import dataclasses
import math

import numpy as np
import pytest

import vcs_env
from baselines.vcs import VCSPlanner
from baselines.vcs import experiments as X
from vcs_env.contacts import contact_events
from vcs_env.engine import NavEngine
from vcs_env.metrics import episode_metrics
from vcs_env.rollout import planner_controller, run_episodes
from vcs_env.scenario import ObstacleTrajectory
from vcs_env.suites import get_suite

SAFETY_OFF = dict(arriving_non_reactive=False, stop_margin=False, ramp_check=False, fallback="penalty")
"""The rules that keep the robot off parked robots and static obstacles, all off."""


def _run(scenario, seeds, **params):
    return run_episodes(scenario, planner_controller(VCSPlanner(**params)), seeds)


def _parked_contacts(ep) -> int:
    """Contacts (robot-steps) with a robot that had already parked."""
    count = 0
    for t, i in zip(*np.nonzero(ep.robot_contact)):
        parked = (ep.reached_step >= 0) & (ep.reached_step <= t)
        gaps = np.linalg.norm(ep.pos[t + 1] - ep.pos[t + 1, i], axis=-1) - ep.radius - ep.radius[i]
        gaps[i] = np.inf
        count += bool(parked[np.argmin(gaps)])
    return count


def test_dense_random_layouts_parked_robots_are_not_hit():
    """12 robots in a 8 m square park among the traffic. With the safety rules no robot touches
    a parked one; with them off (every active robot reciprocal, a fixed 1 s margin, end
    velocities judged alone, the plain fallback penalty) robots run into parked ones (measured:
    contacts in 4 of these 10 episodes)."""
    scenario = vcs_env.make_scenario("random", n_robots=12, arena_half_size=4.0, on_collision="continue")
    seeds = range(5000, 5010)
    safe = _run(scenario, seeds)
    ablated = _run(scenario, seeds, **SAFETY_OFF)
    assert sum(_parked_contacts(e) for e in safe) == 0
    assert not any(episode_metrics(e)["collision"] for e in safe)
    assert sum(_parked_contacts(e) > 0 for e in ablated) >= 2


def _robot_contacts_at_fault(ep) -> int:
    """At-fault contacts between two robots that both still drive (``vcs_env.contacts``)."""
    return sum(c.kind == "robot" and c.at_fault for c in contact_events(ep))


def test_ramp_check_keeps_turning_robots_off_driving_ones():
    """A large turn whose end velocity leaves the other robot's HRVO cone can sweep through that
    robot on the way. The ramp check covers driving robots under the reciprocal assumption (the
    other takes the mirror of the change). These are the dense random layouts of seeds
    5100-5399 where the ramp check of non-reactive bodies alone let a robot turn into a driving
    one (4 of 300 episodes; 1 of 300, seed 5290, with driving robots covered): no contact
    between driving robots with it, contacts in every one of them with the ramp check off (and
    ``arriving_goal_twin`` off: the twin where an arriving robot will park also keeps the robots
    of these four episodes apart without the ramp check, measured; and ``step_split`` off, which
    keeps two of them apart on its own)."""
    scenario = vcs_env.make_scenario("random", n_robots=12, arena_half_size=4.0, on_collision="continue")
    seeds = (5142, 5219, 5365, 5368)
    checked = _run(scenario, seeds, arriving_goal_twin=False)
    ablated = _run(scenario, seeds, ramp_check=False, arriving_goal_twin=False, step_split=False)
    assert sum(_robot_contacts_at_fault(e) for e in checked) == 0
    assert sum(_robot_contacts_at_fault(e) > 0 for e in ablated) >= 3
    assert sum(_robot_contacts_at_fault(e) for e in _run(scenario, seeds, ramp_check=False)) == 0


def test_crowd_margin_watches_a_crowd_further_ahead():
    """Among 20 non-reactive crossing obstacles the margin of T_m per contesting mover keeps the
    robot out of the crush that the single-mover margin walks into (measured on these 20
    episodes: 20 against 10 solved); a lone crossing mover still gets the un-conservative
    T_m (test_uc1/uc2)."""
    suite = get_suite("crowd-20-v0")
    seeds = range(7000, 7020)
    full = [episode_metrics(e)["success"] for e in _run(suite.scenario, seeds)]
    alone = [episode_metrics(e)["success"] for e in _run(suite.scenario, seeds, crowd_margin=False)]
    assert np.mean(full) >= 0.9
    assert np.mean(full) >= np.mean(alone) + 0.2


def test_crowd_reach_counts_movers_a_slow_robot_could_meet():
    """A robot that slows among crossing movers closes on none of them, so counting only the
    movers that close on its current velocity shrinks its horizons exactly when the crowd
    surrounds it. Counting every mover it could meet within T_max (crowd_reach) keeps the crowd in
    view. Measured on eight crowd-20 episodes where the two counts differ (the suite's seed 1009,
    the rest fresh): 7 of 8 solved against 1 of 8 with the closing count (crowd_reach=False).
    Both arms without the fallback's play-out against movers (fallback_contact), measured later:
    it also solves 7 of 8 with the closing count."""
    seeds = (1009, 5206, 5224, 5258, 5484, 5949, 6039, 6126)
    scenario = get_suite("crowd-20-v0").scenario
    reach = [episode_metrics(e)["success"] for e in _run(scenario, seeds, fallback_contact=None)]
    closing = [episode_metrics(e)["success"] for e in _run(scenario, seeds, crowd_reach=False, fallback_contact=None)]
    assert sum(reach) >= 6
    assert sum(closing) <= 3
    assert sum(episode_metrics(e)["success"] for e in _run(scenario, seeds)) >= 6


def test_fallback_inside_a_buffer_ranks_by_contact_with_a_clearance():
    """Among 20 crossing movers the robot can end up inside the regulated buffers of movers that
    flank it, where every buffered time to collision is ~0; the fallback then measures time to
    contact at r0 + fallback_clearance, so braking or turning away from the crossing mover ranks
    above keeping course into it. Measured on these fresh seeds (the default's crowd-20 failures
    among 5200-6199 that the rule removes): 3 of 3 solved against 0 of 3 (all collide) with the
    regulated buffer throughout (fallback_clearance=None). Both arms count contesting movers by
    closing speed (crowd_reach=False), the rule these seeds were picked under, and neither plays
    candidates out against the movers (fallback_contact), a rule measured later."""
    suite = get_suite("crowd-20-v0")
    seeds = (5246, 5521, 5989)
    arm = dict(crowd_reach=False, fallback_contact=None)
    new = [episode_metrics(e) for e in _run(suite.scenario, seeds, **arm)]
    old = [episode_metrics(e) for e in _run(suite.scenario, seeds, **arm, fallback_clearance=None)]
    assert all(m["success"] == 1.0 for m in new)
    assert sum(m["collision"] for m in old) >= 2


@pytest.mark.parametrize("fallback", ["least_harm", "penalty"])
def test_fallback_never_speeds_up_into_what_it_touches(fallback):
    """A robot already overlapping a static obstacle that lies between it and its goal: no
    velocity is admissible. The least-harm fallback brakes and turns away; the plain penalty
    (every candidate has t_c = 0) falls back on the goal term and drives on into it."""
    wall = ObstacleTrajectory(times=(0.0,), positions=((0.45, 0.0),), radius=0.25)
    scenario = X._scenario(((-1.0, 0.0),), ((5.0, 0.0),), [wall], r_ca=6.0, speeds=(0.6,), headings=(0.0,))
    eng = NavEngine(scenario)
    eng.reset([0])
    eng.world.pos[0, 0] = (0.0, 0.0)  # 0.05 m deep inside the obstacle
    planner = VCSPlanner(fallback=fallback)
    planner.plan(eng.world)
    assert planner.last["fallback"][0, 0]
    dv, dth = planner.last["target"][0, 0]
    if fallback == "least_harm":
        assert dv < 0.0 or abs(dth) >= math.pi / 2 - 1e-9
        # the commanded first step does not close on the obstacle faster than now
        step = eng.world.speed[0, 0] + np.clip(dv, -0.05, 0.05)
        head = np.clip(dth, -0.1 * math.pi / 2, 0.1 * math.pi / 2)
        assert step * math.cos(head) <= eng.world.speed[0, 0] + 1e-12
    else:
        assert dv >= 0.0 and abs(dth) < 0.5


def test_progress_stall_detects_creeping_without_a_slow_speed():
    """A robot that circles its goal at 0.3 m/s (well above the stall speed) gains no ground:
    after ``progress_window`` it detours; with the progress test off it never does."""
    scenario = X._scenario(((2.0, 0.0),), ((0.0, 0.0),), [], r_ca=6.0, speeds=(0.3,), headings=(math.pi / 2,))
    for window, expect in ((3.0, True), (0.0, False)):
        eng = NavEngine(scenario)
        eng.reset([0])
        w = eng.world
        planner = VCSPlanner(progress_window=window)
        detoured = False
        for k in range(60):  # 6 s on a circle of radius 2 m around the goal
            ang = 0.3 * 0.1 * k / 2.0
            w.pos[0, 0] = (2.0 * math.cos(ang), 2.0 * math.sin(ang))
            w.heading[0, 0] = ang + math.pi / 2
            w.steps[:] = k
            planner.plan(w)
            detoured |= bool(planner.last["detour"][0, 0])
        assert detoured == expect, window


@pytest.mark.slow
def test_stopping_obstacles_keep_the_robot_from_following_closer_than_it_brakes():
    """Obstacles that stop and go (``obstacle_motion="stop_and_go"``): a robot following one closer
    than its braking distance runs into it when it stops. With ``stopping_obstacles`` every moving
    obstacle also counts as static where it is (a twin, as for an arriving robot): at-fault
    obstacle contacts in 2 of these 30 crowd-20 episodes, against 7 with the default (measured)."""
    scenario = vcs_env.make_scenario(
        get_suite("crowd-20-v0").scenario, obstacle_motion="stop_and_go", on_collision="continue"
    )
    seeds = range(20000, 20030)

    def at_fault(eps):
        return sum(any(c.kind == "obstacle" and c.at_fault for c in contact_events(e)) for e in eps)

    assert at_fault(_run(scenario, seeds, stopping_obstacles=True)) <= 2
    assert at_fault(_run(scenario, seeds)) >= 5


def test_goal_twin_keeps_followers_off_a_robot_that_parks_at_speed():
    """An arriving robot that is faster than it can brake to its goal parks there dead at speed
    (the simulator parks it on arrival). ``random-dense-holonomic-v0`` seeds 1044 and 1092: a
    robot behind or beside such a robot, at a gap shorter than its own braking distance, ran
    into it where it parked (robot 7 into robot 8 at 0.8 m/s, robot 4 into robot 7). With
    ``arriving_goal_twin`` it keeps its braking distance from the spot the other robot will park
    on, told by its communicated preferred velocity: no at-fault contact (measured). Both arms
    without ``holonomic_window_fit``, a rule measured later (with it, one of the two is avoided
    without the twin too)."""
    suite = get_suite("random-dense-holonomic-v0")
    seeds = (1044, 1092)

    def at_fault(eps):
        return sum(any(c.at_fault for c in contact_events(e)) for e in eps)

    assert at_fault(_run(suite.scenario, seeds, holonomic_window_fit=False)) == 0
    assert at_fault(_run(suite.scenario, seeds, holonomic_window_fit=False, arriving_goal_twin=False)) == 2
    assert at_fault(_run(suite.scenario, seeds)) == 0


def _obstacle_faults(eps) -> int:
    """Episodes with an at-fault contact with an obstacle."""
    return sum(any(c.kind == "obstacle" and c.at_fault for c in contact_events(e)) for e in eps)


def _solved(eps) -> int:
    """Episodes solved."""
    return sum(bool(episode_metrics(e)["success"]) for e in eps)


def test_mirror_images_see_obstacles_coming_back_off_the_arena_edge():
    """Obstacles faster than the robot reflect off the arena's edges (``dynamic-fast-v0``'s
    scenario, seeds no suite uses). A robot that plans against their velocity alone is caught by
    the bounce; with ``mirror_bounces`` it also plans against each obstacle's mirror image in the
    edge it moves toward, which moves straight along the path the obstacle takes after the bounce:
    at-fault obstacle contacts in 2 of these 50 episodes, against 9 without (measured; both arms
    without the fallback's play-out against movers, a rule measured later: with it, 6 without the
    images)."""
    scenario = get_suite("dynamic-fast-v0").scenario
    seeds = range(5000, 5050)
    assert _obstacle_faults(_run(scenario, seeds, fallback_contact=None)) <= 3
    assert _obstacle_faults(_run(scenario, seeds, mirror_bounces=False, fallback_contact=None)) >= 7


def test_no_follow_keeps_the_robot_from_riding_inside_a_movers_buffer():
    """``dynamic-v0``'s scenario, seeds 5089 and 5291: a robot that may close on a receding
    obstacle inside its buffer rides a few centimetres behind it for a second or more, and touches
    it, driving toward it, when the obstacle turns. With ``no_follow`` it closes on a mover whose
    buffer it is in no faster than it could brake within the gap: no at-fault contact, against
    one in each episode (measured)."""
    scenario = get_suite("dynamic-v0").scenario
    seeds = (5089, 5291)
    # Measured before movers that turn and the fallback's play-out against movers: with either on,
    # one or neither episode has the contact without no_follow.
    before = dict(mover_turn_lead=None, fallback_contact=None)
    assert _obstacle_faults(_run(scenario, seeds, **before)) == 0
    assert _obstacle_faults(_run(scenario, seeds, **before, no_follow=False)) == 2
    assert _obstacle_faults(_run(scenario, seeds)) == 0


def test_escalating_detours_back_a_wedged_robot_out():
    """Robots among robots that park in the traffic (``random-dense-v0``'s scenario, seeds no suite
    uses): a robot that ends up between two parked robots, a few centimetres from each, can only
    move back out, away from its goal; a detour that keeps right by 45 degrees stays blocked, and
    the robot waits there for good. With ``detour_escalate`` each detour without progress turns
    further, up to a half turn: all seven of these episodes solved, against none without
    (measured, with the gates between parked robots closed, ``fit_discs=False``, and turning toward the goal's own
    heading, ``free_turn=False``, as before them; with both, the default, all seven are solved)."""
    scenario = get_suite("random-dense-v0").scenario
    seeds = (5016, 5032, 5084, 5149, 5180, 5197, 5238)

    assert _solved(_run(scenario, seeds)) == 7
    before = dict(fit_discs=False, free_turn=False)
    assert _solved(_run(scenario, seeds, **before)) == 7
    assert _solved(_run(scenario, seeds, detour_escalate=False, **before)) == 0


def test_a_robot_stalled_at_rest_turns_in_place_toward_its_detour():
    """12 unicycles among 10 static obstacles in a 10 m square (seeds no suite uses). A robot that
    stopped a few centimetres beside an obstacle, facing it, closes on it in every way of starting
    off (the ramp check refuses them), and at zero speed every heading costs the same goal term,
    so it stood there for good, detour after detour. With ``stall_turn`` a robot that detours from
    rest measures its goal in the velocity change space and turns in place first: all six of these
    episodes solved, against none without (measured, with the gates between static discs closed,
    ``fit_discs=False``, as before them). With the gates fitted, the default, the turn still counts:
    five of the six against three without it (seed 5037 is lost through a fitted gate, vcs-calibration §7)."""
    scenario = vcs_env.make_scenario(
        "random", n_robots=12, n_obstacles=10, obstacle_motion="static", arena_half_size=5.0, on_collision="continue"
    )
    seeds = (5000, 5037, 5050, 5051, 5070, 5092)

    assert _solved(_run(scenario, seeds, fit_discs=False)) == 6
    assert _solved(_run(scenario, seeds, fit_discs=False, stall_turn=False)) == 0
    assert _solved(_run(scenario, seeds)) > _solved(_run(scenario, seeds, stall_turn=False))


def test_turned_velocities_turn_at_the_measured_rate_and_skip_jumps():
    """The oracle of ``VCSParams.mover_turn_lead``: a velocity that turned by 0.05 rad over a 0.1 s
    period is taken 0.2 s ahead (turned 0.1 rad more); a bounce (a turn faster than
    ``MAX_TURN_RATE``), an obstacle at rest and a world without a previous period keep theirs."""
    from baselines.vcs.planner import MAX_TURN_RATE, turned_velocities

    def polar(angle, speed=1.5):
        return speed * np.array([math.cos(angle), math.sin(angle)])

    before = np.array([[polar(0.3), polar(0.0), [0.0, 0.0]], [polar(0.3), polar(0.0), polar(1.0)]])
    now = np.array(
        [[polar(0.35), polar(MAX_TURN_RATE * 0.1 + 0.01), [0.0, 0.0]], [polar(0.35), polar(0.0), polar(1.0)]]
    )
    out = turned_velocities(before, now, np.array([True, False]), 0.1, 0.2)
    np.testing.assert_allclose(out[0, 0], polar(0.45), atol=1e-12)
    np.testing.assert_allclose(out[0, 1:], now[0, 1:], atol=1e-12)
    np.testing.assert_allclose(out[1], now[1], atol=1e-12)  # no previous period in world 1


def test_mover_turn_lead_changes_nothing_for_movers_that_do_not_turn():
    """Obstacles that move straight (``obstacle_motion="constant"``, no bounces) keep their
    velocity: the same episodes, step for step."""
    scenario = dataclasses.replace(get_suite("dynamic-v0").scenario, obstacle_motion="constant", bounce=False)
    a = _run(scenario, [5000, 5001], mover_turn_lead=None)
    b = _run(scenario, [5000, 5001])
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.pos, y.pos)


def test_mover_turn_lead_keeps_off_movers_that_turn_toward_the_robot():
    """``dynamic-fast-v0``'s scenario (obstacles of 1.2-1.8 m/s that turn at up to 0.6 rad/s), the
    fresh seeds among 5000-5099 where the robot without the lead drives into an obstacle: taken
    0.2 s ahead on its turn (the default), none of these four ends in an at-fault contact (measured; over seeds
    5000-5099 the count is 3 against 5, over 5000-5299 the rate 0.023 against 0.057, and success
    0.61 against 0.51, docs/vcs-calibration.md)."""
    scenario = get_suite("dynamic-fast-v0").scenario
    seeds = (5014, 5015, 5062, 5072)
    assert _obstacle_faults(_run(scenario, seeds, mover_turn_lead=None)) == 4
    assert _obstacle_faults(_run(scenario, seeds)) == 0


def _mover_contact_oracle(speed, heading, dv, dth, dv1, dth1, dt, rel, vel, r0, horizon):
    """First contact [s] and speed toward the obstacle then [m/s], stepping the ramp by hand: speed
    and heading move toward (speed + dv, heading + dth) by at most (dv1, dth1) a step, the obstacle
    at ``rel`` [m] (relative to the robot) moves at ``vel`` [m/s]."""
    p, q = np.zeros(2), np.asarray(rel, dtype=float)
    for k in range(1, int(round(horizon / dt)) + 1):
        s = speed + float(np.clip(dv, -k * dv1, k * dv1))
        h = heading + float(np.clip(dth, -k * dth1, k * dth1))
        v = s * np.array([math.cos(h), math.sin(h)])
        p, q = p + v * dt, q + np.asarray(vel) * dt
        gap = q - p
        if np.linalg.norm(gap) < r0:
            return k * dt, max(float(v @ gap / np.linalg.norm(gap)), 0.0)
    return math.inf, 0.0


@pytest.mark.parametrize(
    "dv,dth", [(0.5, 0.0), (-0.5, 0.0), (0.5, math.pi / 2), (0.5, -math.pi / 2), (0.2, -math.pi / 4)]
)
def test_mover_contact_plays_the_ramp_against_the_mover(dv, dth):
    """The oracle of ``VCSParams.fallback_contact``'s play-out (:func:`~baselines.vcs.kernel.fallback.mover_contact`):
    a unicycle at 0.5 m/s heading east, a mover 2 m ahead and 1.5 m to the left crossing at
    (-0.5, -1.4) m/s: full speed ahead meets it after 1.1 s head on, turning right later and less
    head on, braking or turning left not at all. A driving robot is not counted."""
    from baselines.vcs.kernel.fallback import mover_contact
    from baselines.vcs.kernel.records import K_MOVER, K_RECIPROCAL, NEIGHBOUR, ROBOT

    r = np.zeros(1, dtype=ROBOT)
    r["v_r"], r["th"], r["vrx"], r["dv1"], r["dth1"], r["dt"] = 0.5, 0.0, 0.5, 0.05, 0.157, 0.1
    nbs = np.zeros(2, dtype=NEIGHBOUR)
    nbs["px"], nbs["py"], nbs["d"], nbs["r0"] = 2.0, 1.5, 2.5, 0.6
    nbs["vjx"], nbs["vjy"] = -0.5, -1.4
    nbs["kind"] = K_MOVER, K_RECIPROCAL  # the same body as a driving robot: not counted
    t, toward = mover_contact(nbs, 2, r[0], dv, dth, 0.0, 5.0)
    t_ref, toward_ref = _mover_contact_oracle(0.5, 0.0, dv, dth, 0.05, 0.157, 0.1, (2.0, 1.5), (-0.5, -1.4), 0.6, 5.0)
    assert t == pytest.approx(t_ref) and toward == pytest.approx(toward_ref)
    t, toward = mover_contact(nbs, 2, r[0], dv, dth, 0.1, 5.0)  # a clearance widens the contact radius
    t_ref, toward_ref = _mover_contact_oracle(0.5, 0.0, dv, dth, 0.05, 0.157, 0.1, (2.0, 1.5), (-0.5, -1.4), 0.7, 5.0)
    assert t == pytest.approx(t_ref) and toward == pytest.approx(toward_ref)
    far = nbs.copy()  # 20 m away at 2 m/s: out of reach within 5 s (the play-out's pruning)
    far["px"], far["py"], far["d"], far["vjx"], far["vjy"] = 20.0, 0.0, 20.0, -2.0, 0.0
    assert mover_contact(far, 1, r[0], dv, dth, 0.0, 5.0) == (math.inf, 0.0)
    assert _mover_contact_oracle(0.5, 0.0, dv, dth, 0.05, 0.157, 0.1, (20.0, 0.0), (-2.0, 0.0), 0.6, 5.0)[0] == math.inf
    nbs["kind"] = K_RECIPROCAL
    assert mover_contact(nbs, 2, r[0], dv, dth, 0.0, 5.0) == (math.inf, 0.0)


def test_fallback_contact_changes_nothing_without_moving_obstacles():
    """Among robots only (``circle-16-v0``'s scenario), where the fallback is used, the play-out
    against moving obstacles has nothing to count: the same episodes, step for step."""
    scenario = get_suite("circle-16-v0").scenario
    a = _run(scenario, [5000, 5001], fallback_contact=None)
    planner, fell_back = VCSPlanner(), []

    def control(world, obs):
        action = planner.act(world, "delta")
        fell_back.append(bool(planner.last["fallback"].any()))
        return action

    b = run_episodes(scenario, control, [5000, 5001])
    assert any(fell_back)  # the fallback ran (42 robot-steps when measured)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.pos, y.pos)


def test_fallback_contact_escapes_movers_faster_than_the_robot_late_and_not_head_on():
    """``dynamic-fast-v0``'s scenario, the fresh seeds among 5000-5099 where the default without the
    play-out drives into a mover after a run of fallback steps (it kept its forward speed and
    dodged sideways into a mover that turned toward it): with it, neither ends in an at-fault
    contact (measured; over seeds 5000-5099 the count is 1 against 3, over 5000-5299 the rate 0.013
    against 0.023 and over 6000-6499 0.026 against 0.038, docs/vcs-calibration.md)."""
    scenario = get_suite("dynamic-fast-v0").scenario
    seeds = (5030, 5082)
    assert _obstacle_faults(_run(scenario, seeds, fallback_contact=None)) == 2
    assert _obstacle_faults(_run(scenario, seeds)) == 0


def test_holonomic_window_fit_keeps_lateral_escapes_from_fast_movers():
    """``dynamic-fast-v0``'s scenario with holonomic robots (a_max 0.5 m/s^2), the fresh seeds among
    5000-5099 where the window grid over every speed and direction (of which a small disc keeps a
    few points along the heading) ends in an at-fault contact with an obstacle: with the grid fitted
    to the disc, none does (measured; over seeds 5000-5099 the count is 16 against 25, over
    6000-6199 the rate 0.20 against 0.265, docs/vcs-calibration.md)."""
    scenario = get_suite("dynamic-fast-v0").scenario
    scenario = dataclasses.replace(scenario, robot=dataclasses.replace(scenario.robot, holonomic=True))
    seeds = (5000, 5042, 5062, 5089)
    assert _obstacle_faults(_run(scenario, seeds, holonomic_window_fit=False)) == 4
    assert _obstacle_faults(_run(scenario, seeds)) == 0


def test_holonomic_window_fit_changes_nothing_where_the_disc_holds_the_domain():
    """CrowdNav's robot (a_max 10 m/s^2, dt 0.25 s) reaches every velocity in one step: its window
    disc always holds the whole domain, and the fitted grid is the full one, step for step."""
    scenario = get_suite("crowdnav-circle-v0").scenario
    a = _run(scenario, [5000, 5001], holonomic_window_fit=False)
    b = _run(scenario, [5000, 5001])
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.pos, y.pos)


@pytest.mark.filterwarnings("ignore::baselines.vcs.CoarseStepWarning")
@pytest.mark.parametrize("dt", [0.5, 1.0])
def test_step_split_keeps_robots_apart_within_coarse_steps(dt):
    """Every robot plans from the same snapshot, then drives a whole step: the velocity obstacles' guess of the other's
    next velocity (the mirror of one's change) is off by up to 2 a_max dt. Fast robots (3 m/s, 10 m/s^2) on a circle at
    coarse steps each cleared the other's predicted motion and drove into its actual one; with each first step keeping
    its share of every gap (``step_split``) no driving robot touches another (measured: none at either step with it,
    contacts in all 8 episodes without; at the suites' steps the plans are the same either way)."""
    robot = vcs_env.RobotSpec(v_max=3.0, a_max=10.0)
    scenario = vcs_env.make_scenario("circle", n_robots=8, dt=dt, robot=robot, on_collision="continue")
    seeds = range(5000, 5008)
    split = _run(scenario, seeds)
    ablated = _run(scenario, seeds, step_split=False)
    assert sum(_robot_contacts_at_fault(e) for e in split) == 0
    assert all(np.all(e.reached_step >= 0) for e in split)
    assert sum(_robot_contacts_at_fault(e) > 0 for e in ablated) >= 6
