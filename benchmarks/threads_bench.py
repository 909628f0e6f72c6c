"""``python -m benchmarks.threads_bench``: thread scaling of the batched engine and the lidar's cost (issue 45).

Times :meth:`vcs_env.engine.NavEngine.step` (auto-reset on, random actions from a pool drawn
before timing) on the env benchmark's worlds (:func:`benchmarks.env_bench.our_scenario`: the
``dynamic`` preset, ``n = 3`` robots, 10 obstacles turning at random and bouncing off the arena)
at ``B = 1024`` and ``4096`` worlds, without lidar and with 12 and 64 beams, on 1, 2 and all
usable cores (:func:`vcs_env.set_threads`); the serial/parallel crossover at small ``B`` (the
reason for :data:`vcs_env.threads.MIN_PARALLEL_BATCH`, which is lowered to 1 for those rows); and
the VCS expert driving ``B = 256`` worlds of three suites (:func:`expert_rate`). Beside each row at one
thread, VMAS ``navigation`` on the CPU with one torch thread, same ``n`` and ``B`` (:func:`vmas_rate`): with
its lidar of as many rays (12 by default; it senses the other agents; ``n_lidar_rays=0`` for the rows
without lidar), agent collisions on. Its worlds hold the agents alone, ours 10 moving obstacles more, so
our engine is also timed without them (one thread, the "open" column).

Wall-clock rates (threads make CPU time meaningless), best of ``--repeats`` runs, in robot-steps
per second (acting robots advanced by one step). The load average is printed beside them: on a
shared machine the rates at 2+ threads are only as good as the idle cores.

Writes a Markdown table (``--out``, default ``runs/bench-threads/THREADS.md``; ``runs/`` is not
committed) and the numbers as JSON next to it. A committed report is only overwritten when
``--out`` names it (``--out benchmarks/THREADS.md``).
"""

from __future__ import annotations

from . import threading_env  # noqa: F401  (first, before numpy and numba: the thread settings)

# isort: split
import argparse
import dataclasses
import datetime
import os
import shlex
import sys
import time
from pathlib import Path

import numpy as np

N_ROBOTS = 3
BATCHES = (1024, 4096)
BEAMS = (0, 12, 64)
CROSSOVER_BATCHES = (16, 32, 64, 128, 256)
EXPERT_SUITES = ("circle-16-v0", "crowd-20-v0", "doorway-v0")
EXPERT_BATCH = 256
EXPERT_STEPS = 30
DEFAULT_OUT = Path("runs") / "bench-threads" / "THREADS.md"


def engine_rate(B: int, beams: int, n_threads: int, steps: int, repeats: int, n_obstacles: int | None = None) -> float:
    """Best wall-clock robot-steps/s of ``steps`` engine steps at ``B`` worlds, over ``repeats`` runs
    (``n_obstacles``: other than the env benchmark's 10; 0 for the robots alone)."""
    from vcs_env import threads
    from vcs_env.engine import NavEngine
    from vcs_env.lidar import LidarSpec

    from .env_bench import our_scenario

    s = our_scenario(N_ROBOTS) if n_obstacles is None else our_scenario(N_ROBOTS, n_obstacles)
    if beams:
        s = dataclasses.replace(s, lidar=LidarSpec(n_beams=beams))
    threads.set_threads(n_threads)
    eng = NavEngine(s, B)
    eng.reset(list(range(B)))
    pool = np.random.default_rng(0).uniform(-1.0, 1.0, (16, B, N_ROBOTS, 2))
    for k in range(3):  # compile, warm caches
        eng.step(pool[k], autoreset=True)
    best = 0.0
    for _ in range(repeats):
        acting = 0
        t0 = time.perf_counter()
        for k in range(steps):
            acting += int(eng.world.active.sum())
            eng.step(pool[k % 16], autoreset=True)
        best = max(best, acting / (time.perf_counter() - t0))
    return best


def vmas_rate(B: int, beams: int, steps: int, repeats: int) -> float:
    """Best wall-clock agent-steps/s of ``steps`` steps of VMAS ``navigation`` at ``B`` worlds and ``n = 3``
    (one torch thread), agent collisions on, its lidar with ``beams`` rays (none with 0); NaN when VMAS is not
    installed."""
    from .env_bench import vmas_env
    from .peers import torch_single_thread
    from .timing import Missing

    torch_single_thread()
    try:
        step = vmas_env(N_ROBOTS, B, n_lidar_rays=beams)
    except Missing:
        return float("nan")
    for _ in range(3):
        step()
    best = 0.0
    for _ in range(repeats):
        t0 = time.perf_counter()
        units = sum(step() for _ in range(steps))
        best = max(best, units / (time.perf_counter() - t0))
    return best


def machine() -> dict:
    from vcs_env import threads

    from .timing import machine_info

    info = machine_info()
    info["numba_threads"] = threads.max_threads()
    return info


def expert_rate(suite: str, B: int, n_threads: int, steps: int, repeats: int) -> float:
    """Best wall-clock robot-steps/s of ``steps`` steps of ``B`` worlds of ``suite``'s scenario driven
    by the VCS expert (planning and stepping: what expert data collection and ``compare`` run)."""
    from baselines.vcs import VCSPlanner
    from vcs_env import threads
    from vcs_env.engine import NavEngine
    from vcs_env.suites import get_suite

    threads.set_threads(n_threads)
    eng = NavEngine(get_suite(suite).scenario, B)
    best = 0.0
    for _ in range(repeats + 1):  # the first run compiles and warms up
        eng.reset(list(range(B)))
        planner = VCSPlanner()
        acted = 0
        t0 = time.perf_counter()
        for _ in range(steps):
            acted += int(eng.world.active.sum())
            eng.step(planner.act(eng.world, "delta"))
        best = max(best, acted / (time.perf_counter() - t0))
    return best


def run(
    steps: int, repeats: int, batches=BATCHES, beams=BEAMS, crossover=CROSSOVER_BATCHES, quick: bool = False
) -> dict:
    from vcs_env import threads

    counts = sorted({1, min(2, threads.max_threads()), threads.max_threads()})
    info = machine()
    rows = []
    for B in batches:
        for k in beams:
            rates = {t: engine_rate(B, k, t, steps, repeats) for t in counts}
            vmas = vmas_rate(B, k, steps, repeats)
            open_rate = engine_rate(B, k, 1, steps, repeats, n_obstacles=0)
            rows.append({"B": B, "beams": k, "rates": rates, "vmas": vmas, "open": open_rate})
            print(
                f"B={B} beams={k}: " + ", ".join(f"{t} thr {r / 1e6:.3f} M/s" for t, r in rates.items())
                + f", VMAS {vmas / 1e6:.3f} M/s, ours open {open_rate / 1e6:.3f} M/s",
                flush=True,
            )  # fmt: skip
    cross = []
    old = threads.MIN_PARALLEL_BATCH
    threads.MIN_PARALLEL_BATCH = 1
    try:
        for B in crossover:
            rates = {t: engine_rate(B, 0, t, max(steps, 200), repeats) for t in counts}
            cross.append({"B": B, "beams": 0, "rates": rates})
            print(f"crossover B={B}: " + ", ".join(f"{t} thr {r / 1e6:.3f} M/s" for t, r in rates.items()), flush=True)
    finally:
        threads.MIN_PARALLEL_BATCH = old
    expert = []
    for suite in EXPERT_SUITES[:1] if quick else EXPERT_SUITES:
        B, n_steps = (16, 2) if quick else (EXPERT_BATCH, EXPERT_STEPS)
        rates = {t: expert_rate(suite, B, t, n_steps, min(repeats, 3)) for t in counts}
        expert.append({"suite": suite, "B": B, "rates": rates})
        print(f"expert {suite} B={B}: " + ", ".join(f"{t} thr {r / 1e3:.1f} k/s" for t, r in rates.items()), flush=True)
    threads.set_threads()
    info["load_average_end"] = list(os.getloadavg())
    import numba

    try:
        info["threading_layer"] = numba.threading_layer()
    except ValueError:  # no parallel kernel ran (one thread, NUMBA_NUM_THREADS=1): numba started no layer
        info["threading_layer"] = "none (no parallel kernel ran)"
    info["omp_wait_policy"] = os.environ.get("OMP_WAIT_POLICY", "unset")
    return {
        "machine": info, "threads": counts, "rows": rows, "crossover": cross, "expert": expert, "steps": steps,
        "repeats": repeats, "quick": quick,
        "expert_steps": 2 if quick else EXPERT_STEPS, "expert_repeats": min(repeats, 3),
    }  # fmt: skip


def render(res: dict) -> str:
    m, counts = res["machine"], res["threads"]
    now = res.get("date") or datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    command = res.get("command", "python -m benchmarks.threads_bench")
    quick = " A quick run (--quick: tiny sizes; the numbers mean nothing)." if res.get("quick") else ""
    out = [
        "# Thread scaling of the batched engine (issue 45)",
        "",
        f"Generated by `{command}` on {now}:{quick} {res['steps']} steps, best of "
        f"{res['repeats']} runs, wall clock, robot-steps/s (M = 10^6), n = {N_ROBOTS}, the env benchmark's "
        "`dynamic` worlds (10 moving obstacles), auto-reset on.",
        "",
        f"Machine: {m['cpu']}, {m['logical_cores']} logical cores, {m['usable_cores']} usable, "
        f"NUMBA_NUM_THREADS={m['numba_threads']}, {m['platform']}, Python {m['python']}, "
        f"numba {m['packages'].get('numba')} (threading layer {m['threading_layer']}, OMP_WAIT_POLICY "
        f"{m['omp_wait_policy']}), numpy {m['packages'].get('numpy')}. Load average (1, 5, 15 min) "
        f"at start {', '.join(f'{x:.2f}' for x in m['load_average'])}, at end "
        f"{', '.join(f'{x:.2f}' for x in m['load_average_end'])}: other jobs on the machine take cores from the "
        "runs at 2+ threads.",
        "",
        "| B | lidar beams | " + " | ".join(f"{t} thread{'s' if t > 1 else ''} [M/s]" for t in counts)
        + " | " + " | ".join(f"speed-up {t}/1" for t in counts[1:]) + " | lidar cost (1 thread) "
        "| VMAS, 1 thread [M/s] | ours / VMAS (1 thread) | ours, open, 1 thread [M/s] | ours, open / VMAS |",
        "|---|---|" + "---|" * (2 * len(counts) + 4),
    ]  # fmt: skip
    base = {(r["B"], t): r["rates"][t] for r in res["rows"] if r["beams"] == 0 for t in counts}
    for r in res["rows"]:
        rates = r["rates"]
        cost = base[(r["B"], 1)] / rates[1] if (r["B"], 1) in base else float("nan")
        vmas, open_rate = r.get("vmas", float("nan")), r.get("open", float("nan"))
        out.append(
            f"| {r['B']} | {r['beams'] or 'none'} | "
            + " | ".join(f"{rates[t] / 1e6:.3f}" for t in counts)
            + " | "
            + " | ".join(f"{rates[t] / rates[1]:.2f}x" for t in counts[1:])
            + f" | {cost:.2f}x | {vmas / 1e6:.3f} | {rates[1] / vmas:.2f}x | {open_rate / 1e6:.3f} | "
            f"{open_rate / vmas:.2f}x |"
        )
    out += [
        "",
        "Lidar cost: the step without lidar over the step with it (time ratio), 1 thread. Targets (issue 45): "
        ">= 1.8x from 1 to 2 threads at B = 4096; 12 beams <= 2x, 64 beams <= 4x the step without lidar. VMAS: "
        "`navigation` on the CPU, one torch thread, agent collisions on, the agents alone (no obstacles; ours have "
        "10 moving obstacles more), with its lidar of that many rays (`n_lidar_rays=0` without). Ours, open: our "
        "worlds without the obstacles (the robots alone, as VMAS's), the like-for-like column. nan: VMAS not "
        "installed.",
        "",
        "Crossover (no lidar, parallel twins forced at every B): where threads start to pay.",
        "",
        "| B | " + " | ".join(f"{t} thread{'s' if t > 1 else ''} [M/s]" for t in counts) + " |",
        "|---|" + "---|" * len(counts),
    ]
    for r in res["crossover"]:
        out.append(f"| {r['B']} | " + " | ".join(f"{r['rates'][t] / 1e6:.3f}" for t in counts) + " |")
    out += [
        "",
        f"The VCS expert driving the suites' worlds ({res.get('expert_steps', EXPERT_STEPS)} steps from the reset, "
        f"planning and stepping, best of {res.get('expert_repeats', 3)} runs after a warm-up; robot-steps/s, k = "
        "10^3): the planner's world loop runs in parallel "
        "too; its Python glue (preferred velocities, routes among walls) and the env step's do not.",
        "",
        "| suite | B | " + " | ".join(f"{t} thread{'s' if t > 1 else ''} [k/s]" for t in counts)
        + " | " + " | ".join(f"speed-up {t}/1" for t in counts[1:]) + " |",
        "|---|---|" + "---|" * (2 * len(counts) - 1),
    ]  # fmt: skip
    for r in res.get("expert", []):
        rates = r["rates"]
        out.append(
            f"| `{r['suite']}` | {r['B']} | "
            + " | ".join(f"{rates[t] / 1e3:.1f}" for t in counts)
            + " | "
            + " | ".join(f"{rates[t] / rates[1]:.2f}x" for t in counts[1:])
            + " |"
        )
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.threads_bench", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"Markdown report (default {DEFAULT_OUT})")
    p.add_argument("--steps", type=int, default=100, help="engine steps per timed run")
    p.add_argument("--repeats", type=int, default=5, help="timed runs per number (the best counts)")
    p.add_argument("--quick", action="store_true", help="tiny sizes (smoke test; the numbers mean nothing)")
    a = p.parse_args(argv)
    if a.steps < 1 or a.repeats < 1:  # rates of 0: the report's ratios divided by them after the whole run
        p.error(f"--steps and --repeats must be >= 1, got --steps {a.steps} --repeats {a.repeats}")
    started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    if a.quick:
        res = run(3, 1, batches=(64,), beams=(0, 4), crossover=(16,), quick=True)
    else:
        res = run(a.steps, a.repeats)
    res["date"] = started
    res["command"] = "python -m benchmarks.threads_bench " + shlex.join(argv if argv is not None else sys.argv[1:])
    res["command"] = res["command"].strip()
    text = render(res)
    from .timing import write_report

    write_report(a.out, text, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
