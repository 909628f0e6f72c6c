"""The probe table (issue 13): each probe changes one field of its family's suite, runs on seeds
no suite uses, and ``vcs-env probe`` scores policies on the same episodes as ``compare`` does."""

import json

import pytest

import vcs_cli as cli
from agents.config import family_suite
from agents.evaluate import evaluate
from agents.evaluate.probes import (
    AXES,
    PROBE_SEED_BASE,
    PROBES,
    Probe,
    gaps,
    inside_training,
    policy_labels,
    select_probes,
    training_boxes,
)
from vcs_env.scenario import MAPS, SCENARIOS
from vcs_env.suites import SUITES


def test_each_probe_changes_only_its_fields_and_uses_no_suite_seed():
    used = {s for suite in SUITES.values() for s in suite.seeds}
    for probe in PROBES:
        suite = probe.suite(3)
        assert not used & set(suite.seeds), probe.name
        base = family_suite({**SCENARIOS, **MAPS}[probe.scenario].kind).scenario
        changed = {
            f
            for f in (*AXES, *set(probe.changes) & {"layout_radius"})
            if getattr(suite.scenario, f) != getattr(base, f)
        }
        assert changed == set(probe.changes), probe.name
        assert suite.scenario.on_collision == "continue"


def test_a_probe_out_that_is_a_file_is_refused_before_any_episode(tmp_path, capsys):
    import vcs_cli as cli

    (tmp_path / "table.zip").write_text("")
    args = ["probe", "--policies", "vcs", "--families", "circle", "--episodes", "1", "--no-progress"]
    assert cli.main([*args, "--out", str(tmp_path / "table.zip")]) == 2
    captured = capsys.readouterr()
    assert "is a file: give a directory" in captured.err and "circle" not in captured.out  # no table: no episode run


def test_bad_probe_requests_are_named():
    with pytest.raises(ValueError, match="unknown probe families \\['circel'\\]"):
        select_probes("circle,circel")
    with pytest.raises(ValueError, match="positive integer"):
        PROBES[0].suite(0)
    with pytest.raises(ValueError, match="labelled 'circle8'.*LABEL=PATH"):
        policy_labels(["policies/circle8/model.zip", "other/circle8.zip"])
    assert list(policy_labels(["hrvo", "policies/circle8/model.zip"])) == ["vcs", "hrvo", "circle8"]
    # LABEL=SPEC names a policy: two checkpoints of one run directory side by side.
    named = policy_labels(["final=runs/a/ppo/model.zip", "best=runs/a/ppo/best_model.zip"], expert=None)
    assert named == {"final": "runs/a/ppo/model.zip", "best": "runs/a/ppo/best_model.zip"}
    with pytest.raises(ValueError, match="labelled 'vcs'"):
        policy_labels(["vcs=policies/circle8/model.zip"])


def test_gap_check_counts_only_probes_the_expert_solves():
    def row(name, vcs, pol):
        return {
            "probe": name,
            "policies": {"vcs": {"success": vcs}, "hrvo": {"success": 0.0}, "pol": {"success": pol}},
        }  # noqa: E731

    table = {"expert": "vcs", "probes": [row("a", 1.0, 0.95), row("b", 0.96, 0.80), row("c", 0.90, 0.10)]}
    assert gaps(table, planners={"vcs", "hrvo"}) == {"pol": [("b", pytest.approx(0.16))]}
    # A gap of exactly 10 points is within the bar at any episode count (79/80 against 71/80 read 0.10000000000000009).
    table = {"expert": "vcs", "probes": [row("d", 79 / 80, 71 / 80), row("e", 76 / 80, 68 / 80)]}
    assert gaps(table, planners={"vcs", "hrvo"}) == {"pol": []}


def test_probes_inside_a_policys_training_ranges_are_named_and_left_out_of_its_gaps():
    record = json.loads(open("policies/generalist/model.json").read())
    boxes = training_boxes(record)
    assert len(boxes) == len(record["config"]["mixture"])
    inside = {p.name: inside_training(p, boxes) for p in PROBES}
    # Points of the generalist's mixture, or inside one entry's ranges:
    assert inside["circle[n_robots=10]"] == "circle-8-v0:n_robots=4-12/4,jitter=0.1-0.5/0.2"
    assert inside["dynamic[obstacle_speed=1.0-1.3]"] == "dynamic-v0:obstacle_speed=0.6-1.2"  # 1.0-1.2 of it
    assert inside["crowd[obstacle_speed=0.2-0.5]"] is None  # slower than every crowd it trained among
    # A probe's interval counts as in training once it overlaps a range, not only when it lies within one
    speeds = [
        (
            "crowd-5-v0:obstacle_speed=1.1-1.4",
            "crowd",
            {"n_robots": (1, 1), "n_obstacles": (5, 5), "jitter": (0, 0), "obstacle_speed": (1.1, 1.4)},
        )
    ]
    assert inside_training(Probe("crowd", "obstacle speed", {"obstacle_speed": (1.0, 1.5)}), speeds) == speeds[0][0]
    assert inside_training(Probe("crowd", "obstacle speed", {"obstacle_speed": (1.4, 1.6)}), speeds) is None
    # ... and every family it trained on keeps probes beyond all its ranges.
    held = {p.scenario for p in PROBES if inside[p.name] is None}
    assert held >= {"circle", "swap", "crossing", "crowd", "dynamic"}
    assert sum(v is None for v in inside.values()) >= 9
    # A one-scenario run: only its own point is inside.
    circle8 = training_boxes({"config": {"scenario": "circle", "n_robots": 8, "jitter": 0.1}})
    assert inside_training(Probe("circle", "jitter", {"jitter": 0.1}), circle8) == "circle"
    assert inside_training(Probe("circle", "robots", {"n_robots": 10}), circle8) is None
    # The box is the scenario the run trained on (no start jitter here), not its family's suite (jitter 0.1).
    circle12 = training_boxes({"config": {"scenario": "circle", "n_robots": 12}})
    assert inside_training(Probe("circle", "n_robots=12", {"n_robots": 12}), circle12) is None
    assert training_boxes({}) == []
    # A bc run trained on its dataset's scenarios (its config names the data, the record keeps the collect config).
    bc = {"config": {"data": "d.npz"}, "dataset_meta": {"config": {"scenario": "crowd-5-v0", "n_obstacles": 3}}}
    assert inside_training(Probe("crowd", "obstacles", {"n_obstacles": 3}), training_boxes(bc)) == "crowd-5-v0"
    # The gap check skips the cells of probes a policy trained on.
    row = {"probe": "a", "policies": {"vcs": {"success": 1.0}, "pol": {"success": 0.5}}, "inside": {"pol": "x"}}
    assert gaps({"expert": "vcs", "probes": [row]}, planners={"vcs"}) == {"pol": []}


def test_the_v2_recipe_trains_on_every_family_and_on_no_probe():
    """The mixture of policies/generalist-v2.sh covers every probe family, and no probe lies inside one of
    its entries' ranges: the probe table is held out from the v2 generalist by construction."""
    import re
    import shlex
    from pathlib import Path

    text = (Path(__file__).parents[1] / "policies" / "generalist-v2.sh").read_text()
    mixture = shlex.split(re.search(r"^MIX=\((.*?)^\)", text, re.S | re.M)[1], comments=True)
    boxes = training_boxes({"config": {"mixture": mixture, "n_wall_points": 6}})
    assert len(boxes) == len(mixture) >= 20
    assert {p.scenario for p in PROBES} <= {kind for _, kind, _ in boxes}
    assert {p.name: inside_training(p, boxes) for p in PROBES} == {p.name: None for p in PROBES}


def test_cli_probe_matches_evaluate_on_the_same_episodes(tmp_path, capsys):
    out = tmp_path / "probe"
    args = ["probe", "--policies", "vcs,straight", "--families", "swap, swap", "--episodes", "2", "--out", str(out)]
    assert cli.main([*args, "--no-progress"]) == 0
    table = json.loads((out / "probes.json").read_text())
    swap = [p for p in PROBES if p.scenario == "swap"]
    assert [r["probe"] for r in table["probes"]] == [p.name for p in swap]
    for probe, row in zip(swap, table["probes"]):
        for name in ("vcs", "straight"):
            res = evaluate(name, probe.suite(2), progress=False)
            assert row["policies"][name]["success"] == res.summary["success"]["mean"]
            assert row["policies"][name]["collision"] == res.summary["collision"]["mean"]
    md = (out / "probes.md").read_text()
    assert "vcs-env probe --policies vcs,straight" in md and f"seeds from {PROBE_SEED_BASE}" in md
    assert "--families 'swap, swap'" in md  # the recorded command runs as written
    assert cli.main(["probe", "--policies", "vcs", "--families", "nope", "--out", str(out)]) == 2
    assert "unknown probe families" in capsys.readouterr().err
    assert isinstance(Probe("circle", "jitter", {"jitter": 0.2}).name, str)
