"""Obstacle motions of one's own: batched worlds run as they do one by one, whatever the model's ``reflect`` writes."""

import numpy as np

from vcs_env.engine import NavEngine
from vcs_env.obstacles import ObstacleMotion
from vcs_env.scenario import make_scenario


class _Heading(ObstacleMotion):
    """Turning at a drawn rate; ``reflect`` rewrites every obstacle's heading (wrapped), bounced or not."""

    name = "heading"

    def init(self, rng, scenario, pos, target):
        return {"h": rng.uniform(-np.pi, np.pi, len(pos)), "w": rng.normal(0.0, 0.5, len(pos))}

    def velocity(self, params, t, pos, dt):
        params["h"] = params["h"] + params["w"] * dt
        return 0.4 * np.stack((np.cos(params["h"]), np.sin(params["h"])), -1)

    def reflect(self, params, flip):
        x, y = np.cos(params["h"]), np.sin(params["h"])
        params["h"] = np.arctan2(np.where(flip[..., 1], -y, y), np.where(flip[..., 0], -x, x))


def test_a_reflect_that_rewrites_every_obstacle_keeps_batched_worlds_as_one_by_one():
    """reflect runs on steps where some world bounced: a model that re-wraps every heading there moved the other
    worlds' obstacles off their one-by-one paths (0 of 3 equal after 150 steps)."""
    scenario = make_scenario("dynamic", n_obstacles=4, bounce=True)
    seeds = [3, 4, 5, 6]

    def run(worlds):
        engine = NavEngine(scenario, len(worlds), obstacle_motion=_Heading())
        engine.reset(worlds)
        for _ in range(150):
            engine.step(np.zeros((len(worlds), scenario.n_robots, 2)), autoreset=True)
        return engine.world.obs_pos

    batched = run(seeds)
    assert all(np.array_equal(batched[b], run([s])[0]) for b, s in enumerate(seeds))


class _Counting(_Heading):
    """Also keeps a count of its calls in ``params``: one number, not per world."""

    def velocity(self, params, t, pos, dt):
        params["calls"] = params.get("calls", 0) + 1
        return super().velocity(params, t, pos, dt)


def test_a_parameter_that_is_not_per_world_is_left_to_the_model():
    scenario = make_scenario("dynamic", n_obstacles=4, bounce=True)
    engine = NavEngine(scenario, 2, obstacle_motion=_Counting())
    engine.reset([3, 4])
    for _ in range(150):  # bounces: the restore of calm worlds indexed the count by world (an IndexError)
        engine.step(np.zeros((2, scenario.n_robots, 2)))
    assert engine.sim.motion_params["calls"] == 150
