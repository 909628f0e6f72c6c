"""The periodic evaluation of ``vcs-env train``, one for every backend (SB3 and RLlib).

:class:`PeriodicEval` plays ``eval_episodes`` fixed seeds (``eval_seed``, ``eval_seed + 1``, ...)
with deterministic actions on the training scenarios (:func:`agents.evaluate.score_scenarios`:
episode ``j`` plays mixture scenario ``j % S``; the episode runner and success definition of the
suites) and, with ``--eval-suite``, scores the policy on that named suite with
:func:`agents.evaluate.evaluate`. Each evaluation is one line of ``<out>/eval.jsonl`` and one
printed line, and it tells whether it is the best so far (:data:`BEST_KEY`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from vcs_env.files import write_text
from vcs_env.observations import SENSOR_FIELDS
from vcs_env.scenario import Scenario
from vcs_env.suites import get_suite

from ..evaluate import evaluate, scalar_results, score_scenarios
from ..policies import predictor_controller
from ..residual import Residual, ResidualPolicy
from ..runs import TrainConfig, jsonable

BEST_KEY = ((1, "episode_success"), (1, "robot_success"), (-1, "robot_collision"), (-1, "time_to_goal"))
"""best_model.zip: most successful episodes, then robots, then fewest collisions, then fastest."""
LOGGED = ("episode_success", "episode_collision", "robot_success", "robot_collision", "time_to_goal")
"""Results logged as ``eval/*`` (TensorBoard)."""


def _key(res: dict[str, Any]) -> tuple[float, ...]:
    return tuple(-math.inf if res.get(k) is None else s * res[k] for s, k in BEST_KEY)


class PeriodicEval:
    """Evaluate a policy during training; keep the history and the best key.

    Args:
        cfg: the run (``eval_seed``, ``eval_episodes``, ``eval_suite``).
        scenarios: the training scenarios (one, or a mixture's).
        out: the run directory (``eval.jsonl`` is appended to).
        t_start: ``time.time()`` at the start of the run, for ``wall_time`` [s].
    """

    def __init__(self, cfg: TrainConfig, scenarios: Sequence[Scenario], out: Path, t_start: float):
        self.cfg, self.scenarios, self.out, self.t_start = cfg, list(scenarios), Path(out), t_start
        self.seeds = list(range(cfg.eval_seed, cfg.eval_seed + cfg.eval_episodes))
        self.history: list[dict[str, Any]] = []
        self.best: tuple[float, ...] | None = None
        self.residual = Residual.of(cfg)
        """The planner a residual policy corrects (``--residual``), evaluated together with it."""
        self.improved = False
        """Whether the last evaluation was the best so far."""
        self.suite = None
        """``cfg.eval_suite`` observed as the run observes (its sensing fields, which never change an episode; the
        suite's own could give the network observations of another size, found only at the first evaluation)."""
        if cfg.eval_suite:
            suite, sensing = get_suite(cfg.eval_suite), {f: getattr(self.scenarios[0], f) for f in SENSOR_FIELDS}
            self.suite = dataclasses.replace(suite, scenario=dataclasses.replace(suite.scenario, **sensing))

    def restore(self, timesteps: int) -> None:
        """Resuming at ``timesteps`` in ``out``: the run's evaluations up to there stay its history
        (later ones, of a branch the resume abandons, leave eval.jsonl) and the best of them stays
        the one to beat."""
        log = self.out / "eval.jsonl"
        if not log.exists():
            return
        rows = []
        for k, line in enumerate(log.read_text().splitlines()):
            try:
                rows += [json.loads(line)] if line.strip() else []
            except ValueError as e:  # e.g. the last line of a run killed while it wrote it
                raise ValueError(
                    f"{log} line {k + 1} is not JSON ({e}): remove or mend that line, then resume again"
                ) from None
        self.history = [r for r in rows if r.get("timesteps", 0) <= timesteps]
        write_text(log, "".join(json.dumps(r, allow_nan=False) + "\n" for r in self.history))
        for r in self.history:
            self.best = _key(r) if self.best is None or _key(r) > self.best else self.best

    def __call__(self, predictor: Any, timesteps: int, log: Callable[[str, float], None] | None = None) -> dict:
        """Evaluate ``predictor`` (an SB3-style ``PolicyPredictor``) after ``timesteps`` steps of
        training; ``log(name, value)`` records ``eval/*`` and ``suite/*`` (e.g. SB3's logger)."""
        cfg, t0 = self.cfg, time.time()
        controller = predictor_controller(predictor)
        if self.residual is not None:
            controller = self.residual.controller(controller)
            predictor = ResidualPolicy(predictor, self.residual)
        res = scalar_results(score_scenarios(controller, self.scenarios, self.seeds))
        suite = ""
        if self.suite is not None:
            summary = evaluate(predictor, self.suite, progress=False).summary
            s = res["suite"] = {k: summary[k]["mean"] for k in ("success", "collision", "time_to_goal")}
            suite = f"; {cfg.eval_suite}: success {s['success']:.2f} collision {s['collision']:.2f}"
        res.update(
            timesteps=int(timesteps),
            wall_time=round(time.time() - self.t_start, 1),
            eval_seconds=round(time.time() - t0, 2),
        )
        if log is not None:
            for k, v in res.get("suite", {}).items():
                log(f"suite/{k}", v)
            for k in LOGGED:
                log(f"eval/{k}", res[k])
        self.history.append(res)
        with open(self.out / "eval.jsonl", "a") as f:  # strict JSON: NaN (no episode solved) as null
            f.write(json.dumps(jsonable(res), allow_nan=False) + "\n")
        print(
            f"[eval @ {res['timesteps']:>9d}] success {res['episode_success']:.2f} (robots "
            f"{res['robot_success']:.3f}) collision {res['episode_collision']:.2f} (robots "
            f"{res['robot_collision']:.3f}) time-to-goal {res['time_to_goal']:.2f} s{suite}  "
            f"[{res['wall_time']:.0f} s]",
            flush=True,
        )
        key = tuple(s * res[k] for s, k in BEST_KEY)
        self.improved = self.best is None or key > self.best
        self.best = key if self.improved else self.best
        return res
