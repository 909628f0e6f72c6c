"""Score planners and learned policies on the named suites (:mod:`vcs_env.suites`).

One harness for every kind of policy (:mod:`agents.policies`: planner names or objects,
SB3-style ``predict`` objects, checkpoint paths). :func:`evaluate` runs a suite through
:func:`vcs_env.rollout.run_episodes` (many worlds per call) and returns per-episode metric rows
(:data:`vcs_env.metrics.METRICS`), their aggregate and the compute time per robot decision.
:func:`compare` evaluates several policies on the same episodes and, as gym-collision-avoidance
does, takes time and path statistics only over the episodes *every* policy solved, so a cautious
policy that fails the hard cases is not rewarded with a short mean time. :func:`score_seeds` is
the quick closed-loop check that training and behaviour cloning run periodically.

This package is the evaluation layer: the harness (here), the report (markdown table, plots;
:mod:`agents.evaluate.report`), the probe table (:mod:`agents.evaluate.probes`) and checkpoint
selection (:mod:`agents.evaluate.selection`); the ``evaluate``, ``compare``, ``probe`` and
``select`` commands are :mod:`vcs_cli.evaluate`::

    vcs-env evaluate --suite circle-16-v0 --policy vcs --json out.json
    vcs-env compare --suite crowd-5-v0 --policies vcs,straight,runs/ppo/model.zip --out runs/compare

This module imports neither torch nor stable-baselines3 at import time.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vcs_env.metrics import aggregate, episode_metrics, robots_succeeded
from vcs_env.rollout import Controller, Episode, Hook, run_episodes, warm_up
from vcs_env.scenario import Scenario
from vcs_env.suites import Suite, get_suite

from ..mixture import mixture_split
from ..policies import policy_label, resolve_policy
from ..runs import jsonable

DEFAULT_BATCH = 25
"""Worlds stepped together. Smaller batches waste less time on worlds that already ended
(they idle until the slowest one of their batch ends) and update the progress bar more often;
larger ones amortize the per-step Python overhead."""

EXTRA_TIME_PERCENTILES = (50, 75, 90)


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
def solved_rows(rows: Sequence[dict[str, float]]) -> np.ndarray:
    """``(E,)`` bool: the episodes of ``rows`` (:func:`~vcs_env.metrics.episode_metrics`) counted as a success."""
    return np.array([r["success"] == 1.0 for r in rows], dtype=bool)


@dataclass
class EvalResult:
    """One policy on one suite."""

    policy: str
    """Display name."""
    suite: Suite
    rows: list[dict[str, float]]
    """Per-episode metrics (:func:`~vcs_env.metrics.episode_metrics`), in the order of ``suite.seeds``."""
    summary: dict[str, dict[str, float]]
    """:func:`~vcs_env.metrics.aggregate` of ``rows``: rates over all episodes, time and path over the episodes the
    policy solved (as :func:`compare` of this policy alone)."""
    compute_time: float
    """Controller wall time summed over the suite [s]."""
    decisions: int
    """Robot decisions made (active robot-steps)."""
    wall_time: float
    """Wall time of the whole evaluation, simulation included [s]."""
    episodes: dict[int, Episode] = field(default_factory=dict)
    """Recorded episodes kept on request, by index into ``suite.seeds``."""
    shield: dict[str, float] | None = None
    """Parameters of the safety shield the policy ran with (:mod:`agents.shield`), or None."""

    @property
    def seconds_per_decision(self) -> float:
        """Controller time per robot decision [s]."""
        return self.compute_time / max(self.decisions, 1)

    @property
    def solved(self) -> np.ndarray:
        """``(E,)`` bool: episodes counted as a success."""
        return solved_rows(self.rows)

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
                "shield": self.shield,
                "summary": self.summary,
                "episodes": [{"seed": s, **r} for s, r in zip(self.suite.seeds, self.rows)],
            }
        )


@contextlib.contextmanager
def _seeded_sampling(seed: int, deterministic: bool):
    """Draw an SB3 policy's sampled actions (torch's global generator) from ``seed``, restoring
    torch's generator state afterwards; nothing to do for deterministic actions or without torch."""
    torch = sys.modules.get("torch")
    if deterministic or torch is None:
        yield
        return
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed % 2**63)
        yield


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
    shield: bool = True,
) -> EvalResult:
    """Run every episode of ``suite`` with ``policy`` and measure it.

    Args:
        policy: planner name, :class:`~vcs_env.planning.Planner`, ``PolicyPredictor`` object or
            SB3 checkpoint path (module docstring).
        suite: suite name or :class:`~vcs_env.suites.Suite`.
        name: display name (default: derived from ``policy``).
        action_mode: action units of the policy (``delta`` or ``absolute``; planners adapt).
        deterministic: passed to ``predict``. Sampled actions (False) of an SB3 policy come from
            torch's generator seeded from the suite's first seed (torch's global state is restored
            afterwards): the same suite and ``batch_size`` give the same episodes.
        batch_size: worlds stepped together (see :data:`DEFAULT_BATCH`).
        keep_episodes: indices into ``suite.seeds`` whose recorded episodes to keep (for plots).
        progress: show a progress bar; None shows one when stderr is a terminal.
        shield: False runs a checkpoint without the shield its run record names (:mod:`agents.shield`).

    Returns:
        The per-episode rows, their aggregate and the timing.
    """
    suite = get_suite(suite)
    if isinstance(batch_size, bool) or not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
        raise ValueError(f"batch_size must be an integer >= 1, got {batch_size!r}")
    keep = {int(k) for k in keep_episodes}
    bad = [k for k in keep if not 0 <= k < suite.n_episodes]
    if bad:
        raise ValueError(f"episode indices {bad} are out of range for {suite.name} (0..{suite.n_episodes - 1})")
    resolved = resolve_policy(policy, suite.scenario, action_mode, deterministic, name, shield)
    show = sys.stderr.isatty() if progress is None else bool(progress)
    bar = _Progress(suite.n_episodes, f"{resolved.name} on {suite.name}", show)
    rows: list[dict[str, float]] = []
    kept: dict[int, Episode] = {}
    compute, decisions = 0.0, 0
    with _seeded_sampling(int(suite.seeds[0]), deterministic):
        scenario = resolved.scenario or suite.scenario  # the suite's worlds, as the policy senses them
        warm_up(scenario, resolved.controller, suite.seeds[0], action_mode)
        t0 = time.perf_counter()
        try:
            for start in range(0, suite.n_episodes, batch_size):
                seeds = suite.seeds[start : start + batch_size]
                episodes = run_episodes(scenario, resolved.controller, seeds, action_mode=action_mode)
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
        summary=aggregate(rows, solved_mask=solved_rows(rows)),
        compute_time=compute,
        decisions=decisions,
        wall_time=time.perf_counter() - t0,
        episodes=kept,
        shield=resolved.shield,
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
    names = [label or policy_label(os.fspath(p)) for label, p in named if label or isinstance(p, (str, os.PathLike))]
    if len(set(names)) != len(names):  # fail before spending time on the first ones (the names evaluate gives)
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


# --------------------------------------------------------------------------- training-time check
def scalar_results(res: dict[str, Any]) -> dict[str, float]:
    """The numbers of a :func:`score_seeds` result (without its per-robot arrays)."""
    return {k: v for k, v in res.items() if isinstance(v, (int, float))}


def score_seeds(
    controller: Controller, scenario: Scenario, seeds: Sequence[int], action_mode: str = "delta"
) -> dict[str, Any]:
    """Play one episode per seed (all worlds at once) and score robots and episodes: the quick
    closed-loop check of ``vcs-env train`` and ``vcs-env bc`` (the suites use :func:`evaluate`).

    Args:
        controller: e.g. ``agents.policies.predictor_controller(policy)`` or a planner's.
        scenario: the episode family, unchanged.
        seeds: one reset seed per episode (world).

    Returns:
        Rates over episodes (``episode_success``: the ``success`` metric, every robot arrived
        without touching anything; ``episode_collision``: some robot touched something), over
        robots (``robot_success``: :func:`vcs_env.metrics.robots_succeeded`, ``robot_collision``),
        ``time_to_goal`` (mean over robots that arrived [s]), ``return`` (mean per-robot return
        of the scenario's reward), ``episodes``, and the per-robot arrays (``success``,
        ``collision``, ``time``: ``(episodes, n)``).
    """
    returns = _Returns()
    episodes = run_episodes(scenario, controller, seeds, action_mode=action_mode, hooks=[returns])
    touched = np.array([ep.collided.any(axis=0) for ep in episodes])
    reached = np.array([ep.reached_step >= 0 for ep in episodes])
    success = robots_succeeded(reached, touched)
    ttg = np.array([np.where(ep.reached_step >= 0, ep.reached_step * ep.dt, np.nan) for ep in episodes])
    rows = [episode_metrics(ep) for ep in episodes]
    return {
        "episodes": len(episodes),
        "episode_success": float(np.mean([r["success"] for r in rows])),
        "episode_collision": float(np.mean([r["collision"] for r in rows])),
        "robot_success": float(success.mean()),
        "robot_collision": float(touched.mean()),
        "time_to_goal": float(ttg[reached].mean()) if reached.any() else math.nan,
        "return": float(returns.total.mean()),
        "success": success,
        "collision": touched,
        "time": ttg,
    }


def score_scenarios(
    controller: Controller, scenarios: Sequence[Scenario], seeds: Sequence[int], action_mode: str = "delta"
) -> dict[str, Any]:
    """:func:`score_seeds` over a mixture: episode ``j`` plays ``scenarios[j % len(scenarios)]``
    with ``seeds[j]``. Episode rates are over all episodes, robot rates and ``time_to_goal`` over
    all robots; the per-robot arrays are flattened. One scenario gives :func:`score_seeds`. Fewer seeds than
    scenarios leave the last scenarios unplayed: a ``UserWarning`` says so."""
    if len(seeds) < len(scenarios):
        warnings.warn(
            f"{len(seeds)} evaluation episodes over a mixture of {len(scenarios)} scenarios: episode j plays scenario "
            f"j % {len(scenarios)}, so the last {len(scenarios) - len(seeds)} are not scored (give at least "
            f"{len(scenarios)} episodes, e.g. --eval-episodes {len(scenarios)})",
            stacklevel=2,
        )
    if len(scenarios) == 1:
        return score_seeds(controller, scenarios[0], seeds, action_mode)
    parts = [score_seeds(controller, s, part, action_mode) for s, part in mixture_split(scenarios, seeds)]
    episodes = sum(p["episodes"] for p in parts)
    flat = {k: np.concatenate([p[k].ravel() for p in parts]) for k in ("success", "collision", "time")}
    reached = ~np.isnan(flat["time"])
    robots = np.array([p["success"].size for p in parts])
    return {
        "episodes": episodes,
        "episode_success": sum(p["episode_success"] * p["episodes"] for p in parts) / episodes,
        "episode_collision": sum(p["episode_collision"] * p["episodes"] for p in parts) / episodes,
        "robot_success": float(flat["success"].mean()),
        "robot_collision": float(flat["collision"].mean()),
        "time_to_goal": float(flat["time"][reached].mean()) if reached.any() else math.nan,
        "return": float(np.dot([p["return"] for p in parts], robots) / robots.sum()),
        **flat,
    }


class _Returns(Hook):
    """Sums each robot's reward over the steps it acted (``total``: ``(episodes, n)``)."""

    def __init__(self) -> None:
        self.batches: list[np.ndarray] = []

    def begin(self, engine, seeds, first) -> None:
        self.batches.append(np.zeros((len(seeds), engine.world.n_robots)))

    def step(self, s) -> None:
        self.batches[-1] += np.where(s.acting, s.result.reward, 0.0)

    @property
    def total(self) -> np.ndarray:
        return np.concatenate(self.batches)
