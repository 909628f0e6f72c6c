"""Observation v2 from a user's side: a checkpoint runs on any suite with the sensing it was trained with,
the sensing fields change no episode, and a policy blind to walls is warned about among them."""

import dataclasses
import json

import pytest

from agents.evaluate import evaluate
from vcs_env.suites import get_suite


def test_a_checkpoint_runs_with_the_sensing_it_was_trained_with_and_warns_among_walls():
    """The released circle8 reads observation v1: the harness runs it on a v2 suite's worlds with v1
    sensing (only the sensing fields change, and they change no episode: the expert's are the same
    with other sensing); among walls it warns that it cannot see them."""
    from agents.policies import BlindWarning, resolve_policy

    suite = get_suite("circle-8-v0-smoke")
    resolved = resolve_policy("policies/circle8/model.zip", suite.scenario)
    assert resolved.scenario.observation == 1 and suite.scenario.observation == 2
    assert dataclasses.replace(resolved.scenario, observation=2) == suite.scenario
    sensed = dataclasses.replace(suite.scenario, observation=1, n_wall_points=3, n_neighbors=4)
    other = dataclasses.replace(suite, scenario=sensed)

    def episodes(res):  # NaN equals NaN in JSON; compute times differ from run to run
        return json.dumps([{k: v for k, v in row.items() if "decision" not in k} for row in res.rows])

    assert episodes(evaluate("vcs", other)) == episodes(evaluate("vcs", suite))
    with pytest.warns(BlindWarning, match="'circle8' cannot see walls .* kind='doorway' has walls"):
        resolve_policy("policies/circle8/model.zip", get_suite("doorway-v0-smoke").scenario)
