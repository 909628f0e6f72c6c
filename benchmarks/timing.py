"""Timing primitives shared by the benchmarks: the measuring loop, side-by-side repeats, fits,
and a description of the machine.

Every benchmark is a set of *contestants* (ours and the peers) measured on one configuration.
A contestant is built once (set-up is never timed) and gives a ``step()`` callable that does one
unit of work and returns how many robot-steps (or robot-decisions) it did. The contestants of a
configuration are measured in turn, repeat after repeat (ours, peer, ours, peer, ...), so a
change of load on the shared machine hits all of them alike; the reported rate is the median
over repeats.

Rates are per CPU second of the benchmark process (``time.process_time``), not per wall
second: the machine is shared with other jobs, and CPU time does not count the time the
process waits for a core. Everything measured runs on one thread (numpy, numba kernels,
RVO2, torch set to one thread), so CPU time is the work done. Wall-clock rates are kept too
(``wall_rates``), and their ratio to the CPU rates is the share of a core the process got.
"""

from __future__ import annotations

import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata

import numpy as np

from vcs_env.files import write_text

Step = Callable[[], "int | tuple[int, float]"]
"""One unit of work. Returns the robot-steps (or decisions) done, or ``(units, seconds)`` when
it times the part that counts itself (for lower bounds that exclude untimed restore work)."""


@dataclass
class Budget:
    """How long one measurement runs."""

    warmup: int = 2
    """Untimed calls before timing (JIT loading, caches, first allocation)."""
    min_time: float = 0.3
    """A measurement runs at least this long [s of wall time] ..."""
    min_calls: int = 3
    """... and at least this many calls."""
    repeats: int = 3
    """Measurements per contestant; the median is reported."""


@dataclass
class Result:
    """Outcome of one contestant on one configuration."""

    status: str = "ok"
    """``ok``, ``missing: <reason>`` (the peer cannot be imported) or ``error: <reason>``."""
    rates: list[float] = field(default_factory=list)
    """Units per CPU second [1/s] of every repeat."""
    wall_rates: list[float] = field(default_factory=list)
    """Units per wall-clock second [1/s] of every repeat."""
    calls: list[int] = field(default_factory=list)
    """Timed calls of every repeat."""

    @property
    def ok(self) -> bool:
        return self.status == "ok" and bool(self.rates)

    @property
    def rate(self) -> float:
        """Median units per second [1/s] (NaN if not measured)."""
        return statistics.median(self.rates) if self.ok else float("nan")

    def as_dict(self) -> dict:
        return {
            "status": self.status,
            "median_rate": self.rate,
            "rates": self.rates,
            "wall_rates": self.wall_rates,
            "calls": self.calls,
        }


def measure(step: Step, budget: Budget) -> tuple[float, float, int]:
    """Units per CPU second and per wall second [1/s] of ``step``, and the timed calls."""
    for _ in range(budget.warmup):
        step()
    units, self_timed, calls = 0, 0.0, 0
    c0, t0 = time.process_time(), time.perf_counter()
    while True:
        out = step()
        calls += 1
        if isinstance(out, tuple):
            units += out[0]
            self_timed += out[1]
        else:
            units += out
        wall = time.perf_counter() - t0
        if calls >= budget.min_calls and wall >= budget.min_time:
            break
    cpu = time.process_time() - c0
    if self_timed > 0:  # the step timed only the part that counts
        wall = cpu = self_timed
    return units / max(cpu, 1e-9), units / max(wall, 1e-9), calls


def side_by_side(builders: dict[str, Callable[[], Step]], budget: Budget) -> dict[str, Result]:
    """Build every contestant, then measure them in turn for ``budget.repeats`` rounds.

    A builder raises :class:`Missing` when its peer is not installed, any other exception
    marks the contestant as ``error`` (with the message); both are reported, never skipped.
    """
    results: dict[str, Result] = {}
    steps: dict[str, Step] = {}
    for name, build in builders.items():
        try:
            steps[name] = build()
            results[name] = Result()
        except Missing as e:
            results[name] = Result(status=f"missing: {e}")
        except Exception as e:  # a peer that breaks is a result too
            results[name] = Result(status=f"error: {type(e).__name__}: {e}")
    for _ in range(budget.repeats):
        for name, step in steps.items():
            if results[name].status != "ok":
                continue
            try:
                rate, wall_rate, calls = measure(step, budget)
            except Exception as e:
                results[name].status = f"error: {type(e).__name__}: {e}"
                continue
            results[name].rates.append(rate)
            results[name].wall_rates.append(wall_rate)
            results[name].calls.append(calls)
    return results


class Missing(Exception):
    """A peer package cannot be imported (the message says why)."""


def fit_exponent(x, y) -> float:
    """Least-squares slope of ``log y`` against ``log x`` (``y ~ x^p``); NaN with < 2 points."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])


def ratio(a: float, b: float) -> float:
    """``a / b`` or NaN."""
    if not (math.isfinite(a) and math.isfinite(b)) or b == 0:
        return float("nan")
    return a / b


PACKAGES = (
    "vcs-env",
    "numpy",
    "numba",
    "gymnasium",
    "pettingzoo",
    "torch",
    "stable-baselines3",
    "mpe2",
    "vmas",
    "pyrvo",
    "pygame",
)


def machine_info() -> dict:
    """CPU model and cores, OS, Python and package versions, load average."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return {
        "cpu": cpu,
        "logical_cores": os.cpu_count(),
        "usable_cores": usable,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "packages": versions,
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
    }


def write_report(out, text: str, res: dict) -> None:
    """Print a benchmark's Markdown ``text`` and write it to ``out`` (a Path), its numbers ``res`` as JSON
    beside it (``out`` with suffix ``.json``)."""
    import json

    print(text)
    write_text(out, text)
    write_text(out.with_suffix(".json"), json.dumps(res, indent=1, default=str) + "\n")
    print(f"wrote {out} and {out.with_suffix('.json')}")
