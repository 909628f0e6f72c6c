"""Score planners and learned policies on the named suites (:mod:`vcs_env.suites`).

One harness for every kind of policy:

* a planner name from ``baselines.PLANNERS`` (``"vcs"``, ``"straight"``, ...), or a
  :class:`~vcs_env.planning.Planner` instance: it sees the privileged world state;
* any object with the SB3 ``PolicyPredictor`` method
  ``predict(observation, state=None, episode_start=None, deterministic=False) -> (actions, state)``:
  it sees per-robot observations; each step it is called once with the observations of all
  robots of all worlds stacked, ``(B * n, D)``, and returns ``(B * n, 2)`` actions (rows of robots
  that are not active are ignored);
* the path of a stable-baselines3 PPO checkpoint (``.zip``), loaded on the CPU.

:func:`evaluate` runs a suite through :func:`vcs_env.rollout.run_episodes` (many worlds per call)
and returns per-episode metric rows (:func:`vcs_env.metrics.episode_metrics`), their aggregate
and the compute time per robot decision. :func:`compare` evaluates several policies on the same
episodes and, as gym-collision-avoidance does, takes time and path statistics only over the
episodes *every* policy solved, so a cautious policy that fails the hard cases is not rewarded
with a short mean time.

Command line (registered in :data:`vcs_env.cli.COMMAND_MODULES`)::

    vcs-env evaluate --suite circle-16-v0 --policy vcs --json out.json
    vcs-env compare --suite crowd-5-v0 --policies vcs,straight,runs/ppo/model.zip --out results/

This module imports neither torch nor stable-baselines3 at import time; loading a checkpoint
does, inside :func:`load_checkpoint` (through :func:`agents.checkpoint.load_model`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.metrics import RATE_METRICS, aggregate, episode_metrics
from vcs_env.planning import Planner, make_planner
from vcs_env.rollout import Controller, Episode, planner_controller, run_episodes
from vcs_env.scenario import Scenario
from vcs_env.state import WorldState
from vcs_env.suites import Suite, get_suite, suite_names

from .checkpoint import check_observation_space, jsonable, load_model

DEFAULT_BATCH = 25
"""Worlds stepped together. Smaller batches waste less time on worlds that already ended
(they idle until the slowest one of their batch ends) and update the progress bar more often;
larger ones amortize the per-step Python overhead."""

TABLE_COLUMNS: tuple[tuple[str, str], ...] = (
    ("success", "success"),
    ("collision", "collision"),
    ("robot_collision", "robot-robot"),
    ("obstacle_collision", "robot-obstacle"),
    ("timeout", "timeout"),
    ("deadlock", "deadlock"),
    ("time_to_goal", "time to goal [s]"),
    ("extra_time", "extra time [s]"),
    ("path_ratio", "path ratio"),
    ("min_separation", "min separation [m]"),
    ("heading_change", "heading change [rad]"),
    ("speed_reversals", "speed reversals"),
    ("jerk", "jerk [m/s^3]"),
)
"""(metric, column header) of the comparison table, in order; ms/decision is appended."""

SOLVED_ONLY = ("time_to_goal", "makespan", "extra_time", "path_length", "path_ratio")
"""Metrics :func:`vcs_env.metrics.aggregate` restricts to the ``solved_mask`` episodes."""

EXTRA_TIME_PERCENTILES = (50, 75, 90)


# --------------------------------------------------------------------------- policies
@dataclass
class ResolvedPolicy:
    """A policy made ready to drive :func:`~vcs_env.rollout.run_episodes`."""

    name: str
    """Display name (planner name, checkpoint file stem, class name)."""
    controller: Controller
    """``controller(world, obs (B, n, D)) -> actions (B, n, 2)``."""
    kind: str
    """``planner``, ``predictor`` or ``checkpoint``."""


def is_checkpoint_spec(spec: Any) -> bool:
    """True if ``spec`` names a file rather than a registered planner: a path object, a string
    ending in ``.zip`` or holding a path separator, or any other string that is not a
    registered planner name but an existing file (with or without ``.zip``)."""
    if isinstance(spec, os.PathLike):
        return True
    if not isinstance(spec, str):
        return False
    if spec.endswith(".zip") or "/" in spec or os.sep in spec:
        return True
    from baselines import PLANNERS  # lazy, like vcs_env.planning.make_planner

    return spec not in PLANNERS and (os.path.isfile(spec) or os.path.isfile(spec + ".zip"))


def _check_action_space(space: Any, what: str) -> None:
    shape = getattr(space, "shape", None)
    if shape is not None and tuple(shape) != (2,):
        raise ValueError(f"{what} produces actions of shape {tuple(shape)}, the env needs (2,)")


def load_checkpoint(path: str | os.PathLike, scenario: Scenario):
    """Load a stable-baselines3 PPO checkpoint on the CPU and check it fits ``scenario``.

    Args:
        path: the ``.zip`` file (the suffix may be left out) or a run directory with ``model.zip``.
        scenario: the scenario whose observation space the model must take.

    Returns:
        The loaded ``stable_baselines3.PPO`` model (a ``PolicyPredictor``).

    Raises:
        agents.checkpoint.CheckpointError: (a ``ValueError``) the file is missing, corrupt or not
            a PPO checkpoint, or its spaces do not fit.
        ImportError: stable-baselines3 is not installed.
    """
    try:
        import stable_baselines3  # noqa: F401
    except ImportError as e:
        raise ImportError(
            f"loading the checkpoint {str(path)!r} needs stable-baselines3; install it with: "
            f"pip install 'vcs-env[train]' ({e})"
        ) from None
    model = load_model(path, scenario)
    _check_action_space(model.action_space, f"checkpoint {str(path)!r}")
    return model


def predictor_controller(predictor: Any, deterministic: bool = True, name: str = "policy") -> Controller:
    """A controller from an SB3-style ``PolicyPredictor``.

    Each call stacks the observations ``(B, n, D)`` into ``(B * n, D)``, calls ``predict`` once
    and reshapes the actions back to ``(B, n, 2)``. A recurrent state is threaded through the
    calls of one batch of episodes and reset (``episode_start``) when a new batch starts.
    Actions of robots that are not active are replaced by zeros (the simulator ignores them).
    """
    state = None

    def control(world: WorldState, obs: np.ndarray) -> np.ndarray:
        nonlocal state
        B, n, D = obs.shape
        starts = np.repeat(np.asarray(world.steps) == 0, n)
        if starts.all():
            state = None
        actions, state = predictor.predict(
            obs.reshape(B * n, D), state=state, episode_start=starts, deterministic=deterministic
        )
        actions = np.asarray(actions, dtype=np.float64)
        if actions.shape not in ((B * n, 2), (B, n, 2)):
            raise ValueError(
                f"policy {name!r} returned actions of shape {actions.shape} for observations of shape "
                f"{(B * n, D)}; expected {(B * n, 2)}"
            )
        return np.where(world.active[..., None], actions.reshape(B, n, 2), 0.0)

    return control


def resolve_policy(
    policy: Any, scenario: Scenario, action_mode: str = "delta", deterministic: bool = True, name: str | None = None
) -> ResolvedPolicy:
    """Turn a planner name, :class:`Planner`, ``PolicyPredictor`` or checkpoint path into a controller.

    Raises:
        ValueError: unknown planner name, bad checkpoint, observation space mismatch, or an
            object that is none of the accepted kinds.
        ImportError: a planner or checkpoint needs an optional extra that is not installed.
    """
    if isinstance(policy, Planner):
        return ResolvedPolicy(name or policy.name, planner_controller(policy, action_mode), "planner")
    if is_checkpoint_spec(policy):
        model = load_checkpoint(policy, scenario)
        label = name or Path(policy).stem
        return ResolvedPolicy(label, predictor_controller(model, deterministic, label), "checkpoint")
    if isinstance(policy, str):
        planner = make_planner(policy)
        return ResolvedPolicy(name or policy, planner_controller(planner, action_mode), "planner")
    if callable(getattr(policy, "predict", None)):
        label = name or getattr(policy, "name", None) or type(policy).__name__
        if getattr(policy, "observation_space", None) is not None:
            check_observation_space(policy.observation_space, scenario, f"policy {label!r}")
        return ResolvedPolicy(str(label), predictor_controller(policy, deterministic, str(label)), "predictor")
    raise ValueError(
        "a policy must be a planner name, a vcs_env.planning.Planner, an object with an SB3-style "
        f"predict(observation, state, episode_start, deterministic) method, or a checkpoint path; got "
        f"{type(policy).__name__}"
    )


# --------------------------------------------------------------------------- progress
class _Progress:
    """tqdm when installed (the ``train`` extra), else a one-line counter on stderr."""

    def __init__(self, total: int, desc: str, enabled: bool):
        self.total, self.desc, self.enabled, self.count = total, desc, enabled, 0
        self.bar = None
        if enabled:
            try:
                from tqdm.auto import tqdm
            except ImportError:
                tqdm = None
            if tqdm is not None:
                self.bar = tqdm(total=total, desc=desc, unit="ep", leave=False, file=sys.stderr)

    def update(self, k: int) -> None:
        self.count += k
        if self.bar is not None:
            self.bar.update(k)
        elif self.enabled:
            print(f"\r{self.desc}: {self.count}/{self.total} episodes", end="", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.enabled:
            print(file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- evaluate
@dataclass
class EvalResult:
    """One policy on one suite."""

    policy: str
    """Display name."""
    suite: Suite
    rows: list[dict[str, float]]
    """Per-episode metrics (:func:`~vcs_env.metrics.episode_metrics`), in the order of ``suite.seeds``."""
    summary: dict[str, dict[str, float]]
    """:func:`~vcs_env.metrics.aggregate` of ``rows`` over all episodes."""
    compute_time: float
    """Controller wall time summed over the suite [s]."""
    decisions: int
    """Robot decisions made (active robot-steps)."""
    wall_time: float
    """Wall time of the whole evaluation, simulation included [s]."""
    episodes: dict[int, Episode] = field(default_factory=dict)
    """Recorded episodes kept on request, by index into ``suite.seeds``."""

    @property
    def seconds_per_decision(self) -> float:
        """Controller time per robot decision [s]."""
        return self.compute_time / max(self.decisions, 1)

    @property
    def solved(self) -> np.ndarray:
        """``(E,)`` bool: episodes counted as a success."""
        return np.array([r["success"] == 1.0 for r in self.rows], dtype=bool)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (NaN becomes None)."""
        return jsonable(
            {
                "policy": self.policy,
                "suite": self.suite.name,
                "fingerprint": self.suite.fingerprint,
                "ms_per_decision": 1e3 * self.seconds_per_decision,
                "decisions": self.decisions,
                "wall_time": self.wall_time,
                "summary": self.summary,
                "episodes": [{"seed": s, **r} for s, r in zip(self.suite.seeds, self.rows)],
            }
        )


def evaluate(
    policy: Any,
    suite: str | Suite,
    *,
    name: str | None = None,
    action_mode: str = "delta",
    deterministic: bool = True,
    batch_size: int = DEFAULT_BATCH,
    keep_episodes: Sequence[int] = (),
    progress: bool | None = None,
) -> EvalResult:
    """Run every episode of ``suite`` with ``policy`` and measure it.

    Args:
        policy: planner name, :class:`~vcs_env.planning.Planner`, ``PolicyPredictor`` object or
            SB3 checkpoint path (module docstring).
        suite: suite name or :class:`~vcs_env.suites.Suite`.
        name: display name (default: derived from ``policy``).
        action_mode: action units of the policy (``delta`` or ``absolute``; planners adapt).
        deterministic: passed to ``predict``.
        batch_size: worlds stepped together (see :data:`DEFAULT_BATCH`).
        keep_episodes: indices into ``suite.seeds`` whose recorded episodes to keep (for plots).
        progress: show a progress bar; None shows one when stderr is a terminal.

    Returns:
        The per-episode rows, their aggregate and the timing.
    """
    suite = get_suite(suite)
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    keep = {int(k) for k in keep_episodes}
    bad = [k for k in keep if not 0 <= k < suite.n_episodes]
    if bad:
        raise ValueError(f"episode indices {bad} are out of range for {suite.name} (0..{suite.n_episodes - 1})")
    resolved = resolve_policy(policy, suite.scenario, action_mode, deterministic, name)
    show = sys.stderr.isatty() if progress is None else bool(progress)
    bar = _Progress(suite.n_episodes, f"{resolved.name} on {suite.name}", show)
    rows: list[dict[str, float]] = []
    kept: dict[int, Episode] = {}
    compute, decisions = 0.0, 0
    # Warm-up (JIT compilation, cache loading, lazy imports) so it does not count as decision time.
    run_episodes(suite.scenario, resolved.controller, suite.seeds[:1], action_mode=action_mode, max_steps=2)
    t0 = time.perf_counter()
    try:
        for start in range(0, suite.n_episodes, batch_size):
            seeds = suite.seeds[start : start + batch_size]
            episodes = run_episodes(suite.scenario, resolved.controller, seeds, action_mode=action_mode)
            for i, ep in enumerate(episodes, start):
                rows.append(episode_metrics(ep))
                compute += ep.compute_time
                decisions += ep.decisions
                if i in keep:
                    kept[i] = ep
            bar.update(len(seeds))
    finally:
        bar.close()
    return EvalResult(
        policy=resolved.name,
        suite=suite,
        rows=rows,
        summary=aggregate(rows),
        compute_time=compute,
        decisions=decisions,
        wall_time=time.perf_counter() - t0,
        episodes=kept,
    )


# --------------------------------------------------------------------------- compare
@dataclass
class Comparison:
    """Several policies on the same episodes of one suite."""

    suite: Suite
    results: dict[str, EvalResult]
    """Per policy, by display name, in the given order."""
    solved_by_all: np.ndarray
    """``(E,)`` bool: episodes every policy solved."""
    summaries: dict[str, dict[str, dict[str, float]]]
    """Per policy: aggregate with time and path metrics over ``solved_by_all`` only."""
    extra_time_percentiles: dict[str, dict[str, float]]
    """Per policy: p50/p75/p90 of the episodes' mean extra time over ``solved_by_all`` [s]."""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (NaN becomes None)."""
        return jsonable(
            {
                "suite": self.suite.name,
                "fingerprint": self.suite.fingerprint,
                "description": self.suite.description,
                "scenario": dataclasses.asdict(self.suite.scenario),
                "seeds": list(self.suite.seeds),
                "solved_by_all": self.solved_by_all.tolist(),
                "n_solved_by_all": int(self.solved_by_all.sum()),
                "policies": {
                    name: {
                        "summary_solved_by_all": self.summaries[name],
                        "extra_time_percentiles": self.extra_time_percentiles[name],
                        **res.to_dict(),
                    }
                    for name, res in self.results.items()
                },
            }
        )


def _named(policies: Sequence[Any] | Mapping[str, Any]) -> list[tuple[str | None, Any]]:
    if isinstance(policies, Mapping):
        return [(str(k), v) for k, v in policies.items()]
    if isinstance(policies, (str, os.PathLike)):
        return [(None, policies)]
    return [(None, p) for p in policies]


def compare(policies: Sequence[Any] | Mapping[str, Any], suite: str | Suite, **kwargs) -> Comparison:
    """Evaluate each policy on the same episodes of ``suite``.

    Args:
        policies: a sequence of policies (anything :func:`evaluate` takes) or ``{name: policy}``.
        suite: suite name or :class:`~vcs_env.suites.Suite`.
        **kwargs: passed to :func:`evaluate` (``action_mode``, ``batch_size``, ``keep_episodes``, ...).

    Returns:
        The results, with time and path statistics over the episodes every policy solved.

    Raises:
        ValueError: no policies, or two policies with the same display name.
    """
    suite = get_suite(suite)
    named = _named(policies)
    if not named:
        raise ValueError("compare needs at least one policy")
    names = [label or p for label, p in named if isinstance(label or p, str)]
    if len(set(names)) != len(names):  # fail before spending time on the first ones
        raise ValueError(f"policies must have distinct names, got {names}; pass a {{name: policy}} mapping")
    results: dict[str, EvalResult] = {}
    for label, policy in named:
        res = evaluate(policy, suite, name=label, **kwargs)
        if res.policy in results:
            raise ValueError(f"two policies are named {res.policy!r}; pass a {{name: policy}} mapping")
        results[res.policy] = res
    solved = np.logical_and.reduce([r.solved for r in results.values()])
    summaries = {k: aggregate(r.rows, solved_mask=solved) for k, r in results.items()}
    pct = {}
    for k, r in results.items():
        extra = np.array([row["extra_time"] for row in r.rows])[solved]
        extra = extra[np.isfinite(extra)]
        pct[k] = {f"p{q}": float(np.percentile(extra, q)) if extra.size else math.nan for q in EXTRA_TIME_PERCENTILES}
    return Comparison(suite, results, solved, summaries, pct)


# --------------------------------------------------------------------------- reports
def format_stat(stat: Mapping[str, float], rate: bool, digits: int = 2) -> str:
    """``0.95 [0.89, 0.98]`` for a rate, ``12.30 ± 0.41`` for a mean, ``-`` when undefined."""
    m = stat.get("mean", math.nan)
    if stat.get("n", 0) == 0 or not math.isfinite(m):
        return "-"
    if rate:
        return f"{m:.{digits}f} [{stat['low']:.{digits}f}, {stat['high']:.{digits}f}]"
    return f"{m:.{digits}f} ± {stat['high'] - m:.{digits}f}"


def table_lines(comparison: Comparison) -> list[str]:
    """The markdown table of a comparison, one row per policy (columns :data:`TABLE_COLUMNS`)."""
    head = ["policy"] + [h for _, h in TABLE_COLUMNS] + ["ms/decision"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, summ in comparison.summaries.items():
        cells = [name] + [format_stat(summ.get(k, {}), k in RATE_METRICS) for k, _ in TABLE_COLUMNS]
        cells.append(f"{1e3 * comparison.results[name].seconds_per_decision:.3f}")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def markdown_table(comparison: Comparison) -> str:
    """The comparison as a markdown document: title, table, legend, extra-time percentiles."""
    lines = table_lines(comparison)
    s = comparison.suite
    n_all, n_solved = s.n_episodes, int(comparison.solved_by_all.sum())
    pct_head = " | ".join(f"p{q}" for q in EXTRA_TIME_PERCENTILES)
    if n_solved == 0:
        never = [k for k, r in comparison.results.items() if not r.solved.any()]
        hint = f" ({', '.join(never)} solved none: leave it out to compare times)" if never else ""
        lines += ["", f"No episode was solved by every policy, so there are no time or path statistics{hint}."]
    pct_rows = [
        f"| {name} | " + " | ".join(_fmt(p[f"p{q}"]) for q in EXTRA_TIME_PERCENTILES) + " |"
        for name, p in comparison.extra_time_percentiles.items()
    ]
    return "\n".join(
        [
            f"# {s.name}",
            "",
            f"{s.description}. {n_all} episodes (seeds {s.seeds[0]}..{s.seeds[-1]}), suite fingerprint "
            f"`{s.fingerprint}`.",
            "",
            *lines,
            "",
            f"Rates over all {n_all} episodes with 95 % Wilson intervals; collision = any contact, split into "
            "robot-robot and robot-obstacle (an episode can have both). Time to goal, extra time (over the "
            f"straight line at v_max) and path ratio over the {n_solved} episodes every policy solved; the other "
            "means over all episodes where defined, ± the 95 % half-width. Min separation is the smallest "
            "surface gap (negative = overlap). ms/decision = policy compute time per active robot per step.",
            "",
            f"Extra time [s] percentiles over the {n_solved} episodes every policy solved:",
            "",
            f"| policy | {pct_head} |",
            "|---|" + "---|" * len(EXTRA_TIME_PERCENTILES),
            *pct_rows,
            "",
        ]
    )


def _fmt(x: float, spec: str = ".2f") -> str:
    return "-" if not math.isfinite(x) else format(x, spec)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "policy"


PLOT_METRICS = (
    "success",
    "collision",
    "timeout",
    "deadlock",
    "time_to_goal",
    "extra_time",
    "path_ratio",
    "min_separation",
    "heading_change",
    "speed_reversals",
    "jerk",
)
"""Metrics that get a bar chart (plus ms/decision)."""


def write_plots(comparison: Comparison, out_dir: str | os.PathLike, episode: int | None = None) -> list[Path]:
    """Bar charts (one per metric of :data:`PLOT_METRICS`, and ms/decision) and, if ``episode``
    is given and kept, one trajectory plot of that episode per policy.

    Figures are drawn without pyplot, so the caller's matplotlib backend (e.g. a notebook's
    inline one) is left alone and nothing needs a display.

    Returns:
        The written PNG files.
    """
    try:
        from matplotlib.figure import Figure
    except ImportError as e:
        raise ImportError(f"plots need matplotlib; install it with: pip install 'vcs-env[render]' ({e})") from None
    from vcs_env.render import plot_trajectories

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = list(comparison.results)
    written = []
    labels = dict(TABLE_COLUMNS)
    for metric in (*PLOT_METRICS, "ms_per_decision"):
        if metric == "ms_per_decision":
            means = [1e3 * comparison.results[k].seconds_per_decision for k in names]
            err = None
            label = "ms per robot decision"
        else:
            stats = [comparison.summaries[k].get(metric, {}) for k in names]
            means = [s.get("mean", math.nan) for s in stats]
            err = np.array(
                [
                    [max(0.0, s.get("mean", 0) - s.get("low", 0)), max(0.0, s.get("high", 0) - s.get("mean", 0))]
                    if s.get("n", 0)
                    else [0.0, 0.0]
                    for s in stats
                ]
            ).T
            err = np.nan_to_num(err)
            label = labels.get(metric, metric) + (" (solved by all)" if metric in SOLVED_ONLY else "")
        fig = Figure(figsize=(max(3.0, 0.9 * len(names) + 1.5), 3.2))
        ax = fig.subplots()
        ax.bar(range(len(names)), np.nan_to_num(means), yerr=err, capsize=4, color="tab:blue", alpha=0.8)
        ax.set_xticks(
            range(len(names)), names, rotation=30 if len(names) > 4 else 0, ha="right" if len(names) > 4 else "center"
        )
        ax.set_ylabel(label)
        ax.set_title(f"{comparison.suite.name}: {label}", fontsize=9)
        if metric in RATE_METRICS:
            ax.set_ylim(0, 1.05)
        path = out / f"bar_{metric}.png"
        fig.savefig(path, dpi=100, bbox_inches="tight")
        written.append(path)
    if episode is not None:
        seed = comparison.suite.seeds[episode]
        for name, res in comparison.results.items():
            ep = res.episodes.get(episode)
            if ep is None:
                continue
            row = res.rows[episode]
            outcome = next(k for k in ("success", "collision", "deadlock", "timeout") if row[k] == 1.0)
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


def write_report(
    comparison: Comparison, out_dir: str | os.PathLike, episode: int | None = 0, plots: bool = True
) -> list[Path]:
    """Write ``results.md``, ``results.json`` and (``plots``) the PNGs into ``out_dir``.

    Returns:
        The written files.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md, js = out / "results.md", out / "results.json"
    md.write_text(markdown_table(comparison))
    js.write_text(json.dumps(comparison.to_dict(), indent=1, allow_nan=False))
    written = [md, js]
    if plots:
        written += write_plots(comparison, out, episode)
    return written


# --------------------------------------------------------------------------- CLI
def _print_summary(res: EvalResult) -> None:
    s = res.suite
    print(
        f"{res.policy} on {s.name} ({s.n_episodes} episodes, fingerprint {s.fingerprint}): "
        f"{res.wall_time:.1f} s, {1e3 * res.seconds_per_decision:.3f} ms/decision"
    )
    print(f"{'metric':<20} {'mean':>9} {'95% interval':>21} {'n':>5}")
    for key, header in TABLE_COLUMNS:
        st = res.summary.get(key)
        if st is None:
            continue
        ci = "-" if st["n"] == 0 else f"[{_fmt(st['low'], '.3f')}, {_fmt(st['high'], '.3f')}]"
        print(f"{header:<20} {_fmt(st['mean'], '.3f'):>9} {ci:>21} {st['n']:>5}")


def _error(command: str, e: Exception) -> int:
    print(f"vcs-env {command}: error: {e}", file=sys.stderr)
    return 2


def cmd_evaluate(args) -> int:
    try:
        res = evaluate(
            args.policy,
            args.suite,
            action_mode=args.action_mode,
            batch_size=args.batch_size,
            progress=False if args.no_progress else None,
        )
    except ImportError as e:  # a missing extra: a message, not a traceback (cli.main handles ValueError)
        return _error("evaluate", e)
    _print_summary(res)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        with open(args.json, "w") as f:
            json.dump(res.to_dict(), f, indent=1, allow_nan=False)
        print(f"wrote {args.json}")
    return 0


def cmd_compare(args) -> int:
    policies = [p.strip() for p in args.policies.split(",") if p.strip()]
    suite = get_suite(args.suite)
    if not 0 <= args.episode < suite.n_episodes:
        raise ValueError(f"--episode must be in 0..{suite.n_episodes - 1} for {suite.name}, got {args.episode}")
    try:
        comp = compare(
            policies,
            suite,
            action_mode=args.action_mode,
            batch_size=args.batch_size,
            keep_episodes=(args.episode,),
            progress=False if args.no_progress else None,
        )
        files = write_report(comp, args.out, episode=args.episode, plots=not args.no_plots)
    except ImportError as e:
        return _error("compare", e)
    print("\n".join(table_lines(comp)))
    print(f"wrote {len(files)} files to {args.out} (results.md, results.json{', plots' if not args.no_plots else ''})")
    return 0


def _common_args(p) -> None:
    p.add_argument(
        "--suite",
        required=True,
        help="suite name: " + ", ".join(suite_names(smoke=False)) + " (each also as NAME-smoke)",
    )
    p.add_argument(
        "--action-mode",
        choices=["delta", "absolute"],
        default="delta",
        help="action units of learned policies (planners adapt)",
    )
    p.add_argument("--batch-size", type=int, default=DEFAULT_BATCH, help="worlds stepped together")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_commands(sub) -> None:
    """Add ``evaluate`` and ``compare`` to the ``vcs-env`` subcommands."""
    p = sub.add_parser("evaluate", help="score one planner or policy on a named suite")
    _common_args(p)
    p.add_argument("--policy", required=True, help="planner name (see baselines.PLANNERS) or SB3 checkpoint .zip")
    p.add_argument("--json", default=None, help="write the summary and per-episode metrics to this JSON file")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("compare", help="score several policies on the same episodes; write a report")
    _common_args(p)
    p.add_argument("--policies", required=True, help="comma-separated planner names and/or checkpoint paths")
    p.add_argument("--out", required=True, help="output directory for results.md, results.json and plots")
    p.add_argument("--episode", type=int, default=0, help="index of the episode whose trajectories to plot")
    p.add_argument("--no-plots", action="store_true", help="skip the matplotlib plots")
    p.set_defaults(func=cmd_compare)
