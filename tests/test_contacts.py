"""Contacts explained: who touched whom, at fault or not, on hand-made episodes."""

import dataclasses
import math

import numpy as np
import pytest

import vcs_env
from vcs_env import metrics
from vcs_env.contacts import FAULT_SPEED, contact_events
from vcs_env.rollout import Episode, run_episodes


def episode(pos, obs_pos, robot_hits, obstacle_hits, acted, reached_step, dt=0.1):
    """Robots ``pos (T+1, n, 2)``, obstacles ``obs_pos (T+1, m, 2)``, radius 0.25 m each."""
    pos, obs_pos = np.asarray(pos, float), np.asarray(obs_pos, float).reshape(len(pos), -1, 2)
    T, n, m = len(pos) - 1, pos.shape[1], obs_pos.shape[1]
    robot_hits = np.asarray(robot_hits, bool).reshape(T, n, n)
    obstacle_hits = np.asarray(obstacle_hits, bool).reshape(T, n, m)
    return Episode(
        seed=0,
        dt=dt,
        radius=np.full(n, 0.25),
        goal=pos[-1],
        obs_radius=np.full(m, 0.25),
        pos=pos,
        heading=np.zeros((T + 1, n)),
        speed=np.zeros((T + 1, n)),
        obs_pos=obs_pos,
        actions=np.zeros((T, n, 2)),
        acted=np.asarray(acted, bool),
        collided=robot_hits.any(2) | obstacle_hits.any(2),
        robot_contact=robot_hits.any(2),
        obstacle_contact=obstacle_hits.any(2),
        min_separation=np.zeros((T, n)),
        reached_step=np.asarray(reached_step),
        straight_time=np.ones(n),
        robot_hits=robot_hits,
        obstacle_hits=obstacle_hits,
    )


def test_a_robot_driving_into_a_parked_one_is_at_fault_and_the_parked_one_is_not():
    # Robot 0 drives +x at 0.5 m/s into robot 1, parked at x = 0.6 since step 0; contact in
    # steps 1 and 2 (one contact), robot 0 stops touching after.
    pos = [[[0.0, 0], [0.6, 0]], [[0.05, 0], [0.6, 0]], [[0.1, 0], [0.6, 0]], [[0.12, 0], [0.6, 0]]]
    hits = np.zeros((3, 2, 2), bool)
    hits[1:, 0, 1] = hits[1:, 1, 0] = True
    ep = episode(pos, np.zeros((4, 0, 2)), hits, np.zeros((3, 2, 0)), [[1, 0]] * 3, [-1, 0])
    (c0, c1) = sorted(contact_events(ep), key=lambda c: c.robot)
    assert (c0.step, c0.robot, c0.kind, c0.other) == (1, 0, "parked", 1)
    assert c0.at_fault and c0.toward == pytest.approx(0.5)
    assert c0.depth == pytest.approx(0.5 - 0.48)  # deepest end-of-step overlap of the run
    assert (c1.kind, c1.other, c1.at_fault, c1.toward) == ("robot", 0, False, 0.0)
    row = metrics.episode_metrics(ep)
    assert row["collision"] == 1 and row["at_fault_collision"] == 1 and row["not_at_fault_collision"] == 0


def test_a_robot_that_one_step_carries_past_a_body_is_at_fault():
    """The direction to the other body is taken where they first touch within the step: from the end of the step, a
    robot carried past a standing robot's centre (speed x dt above its radius) read as moving away from it."""
    pos = [[[0.0, 0.0], [0.6, 0.0]], [[0.9, 0.02], [0.6, 0.0]]]  # 9 m/s for 0.1 s, through robot 1
    hits = np.zeros((1, 2, 2), bool)
    hits[0, 0, 1] = hits[0, 1, 0] = True
    ep = episode(pos, np.zeros((2, 0, 2)), hits, np.zeros((1, 2, 0)), [[1, 0]], [-1, 0])
    (c0, c1) = sorted(contact_events(ep), key=lambda c: c.robot)
    assert c0.at_fault and c0.toward == pytest.approx(9.0, rel=1e-3) and not c1.at_fault
    # The same through a thin wall, simulated: one robot, nothing else in the world, so it alone can be at fault.
    s = vcs_env.Scenario(
        kind="custom", n_robots=1, on_collision="continue", max_steps=5, robot=vcs_env.RobotSpec(v_max=3.0, a_max=10.0),
        custom=vcs_env.CustomLayout(start=[(-0.56, 0)], goal=[(3, 0)], speed=[3.0], walls=[((0, -1), (0, 1))]),
    )  # fmt: skip
    (ep,) = run_episodes(s, lambda w, o: np.ones((1, 1, 2)) * [1.0, 0.0], [0])
    (c,) = contact_events(ep)
    assert c.kind == "wall" and c.at_fault and c.toward == pytest.approx(3.0)


def test_an_obstacle_running_into_a_standing_robot_is_not_its_fault():
    pos = np.zeros((3, 1, 2))
    obs = [[[1.0, 0]], [[0.55, 0]], [[0.4, 0]]]
    ob_hits = np.array([[[False]], [[True]]])
    ep = episode(pos, obs, np.zeros((2, 1, 1)), ob_hits, [[1], [1]], [-1])
    (c,) = contact_events(ep)
    assert (c.step, c.kind, c.other, c.at_fault) == (1, "obstacle", 0, False)
    row = metrics.episode_metrics(ep)
    assert row["at_fault_collision"] == 0 and row["not_at_fault_collision"] == 1 and row["parked_collision"] == 0


def test_moving_past_within_the_tolerance_is_not_at_fault():
    # Robot 0 slides sideways past robot 1 at a speed toward it just under the tolerance.
    v = 0.9 * FAULT_SPEED
    pos = [[[0.0, 0.0], [0.49, 0.0]], [[v * 0.1, 0.2], [0.49, 0.0]]]
    hits = np.ones((1, 2, 2), bool) & ~np.eye(2, dtype=bool)
    ep = episode(pos, np.zeros((2, 0, 2)), hits, np.zeros((1, 2, 0)), [[1, 1]], [-1, -1])
    c0 = next(c for c in contact_events(ep) if c.robot == 0)
    assert c0.kind == "robot" and not c0.at_fault and c0.toward < FAULT_SPEED


def test_episodes_without_the_record_have_no_fault_metrics():
    ep = episode(np.zeros((2, 1, 2)), np.zeros((2, 0, 2)), np.zeros((1, 1, 1)), np.zeros((1, 1, 0)), [[1]], [-1])
    ep.robot_hits = None
    assert math.isnan(metrics.episode_metrics(ep)["at_fault_collision"])
    with pytest.raises(ValueError, match="robot_hits"):
        contact_events(ep)


def test_a_hand_made_episode_that_disagrees_with_itself_is_named():
    """``contact_events`` checks the episode as the metrics do (a position record one step short gave no contact at
    all), and a step of 0 s is refused by both (it divided by zero)."""
    pos = [[[0.0, 0], [0.6, 0]], [[0.05, 0], [0.6, 0]], [[0.1, 0], [0.6, 0]], [[0.12, 0], [0.6, 0]]]
    hits = np.zeros((3, 2, 2), bool)
    hits[1:, 0, 1] = hits[1:, 1, 0] = True
    ep = episode(pos, np.zeros((4, 0, 2)), hits, np.zeros((3, 2, 0)), [[1, 0]] * 3, [-1, 0])
    assert len(contact_events(ep)) == 2
    with pytest.raises(ValueError, match=r"Episode.pos has shape \(3, 2, 2\), expected \(4, 2, 2\)"):
        contact_events(dataclasses.replace(ep, pos=ep.pos[:-1]))
    for call in (contact_events, metrics.episode_metrics):
        with pytest.raises(ValueError, match=r"Episode.dt must be a step length > 0 \[s\], got 0.0"):
            call(dataclasses.replace(ep, dt=0.0))


def test_intervals_refuse_counts_that_are_none():
    for bad in (0, -3, 1.5, True):
        with pytest.raises(ValueError, match="df must be an integer >= 1"):
            metrics.t95(bad)  # 0 and -3 read the table from its end (2.042, 2.052)
    with pytest.raises(ValueError, match=r"successes must lie in \[0, n\] = \[0, 10\], got 12"):
        metrics.wilson_interval(12, 10)  # a math domain error
    with pytest.raises(ValueError, match="n must be a count of episodes"):
        metrics.wilson_interval(5, -1)  # (6.27, -1.40)
    with pytest.raises(ValueError, match=r"every row must have the same metrics: row 1 has \['success'\]"):
        metrics.aggregate([{"success": 1.0, "jerk": 0.1}, {"jerk": 0.2}])  # a bare KeyError: 'success'
