"""Score finished training runs on a suite and tabulate them per method (the RL table of ``docs/training.md``).

Run directories are named ``<anything>_<method>_s<seed>`` (e.g. ``runs/crowd5_ppo_s0``). Every
run's final ``model.zip`` (or, with ``--model best_model.zip``, the policy of its best periodic
evaluation on the training-time seeds 100000.., disjoint from the suites' seeds) is evaluated
with :func:`agents.evaluate.evaluate` (fixed suite seeds, deterministic actions), next to the
VCS expert on the same episodes. Per method the table has the mean over seeds and the per-seed
values of episode success and collision rates, mean time to goal (and its ratio to the
expert's), training timesteps and wall time (pre-training from ``model.json`` ``init``
included)::

    python -m agents.experiments --suite crowd-5-v0 --runs runs/crowd5_*_s* --json results.json \
        --figure docs/crowd5_learning_curves.png

The JSON also holds every run's learning curve (its ``eval.jsonl``: success and collision rates
against timesteps) and ``--figure`` draws them, mean and range over seeds per method.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from collections import defaultdict
from pathlib import Path
from typing import Any

from vcs_env.files import write_text

from .evaluate import evaluate
from .runs import jsonable

RUN_NAME = re.compile(r"(?:.*_)?(?P<method>[^_]+)_s(?P<seed>\d+)$")
"""``<anything>_<method>_s<seed>``: the method is the last name part without underscores."""


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


def learning_curve(run: Path) -> dict[str, list[float]]:
    """The periodic evaluations of a run (``eval.jsonl``) as columns: timesteps, episode success
    and collision rates, mean time to goal [s] (NaN where no episode was solved: null in the file).
    Empty lists if the run has none."""
    cols = {"timesteps": [], "success": [], "collision": [], "time_to_goal": []}
    path = run / "eval.jsonl"
    lines = path.read_text().splitlines() if path.exists() else []
    for line in lines:
        e = json.loads(line)
        cols["timesteps"].append(int(e["timesteps"]))
        cols["success"].append(float(e["episode_success"]))
        cols["collision"].append(float(e["episode_collision"]))
        cols["time_to_goal"].append(math.nan if e["time_to_goal"] is None else float(e["time_to_goal"]))
    return cols


def score_runs(suite: str, runs: list[str], expert: str = "vcs", model: str = "model.zip") -> dict[str, Any]:
    import torch

    torch.set_num_threads(1)

    def stats(res) -> dict[str, float]:
        s = res.summary
        return {k: s[k]["mean"] for k in ("success", "collision", "time_to_goal", "extra_time", "min_separation")}

    ref = stats(evaluate(expert, suite, progress=False))
    rows = []
    for run in sorted(Path(r) for r in runs):
        m = RUN_NAME.search(run.name)
        if not m or not (run / model).exists():
            print(f"skipping {run} (no {model} or name without _s<seed>)")
            continue
        meta = json.loads((run / "model.json").read_text())
        res = stats(evaluate(str(run / model), suite, progress=False))
        wall, pre = run_wall_time(run)
        res.update(
            run=str(run),
            method=m["method"],
            seed=int(m["seed"]),
            timesteps=int(meta.get("num_timesteps", 0)),
            wall_time=wall,
            pretrain_wall_time=pre,
            time_ratio=res["time_to_goal"] / ref["time_to_goal"],
            curve=learning_curve(run),
        )
        rows.append(res)
        print(
            f"{run.name:<32} success {res['success']:.2f} collision {res['collision']:.2f} "
            f"time {res['time_to_goal']:.2f} s ({res['time_ratio']:.2f}x expert) wall {wall:.0f}+{pre:.0f} s",
            flush=True,
        )
    return {"suite": suite, "model": model, "expert": {"name": expert, **ref}, "runs": rows}


def plot_curves(result: dict[str, Any], path: str | Path | None = None, ax=None):
    """Success rate of the periodic evaluations against timesteps: per method the mean over
    seeds (line) and the range (band), the expert's suite success as a dashed line.

    Returns the matplotlib axes; saves the figure to ``path`` if given.
    """
    import matplotlib.pyplot as plt
    import numpy as np

    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 3.8))
    groups: dict[str, list[dict]] = defaultdict(list)
    for r in result["runs"]:
        if r["curve"]["timesteps"]:
            groups[r["method"]].append(r["curve"])
    lowest = result["expert"]["success"]
    for method, curves in groups.items():
        n = min(len(c["timesteps"]) for c in curves)  # seeds evaluated at the same steps
        x = np.array(curves[0]["timesteps"][:n])
        y = np.array([c["success"][:n] for c in curves])
        (line,) = ax.plot(x, y.mean(0), marker="o", ms=3, label=f"{method} ({len(curves)} seeds)")
        ax.fill_between(x, y.min(0), y.max(0), color=line.get_color(), alpha=0.2)
        lowest = min(lowest, float(y.min()))
    ex = result["expert"]
    ax.axhline(ex["success"], color="k", ls="--", lw=1, label=f"{ex['name']} expert (suite)")
    ax.set_xlabel("PPO timesteps (robot-steps)")
    ax.set_ylabel("episode success (eval seeds)")
    ax.set_ylim(max(0.0, math.floor(10 * lowest) / 10 - 0.05), 1.02)
    ax.set_title(result["suite"])
    ax.legend(fontsize=8, loc="lower right")
    if path is not None:
        ax.figure.tight_layout()
        ax.figure.savefig(path, dpi=110)
    return ax


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
    p.add_argument("--model", default="model.zip", help="checkpoint file inside each run (model.zip, best_model.zip)")
    p.add_argument("--figure", default=None, help="write the learning curves (PNG) here")
    args = p.parse_args(argv)
    result = score_runs(args.suite, args.runs, args.expert, args.model)
    table = markdown(result)
    print(table)
    if args.json:
        write_text(args.json, json.dumps(jsonable(result), indent=2, allow_nan=False) + "\n")
    if args.markdown:
        write_text(args.markdown, table)
    if args.figure:
        plot_curves(result, args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
