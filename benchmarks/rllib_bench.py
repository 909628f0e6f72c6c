"""Sampling throughput of RLlib PPO (``vcs-env train --backend rllib``) beside SB3, agent-steps/s.

Same scenario and PPO sizes as :mod:`benchmarks.train_bench` (circle preset, 8 robots, 0.1 m
start jitter; 16 worlds per sampler, 128 steps per rollout slot, minibatch 2048, 10 epochs),
torch on one thread everywhere. Contestants:

* ``sb3`` - SB3 PPO on ``NavVecEnv`` (one process): robot steps per wall second of rollout
  collection (:func:`benchmarks.train_bench.run`, its collection share of the time);
* ``rllib-<adapter>-<K>`` - RLlib PPO with ``K`` env runners (separate processes, one CPU each
  on a local Ray instance) and each env adapter of :mod:`agents.rllib_env`: robot steps sampled
  per wall second of ``EnvRunnerGroup.sample`` (RLlib's ``env_runner_sampling_timer``, which
  waits for all runners), and per wall second of the whole iteration (sampling + learner update).

The first ``warmup`` iterations (actor start-up, first episodes) are not counted. Wall time, not
CPU time: the samplers are other processes, and on this 2-core machine two runners plus the
driver compete for the cores, which is part of what is measured.

Run: ``python -m benchmarks.rllib_bench [--iterations 3] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time

from .timing import machine_info

SCENARIO = dict(scenario="circle", n_robots=8, jitter=0.1)
PPO = dict(n_worlds=16, n_steps=128, batch_size=2048, n_epochs=10)


def rllib_rates(adapter: str, runners: int, iterations: int, warmup: int = 1) -> dict[str, float]:
    """Median sampled and whole-iteration agent-steps/s of ``iterations`` RLlib PPO iterations."""
    import torch

    from agents.rllib_train import RLlibConfig, init_like_sb3, init_ray, ppo_config, sampled_agent_steps

    torch.set_num_threads(1)
    cfg = RLlibConfig(**SCENARIO, **PPO, num_env_runners=runners, env_adapter=adapter, timesteps=10**9)
    ray = init_ray(cfg)
    algo = ppo_config(cfg).build_algo()
    sample, whole = [], []
    try:
        init_like_sb3(algo, cfg.log_std_init)
        before = 0
        for it in range(warmup + iterations):
            t0 = time.perf_counter()
            result = algo.train()
            wall = time.perf_counter() - t0
            steps = sampled_agent_steps(result)
            new, before = steps - before, steps
            if it >= warmup:
                sample.append(new / result["timers"]["env_runner_sampling_timer"])
                whole.append(new / wall)
    finally:
        algo.stop()
        ray.shutdown()
    return {"sampled_per_s": statistics.median(sample), "iteration_per_s": statistics.median(whole)}


def sb3_rates(repeats: int) -> dict[str, float]:
    """SB3 PPO on the same scenario: robot steps per wall second of collection, and of the whole."""
    from .train_bench import TrainSizes, run

    res = run(TrainSizes(repeats=repeats), variants=("none",))["none"]
    wall = statistics.median(res.wall_rates)
    share = statistics.median(res.collect_fraction)
    return {"sampled_per_s": wall / share, "iteration_per_s": wall}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--iterations", type=int, default=3, help="timed RLlib iterations per contestant")
    p.add_argument("--adapters", default="batched,pettingzoo", help="env adapters to measure")
    p.add_argument("--runners", default="1,2", help="numbers of env runners to measure")
    p.add_argument("--json", default=None, help="write the results to this JSON file")
    args = p.parse_args(argv)
    rows = {"sb3": sb3_rates(args.iterations)}
    print(f"sb3: {rows['sb3']}", flush=True)
    for adapter in args.adapters.split(","):
        for k in (int(x) for x in args.runners.split(",")):
            rows[f"rllib-{adapter}-{k}"] = rllib_rates(adapter, k, args.iterations)
            print(f"rllib-{adapter}-{k}: {rows[f'rllib-{adapter}-{k}']}", flush=True)
    out = {
        "machine": machine_info(),
        "python": platform.python_version(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "scenario": SCENARIO,
        "ppo": PPO,
        "rates": rows,
    }
    print("| contestant | sampled agent-steps/s | whole iteration agent-steps/s |")
    print("|---|---|---|")
    for name, r in rows.items():
        print(f"| {name} | {r['sampled_per_s']:,.0f} | {r['iteration_per_s']:,.0f} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
