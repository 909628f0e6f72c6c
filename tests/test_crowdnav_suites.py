"""The CrowdNav suites hold the published protocol (Chen et al., ICRA 2019, and vita-epfl/CrowdNav
``crowd_nav/configs/env.config``): geometry, bodies, speeds, step, time limit, test set size."""

import numpy as np
import pytest

from vcs_env.engine import NavEngine
from vcs_env.suites import SUITES

PROTOCOL = {
    "circle_radius": 4.0,  # [sim] circle_radius [m]
    "square_width": 10.0,  # [sim] square_width [m]
    "human_num": 5,  # [sim] human_num
    "radius": 0.3,  # [humans] / [robot] radius [m]
    "v_pref": 1.0,  # [humans] / [robot] v_pref [m/s]
    "time_step": 0.25,  # [env] time_step [s]
    "time_limit": 25.0,  # [env] time_limit [s]
    "test_size": 500,  # [env] test_size
    "human_policy": "orca",  # [humans] policy
}


@pytest.mark.parametrize("name", ["crowdnav-circle-v0", "crowdnav-square-v0"])
def test_crowdnav_suites_follow_the_protocol(name):
    suite, p = SUITES[name], PROTOCOL
    s = suite.scenario
    assert suite.n_episodes == p["test_size"] and s.n_robots == 1 and s.n_obstacles == p["human_num"]
    assert s.dt == p["time_step"] and s.max_time == pytest.approx(p["time_limit"])
    assert s.robot.radius == p["radius"] and s.obstacle_radius == (p["radius"], p["radius"])
    assert s.robot.v_max == p["v_pref"] and s.robot.holonomic
    assert s.robot.a_max * s.dt >= 2 * s.robot.v_max  # any velocity of the disc in one step
    ped = s.pedestrians
    assert ped.model == p["human_policy"] and ped.v_pref == p["v_pref"] and not ped.sees_robots  # invisible robot
    assert s.circle_radius == p["circle_radius"]
    engine = NavEngine(s, 50)
    engine.reset(list(suite.seeds[:50]))
    w = engine.world
    np.testing.assert_allclose(w.pos[:, 0], [[0.0, -p["circle_radius"]]] * 50, atol=1e-12)
    np.testing.assert_allclose(w.goal[:, 0], [[0.0, p["circle_radius"]]] * 50, atol=1e-12)
    goals = engine.sim.motion_params["goals"][:, :, 0]  # (B, m, 2)
    if "circle" in name:  # on the circle, with CrowdNav's noise of +-v_pref/2 per coordinate
        ring = np.linalg.norm(w.obs_pos, axis=-1)
        assert np.all(np.abs(ring - p["circle_radius"]) <= np.sqrt(2) * 0.5 + 1e-9)
        np.testing.assert_array_equal(goals, -w.obs_pos)  # to the antipode
    else:  # start on one half of the square, goal on the other
        half = p["square_width"] / 2
        assert np.all(np.abs(w.obs_pos) <= half) and np.all(np.abs(goals) <= half)
        assert np.all(np.sign(w.obs_pos[..., 0]) == -np.sign(goals[..., 0]))


def test_crowdnav_variants():
    assert not SUITES["crowdnav-circle-unicycle-v0"].scenario.robot.holonomic
    assert SUITES["crowdnav-circle-unicycle-v0"].scenario.robot.radius == PROTOCOL["radius"]
    assert SUITES["crowdnav-circle-10-v0"].scenario.n_obstacles == 10
    assert SUITES["crowdnav-circle-20-v0"].scenario.n_obstacles == 20
