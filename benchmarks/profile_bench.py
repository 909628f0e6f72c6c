"""Where the time goes: ``cProfile`` of a few hot loops, top functions and files by own time.

The profiler's clock is the wall clock (a CPU-time clock costs ~2 us a call here, more than
many of the profiled functions); on a shared machine the shares are the robust part."""

from __future__ import annotations

import cProfile
import gc
import os
import pstats
import time
from collections.abc import Callable
from pathlib import Path

from .timing import Missing, Step

TOP = 8
"""Functions listed per profile."""


def profile(step: Step, calls: int, top: int = TOP, repeats: int = 3) -> dict:
    """Run ``step`` ``calls`` times under cProfile (after one untimed call), ``repeats`` times,
    and keep the fastest run: on a shared machine a run can lose milliseconds to another
    process, which the wall-clock profiler would book on whichever function was running.

    Returns ``{"seconds_per_call": wall s, "rows": [(function, own seconds per call, share of
    total, calls per step call)]}``; numba kernels appear as one opaque row each.
    """
    step()
    best = None
    for _ in range(repeats):
        gc.collect()  # a full collection of the benchmark process's heap would land on one unlucky row
        prof = cProfile.Profile()
        t0 = time.perf_counter()
        prof.enable()
        for _ in range(calls):
            step()
        prof.disable()
        wall = time.perf_counter() - t0
        if best is None or wall < best[0]:
            best = (wall, prof)
    wall, prof = best
    stats = pstats.Stats(prof)
    total = sum(v[2] for v in stats.stats.values()) or 1.0
    rows, files = [], {}
    ranked = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)
    for (path, line, func), (_, ncalls, tottime, _, _) in ranked[:top]:
        where = func if path == "~" else f"{_short(path)}:{line}({func})"
        rows.append((where, tottime / calls, tottime / total, ncalls / calls))
    for (path, _, func), (_, _, tottime, _, _) in ranked:
        key = _file_group(path, func)
        files[key] = files.get(key, 0.0) + tottime
    by_file = [(f, t / calls, t / total) for f, t in sorted(files.items(), key=lambda kv: kv[1], reverse=True)[:top]]
    return {"seconds_per_call": wall / calls, "rows": rows, "files": by_file}


def _file_group(path: str, func: str) -> str:
    """Our files by name; numpy, torch, ... by package; C built-ins as one group."""
    if path == "~":
        return "C built-ins and numpy ufuncs" if "numpy" in func or "method" in func else "C built-ins"
    short = _short(path)
    if path.startswith(REPO):
        return short
    return short.split("/")[0]


REPO = str(Path(__file__).resolve().parents[1]) + os.sep


def _short(path: str) -> str:
    """A path relative to the repository or to site-packages."""
    if path.startswith(REPO):
        return path[len(REPO) :]
    parts = path.split(os.sep)
    if "site-packages" in parts:
        return "/".join(parts[parts.index("site-packages") + 1 :])
    return "/".join(parts[-2:])


def run(cases: dict[str, tuple[Callable[[], Step], int]]) -> dict[str, dict]:
    """Profile every ``name -> (builder, calls)``; errors are reported, not raised."""
    out = {}
    for name, (build, calls) in cases.items():
        try:
            out[name] = profile(build(), calls)
        except Missing as e:
            out[name] = {"error": f"missing: {e}"}
        except Exception as e:
            out[name] = {"error": f"{type(e).__name__}: {e}"}
    return out
