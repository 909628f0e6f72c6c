"""Issue 13 infrastructure: ad-hoc evaluation from scenario flags, training settings against the
suites, training on mixtures (groups of worlds), reproducible toy runs."""

import json

import pytest

import vcs_cli as cli
from agents.config import (
    ScenarioConfig,
    build_scenario,
    parse_seeds,
    probe_scenario,
    suite_differences,
)
from vcs_env.suites import get_suite


def test_parse_seeds_ranges_and_errors():
    assert parse_seeds("5000:5003") == (5000, 5001, 5002)
    assert parse_seeds("7") == (7,)
    for bad, msg in (("5:3", "0 <= START < STOP"), ("-1:3", "0 <= START"), ("a:b", "START:STOP"), ("1:", "START")):
        with pytest.raises(ValueError, match=msg):
            parse_seeds(bad)


def test_probe_scenario_starts_from_the_family_suite():
    suite = get_suite("circle-8-v0").scenario
    assert probe_scenario(ScenarioConfig(scenario="circle")) == suite
    s = probe_scenario(ScenarioConfig(scenario="circle", n_robots=12, jitter=0.3))
    assert (s.n_robots, s.jitter, s.on_collision, s.min_separation) == (12, 0.3, "continue", 0.3)
    assert s.circle_radius == 5.0 and probe_scenario(ScenarioConfig(n_robots=24)).circle_radius == pytest.approx(7.2)
    crowd = probe_scenario(ScenarioConfig(scenario="crowd", n_obstacles=3, obstacle_speed=(1.0, 1.5)))
    assert (crowd.n_obstacles, crowd.obstacle_speed, crowd.min_separation) == (3, (1.0, 1.5), 0.2)
    assert probe_scenario(ScenarioConfig(scenario="random")).kind == "random"  # no suite: the preset


def test_training_differences_from_the_suite_are_listed():
    suite, diffs = suite_differences(build_scenario(ScenarioConfig(scenario="crowd")))
    assert suite == "crowd-5-v0"
    assert diffs == ["on_collision: terminate (suite: continue)", "min_separation: 0.3 (suite: 0.2)"]
    assert suite_differences(get_suite("swap-v0").scenario) == ("swap-v0", [])
    assert suite_differences(build_scenario(ScenarioConfig(scenario="random"))) == (None, [])


def test_cli_evaluate_and_compare_on_ad_hoc_episodes(tmp_path, capsys):
    out = tmp_path / "out.json"
    args = ["evaluate", "--policy", "vcs", "--scenario", "circle", "--n-robots", "5", "--jitter", "0.3"]
    assert cli.main([*args, "--seeds", "5000:5002", "--json", str(out), "--no-progress"]) == 0
    data = json.loads(out.read_text())
    assert [e["seed"] for e in data["episodes"]] == [5000, 5001]
    assert data["suite"] == "circle[n_robots=5,jitter=0.3]@5000:5002"
    assert data["summary"]["success"]["mean"] == 1.0
    report = tmp_path / "report"
    args = ["compare", "--policies", "vcs,straight", "--scenario", "crowd", "--n-obstacles", "3"]
    assert cli.main([*args, "--seeds", "10:12", "--out", str(report), "--no-plots", "--no-progress"]) == 0
    assert json.loads((report / "results.json").read_text())["seeds"] == [10, 11]
    capsys.readouterr()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--scenario", "circle"], "give --suite NAME, or scenario flags"),
        (["--seeds", "9:3"], "0 <= START < STOP"),
        (["--suite", "swap-v0-smoke", "--n-robots", "4"], "either --suite or scenario flags"),
        (["--scenario", "nope", "--seeds", "1:2"], "unknown scenario 'nope'"),
        (["--scenario", "crowd", "--obstacle-speed", "1", "--seeds", "1:2"], "obstacle_speed must be two numbers"),
    ],
)
def test_cli_ad_hoc_errors_are_messages(args, message, capsys):
    assert cli.main(["evaluate", "--policy", "vcs", "--no-progress", *args]) == 2
    assert message in capsys.readouterr().err
