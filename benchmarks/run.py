"""``python -m benchmarks`` / ``vcs-env bench``: our env, planner and training throughput measured
side by side with real peers (PettingZoo MPE, VMAS, RVO2 ORCA via pyrvo) in one run.

Writes a Markdown report (``--out``, default ``benchmarks/RESULTS.md``) and the raw numbers as
JSON next to it (same name, ``.json``). ``--quick`` uses tiny sizes (the smoke test); its
numbers mean nothing, so without ``--out`` it writes ``runs/bench-quick/RESULTS.md`` (``runs/`` is
not committed), never the committed report. Peers come from the ``bench`` extra (``pip install -e '.[bench]'``); a
peer that cannot be imported is reported as missing, with the reason.

Sections: 1. env throughput (random actions), 2. planner throughput, 3. PPO training
throughput, 4. scaling exponents, 5. profiles (where the time goes). Units: robot-steps per
second for envs and training, robot-decisions per second (and microseconds per decision) for
planners.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from vcs_env.files import write_text

from . import env_bench, peers, planner_bench, profile_bench, rllib_bench, train_bench
from .report import render
from .targets import targets
from .timing import Budget, machine_info, side_by_side

DEFAULT_OUT = Path(__file__).resolve().parent / "RESULTS.md"
QUICK_OUT = Path("runs") / "bench-quick" / "RESULTS.md"
"""Where ``--quick`` writes without ``--out`` (relative to the working directory; ``runs/`` is gitignored)."""


def default_out(quick: bool) -> Path:
    """The report path when ``--out`` is not given: the committed report only for a full run."""
    return QUICK_OUT if quick else DEFAULT_OUT


@dataclass
class Sizes:
    """Everything the run's cost depends on."""

    env_robots: tuple[int, ...] = (4, 10, 32)
    """Agent counts n of the env throughput section."""
    env_batches: tuple[int, ...] = (1, 16, 64, 256)
    """Batch sizes B (worlds) of the batched env contestants."""
    env_budget: Budget = field(default_factory=Budget)
    gym_vector_robots: int = 4
    """Robots per world of the ``gym.make_vec`` comparison."""
    gym_vector_envs: int = 64
    """Envs (worlds) of the ``gym.make_vec`` comparison."""
    gym_vector_others: tuple[str, ...] = ("vcs", "straight")
    """Planners driving the non-learning robots in the ``gym.make_vec`` comparison."""
    gym_vector_budget: Budget = field(
        default_factory=lambda: Budget(warmup=2, min_time=0.0, min_calls=env_bench.EPISODE_STEPS, repeats=3)
    )
    """Both modes step the same worlds with the same actions, so a fixed number of calls (one
    episode length) makes them time the same steps: a time budget would time sync on the first
    steps of the episodes only (every robot still driving) and the vector env on later ones."""
    planner_robots: tuple[int, ...] = (4, 8, 16, 32, 64)
    """Robot counts of the circle and constant-density planner sets."""
    planner_batches: tuple[int, ...] = (1, 16)
    """Batch sizes of the circle planner set."""
    planner_names: tuple[str, ...] = ("vcs", "orca", "pyrvo_raw", "vo", "hrvo")
    snapshots: int = 6
    """World states per configuration (evenly spaced over the approach)."""
    horizon_scale: float = 1.0
    """Snapshots span this fraction of the time to reach the circle's centre."""
    density_horizon: int = 40
    """Steps of the constant-density rollouts."""
    neighbour_robots: int = 32
    """Robots of the neighbourhood-size set (circle, B = 1)."""
    neighbour_r_ca: tuple[float, ...] = (1.0, 2.0, 4.0, 8.0, 16.0)
    """Sensing radii [m] of the neighbourhood-size set."""
    planner_budget: Budget = field(default_factory=lambda: Budget(warmup=1, min_time=0.3, min_calls=6, repeats=3))
    scaling_robots: tuple[int, ...] = (4, 8, 16, 32, 64)
    """Robot counts of our env's scaling sweep."""
    scaling_batches: tuple[int, ...] = (1, 64)
    scaling_budget: Budget = field(default_factory=lambda: Budget(warmup=2, min_time=0.2, min_calls=3, repeats=3))
    train: train_bench.TrainSizes = field(default_factory=train_bench.TrainSizes)
    profile_calls: int = 200
    """Calls per cProfile run (planner profiles use a tenth)."""


def quick_sizes() -> Sizes:
    tiny = Budget(warmup=1, min_time=0.0, min_calls=1, repeats=1)
    return Sizes(
        env_robots=(4,),
        env_batches=(1, 4),
        env_budget=tiny,
        gym_vector_envs=2,
        gym_vector_budget=tiny,
        planner_robots=(4, 8),
        planner_batches=(1, 4),
        snapshots=2,
        horizon_scale=0.1,
        density_horizon=4,
        neighbour_robots=4,
        neighbour_r_ca=(2.0, 6.0),
        planner_budget=Budget(warmup=1, min_time=0.0, min_calls=2, repeats=1),
        scaling_robots=(4, 8),
        scaling_batches=(1,),
        scaling_budget=tiny,
        train=train_bench.TrainSizes(n_robots=4, n_worlds=2, n_steps=16, batch_size=32, n_epochs=1, repeats=1),
        profile_calls=10,
    )


def _results(res: dict) -> dict:
    return {name: r.as_dict() for name, r in res.items()}


def _log(msg: str) -> None:
    print(f"[bench {time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------- sections
def env_section(sz: Sizes) -> dict:
    single, batched = [], []
    for n in sz.env_robots:
        _log(f"env n={n} B=1 pettingzoo vs mpe")
        single.append({"n": n, "results": _results(side_by_side(env_bench.single_builders(n), sz.env_budget))})
        for B in sz.env_batches:
            _log(f"env n={n} B={B} engine, vecenv vs vmas")
            res = side_by_side(env_bench.batched_builders(n, B), sz.env_budget)
            batched.append({"n": n, "B": B, "results": _results(res)})
    walls = []
    for B in (1, max(sz.env_batches)):
        n = sz.gym_vector_robots
        _log(f"env walls n={n} B={B}: {env_bench.MAP_SEGMENTS} segments vs none")
        walls.append({"n": n, "B": B, "results": _results(side_by_side(env_bench.walls_builders(n, B), sz.env_budget))})
    return {"single": single, "batched": batched, "walls": walls}


def gym_vector_section(sz: Sizes) -> list[dict]:
    rows = []
    n, B = sz.gym_vector_robots, sz.gym_vector_envs
    for others in sz.gym_vector_others:
        _log(f"gym.make_vec n={n} B={B} others={others}: vector_entry_point vs sync")
        res = side_by_side(env_bench.gym_vector_builders(n, B, others), sz.gym_vector_budget)
        rows.append({"n": n, "B": B, "others": others, "results": _results(res)})
    return rows


def planner_section(sz: Sizes) -> dict:
    bud = sz.planner_budget
    circle = []
    for n in sz.planner_robots:
        sc = planner_bench.circle_scenario(n)
        horizon = max(1, int(round(sz.horizon_scale * planner_bench.circle_horizon(sc))))
        _log(f"planner circle n={n}: VCS rollout of {horizon} steps for the snapshots")
        states = planner_bench.snapshots(sc, sz.snapshots, horizon)
        for B in sz.planner_batches:
            batch = planner_bench.batch(states, B)
            _log(f"planner circle n={n} B={B}")
            res = side_by_side(planner_bench.builders(batch, sz.planner_names), bud)
            circle.append(_planner_entry(batch, res, n=n, B=B))
    neighbours = []
    n = sz.neighbour_robots
    sc = planner_bench.circle_scenario(n)
    horizon = max(1, int(round(sz.horizon_scale * planner_bench.circle_horizon(sc))))
    _log(f"planner neighbours n={n}: rollout")
    base = planner_bench.batch(planner_bench.snapshots(sc, sz.snapshots, horizon), 1)
    for r in sz.neighbour_r_ca:
        batch = planner_bench.with_r_ca(base, r)
        _log(f"planner neighbours n={n} r_ca={r}")
        res = side_by_side(planner_bench.builders(batch, ("vcs", "orca", "pyrvo_raw", "hrvo")), bud)
        neighbours.append(_planner_entry(batch, res, n=n, B=1, r_ca=r))
    density = []
    B = max(sz.planner_batches)
    for n in sz.planner_robots:
        sc = planner_bench.density_scenario(n)
        _log(f"planner density n={n}: rollout")
        batch = planner_bench.batch(planner_bench.snapshots(sc, sz.snapshots, sz.density_horizon), B)
        res = side_by_side(planner_bench.builders(batch, ("vcs", "orca", "pyrvo_raw", "hrvo")), bud)
        density.append(_planner_entry(batch, res, n=n, B=B, r_ca=sc.r_ca))
    return {"circle": circle, "neighbours": neighbours, "density": density}


def _planner_entry(batch, res, **keys) -> dict:
    decisions = [int(w.active.sum()) for w in batch]
    return {
        **keys,
        "mean_neighbours": planner_bench.mean_neighbours(batch),
        "decisions_per_call": sum(decisions) / len(decisions),
        "results": _results(res),
    }


def scaling_section(sz: Sizes) -> dict:
    rows = []
    for n in sz.scaling_robots:
        builders = {"pettingzoo": lambda n=n: env_bench.pettingzoo_env(n)}
        for B in sz.scaling_batches:
            builders[f"engine_B{B}"] = lambda n=n, B=B: env_bench.engine_env(n, B)
        _log(f"scaling n={n}")
        rows.append({"n": n, "results": _results(side_by_side(builders, sz.scaling_budget))})
    return {"rows": rows}


def profile_section(sz: Sizes) -> dict:
    c = sz.profile_calls
    n_small = min(sz.env_robots)  # where the B = 1 env is closest to MPE
    n_env = max(n_small, min(10, max(sz.env_robots)))
    n_plan = 16 if 16 in sz.planner_robots else sz.planner_robots[-1]
    B_big = max(sz.env_batches)
    sc = planner_bench.circle_scenario(n_plan)
    horizon = max(1, int(round(sz.horizon_scale * planner_bench.circle_horizon(sc))))
    states = planner_bench.batch(planner_bench.snapshots(sc, sz.snapshots, horizon), 1)
    cases = {
        f"pettingzoo env, n={n_small}, B=1": (lambda: env_bench.pettingzoo_env(n_small), c),
        f"MPE simple_spread, n={n_small}": (lambda: env_bench.mpe_env(n_small), c),
        f"engine, n={n_env}, B={B_big}": (lambda: env_bench.engine_env(n_env, B_big), max(2, c // 10)),
        f"vcs planner, circle n={n_plan}, B=1": (lambda: planner_bench.planner_step("vcs", states), max(2, c // 2)),
        f"orca planner, circle n={n_plan}, B=1": (lambda: planner_bench.planner_step("orca", states), max(2, c // 2)),
    }
    n_vec, B_vec = sz.gym_vector_robots, sz.gym_vector_envs
    for mode, calls in (("vector_entry_point", max(2, c // 4)), ("sync", max(2, c // 20))):
        cases[f"gym.make_vec {mode}, n={n_vec}, B={B_vec}, others=vcs"] = (
            lambda mode=mode: env_bench.gym_vector_env(n_vec, B_vec, mode),
            calls,
        )
    _log("profiles")
    return profile_bench.run(cases)


SECTIONS = ("env", "gym_vector", "planner", "training", "scaling", "profiles")


def _commit() -> str:
    try:
        root = Path(__file__).resolve().parents[1]
        sha = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
        return (sha or "unknown") + ("+dirty" if dirty else "")
    except Exception:
        return "unknown"


def run(
    quick: bool = False, out: Path | str | None = None, sections=SECTIONS, command: str = "", merge: bool = False
) -> dict:
    """Run the benchmarks and write ``out`` (Markdown; default :func:`default_out`) and ``out`` with
    ``.json``; returns the data. Our kernels run on one numba thread meanwhile (``vcs_env.set_threads(1)``, then the
    count before), as every peer gets one thread: ``python -m benchmarks`` also sets ``NUMBA_NUM_THREADS=1``, but
    ``vcs-env bench`` starts with the process's default (all usable cores).

    With ``merge``, the sections not run are kept from the existing JSON next to ``out`` (their
    numbers are from that earlier run)."""
    from vcs_env import get_threads, set_threads

    out = Path(out) if out is not None else default_out(quick)
    if out.suffix.lower() == ".json" or out.is_dir():  # before the runs, not after them
        what = "a directory" if out.is_dir() else "the raw numbers' own name (the .json beside the report)"
        raise ValueError(f"--out {str(out)!r} is {what}: give the Markdown report's file name, e.g. RESULTS.md")
    blocked = next((p for p in out.parents if p.exists() and not p.is_dir()), None)
    if blocked is not None:  # found only when the report was written, after every section had run
        raise ValueError(f"--out {str(out)!r} lies under {str(blocked)!r}, a file: give a path in a directory")
    if out.suffix.lower() != ".md":
        raise ValueError(f"--out {str(out)!r} must end in .md: the Markdown report (its numbers go beside it as .json)")
    held = [f for f in (out, out.with_suffix(".json")) if f.exists()]
    if held and not _is_results(out.with_suffix(".json")) and not (merge and out.with_suffix(".json").exists()):
        raise ValueError(
            f"--out {str(out)!r}: {str(held[0])!r} exists and {out.with_suffix('.json').name} is no earlier results of "
            "python -m benchmarks (this would overwrite it); give another name or remove the file first"
        )
    before = get_threads()
    set_threads(1)
    try:
        return _run(quick, out, sections, command, merge)
    finally:
        set_threads(before)


def _is_results(path: Path) -> bool:
    """``path`` holds the raw numbers of an earlier run (a JSON object with its ``meta``: date, commit, quick)."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    meta = data.get("meta") if isinstance(data, dict) else None
    return isinstance(meta, dict) and {"date", "commit", "quick"} <= meta.keys()


def _run(quick: bool, out: Path, sections, command: str, merge: bool) -> dict:
    """:func:`run` on one numba thread."""
    from vcs_env import get_threads

    sz = quick_sizes() if quick else Sizes()
    t0 = time.perf_counter()
    machine = machine_info()
    threads = peers.torch_single_thread()
    data: dict = {"peers": peers.status()}
    if merge and out.with_suffix(".json").exists():
        try:
            old = json.loads(out.with_suffix(".json").read_text())
        except ValueError as e:
            raise ValueError(f"--merge: {out.with_suffix('.json')} is not JSON ({e})") from None
        if not _is_results(out.with_suffix(".json")):
            raise ValueError(f"--merge: {out.with_suffix('.json')} is no results file of python -m benchmarks")
        meta = old["meta"]
        if bool(meta["quick"]) != quick:
            raise ValueError(
                f"--merge: {out.with_suffix('.json')} holds a {'quick' if meta['quick'] else 'full'} run; a "
                f"{'quick' if quick else 'full'} run does not merge with it (tiny sizes mean nothing beside real ones)"
            )
        kept = [k for k in SECTIONS if k in old and k not in sections]
        data.update({k: old[k] for k in kept})
        run_of = {"date": old["meta"]["date"], "commit": old["meta"]["commit"]}
        data["kept"] = {k: old.get("kept", {}).get(k, run_of) for k in kept}
        if "env" in kept:
            data["env"].pop("gym_vector", None)  # runs before the gym_vector section had it in env
    if "env" in sections:
        data["env"] = env_section(sz)
    if "gym_vector" in sections:
        data["gym_vector"] = gym_vector_section(sz)
    if "planner" in sections:
        data["planner"] = planner_section(sz)
    if "training" in sections:
        _log("training")
        data["training"] = {k: r.as_dict() for k, r in train_bench.run(sz.train).items()}
    if "scaling" in sections:
        data["scaling"] = scaling_section(sz)
    if "profiles" in sections:
        data["profiles"] = profile_section(sz)
    data["targets"] = targets(data)
    json_path = out.with_suffix(".json")
    data["meta"] = {
        "command": command or "python -m benchmarks" + (" --quick" if quick else ""),
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "commit": _commit(),
        "quick": quick,
        "machine": machine,
        "load_average_end": machine_info()["load_average"],
        "torch_threads": threads,
        "numba_threads": get_threads(),
        "repeats": sorted({sz.env_budget.repeats, sz.planner_budget.repeats, sz.train.repeats}),
        "budgets": {
            "env": asdict(sz.env_budget),
            "gym_vector": asdict(sz.gym_vector_budget),
            "planner": asdict(sz.planner_budget),
            "scaling": asdict(sz.scaling_budget),
        },
        "train_sizes": asdict(sz.train),
        "wall_seconds": time.perf_counter() - t0,
        "json": json_path.name,
    }
    write_text(json_path, json.dumps(data, indent=1, default=_jsonable) + "\n")
    write_text(out, render(data))
    rllib = Path(__file__).resolve().parent / rllib_bench.DEFAULT_JSON
    if rllib.exists():  # measured separately (needs Ray): keep its section in the report
        rllib_bench.write_section(str(out), rllib_bench.render_section(json.loads(rllib.read_text())))
    _log(f"wrote {out} and {json_path} in {data['meta']['wall_seconds']:.0f} s")
    return data


def _jsonable(x):
    if isinstance(x, tuple):
        return list(x)
    return str(x)


def _command_line() -> str:
    prog = Path(sys.argv[0]).name
    if prog == "__main__.py":  # python -m PACKAGE: the package that ran (benchmarks, or vcs_cli's bench)
        prog = f"python -m {Path(sys.argv[0]).parent.name}"
    return " ".join([prog, *sys.argv[1:]])


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true", help="tiny sizes (smoke test; the numbers mean nothing)")
    p.add_argument(
        "--out",
        default=None,
        help=f"Markdown report; the JSON goes next to it (default benchmarks/RESULTS.md; with --quick {QUICK_OUT})",
    )
    p.add_argument("--sections", default=",".join(SECTIONS), help=f"comma-separated subset of {','.join(SECTIONS)}")
    p.add_argument(
        "--merge", action="store_true", help="keep the sections not run from the existing JSON next to --out"
    )


def cmd_bench(args: argparse.Namespace) -> int:
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    unknown = sorted(set(sections) - set(SECTIONS))
    if unknown or not sections:
        raise ValueError(f"unknown sections {unknown or args.sections!r}; choose from {list(SECTIONS)}")
    data = run(args.quick, args.out, sections, command=_command_line(), merge=args.merge)
    for t in data["targets"]:
        print(f"{t['met']:>14}  {t['target']}")
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="benchmark env, planners and training against MPE, VMAS and RVO2",
        description=__doc__.split("\n\n")[0],
    )
    add_arguments(p)
    p.set_defaults(func=cmd_bench)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return cmd_bench(args)
    except ValueError as e:
        print(f"benchmarks: error: {e}", file=sys.stderr)
        return 2
