"""Shaping study on a mixture (results.md here): final success and steps to a target success per
method and seed, from each run's ``eval.jsonl``. Run directories ``<method>_s<seed>`` under
``$RUNS`` (default ``runs/shaping-mixture``); prints the table."""

import json
import os
import pathlib
import statistics

ROOT = pathlib.Path(os.environ.get("RUNS", "runs/shaping-mixture"))
TARGET = 0.25
"""Episode success at a periodic evaluation that counts as reached."""


def row(method: str) -> str | None:
    final, collision, reach, wall = [], [], [], []
    for seed in range(3):
        path = ROOT / f"{method}_s{seed}" / "eval.jsonl"
        if not path.exists():
            continue
        evals = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
        final.append(evals[-1]["episode_success"])
        collision.append(evals[-1]["episode_collision"])
        hit = next((e["timesteps"] for e in evals if e["episode_success"] >= TARGET), None)
        reach.append("never" if hit is None else f"{hit / 1e6:.1f} M")
        wall.append(evals[-1].get("wall_time", float("nan")))
    if not final:
        return None
    return (
        f"| {method} | {' / '.join(f'{x:.2f}' for x in final)} | "
        f"{statistics.mean(final):.2f} / {statistics.mean(collision):.2f} | {' / '.join(reach)} | "
        f"{' / '.join(f'{w:.0f}' for w in wall)} |"
    )


if __name__ == "__main__":
    print("| method | final success per seed | mean final success / collision | steps to target per seed |", end="")
    print(" wall time per run [s] |\n|---|---|---|---|---|")
    print("\n".join(r for r in map(row, ("ppo", "vcs_imitation", "vcs_potential")) if r))
