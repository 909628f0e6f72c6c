"""The report of a :class:`~agents.evaluate.Comparison`: a markdown table, a JSON file and bar
charts, one per metric that :data:`vcs_env.metrics.METRICS` marks as a table column or plotted."""

from __future__ import annotations

import datetime
import json
import math
import os
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from vcs_env import metrics
from vcs_env.checks import install_hint
from vcs_env.files import write_text
from vcs_env.metrics import OUTCOMES, Metric

from . import EXTRA_TIME_PERCENTILES, Comparison


def table_metrics() -> list[Metric]:
    """Metrics of the comparison table and the ``evaluate`` summary, in order (:attr:`Metric.table`)."""
    return [m for m in metrics.METRICS if m.table]


def format_stat(stat: Mapping[str, float], rate: bool, digits: int = 2) -> str:
    """``0.95 [0.89, 0.98]`` for a rate, ``12.30 ± 0.41`` for a mean (``0.87 [0.67, 1.00]`` where the metric's
    range cuts its interval; ``5.92`` alone from one episode), ``-`` when undefined."""
    m = stat.get("mean", math.nan)
    if stat.get("n", 0) == 0 or not math.isfinite(m):
        return "-"
    lo, hi = stat.get("low", math.nan), stat.get("high", math.nan)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{m:.{digits}f}"
    if rate or abs((hi - m) - (m - lo)) > 1e-9 * max(1.0, abs(m)):
        return f"{m:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"
    return f"{m:.{digits}f} ± {hi - m:.{digits}f}"


def table_lines(comparison: Comparison) -> list[str]:
    """The markdown table of a comparison, one row per policy (columns :func:`table_metrics`, then
    ms/decision)."""
    columns = table_metrics()
    head = ["policy"] + [m.label for m in columns] + ["ms/decision"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, summ in comparison.summaries.items():
        cells = [name] + [format_stat(summ.get(m.name, {}), m.rate) for m in columns]
        cells.append(f"{1e3 * comparison.results[name].seconds_per_decision:.3f}")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def markdown_table(comparison: Comparison, provenance: str | None = None) -> str:
    """The comparison as a markdown document: title, the command, machine and date that made it (``provenance``),
    table, legend, extra-time percentiles."""
    lines = table_lines(comparison)
    s = comparison.suite
    n_all, n_solved = s.n_episodes, int(comparison.solved_by_all.sum())
    pct_head = " | ".join(f"p{q}" for q in EXTRA_TIME_PERCENTILES)
    if n_solved == 0:
        never = [k for k, r in comparison.results.items() if not r.solved.any()]
        hint = f" ({', '.join(never)} solved none: leave it out to compare times)" if never else ""
        lines += ["", f"No episode was solved by every policy, so there are no time or path statistics{hint}."]
    pct_rows = [
        f"| {name} | " + " | ".join(fmt(p[f"p{q}"]) for q in EXTRA_TIME_PERCENTILES) + " |"
        for name, p in comparison.extra_time_percentiles.items()
    ]
    return "\n".join(
        [
            f"# {s.name}",
            "",
            f"{s.description}. {n_all} episodes (seeds {s.seeds[0]}..{s.seeds[-1]}), suite fingerprint "
            f"`{s.fingerprint}`.",
            *(["", provenance] if provenance else []),
            "",
            *lines,
            "",
            f"Rates over all {n_all} episodes with 95 % Wilson intervals; collision = any contact, split into "
            "robot-robot and robot-obstacle (an episode can have both). Time to goal, extra time (over the "
            f"straight line at v_max) and path ratio over the {n_solved} episodes every policy solved; the other "
            "means over all episodes where defined, ± the 95 % half-width (Student's t; [low, high] where the "
            "metric's range cuts it; none from one episode). Min separation is the smallest "
            "surface gap (negative = overlap). ms/decision = policy compute time per active robot per step.",
            *shield_lines({name: res.shield for name, res in comparison.results.items()}),
            "",
            f"Extra time [s] percentiles over the {n_solved} episodes every policy solved:",
            "",
            f"| policy | {pct_head} |",
            "|---|" + "---|" * len(EXTRA_TIME_PERCENTILES),
            *pct_rows,
            "",
        ]
    )


def shield_lines(shields: Mapping[str, dict[str, float] | None]) -> list[str]:
    """A note per policy that ran with a safety shield (``{name: parameters or None}``, :mod:`agents.shield`)."""
    return [f"{name} ran with its safety shield: {describe_shield(p)}." for name, p in shields.items() if p]


def describe_shield(shield: dict[str, float]) -> str:
    """``horizon 1.5 s, margin 0.1 m, robots at most 0.05 m/s`` (and ``, still bodies 0.02 m`` with a still margin,
    ``, no closer to driving robots`` with the driving guard, ``, the policy's turn kept first`` with ``keep_turn``,
    ``, still bodies also along braking`` with ``brake_backup``, ``, counted robots standing`` with ``robots_stand``,
    ``, room to stop short of driving robots`` with ``driving_stop``)."""
    text = f"horizon {shield['horizon']:g} s, margin {shield['margin']:g} m"
    text += f", robots at most {shield['robot_speed']:g} m/s"
    still = shield.get("still_margin")
    text = text if still is None else f"{text}, still bodies {still:g} m"
    text = f"{text}, no closer to driving robots" if shield.get("driving_guard") else text
    text = f"{text}, the policy's turn kept first" if shield.get("keep_turn") else text
    text = f"{text}, still bodies also along braking" if shield.get("brake_backup") else text
    text = f"{text}, counted robots standing" if shield.get("robots_stand") else text
    return f"{text}, room to stop short of driving robots" if shield.get("driving_stop") else text


def fmt(x: float, spec: str = ".2f") -> str:
    """``x`` formatted, or ``-`` if it is not finite."""
    return "-" if not math.isfinite(x) else format(x, spec)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "policy"


TIME_BAR = "ms_per_decision"
"""The bar chart of compute time beside the metrics' (``bar_ms_per_decision.png``)."""


def write_plots(comparison: Comparison, out_dir: str | os.PathLike, episode: int | None = None) -> list[Path]:
    """Bar charts (one per metric with :attr:`~vcs_env.metrics.Metric.plot`, and ms/decision) and, if ``episode``
    is given and kept, one trajectory plot of that episode per policy.

    Figures are drawn without pyplot, so the caller's matplotlib backend (e.g. a notebook's
    inline one) is left alone and nothing needs a display.

    Returns:
        The written PNG files.
    """
    try:
        from matplotlib.figure import Figure
    except ImportError as e:
        raise ImportError(f"plots need matplotlib; install it with: {install_hint('render')} ({e})") from None
    from vcs_env.render import plot_trajectories

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = list(comparison.results)
    written = []

    def bar(key: str, label: str, means, err=None, unit_range: bool = False) -> None:
        fig = Figure(figsize=(max(3.0, 0.9 * len(names) + 1.5), 3.2))
        ax = fig.subplots()
        ax.bar(range(len(names)), np.nan_to_num(means), yerr=err, capsize=4, color="tab:blue", alpha=0.8)
        for i in np.flatnonzero(~np.isfinite(np.asarray(means, dtype=float))):  # undefined: no bar, not a 0
            ax.annotate("n/a", (i, 0), ha="center", va="bottom", fontsize=8, color="0.4")
        ax.set_xticks(
            range(len(names)), names, rotation=30 if len(names) > 4 else 0, ha="right" if len(names) > 4 else "center"
        )
        ax.set_ylabel(label)
        ax.set_title(f"{comparison.suite.name}: {label}", fontsize=9)
        if unit_range:
            ax.set_ylim(0, 1.05)
        path = out / f"bar_{key}.png"
        fig.savefig(path, dpi=100, bbox_inches="tight")
        written.append(path)

    for metric in (m for m in metrics.METRICS if m.plot):
        stats = [comparison.summaries[k].get(metric.name, {}) for k in names]
        err = np.array(
            [
                [max(0.0, s.get("mean", 0) - s.get("low", 0)), max(0.0, s.get("high", 0) - s.get("mean", 0))]
                if s.get("n", 0)
                else [0.0, 0.0]
                for s in stats
            ]
        ).T
        label = metric.label + (" (solved by all)" if metric.solved_only else "")
        means = [s.get("mean", math.nan) for s in stats]
        bar(metric.name, label, means, np.nan_to_num(err), unit_range=metric.rate)
    bar(TIME_BAR, "ms per robot decision", [1e3 * comparison.results[k].seconds_per_decision for k in names])
    if episode is not None:
        seed = comparison.suite.seeds[episode]
        for name, res in comparison.results.items():
            ep = res.episodes.get(episode)
            if ep is None:
                continue
            row = res.rows[episode]
            outcome = next(k for k in OUTCOMES if row[k] == 1.0)
            fig = Figure(figsize=(6, 6))
            plot_trajectories(
                ep.pos,
                ep.goal,
                ep.radius,
                ep.obs_pos,
                ep.obs_radius,
                ax=fig.subplots(),
                title=f"{name}: {comparison.suite.name} episode {episode} (seed {seed}), {outcome}",
            )
            path = out / f"trajectory_{_safe(name)}_ep{episode}.png"
            fig.savefig(path, dpi=100, bbox_inches="tight")
            written.append(path)
    return written


PLOT_FILES = re.compile(r"bar_[a-z0-9_]+\.png|trajectory_.+_ep[0-9]+\.png")
"""The names of the plots a report writes (:func:`write_plots`): ``bar_<metric>.png``,
``trajectory_<policy>_ep<k>.png``."""


def earlier_plots(out: Path) -> list[Path]:
    """The plots of an earlier report in ``out`` (:data:`PLOT_FILES`, for a known metric's bars): none unless ``out``
    holds its ``results.json``; other files are the user's."""
    if not (out / "results.json").is_file():
        return []
    bars = {m.name for m in metrics.METRICS if m.plot} | {TIME_BAR}  # the bars write_plots draws
    return sorted(
        p
        for p in out.glob("*.png")
        if PLOT_FILES.fullmatch(p.name) and (not p.name.startswith("bar_") or p.name[4:-4] in bars)
    )


def write_report(
    comparison: Comparison,
    out_dir: str | os.PathLike,
    episode: int | None = 0,
    plots: bool = True,
    provenance: str | None = None,
) -> list[Path]:
    """Write ``results.md``, ``results.json`` and (``plots``) the PNGs into ``out_dir``; the plots of an earlier report
    there (:func:`earlier_plots`: ``bar_<metric>.png``, ``trajectory_<policy>_ep<k>.png`` beside its ``results.json``)
    go first, so that every file of the report is of this comparison; any other file is left alone.
    ``provenance``: the command, machine and date that made it (``vcs-env compare`` gives :func:`provenance`), a line
    of ``results.md`` and the JSON's ``"provenance"``.

    Returns:
        The written files.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for old in earlier_plots(out):
        old.unlink()
    md, js = out / "results.md", out / "results.json"
    write_text(md, markdown_table(comparison, provenance))
    write_text(js, results_json({**({"provenance": provenance} if provenance else {}), **comparison.to_dict()}))
    written = [md, js]
    if plots:
        written += write_plots(comparison, out, episode)
    return written


def provenance(command: str, machine: dict) -> str:
    """``command`` (a shell line) with the date and ``machine`` (:func:`benchmarks.timing.machine_info`: ``cpu``,
    ``usable_cores``, ``load_average``, and ``python`` and ``packages``: the versions a rerun matches), as a report
    records it."""
    load = ", ".join(f"{x:.1f}" for x in machine.get("load_average") or ())
    packages = machine.get("packages") or {}
    versions = "".join(
        f", {name} {packages[name]}"
        for name in ("vcs-env", "numpy", "numba", "torch")
        if packages.get(name, "not installed") != "not installed"
    )
    return (
        f"`{command}` ({datetime.date.today().isoformat()}, {machine['cpu']}, {machine['usable_cores']} cores, load "
        f"average {load}; Python {machine.get('python', '?')}{versions})"
    )


def _rounded(x, digits: int = 6):
    """``x`` with every float rounded to ``digits`` significant digits (metrics, not state: 1e-6 relative
    is far below any difference a table shows), recursively through dicts and lists."""
    if isinstance(x, float):
        return float(f"{x:.{digits}g}")
    if isinstance(x, dict):
        return {k: _rounded(v, digits) for k, v in x.items()}
    if isinstance(x, list):
        return [_rounded(v, digits) for v in x]
    return x


def results_json(data: dict) -> str:
    """``results.json`` text: indented, floats to 6 significant digits, and each policy's episodes as a
    table, ``{"columns": [metric, ...], "rows": [[value, ...], ...]}`` with one line per episode (a
    500-episode suite of three policies stays a few hundred kB)."""
    data = _rounded(data)
    tables = {}
    for name, result in data.get("policies", {}).items():
        episodes = result.get("episodes", [])
        columns = list(episodes[0]) if episodes else []
        key = f"@episodes:{name}@"
        rows = ",\n".join("    " + json.dumps([ep.get(c) for c in columns], allow_nan=False) for ep in episodes)
        tables[key] = f'{{\n   "columns": {json.dumps(columns)},\n   "rows": [\n{rows}\n   ]\n  }}'
        result["episodes"] = key
    text = json.dumps(data, indent=1, allow_nan=False)
    for key, table in tables.items():
        text = text.replace(json.dumps(key), table)
    return text + "\n"
