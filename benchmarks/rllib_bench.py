"""Sampling throughput of RLlib PPO (``vcs-env train --backend rllib``) beside SB3, agent-steps/s.

Same scenario and PPO sizes as :mod:`benchmarks.train_bench` (circle preset, 8 robots, 0.1 m
start jitter; 16 worlds per sampler, 128 steps per rollout slot, minibatch 2048, 10 epochs),
torch on one thread everywhere. Contestants:

* ``sb3`` - SB3 PPO on ``NavVecEnv`` (one process): robot steps per wall second of rollout
  collection, of the update, and of the whole (:func:`benchmarks.train_bench.run`, split by its
  collection share of the CPU time);
* ``rllib-<adapter>-<K>`` - RLlib PPO with ``K`` env runners (separate processes, one CPU each
  on a local Ray instance) and each env adapter of :mod:`agents.train.rllib_env`: robot steps sampled
  per wall second of ``EnvRunnerGroup.sample`` (RLlib's ``env_runner_sampling_timer``, which
  waits for all runners), per wall second of the rest of the iteration (the learner's update and
  the weight sync: the ceiling that more runners cannot lift), and of the whole iteration.

The first ``warmup`` iterations (actor start-up, first episodes) are not counted. Wall time, not
CPU time: the samplers are other processes, and on this 2-core machine two runners plus the
driver compete for the cores, which is part of what is measured.

Run: ``python -m benchmarks.rllib_bench [--iterations 3] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

from vcs_env.files import write_text

from .timing import machine_info

SCENARIO = dict(scenario="circle", n_robots=8, jitter=0.1)
PPO = dict(n_worlds=16, n_steps=128, batch_size=2048, n_epochs=10)


def rllib_rates(adapter: str, runners: int, iterations: int, warmup: int = 1) -> dict[str, float]:
    """Median agent-steps/s of RLlib PPO: sampling alone (every runner's ``sample()`` at once, as
    one PPO iteration asks for it), and whole ``Algorithm.train()`` iterations (sampling, update,
    weight sync); the update's own rate follows from the two (the iteration is synchronous)."""
    import torch

    from agents.runs import RLlibConfig
    from agents.train.rllib import init_ray, ppo_config, set_log_std

    torch.set_num_threads(1)
    cfg = RLlibConfig(**SCENARIO, **PPO, num_env_runners=runners, env_adapter=adapter, timesteps=10**9)
    ray = init_ray(cfg)
    algo = ppo_config(cfg).build_algo()
    group = algo.env_runner_group
    sample, whole = [], []
    try:
        set_log_std(algo, cfg.log_std_init)
        for it in range(warmup + iterations):
            t0 = time.perf_counter()
            if runners:
                batches = group.foreach_env_runner(lambda er: er.sample(), local_env_runner=False)
            else:
                batches = [group.local_env_runner.sample()]
            t1 = time.perf_counter()
            steps = sum(e.agent_steps() for eps in batches for e in eps)
            result = algo.train()
            wall = time.perf_counter() - t1
            per_agent = result["env_runners"]["num_agent_steps_sampled"].values()
            trained = sum(float(v) for v in per_agent if v == v)  # robot steps this iteration (NaN: none)
            if it >= warmup:
                sample.append(steps / (t1 - t0))
                whole.append(trained / wall)
    finally:
        algo.stop()
        ray.shutdown()
    s, w = statistics.median(sample), statistics.median(whole)
    rest = 1 / w - 1 / s  # seconds per robot step outside sampling; < 0 when load made sampling slower alone
    return {"sampled_per_s": s, "iteration_per_s": float(w), "update_per_s": 1 / rest if rest > 0 else float("nan")}


def sb3_rates(repeats: int) -> dict[str, float]:
    """SB3 PPO on the same scenario: robot steps per wall second of collection, and of the whole."""
    from .train_bench import TrainSizes, run

    res = run(TrainSizes(repeats=repeats), variants=("none",))["none"]
    wall = statistics.median(res.wall_rates)
    share = statistics.median(res.collect_fraction)
    return {"sampled_per_s": wall / share, "iteration_per_s": wall, "update_per_s": wall / (1 - share)}


def _fmt(x: float) -> str:
    return "-" if x != x else f"{x:,.0f}"


def ray_version() -> str:
    from importlib import metadata

    return metadata.version("ray")


SECTION = "## 6. Ray RLlib: sampling throughput beside SB3"


def write_section(path: str, text: str) -> None:
    """Put ``text`` (starting with :data:`SECTION`) into the Markdown file ``path``: replace the
    section if it is there (up to the next ``## `` heading), else append it."""
    from pathlib import Path

    p = Path(path)
    old = p.read_text() if p.exists() else ""
    start = old.find(SECTION)
    if start < 0:
        write_text(p, old.rstrip("\n") + "\n\n" + text)
        return
    end = old.find("\n## ", start + len(SECTION))
    rest = "" if end < 0 else "\n" + old[end + 1 :]
    write_text(p, old[:start] + text.rstrip("\n") + "\n" + rest)


def scaling_note(rows: dict[str, dict[str, float]]) -> str:
    """What the measured rates say about more runners and nodes (a paragraph for RESULTS.md)."""
    out = []
    for adapter in ("pettingzoo", "batched"):
        one, two = rows.get(f"rllib-{adapter}-1"), rows.get(f"rllib-{adapter}-2")
        if one and two:
            out.append(
                f"`{adapter}`: 2 runners sample {two['sampled_per_s'] / one['sampled_per_s']:.2f}x one runner's "
                f"rate and train at {two['iteration_per_s'] / one['iteration_per_s']:.2f}x"
            )
    sb3 = rows.get("sb3")
    rl = rows.get("rllib-pettingzoo-1") or rows.get("rllib-batched-1")
    ratio = ""
    if sb3 and rl:
        ratio = (
            f"; one RLlib runner trains at {rl['iteration_per_s'] / sb3['iteration_per_s']:.2f}x SB3's rate, whose "
            f"update alone ran at {sb3['update_per_s']:,.0f} robot steps/s (a proxy for the learner's ceiling: "
            "the same network, batch and epochs on one core)"
        )
    return (
        "Measured here: " + "; ".join(out) + ratio + ". On this 2-core machine two runners and the learner "
        "share two cores (with other jobs), so 2 runners cannot double anything. With more nodes: an RLlib "
        "PPO iteration is synchronous (all runners sample, then the learner updates on the driver, then the "
        "weights go back), so sampling time falls as 1/runners while the update (10 epochs over 16 k robot "
        "steps on one core) stays, and the throughput approaches the update rate: the learner bounds it, "
        "not the object store. Per iteration a runner "
        "ships about 16 k x 72 float32 observations plus actions, rewards and log-probabilities (about 6 MB "
        "for all runners together, milliseconds on a LAN) and receives the weights (about 40 k parameters, "
        "160 kB). Past that bound the next steps are more learners (`num_learners`, GPUs) or larger batches "
        "per update, neither exercised here."
    )


DEFAULT_JSON = "rllib_bench.json"
"""The results file beside RESULTS.md; ``python -m benchmarks`` re-renders section 6 from it."""


def render_table(rows: dict[str, dict[str, float]]) -> list[str]:
    table = ["| contestant | training (whole iterations) | sampling alone (separate calls) |", "|---|---|---|"]
    for name, r in rows.items():
        table.append(f"| {name} | " + " | ".join(_fmt(x) for x in (r["iteration_per_s"], r["sampled_per_s"])) + " |")
    return table


def render_section(out: dict) -> str:
    """Section 6 of RESULTS.md from a results dict (:func:`main`'s JSON)."""
    rows, m = out["rates"], out["machine"]
    load = ", ".join(f"{x:.2f}" for x in m["load_average"] or [])
    end = ", ".join(f"{x:.2f}" for x in out.get("load_average_end") or [])
    head = [
        SECTION,
        "",
        f"Generated by `{out['command']}` on {out['date']}; {m['cpu']}, {m['usable_cores']} cores, load "
        f"average {load} at start and {end} at the end (other jobs ran); ray {out['ray']}. Robot steps "
        f"per wall-clock second, median of {out['iterations']} iterations after one warm-up: of whole "
        "PPO iterations (sampling, update, weight sync), and of separate sampling calls (every runner's "
        "`sample()` at once; SB3: its train_bench run split by its collection share, steps including the "
        "padding slots of robots that finished). Under this load the separate RLlib sampling calls came "
        "out slower than whole iterations, so only the first column compares backends and runner counts. "
        "Scenario circle, 8 robots, 0.1 m jitter; 16 worlds per sampler, 128 steps per "
        "slot per update, minibatch 2048, 10 epochs (the `vcs-env train` defaults).",
        "",
    ]
    return "\n".join(head + render_table(rows)) + "\n\n" + scaling_note(rows) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--iterations", type=int, default=3, help="timed RLlib iterations per contestant")
    p.add_argument("--adapters", default="pettingzoo,batched", help="env adapters to measure")
    p.add_argument("--runners", default="1,2", help="numbers of env runners to measure")
    p.add_argument("--json", default=None, help="write the results to this JSON file")
    p.add_argument("--markdown", default=None, help="write the table as a section of this file (RESULTS.md)")
    p.add_argument("--from-json", default=None, help="no measuring: rewrite the section from this JSON file")
    args = p.parse_args(argv)
    if args.from_json:
        with open(args.from_json) as f:
            out = json.load(f)
    else:
        out = {
            "machine": machine_info(),
            "python": platform.python_version(),
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "command": "python -m benchmarks.rllib_bench " + " ".join(argv if argv is not None else sys.argv[1:]),
            "ray": ray_version(),
            "iterations": args.iterations,
            "scenario": SCENARIO,
            "ppo": PPO,
        }
        rows = {"sb3": sb3_rates(args.iterations)}
        print(f"sb3: {rows['sb3']}", flush=True)
        for adapter in args.adapters.split(","):
            for k in (int(x) for x in args.runners.split(",")):
                rows[f"rllib-{adapter}-{k}"] = rllib_rates(adapter, k, args.iterations)
                print(f"rllib-{adapter}-{k}: {rows[f'rllib-{adapter}-{k}']}", flush=True)
        out["rates"] = rows
        out["load_average_end"] = list(os.getloadavg())
    print("\n".join(render_table(out["rates"])))
    if args.markdown:
        write_section(args.markdown, render_section(out))
    if args.json and not args.from_json:
        write_text(args.json, json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
