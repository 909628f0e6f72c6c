"""The safety shield's ablation on the released generalist (v1): with and without its shield on the same fresh
dynamic episodes; its run record names the rules it was written with (agents.shield)."""

import pytest

from agents.evaluate import evaluate
from vcs_env.scenario import SCENARIOS
from vcs_env.suites import Suite

GENERALIST = "policies/generalist/model.zip"


@pytest.mark.slow
def test_the_shield_lowers_the_generalists_collisions_on_dynamic_obstacles():
    """The ablation: the released network with and without its shield on the same fresh dynamic episodes
    (seeds no suite, probe or validation set uses)."""
    suite = Suite("dynamic-fresh", SCENARIOS["dynamic"], tuple(range(60000, 60200)), "fresh dynamic episodes")
    shielded_run = evaluate(GENERALIST, suite, progress=False)
    network_run = evaluate(GENERALIST, suite, progress=False, shield=False)
    # the release's record predates still_margin: it keeps margin for every body (None)
    want = {"horizon": 1.5, "margin": 0.1, "robot_speed": 0.05}
    want |= {"still_margin": None, "driving_guard": False, "keep_turn": False, "brake_backup": False}
    want |= {"driving_stop": False, "robots_stand": False}
    assert shielded_run.to_dict()["shield"] == want
    assert network_run.to_dict()["shield"] is None  # what ran is in the results
    shielded, network = shielded_run.summary, network_run.summary
    assert shielded["collision"]["mean"] < network["collision"]["mean"]
    assert shielded["success"]["mean"] > network["success"]["mean"]
    assert shielded["time_to_goal"]["mean"] < 1.1 * network["time_to_goal"]["mean"]
