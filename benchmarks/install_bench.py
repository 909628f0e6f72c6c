"""``python -m benchmarks.install_bench``: what the README's install, run and test commands cost on a fresh machine.

Runs, from the checkout it is started in, the README's commands in throwaway virtual environments and
times them by the wall clock:

* **light**: ``pip install -e ".[render]"`` in a fresh venv (seconds, and the venv's size on disk), then
  the README's "Run" command twice in an empty directory with an empty numba cache
  (``NUMBA_CACHE_DIR``): the first call compiles the kernels, the second reads them back.
* **full** (``--full``): ``pip install torch==2.13.0``, ``pip install -e ".[all]"`` and
  ``pip install --no-deps benchmarl==1.5.2`` in another fresh venv (seconds each, the venv's size).
* **tests** (``--tests``, implies ``--full``): in that venv, each from an empty numba cache, the README's
  quick subset and full suite (seconds, pytest's summary line), as CI runs them.

pip's own download cache is whatever the machine has (the report names the index pip used), so the
install times are a machine's, not the internet's. Writes a Markdown report (``--out``, default
``runs/bench-install/INSTALL.md``; ``runs/`` is not committed) and the numbers as JSON beside it; the
committed report is ``--out benchmarks/INSTALL.md``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = Path("runs") / "bench-install" / "INSTALL.md"
LIGHT = (("pip", "install", "-e", ".[render]"),)
FULL = (
    ("pip", "install", "torch==2.13.0"),
    ("pip", "install", "-e", ".[all]"),
    ("pip", "install", "--no-deps", "benchmarl==1.5.2"),
)
RUN = ("vcs-env", "rollout", "--scenario", "circle", "--n-robots", "8", "--planner", "vcs", "--episodes", "3")
RUN = (*RUN, "--seed", "0", "--gif", "circle.gif")
TESTS = (("python", "-m", "pytest", "-m", "not slow", "-q"), ("python", "-m", "pytest", "-q"))
SOURCE = re.compile(r"(index-url|find-links)=")
HEADLESS = {"SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy", "MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1"}


def tree_size(path: Path) -> int:
    """Bytes of the regular files under ``path`` (symbolic links not followed)."""
    total = 0
    for base, _, files in os.walk(path):
        for name in files:
            p = os.path.join(base, name)
            if not os.path.islink(p):
                total += os.path.getsize(p)
    return total


def timed(cmd: tuple[str, ...], venv: Path, cwd: Path, env: dict[str, str]) -> dict:
    """Run ``cmd`` with ``venv``'s executables first on the PATH; its wall seconds and its output's last line.
    A command that fails stops the benchmark, naming the command and the end of its output."""
    env = {**os.environ, **HEADLESS, **env, "VIRTUAL_ENV": str(venv)}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env['PATH']}"
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        out = (proc.stdout + proc.stderr).strip().splitlines()
        raise SystemExit(f"`{shlex.join(cmd)}` failed (exit {proc.returncode}):\n" + "\n".join(out[-30:]))
    out = proc.stdout.strip().splitlines()
    return {"command": shlex.join(cmd), "seconds": seconds, "last_line": out[-1] if out else ""}


def fresh_venv(where: Path) -> Path:
    venv = where / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    return venv


def run(args) -> dict:
    from .timing import machine_info

    res = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"), "info": machine_info()}
    res["argv"] = "python -m benchmarks.install_bench " + " ".join(args.argv)
    config = subprocess.run([sys.executable, "-m", "pip", "config", "list"], capture_output=True, text=True).stdout
    sources = sorted({line.split("=", 1)[1].strip("'") for line in config.splitlines() if SOURCE.search(line)})
    res["pip_sources"] = sources or ["PyPI"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        venv = fresh_venv(tmp / "light")
        steps = [timed(c, venv, ROOT, {}) for c in LIGHT]
        res["light"] = {"steps": steps, "bytes": tree_size(venv)}
        work, cache = tmp / "run", tmp / "numba-light"
        work.mkdir()
        calls = [timed(RUN, venv, work, {"NUMBA_CACHE_DIR": str(cache)}) for _ in range(2)]
        res["run"] = {"first": calls[0], "second": calls[1]}
        if args.full or args.tests:
            venv = fresh_venv(tmp / "full")
            steps = [timed(c, venv, ROOT, {}) for c in FULL]
            res["full"] = {"steps": steps, "bytes": tree_size(venv)}
        if args.tests:  # each from an empty kernel cache, as on a clean clone
            res["tests"] = [
                timed(c, venv, ROOT, {"NUMBA_CACHE_DIR": str(tmp / f"numba-tests-{k}")}) for k, c in enumerate(TESTS)
            ]
    res["load_average_end"] = list(os.getloadavg())
    return res


def _mb(n: int) -> str:
    return f"{n / 1e6:,.0f} MB"


def _min(seconds: float) -> str:
    m, s = divmod(round(seconds), 60)
    return f"{m} min {s} s" if m else f"{s} s"


def render(res: dict) -> str:
    info = res["info"]
    lines = [
        "# Install, first run and tests on a fresh environment",
        "",
        f"Generated by `{res['argv']}` on {res['date']} from a checkout of this repository. Wall clock.",
        "",
        f"Machine: {info['cpu']}, {info['logical_cores']} logical cores ({info['usable_cores']} usable), "
        f"{info['platform']}, Python {info['python']}. Load average (1, 5, 15 min) at start "
        f"{', '.join(f'{x:.2f}' for x in info['load_average'])}, at end "
        f"{', '.join(f'{x:.2f}' for x in res['load_average_end'])}. pip's sources: {', '.join(res['pip_sources'])}.",
        "",
        "| step | command | wall time | result |",
        "|---|---|---|---|",
    ]
    for key, title in (("light", "light install"), ("full", "full install")):
        if key in res:
            for s in res[key]["steps"]:
                lines.append(f"| {title} | `{s['command']}` | {_min(s['seconds'])} | |")
            lines.append(f"| {title}: size of the venv | | | {_mb(res[key]['bytes'])} |")
    for key, title in (("first", "first call (empty kernel cache)"), ("second", "second call")):
        s = res["run"][key]
        lines.append(f"| {title} | `{s['command']}` | {_min(s['seconds'])} | {s['last_line'][:80]} |")
    for s, title in zip(res.get("tests", ()), ("quick subset", "full suite")):
        lines.append(f"| {title} (empty kernel cache) | `{s['command']}` | {_min(s['seconds'])} | {s['last_line']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.install_bench", description=__doc__.split("\n")[0])
    parser.add_argument("--full", action="store_true", help="also the full install (torch, every extra)")
    parser.add_argument("--tests", action="store_true", help="also the quick subset and the full test suite")
    parser.add_argument(
        "--out", type=Path, default=DEFAULT_OUT, help=f"Markdown report, the JSON beside it (default {DEFAULT_OUT})"
    )
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    from .timing import write_report

    res = run(args)
    write_report(args.out, render(res), res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
