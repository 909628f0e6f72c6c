"""``results.json`` keeps every episode's metrics in a compact table that reads back losslessly
(up to 6 significant digits); a report rewritten into its directory removes its own earlier plots only."""

import json
import math

from agents.evaluate.report import earlier_plots, results_json


def test_results_json_is_a_table_per_policy_that_reads_back():
    episodes = [
        {"seed": 1000 + i, "success": float(i % 2), "time_to_goal": math.pi * i, "min_separation": 1 / (i + 3)}
        for i in range(5)
    ]
    data = {"suite": "s", "policies": {"vcs": {"summary": {"success": 0.4}, "episodes": episodes}}}
    text = results_json(data)
    back = json.loads(text)
    table = back["policies"]["vcs"]["episodes"]
    assert table["columns"] == ["seed", "success", "time_to_goal", "min_separation"]
    assert len(table["rows"]) == 5 and sum(line.startswith("    [1") for line in text.splitlines()) == 5  # a line each
    for ep, row in zip(episodes, table["rows"]):
        for value, kept in zip(ep.values(), row):
            assert kept == value if isinstance(value, int) else math.isclose(kept, value, rel_tol=5e-6)
    assert back["policies"]["vcs"]["summary"] == {"success": 0.4} and back["suite"] == "s"
    # A policy without episodes and a file without policies are written as they are.
    assert json.loads(results_json({"policies": {"x": {"episodes": []}}})) == {
        "policies": {"x": {"episodes": {"columns": [], "rows": []}}}
    }
    assert json.loads(results_json({"suite": "s"})) == {"suite": "s"}


def test_a_report_removes_only_its_own_earlier_plots(tmp_path):
    ours = ["bar_success.png", "bar_ms_per_decision.png", "trajectory_vcs_ep0.png", "trajectory_my_net_ep12.png"]
    mine = ["bar_mine.png", "trajectory_holiday.png", "photo.png", "bar_success.jpg"]
    for name in ours + mine:
        (tmp_path / name).write_bytes(b"x")
    assert earlier_plots(tmp_path) == []  # no earlier report here: every file is the user's
    (tmp_path / "results.json").write_text("{}")
    assert [p.name for p in earlier_plots(tmp_path)] == sorted(ours)
