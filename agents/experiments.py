"""Score finished training runs on a suite and tabulate them per method (the README's RL table).

Run directories are named ``<anything>_<method>_s<seed>`` (e.g. ``runs/crowd5_ppo_s0``); every
run's final ``model.zip`` is evaluated with :func:`agents.evaluate.evaluate` (fixed suite seeds,
deterministic actions), next to the VCS expert on the same episodes. Per method the table has
the mean over seeds and the per-seed values of episode success and collision rates, mean time
to goal (and its ratio to the expert's), training timesteps and wall time (pre-training from
``model.json`` ``init`` included)::

    python -m agents.experiments --suite crowd-5-v0 --runs runs/crowd5_*_s* --json results.json
"""

from __future__ import annotations

import argparse
import json
import math
import re
from collections import defaultdict
from pathlib import Path
from typing import Any

RUN_NAME = re.compile(r"(?P<method>.+)_s(?P<seed>\d+)$")


def _mean(xs):
    xs = [x for x in xs if x is not None and not math.isnan(x)]
    return sum(xs) / len(xs) if xs else math.nan


def run_wall_time(run: Path) -> tuple[float, float]:
    """(PPO wall time, pre-training wall time) [s] of a run from its JSON files."""
    meta = json.loads((run / "model.json").read_text())
    pre = 0.0
    init = meta.get("config", {}).get("init")
    if init:
        init_meta = Path(init).with_suffix(".json")
        if init_meta.exists():
            pre = float(json.loads(init_meta.read_text()).get("wall_time") or 0.0)
    return float(meta.get("wall_time") or 0.0), pre


def score_runs(suite: str, runs: list[str], expert: str = "vcs") -> dict[str, Any]:
    import torch

    torch.set_num_threads(1)
    from .evaluate import evaluate

    def stats(res) -> dict[str, float]:
        s = res.summary
        return {k: s[k]["mean"] for k in ("success", "collision", "time_to_goal", "extra_time", "min_separation")}

    ref = stats(evaluate(expert, suite, progress=False))
    rows = []
    for run in sorted(Path(r) for r in runs):
        m = RUN_NAME.search(run.name)
        if not m or not (run / "model.zip").exists():
            print(f"skipping {run} (no model.zip or name without _s<seed>)")
            continue
        meta = json.loads((run / "model.json").read_text())
        res = stats(evaluate(str(run / "model.zip"), suite, progress=False))
        wall, pre = run_wall_time(run)
        res.update(
            run=str(run),
            method=m["method"],
            seed=int(m["seed"]),
            timesteps=int(meta.get("num_timesteps", 0)),
            wall_time=wall,
            pretrain_wall_time=pre,
            time_ratio=res["time_to_goal"] / ref["time_to_goal"],
        )
        rows.append(res)
        print(
            f"{run.name:<32} success {res['success']:.2f} collision {res['collision']:.2f} "
            f"time {res['time_to_goal']:.2f} s ({res['time_ratio']:.2f}x expert) wall {wall:.0f}+{pre:.0f} s",
            flush=True,
        )
    return {"suite": suite, "expert": {"name": expert, **ref}, "runs": rows}


def markdown(result: dict[str, Any]) -> str:
    ex = result["expert"]
    lines = [
        f"Suite `{result['suite']}` (deterministic actions). Expert `{ex['name']}`: success {ex['success']:.2f}, "
        f"collision {ex['collision']:.2f}, time to goal {ex['time_to_goal']:.2f} s.",
        "",
        "| method | seeds | success | collision | time to goal [s] | / expert | timesteps | wall [min] "
        "| per seed (success / collision / time) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    groups: dict[str, list[dict]] = defaultdict(list)
    for r in result["runs"]:
        groups[r["method"]].append(r)
    for method, rs in groups.items():
        rs = sorted(rs, key=lambda r: r["seed"])
        per_seed = "; ".join(
            f"s{r['seed']}: {r['success']:.2f} / {r['collision']:.2f} / {r['time_to_goal']:.2f}" for r in rs
        )
        wall = _mean([r["wall_time"] + r["pretrain_wall_time"] for r in rs]) / 60
        lines.append(
            f"| {method} | {','.join(str(r['seed']) for r in rs)} | {_mean([r['success'] for r in rs]):.3f} "
            f"| {_mean([r['collision'] for r in rs]):.3f} | {_mean([r['time_to_goal'] for r in rs]):.2f} "
            f"| {_mean([r['time_ratio'] for r in rs]):.2f} | {int(_mean([r['timesteps'] for r in rs])):,} "
            f"| {wall:.1f} | {per_seed} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m agents.experiments", description=__doc__.split("\n\n")[0])
    p.add_argument("--suite", required=True, help="suite name, e.g. circle-8-v0")
    p.add_argument("--runs", nargs="+", required=True, help="run directories (<name>_<method>_s<seed>)")
    p.add_argument("--expert", default="vcs", help="reference planner")
    p.add_argument("--json", default=None, help="write the scores here")
    p.add_argument("--markdown", default=None, help="write the table here")
    args = p.parse_args(argv)
    result = score_runs(args.suite, args.runs, args.expert)
    table = markdown(result)
    print(table)
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
    if args.markdown:
        Path(args.markdown).write_text(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
