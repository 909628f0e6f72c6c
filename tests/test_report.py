"""``results.json`` keeps every episode's metrics in a compact table that reads back losslessly
(up to 6 significant digits)."""

import json
import math

from agents.evaluate.report import results_json


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
