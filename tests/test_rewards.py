"""Reward terms as objects: the built-ins match RewardWeights, and a term of one's own is one
object passed to the env."""

import dataclasses

import numpy as np
import pytest

import vcs_env
from vcs_env.engine import NavEngine
from vcs_env.rewards import TERMS, RewardTerm, StepInput, weighted_sum
from vcs_env.scenario import RewardWeights


class Speed(RewardTerm):
    """The speed after the step [m/s], zero for robots that did not act."""

    name = "speed"

    def __call__(self, x: StepInput) -> np.ndarray:
        return np.where(x.events.acted, x.world.speed, 0.0)


def test_every_built_in_term_has_a_weight_and_a_unique_name():
    assert [t.name for t in TERMS] == [f.name for f in dataclasses.fields(RewardWeights)]


def test_a_term_object_is_computed_weighted_and_reported():
    s = vcs_env.make_scenario("swap", rewards={"progress": 0.0, "arrival": 0.0, "collision": 0.0, "time": 0.0})
    eng = NavEngine(s, reward_terms={"speed": (2.0, Speed()), "half_speed": (1.0, lambda w, e, a: 0.5 * w.speed)})
    eng.reset(seeds=[0])
    res = eng.step(np.ones((1, 2, 2)))  # full acceleration: speed a_max dt = 0.05 m/s
    np.testing.assert_allclose(res.terms["speed"], 0.05)
    np.testing.assert_allclose(res.terms["half_speed"], 0.025)
    np.testing.assert_allclose(res.reward, 2.0 * 0.05 + 0.025)
    assert list(res.terms) == ["progress", "arrival", "collision", "time", "speed", "half_speed"]
    assert res.info(0)["reward_terms"]["speed"] == pytest.approx(0.05)


def test_built_in_terms_by_hand():
    s = vcs_env.make_scenario("swap", rewards={"vcs_imitation": 1.0})
    eng = NavEngine(s)
    eng.reset(seeds=[0])
    expert = eng.expert_action.copy()
    res = eng.step(np.stack((np.zeros(2), expert[0, 1]))[None])  # robot 0 stands, robot 1 follows
    ev = res.events
    np.testing.assert_array_equal(res.terms["progress"], ev.goal_dist_before - ev.goal_dist_after)
    np.testing.assert_array_equal(res.terms["time"], -s.dt)
    np.testing.assert_array_equal(res.terms["arrival"], 0.0)
    assert np.hypot(*expert[0, 0]) > 0.1
    np.testing.assert_allclose(res.terms["vcs_imitation"], [[-np.hypot(*expert[0, 0]) / (2 * np.sqrt(2)), 0.0]])
    assert "vcs_potential" not in res.terms  # expert terms are computed only when weighted
    w = s.rewards
    expected = w.progress * res.terms["progress"] + w.time * res.terms["time"] + res.terms["vcs_imitation"]
    np.testing.assert_allclose(res.reward, expected, rtol=1e-12)


def test_weighted_sum_skips_zero_weights_and_keeps_the_shape():
    terms = {"a": np.ones((2, 3)), "b": np.full((2, 3), 2.0)}
    np.testing.assert_array_equal(weighted_sum(terms, {"a": 0.0, "b": 0.5}), 1.0)
    np.testing.assert_array_equal(weighted_sum(terms, {}), np.zeros((2, 3)))


@pytest.mark.parametrize(
    "terms, match",
    [
        ({"time": (1.0, Speed())}, "'time' already exists"),
        ({"x": 1.0}, r"must be a \(weight, fn\) pair"),
        ({"x": (1.0, "no")}, "not callable"),
    ],
)
def test_bad_reward_terms_raise(terms, match):
    with pytest.raises(ValueError, match=match):
        NavEngine(vcs_env.make_scenario("swap"), reward_terms=terms)


def test_potential_shaping_needs_a_planner_with_a_potential():
    with pytest.raises(ValueError, match="'straight' has none"):
        NavEngine(vcs_env.make_scenario("swap", rewards={"vcs_potential": 1.0}), expert="straight")
