"""``python -m benchmarks.jaxmarl_bench``: the batched engine against JaxMARL's MPE on jax-CPU (issue 45).

Contestants, at the same agent count (``n = 3``) and batch size ``B`` (1024 and 4096 worlds), with
random actions from a pool drawn before timing (no contestant pays for sampling):

* ``ours`` - :class:`vcs_env.engine.NavEngine` on the env benchmark's worlds
  (:func:`benchmarks.env_bench.engine_env`: the ``dynamic`` preset, 3 robots, 10 obstacles turning
  at random and bouncing off the arena, swept collision checks, ``on_collision="continue"``,
  200-step episodes), auto-reset on; each step returns observations, rewards and ends.
* ``ours_open`` - the same engine and worlds without the obstacles: 3 robots alone, the bodies
  simple_spread holds (its 3 landmarks are goals nothing collides with), the like-for-like row.
* ``jaxmarl_step`` - JaxMARL ``MPE_simple_spread_v3`` (3 agents, its default 3 landmarks,
  continuous actions, ``max_steps=200`` as ours), ``jax.jit(jax.vmap(env.step))`` over ``B``
  worlds, one call per step from Python (the state buffers donated), blocked on its outputs
  (observations, state, rewards, dones) every step, as a host-driven learner loop would.
* ``jaxmarl_scan`` - the same step inside ``jax.lax.scan`` (:data:`SCAN_STEPS` steps per jitted
  call; observations, rewards and dones carried, so XLA cannot drop them): JaxMARL's own way of
  rolling out, without Python between steps.

JaxMARL's ``step`` auto-resets: it computes a fresh reset (and its observations) on every step and
selects it where the episode ended (``step >= max_steps``; simple_spread has no other end). Ours
resets, after the step, only the worlds whose episode ended (no robot active, or 200 steps).

Two processes, one per table, each measuring its contestants in turn, round after round (ours,
ours_open, jaxmarl_step, jaxmarl_scan, ours, ...; :func:`benchmarks.timing.side_by_side`), so a change of load
hits all of them alike. A timed run is one episode of every world: :data:`EPISODE_STEPS` steps of
all ``B`` worlds. Our worlds start together and end together, so each run holds one reset of all
``B`` worlds (layouts drawn on the host: a large share of our time) at the same rate as in training;
shorter runs would time our cheap mid-episode steps only. jit compilation is done (and blocked on)
at build time, before one untimed warm-up episode. Rates are robot-steps (agent-steps) per
wall-clock second, the median over rounds:

1. one thread each: ``vcs_env.set_threads(1)``, and for XLA ``XLA_FLAGS`` =
   :data:`XLA_ONE_THREAD`, set before jax is imported; these flags alone left jax's CPU client
   splitting the B = 4096 step over both cores (1.8 CPU seconds per wall second), so the process is
   also pinned to one core, the least busy one (:func:`core_busy`), before jax starts its thread pool;
2. ours on 2 threads against jax with its default threading (``XLA_FLAGS`` unset).

The CPU seconds per wall second of each contestant are kept (``cpu_share``): above 1 a contestant
used more than one core. Writes a Markdown table (``--out``, default
``runs/bench-jaxmarl/JAXMARL.md``; ``runs/`` is not committed) and the numbers as JSON next to it.

JaxMARL (``pip install jaxmarl``, 0.2.0 with jax 0.10.2 when measured) installs beside the CPU
build of torch 2.13.0 in the project's environment, adding packages and changing none; where it
does not, run this module with the python of a separate environment that has
``pip install torch==2.13.0 && pip install -e . && pip install jaxmarl`` (torch first).
"""

from __future__ import annotations

from . import threading_env  # noqa: F401  (first, before numpy and numba: the thread settings)

# isort: split
import argparse
import datetime
import json
import os
import shlex
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np

from .env_bench import EPISODE_STEPS, engine_env, our_scenario  # EPISODE_STEPS: both sides' episodes (MPE's own: 25)

N_AGENTS = 3
BATCHES = (1024, 4096)
SCAN_STEPS = 50
"""Steps per jitted call of ``jaxmarl_scan``."""
POOL = 16
"""Pre-drawn action sets (and random keys) cycled through."""
XLA_ONE_THREAD = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
ENV_ID = "MPE_simple_spread_v3"
PHASES = {"one_thread": 1, "default_threads": 2}
"""Phase -> threads of our engine (jax: one thread in the first, its default in the second)."""
CONTESTANTS = ("ours", "ours_open", "jaxmarl_step", "jaxmarl_scan")
VERSIONS = ("jax", "jaxlib", "jaxmarl", "flax", "chex")
ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = Path("runs") / "bench-jaxmarl" / "JAXMARL.md"


JAXMARL_HINT = "pip install jaxmarl==0.2.0 (not part of the bench extra; it installs jax beside torch)"


def _jaxmarl_env():
    from .timing import Missing

    try:
        import jax
        import jaxmarl
    except Exception as e:  # ImportError, or a broken install that fails while importing
        raise Missing(f"cannot import JaxMARL ({type(e).__name__}: {e}); {JAXMARL_HINT}") from None
    env = jaxmarl.make(ENV_ID, num_agents=N_AGENTS, action_type="Continuous", max_steps=EPISODE_STEPS)
    return jax, env


def _pools(jax, env, B: int, seed: int):
    """``POOL`` key sets ``(POOL, B, 2)`` and actions ``{agent: (POOL, B, dim)}`` in the action box."""
    rng = np.random.default_rng(seed)
    keys = jax.random.split(jax.random.PRNGKey(seed), POOL * B).reshape(POOL, B, -1)
    acts = {}
    for a in env.agents:
        space = env.action_space(a)
        low, high = np.broadcast_to(space.low, space.shape), np.broadcast_to(space.high, space.shape)
        acts[a] = jax.numpy.asarray(rng.uniform(low, high, (POOL, B, *space.shape)).astype(np.float32))
    return keys, acts


def jaxmarl_step_env(B: int, seed: int = 0):
    """One jitted, vmapped ``env.step`` per call, blocked on; returns agent-steps."""
    jax, env = _jaxmarl_env()
    keys, acts = _pools(jax, env, B, seed)
    acts = [{a: v[k] for a, v in acts.items()} for k in range(POOL)]
    _, state = jax.jit(jax.vmap(env.reset))(keys[0])
    vstep = jax.jit(jax.vmap(env.step), donate_argnums=1)
    held = [state, 0]
    jax.block_until_ready(vstep(keys[1], jax.tree.map(lambda x: x.copy(), state), acts[1]))  # compile

    def step() -> int:
        k = held[1] = (held[1] + 1) % POOL
        obs, held[0], reward, dones, _ = vstep(keys[k], held[0], acts[k])
        jax.block_until_ready((obs, held[0], reward, dones))
        return B * N_AGENTS

    return step


def jaxmarl_scan_env(B: int, seed: int = 0, steps: int = SCAN_STEPS):
    """``steps`` vmapped steps in one jitted ``lax.scan``, blocked on; returns agent-steps."""
    jax, env = _jaxmarl_env()
    jnp = jax.numpy
    keys, acts = _pools(jax, env, B, seed)
    vstep = jax.vmap(env.step)
    obs0, state = jax.jit(jax.vmap(env.reset))(keys[0])
    _, _, reward0, dones0, _ = jax.jit(jax.vmap(env.step))(keys[1], state, {a: v[1] for a, v in acts.items()})

    def roll(carry, start, keys, acts):
        def body(carry, k):
            obs, state, reward, dones, _ = vstep(keys[k % POOL], carry[0], {a: v[k % POOL] for a, v in acts.items()})
            return (state, obs, reward, dones), None

        carry, _ = jax.lax.scan(body, carry, start + jnp.arange(steps))
        return carry

    roll = jax.jit(roll, donate_argnums=0)
    held = [(state, obs0, reward0, dones0), 0]
    jax.block_until_ready(roll(jax.tree.map(lambda x: x.copy(), held[0]), 0, keys, acts))  # compile

    def step() -> int:
        held[0] = roll(held[0], held[1], keys, acts)
        held[1] = (held[1] + steps) % POOL
        jax.block_until_ready(held[0])
        return steps * B * N_AGENTS

    return step


def episode_of(step, calls: int):
    """A contestant whose one call is ``calls`` calls of ``step`` (one episode of every world); one
    untimed episode first (warm-up, after jit compilation)."""

    def run() -> int:
        return sum(step() for _ in range(calls))

    run()
    return run


def builders(B: int, split: dict) -> dict:
    def ours():
        run = episode_of(engine_env(N_AGENTS, B, split=split), EPISODE_STEPS)
        split.update(units=0, seconds=0.0)  # from the timed runs only
        return run

    return {
        "ours": ours,
        "ours_open": lambda: episode_of(engine_env(N_AGENTS, B, scenario=our_scenario(N_AGENTS, 0)), EPISODE_STEPS),
        "jaxmarl_step": lambda: episode_of(jaxmarl_step_env(B), EPISODE_STEPS),
        "jaxmarl_scan": lambda: episode_of(jaxmarl_scan_env(B), EPISODE_STEPS // SCAN_STEPS),
    }


def core_busy(seconds: float = 0.5) -> dict[int, float]:
    """Busy share of every core over ``seconds`` (``/proc/stat``; empty where it is missing)."""
    import time

    def ticks() -> dict[int, tuple[int, int]]:
        out = {}
        try:
            with open("/proc/stat") as f:
                for line in f:
                    name, *v = line.split()
                    if name.startswith("cpu") and name != "cpu":
                        v = [int(x) for x in v]
                        out[int(name[3:])] = (sum(v), v[3] + v[4])  # total, idle + iowait
        except (OSError, ValueError):
            return {}
        return out

    a = ticks()
    time.sleep(seconds)
    b = ticks()
    return {c: 1.0 - (b[c][1] - a[c][1]) / max(1, b[c][0] - a[c][0]) for c in sorted(b) if c in a}


def run_phase(phase: str, batches, budget) -> dict:
    """Measure every contestant at every ``B`` in this process (jax's threading is fixed by now)."""
    import time

    busy = core_busy()
    info = {"load_average": list(os.getloadavg()), "xla_flags": os.environ.get("XLA_FLAGS", "unset")}
    info["core_busy_at_start"] = busy
    if PHASES[phase] == 1 and busy:  # XLA's flags leave its thread pool at the usable cores: pin to one
        usable = os.sched_getaffinity(0)
        core = min((c for c in busy if c in usable), key=busy.get, default=None)
        if core is not None:  # /proc/stat's cores and the affinity set may not meet (containers)
            os.sched_setaffinity(0, {core})
        info["pinned_to_core"] = core

    from vcs_env import threads

    from .timing import side_by_side

    info["our_threads"] = threads.set_threads(min(PHASES[phase], threads.max_threads()))
    rows = []
    for B in batches:
        t0 = time.perf_counter()
        split = {"units": 0, "seconds": 0.0}
        res = side_by_side(builders(B, split), budget)
        row = {"B": B, "seconds": time.perf_counter() - t0, "ours_between_resets": _ratio(**split)}
        for name, r in res.items():
            d = r.as_dict()
            d["median_wall_rate"] = float(np.median(r.wall_rates)) if r.ok else float("nan")
            d["best_wall_rate"] = max(r.wall_rates) if r.ok else float("nan")
            d["cpu_share"] = float(np.median(np.divide(r.wall_rates, r.rates))) if r.ok else float("nan")
            row[name] = d
        rows.append(row)
        print(
            f"[{phase}] B={B}: "
            + ", ".join(f"{k} {row[k]['median_wall_rate'] / 1e6:.3f} M/s ({row[k]['status']})" for k in CONTESTANTS),
            flush=True,
        )
    try:
        import jax

        info["jax_devices"] = [str(d) for d in jax.devices()]
    except Exception as e:
        info["jax_devices"] = f"jax not importable ({type(e).__name__})"
    if threads.get_threads() > 1:
        import numba

        try:
            info["threading_layer"] = numba.threading_layer()
        except ValueError:  # no parallel kernel ran (B below MIN_PARALLEL_BATCH)
            info["threading_layer"] = "not started"
    info["load_average_end"] = list(os.getloadavg())
    info["core_busy_at_end"] = core_busy()
    return {"phase": phase, "info": info, "rows": rows}


def machine() -> dict:
    from vcs_env import threads

    from .timing import machine_info

    info = machine_info()
    info["numba_threads"] = threads.max_threads()
    for name in VERSIONS:
        try:
            info["packages"][name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            info["packages"][name] = "not installed"
    return info


def wait_idle(limit: float, busy: float = 0.25) -> float:
    """Wait up to ``limit`` seconds for every usable core to be less than ``busy`` busy (other jobs);
    returns the seconds waited."""
    import time

    t0 = time.perf_counter()
    while time.perf_counter() - t0 < limit and max(core_busy(1.0).values(), default=0.0) >= busy:
        pass
    return time.perf_counter() - t0


def run(args) -> dict:
    """Both phases, each in a fresh process (XLA reads its flags once, at start)."""
    info = machine()
    phases = []
    for phase in PHASES:
        waited = wait_idle(args.wait_idle)
        env = dict(os.environ)
        env.pop("XLA_FLAGS", None)
        if PHASES[phase] == 1:
            env["XLA_FLAGS"] = XLA_ONE_THREAD
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "phase.json"
            cmd = [sys.executable, "-m", "benchmarks.jaxmarl_bench", "--phase", phase, "--phase-out", str(out)]
            cmd += ["--batches", *map(str, args.batches), "--repeats", str(args.repeats)]
            subprocess.run(cmd, env=env, cwd=ROOT, check=True)
            phases.append(json.loads(out.read_text()))
            phases[-1]["info"]["waited_for_idle_cores"] = waited
    info["load_average_end"] = list(os.getloadavg())
    return {"machine": info, "phases": phases, "repeats": args.repeats}


def _ratio(units: float, seconds: float) -> float:
    return units / seconds if seconds and np.isfinite(units) and np.isfinite(seconds) else float("nan")


def _times(a: float, b: float) -> str:
    """``a / b`` as a ratio, or ``-`` where either side was not measured."""
    r = _ratio(a, b)
    return f"{r:.2f}x" if np.isfinite(r) else "-"


def _loads(x) -> str:
    return ", ".join(f"{v:.2f}" for v in x)


def render(res: dict) -> str:
    m = res["machine"]
    p = m["packages"]
    out = [
        "# The batched engine against JaxMARL's MPE on jax-CPU (issue 45)",
        "",
        f"Generated by `{res.get('command', 'python -m benchmarks.jaxmarl_bench')}` on {res.get('date', '?')}: "
        f"robot-steps (agent-steps) per wall-clock second (M = 10^6), n = {N_AGENTS}, random actions, "
        f"{EPISODE_STEPS}-step episodes, auto-reset on both sides. A timed run is one episode of every world "
        f"({EPISODE_STEPS} steps of all B; our worlds start together, so it holds one reset of each); the "
        f"contestants run in turn, {res['repeats']} rounds, and the median counts.",
        "",
        f"Machine: {m['cpu']}, {m['logical_cores']} logical cores, {m['usable_cores']} usable, {m['platform']}, "
        f"Python {m['python']}; vcs-env {p.get('vcs-env')}, numba {p.get('numba')}, numpy {p.get('numpy')}, "
        f"torch {p.get('torch')}; jax {p.get('jax')}, jaxlib {p.get('jaxlib')}, jaxmarl {p.get('jaxmarl')}, "
        f"flax {p.get('flax')}. Load average (1, 5, 15 min) at start {_loads(m['load_average'])}, at end "
        f"{_loads(m['load_average_end'])}.",
        "",
        "* **ours**: `NavEngine`, the env benchmark's `dynamic` worlds (3 robots, 10 moving obstacles, swept "
        "collision checks, float64), `step(actions, autoreset=True)` (observations, rewards, ends); only ended "
        "worlds are reset. Counts acting robots.",
        "* **ours, open**: the same without the obstacles (3 robots alone: the bodies simple_spread holds, whose "
        "3 landmarks are goals that nothing collides with), the like-for-like comparison.",
        f"* **JaxMARL step**: `{ENV_ID}` (3 agents, 3 landmarks, continuous 5-dim actions in [0, 1], "
        "`max_steps=200`, float32), `jax.jit(jax.vmap(env.step))`, one call per step, blocked on every step. "
        "Its `step` auto-resets by computing a reset on every step and selecting it where the episode ended.",
        f"* **JaxMARL scan**: the same step in a jitted `lax.scan` of {SCAN_STEPS} steps (no Python between "
        "steps). Counts B x 3 agent-steps per step.",
        "",
    ]
    titles = {
        "one_thread": "One thread each (ours `set_threads(1)`, XLA_FLAGS `{xla}`, the process pinned to core {core})",
        "default_threads": "Ours on {ours} threads, jax with its default threading (XLA_FLAGS {xla})",
    }
    for ph in res["phases"]:
        i = ph["info"]
        out += [
            "## " + titles[ph["phase"]].format(xla=i["xla_flags"], ours=i["our_threads"], core=i.get("pinned_to_core")),
            "",
            f"Load average at start {_loads(i['load_average'])}, at end {_loads(i['load_average_end'])}; busy share "
            "of each core (other jobs) over 0.5 s before: "
            + ", ".join(f"core {c} {b:.2f}" for c, b in i.get("core_busy_at_start", {}).items())
            + ", after: "
            + ", ".join(f"core {c} {b:.2f}" for c, b in i.get("core_busy_at_end", {}).items())
            + f"; waited {i.get('waited_for_idle_cores', 0.0):.0f} s for idle cores.",
            "",
            "| B | ours [M/s] | ours, open [M/s] | JaxMARL step [M/s] | JaxMARL scan [M/s] | ours / step "
            "| ours / scan | ours, open / scan | ours between resets [M/s] | the same / scan "
            "| CPU share ours, open, step, scan |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in ph["rows"]:
            rate = {k: r[k]["median_wall_rate"] for k in CONTESTANTS}
            share = ", ".join(f"{r[k]['cpu_share']:.2f}" for k in CONTESTANTS)
            between = r.get("ours_between_resets", float("nan"))
            out.append(
                f"| {r['B']} | "
                + " | ".join(f"{rate[k] / 1e6:.3f}" for k in CONTESTANTS)
                + f" | {_times(rate['ours'], rate['jaxmarl_step'])} | "
                f"{_times(rate['ours'], rate['jaxmarl_scan'])} | {_times(rate['ours_open'], rate['jaxmarl_scan'])} | "
                f"{between / 1e6:.3f} | "
                f"{_times(between, rate['jaxmarl_scan'])} | {share} |"
            )
        busy = [b for k in ("core_busy_at_start", "core_busy_at_end") for b in i.get(k, {}).values()]
        if busy and max(busy) > 0.5:
            out += [
                "",
                f"Another job held a core at the start or end of this table (busy share up to {max(busy):.2f}): "
                + (
                    "ours on 2 threads then waits at every parallel kernel's barrier for a thread that is not "
                    "running, and its rates here measure that contention, not the engine."
                    if i["our_threads"] > 1
                    else "both sides shared what was left of the pinned core alike."
                ),
            ]
        bad = [
            f"{k} at B = {r['B']}: {r[k]['status']}" for r in ph["rows"] for k in CONTESTANTS if r[k]["status"] != "ok"
        ]
        out += [""] + ([f"Not measured: {'; '.join(bad)}.", ""] if bad else [])
    out += [
        "CPU share: CPU seconds per wall second of the contestant (median over rounds); above 1 it used more than "
        "one core. Ours between resets: our rate over the timed steps in which no world ended (all but the "
        "one step per episode that resets all B worlds), the steady step without the resets' cost. Target "
        "(issue 45): ours >= 2x JaxMARL's jax-CPU MPE at B = 4096 (at the same n; ours, open, holds the same "
        "bodies as simple_spread, ours 10 obstacles more).",
    ]
    if p.get("jaxmarl", "not installed") != "not installed":  # what this project found when it installed it
        out += [
            "",
            "JaxMARL installed beside torch in the project's environment: `pip install jaxmarl==0.2.0` added jax, "
            "jaxlib, flax, chex, gymnax and their dependencies and changed no installed package.",
        ]
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.jaxmarl_bench", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"Markdown report (default {DEFAULT_OUT})")
    p.add_argument("--batches", type=int, nargs="+", default=list(BATCHES), help="batch sizes B")
    p.add_argument("--repeats", type=int, default=5, help="rounds per number (the median counts)")
    p.add_argument("--wait-idle", type=float, default=0.0, help="seconds to wait for idle cores before each table")
    p.add_argument("--quick", action="store_true", help="tiny sizes (smoke test; the numbers mean nothing)")
    p.add_argument("--phase", choices=tuple(PHASES), help=argparse.SUPPRESS)
    p.add_argument("--phase-out", type=Path, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if any(b < 1 for b in a.batches) or a.repeats < 1:  # a run of zero worlds or rounds is a report of nan rows
        p.error(f"--batches and --repeats must be >= 1, got --batches {a.batches} --repeats {a.repeats}")
    if a.quick:
        a.batches, a.repeats = [32], 1
    if a.phase:  # a child process of run(): one table
        from .timing import Budget

        budget = Budget(warmup=0, min_time=0.0, min_calls=1, repeats=a.repeats)  # one episode per run
        a.phase_out.write_text(json.dumps(run_phase(a.phase, a.batches, budget), default=str))
        return 0
    started = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    res = run(a)
    res["date"] = started
    res["command"] = "python -m benchmarks.jaxmarl_bench " + shlex.join(argv if argv is not None else sys.argv[1:])
    res["command"] = res["command"].strip()
    text = render(res)
    from .timing import write_report

    write_report(a.out, text, res)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
