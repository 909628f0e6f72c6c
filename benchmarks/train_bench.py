"""PPO training throughput in agent-steps (robot-steps) per second, torch on one thread.

The learner is SB3 PPO on the ``NavVecEnv`` of ``agents/vec_env.py`` with the hyper-parameters
of ``vcs-env train`` (:class:`agents.train.TrainConfig`, read-only), on the ``circle`` preset
(8 robots) with 0.1 m start jitter. Variants:

* ``none`` - no shaping, no expert;
* ``expert`` - the VCS expert attached and computed at every step (its action for every state,
  as DAgger or ``info["expert_action"]`` need it), no shaping weight;
* ``vcs_imitation`` / ``vcs_potential`` - the shaping terms at their default weights
  (:data:`agents.config.DEFAULT_SHAPING_WEIGHT`); both compute the expert at every step.

One measurement is ``model.learn`` over ``rollouts`` full rollouts (collection and the PPO
update), timed in CPU seconds; building the env and the model is not timed. A callback splits
the time into
collection (env steps + policy forward passes) and the rest (PPO updates).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from .timing import Missing, Result

VARIANTS = ("none", "expert", "vcs_imitation", "vcs_potential")


@dataclass
class TrainSizes:
    """Size of the PPO runs."""

    n_robots: int = 8
    """Robots per world."""
    n_worlds: int = 16
    """Worlds B; the VecEnv has B * n slots."""
    n_steps: int = 128
    """Rollout length per slot (``vcs-env train`` default)."""
    batch_size: int = 2048
    """PPO minibatch (``vcs-env train`` default)."""
    n_epochs: int = 10
    """PPO epochs per update (``vcs-env train`` default)."""
    rollouts: int = 1
    """Rollouts (collect + update) per measurement."""
    repeats: int = 3
    """Measurements per variant (median reported)."""


@dataclass
class TrainResult(Result):
    """:class:`~benchmarks.timing.Result` of one variant: ``rates`` and ``wall_rates`` are agent-steps per CPU and
    per wall-clock second [1/s] of every repeat (one ``model.learn`` each; ``calls`` stays empty)."""

    collect_fraction: list[float] = field(default_factory=list)
    """Share of the CPU time spent collecting rollouts, every repeat."""

    def as_dict(self) -> dict:
        out = super().as_dict()
        del out["calls"]
        return {**out, "collect_fraction": self.collect_fraction}


def _imports():
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.callbacks import BaseCallback

        from agents.config import DEFAULT_SHAPING_WEIGHT
        from agents.train import TrainConfig, ppo_kwargs
        from agents.vec_env import NavVecEnv
    except Exception as e:  # agents/ not there yet, or SB3/torch not installed
        msg = f"agents.vec_env / agents.train / stable_baselines3 not importable ({type(e).__name__}: {e})"
        raise Missing(msg) from None
    return PPO, BaseCallback, DEFAULT_SHAPING_WEIGHT, TrainConfig, ppo_kwargs, NavVecEnv


def run(sizes: TrainSizes, variants=VARIANTS) -> dict[str, TrainResult]:
    """Median PPO throughput per variant (module docstring)."""
    try:
        PPO, BaseCallback, shaping_weight, TrainConfig, ppo_kwargs, NavVecEnv = _imports()
    except Missing as e:
        return {v: TrainResult(status=f"missing: {e}") for v in variants}
    from vcs_env.scenario import make_scenario

    class CollectTimer(BaseCallback):
        def __init__(self):
            super().__init__()
            self.collect = 0.0
            self._t0 = 0.0

        def _on_rollout_start(self) -> None:
            self._t0 = time.process_time()

        def _on_rollout_end(self) -> None:
            self.collect += time.process_time() - self._t0

        def _on_step(self) -> bool:
            return True

    cfg = TrainConfig(
        n_robots=sizes.n_robots,
        jitter=0.1,
        n_worlds=sizes.n_worlds,
        n_steps=sizes.n_steps,
        batch_size=sizes.batch_size,
        n_epochs=sizes.n_epochs,
        progress_bar=False,
        tensorboard=False,
    )
    results = {v: TrainResult() for v in variants}
    for _ in range(sizes.repeats):
        for v in variants:
            if results[v].status != "ok":
                continue
            try:
                rewards = {v: shaping_weight[v]} if v in shaping_weight else {}
                scenario = make_scenario("circle", n_robots=sizes.n_robots, jitter=0.1, rewards=rewards)
                venv = NavVecEnv(scenario, sizes.n_worlds, expert="vcs" if v == "expert" else None, gamma=cfg.gamma)
                model = PPO("MlpPolicy", venv, seed=0, device="cpu", verbose=0, **ppo_kwargs(cfg, scenario))
                total = sizes.rollouts * sizes.n_steps * venv.num_envs
                timer = CollectTimer()
                t0, w0 = time.process_time(), time.perf_counter()
                model.learn(total_timesteps=total, callback=timer, progress_bar=False)
                cpu = time.process_time() - t0
                wall = time.perf_counter() - w0
            except Exception as e:
                results[v].status = f"error: {type(e).__name__}: {e}"
                continue
            results[v].rates.append(model.num_timesteps / cpu)
            results[v].wall_rates.append(model.num_timesteps / wall)
            results[v].collect_fraction.append(timer.collect / cpu)
    return results
