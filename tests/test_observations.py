"""Observation v2 from a user's side: a checkpoint runs on any suite with the sensing it was trained with,
the sensing fields change no episode, a policy blind to walls is warned about among them, and among walls
the goal features follow the route."""

import dataclasses
import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from agents.evaluate import evaluate
from vcs_env.observations import GOAL_REF, observe
from vcs_env.routes import roadmap, waypoints
from vcs_env.scenario import CustomLayout, Scenario
from vcs_env.sim import Simulator
from vcs_env.suites import get_suite


def test_a_checkpoint_runs_with_the_sensing_it_was_trained_with_and_warns_among_walls(tmp_path):
    """The released circle8 reads observation v1: the harness runs it on a v2 suite's worlds with v1
    sensing (only the sensing fields change, and they change no episode: the expert's are the same
    with other sensing); among walls it warns that it cannot see them."""
    from agents.policies import BlindWarning, RobotKindWarning, resolve_policy

    suite = get_suite("circle-8-v0-smoke")
    resolved = resolve_policy("policies/circle8/model.zip", suite.scenario)
    assert resolved.scenario.observation == 1 and suite.scenario.observation == 2
    assert dataclasses.replace(resolved.scenario, observation=2) == suite.scenario
    sensed = dataclasses.replace(suite.scenario, observation=1, n_wall_points=3, n_neighbors=4)
    other = dataclasses.replace(suite, scenario=sensed)

    def episodes(res):  # NaN equals NaN in JSON; compute times differ from run to run
        return json.dumps([{k: v for k, v in row.items() if "decision" not in k} for row in res.rows])

    assert episodes(evaluate("vcs", other)) == episodes(evaluate("vcs", suite))
    doorway = get_suite("doorway-v0-smoke").scenario
    with pytest.warns(BlindWarning, match="'circle8' cannot see walls .* kind='doorway' has walls"):
        resolve_policy("policies/circle8/model.zip", doorway)
    # Without its run record the sensing is the scenario's, and the warning says so (the size check then refuses it).
    bare = tmp_path / "bare" / "model.zip"
    bare.parent.mkdir()
    shutil.copy("policies/circle8/model.zip", bare)
    with pytest.warns(BlindWarning, match="no run record names its sensing"), pytest.raises(ValueError, match="Box"):
        resolve_policy(str(bare), get_suite("doorway-v0-smoke").scenario)
    # Trained on unicycles, run on holonomic robots: its turn would move them sideways.
    holonomic = get_suite("random-dense-holonomic-v0-smoke").scenario
    with pytest.warns(RobotKindWarning, match="trained on unicycle robots .* runs holonomic ones here"):
        resolve_policy("policies/circle8/model.zip", holonomic)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RobotKindWarning)
        resolve_policy("policies/circle8/model.zip", suite.scenario)
    # load_checkpoint, the door of one's own loop, warns the same (it said nothing of the robot kind or the walls)
    from agents.policies import load_checkpoint

    with pytest.warns(RobotKindWarning, match="trained on unicycle robots"):
        load_checkpoint("policies/circle8/model.zip", dataclasses.replace(holonomic, observation=1))
    with pytest.warns(BlindWarning, match="'circle8' cannot see walls"):
        load_checkpoint("policies/circle8/model.zip", dataclasses.replace(doorway, observation=1))
    # A record whose sensing cannot be applied is refused by the fit check, with no blind warning before it
    record = json.loads(Path("policies/circle8/model.json").read_text())
    record["observation"]["version"] = 9
    (bare.parent / "model.json").write_text(json.dumps(record))
    with warnings.catch_warnings():
        warnings.simplefilter("error", BlindWarning)
        with pytest.raises(ValueError, match="reads observation v9"):
            resolve_policy(str(bare), doorway)


def test_among_walls_the_v2_goal_features_follow_the_route_and_v1_reads_the_straight_goal():
    """Robot behind a wall with a door: v2 reads the bearing of its next waypoint (the door's edge,
    to its left) and the route length; v1, and v2 without the wall, read the straight goal ahead."""
    start, goal = ((-2.0, 0.0),), ((2.0, 0.0),)
    door = (((0.0, -4.0), (0.0, 0.5)), ((0.0, 1.5), (0.0, 4.0)))
    s = Scenario(kind="custom", n_robots=1, custom=CustomLayout(start=start, goal=goal, walls=door))
    w = Simulator(s).reset(0)
    target, length = waypoints(w)
    ego = observe(w, s)[0, 0]
    bearing = (target[0, 0] - w.pos[0, 0]) / np.linalg.norm(target[0, 0] - w.pos[0, 0])
    np.testing.assert_allclose(ego[2:4], bearing, atol=1e-6)  # heading 0: robot frame = world frame
    assert ego[3] > 0.1  # the door is to the left of the straight line
    np.testing.assert_allclose(ego[1], length[0, 0] / GOAL_REF, rtol=1e-6)
    assert length[0, 0] > 4.1
    straight = np.array([0.2, 1.0, 0.0], dtype=np.float32)  # 4 m / 20 m, goal dead ahead
    np.testing.assert_allclose(observe(w, dataclasses.replace(s, observation=1))[0, 0, 1:4], straight, atol=1e-6)
    open_floor = dataclasses.replace(s, custom=CustomLayout(start=start, goal=goal))
    np.testing.assert_allclose(observe(Simulator(open_floor).reset(0), open_floor)[0, 0, 1:4], straight, atol=1e-6)


def test_batched_waypoints_equal_the_one_robot_route():
    """:meth:`Roadmap.next_waypoints` (compiled, many robots) against :meth:`Roadmap.next_waypoint`
    (readable, one robot), at random points of a random-walls map, some of them inside walls: the same
    waypoints, and route lengths equal to rounding (the compiled sums may differ in the last bit by
    machine: 9.930437691559137 against ...135 on an Intel Xeon, equal on an AMD EPYC)."""
    w = Simulator(get_suite("walls-v0").scenario).reset(5)
    rm = roadmap(w, 0, float(w.radius[0, 0]))
    rng = np.random.default_rng(0)
    p, g = rng.uniform(-6, 6, (200, 2)), rng.uniform(-6, 6, (200, 2))
    wp, length = rm.next_waypoints(p, g)
    for i in range(len(p)):
        one, total = rm.next_waypoint(p[i], g[i])
        np.testing.assert_array_equal(wp[i], one)
        np.testing.assert_allclose(length[i], total, rtol=1e-12, atol=0.0)
    assert np.isfinite(length).mean() > 0.5 and (wp != g).any(axis=-1).mean() > 0.1
