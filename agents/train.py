"""PPO with one policy shared by all robots (``vcs-env train``), cleanrl style.

One typed :class:`TrainConfig` (a docstring per field = the ``--help`` of its flag), one flat
:func:`train`. A run directory holds::

    <out>/model.zip, model.json           final policy + config/scenario/results (JSON)
    <out>/best_model.zip, best_model.json policy of the best periodic evaluation
    <out>/checkpoints/model_<steps>.zip   periodic checkpoints (+ JSON), resumable (--resume)
    <out>/eval.jsonl                      one line per periodic evaluation
    <out>/tb/                             TensorBoard logs (rollout/*, train/*, eval/*)

Periodic evaluation plays ``eval_episodes`` fixed seeds (``eval_seed``, ``eval_seed + 1``, ...)
with deterministic actions on the training scenario and logs episode and robot success and
collision rates and the mean time to goal (:func:`agents.evaluate.score_seeds`: the episode
runner and success definition of the suites); with ``--eval-suite`` it also scores the policy
on a named suite with :func:`agents.evaluate.evaluate`. With ``--mixture`` the run trains on
several scenarios at once (:class:`agents.vec_env.MixtureVecEnv`) and evaluation episode ``j``
plays mixture scenario ``j % S`` (:func:`agents.evaluate.score_scenarios`). Before training, the
run prints how its scenario differs from the evaluation suite of its family (jitter, collision
handling, spacing ...).

Example::

    vcs-env train --scenario circle --n-robots 8 --jitter 0.1 --timesteps 2000000 --seed 0
    vcs-env train --scenario crowd --timesteps 1000000 --shaping vcs_potential
    vcs-env train --scenario crowd --init runs/bc_crowd/model.zip   # warm start from behaviour cloning
    vcs-env train --mixture circle:n_robots=4-16/4,jitter=0-0.4 crowd:n_obstacles=3-19/8 --n-worlds 64
    vcs-env train --resume runs/ppo_circle/checkpoints/model_500000.zip --timesteps 3000000
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .config import (
    ScenarioConfig,
    add_config_args,
    build_scenario,
    config_command,
    config_from_args,
    mixture_scenarios,
    print_suite_differences,
)

if TYPE_CHECKING:
    from vcs_env.start_states import StartStates


@dataclass
class PolicyConfig:
    """The PPO actor-critic shared by ``train`` and ``bc`` (so a BC checkpoint can seed PPO)."""

    net_arch: tuple[int, ...] = (128, 128)
    """Hidden layer sizes of the (separate) policy and value MLPs."""
    log_std_init: float = -0.5
    """Initial log standard deviation of the Gaussian policy (state independent); actions are
    in [-1, 1], so std 0.6 explores without saturating most actions."""
    features: str = "flat"
    """What the MLPs read: flat (the observation), contact (the observation plus per-neighbour
    contact-time and nearness features computed from it) or slots (a learned encoder shared by the
    neighbour slots, pooled); agents.features. SB3 only."""


@dataclass
class TrainConfig(PolicyConfig, ScenarioConfig):
    """Everything a ``vcs-env train`` run depends on; saved as JSON beside every checkpoint."""

    timesteps: int = 1_000_000
    """Total environment steps, counted per robot (one slot step = one timestep); PPO learns in
    whole rollouts (n_steps x slots), so a run stops at the next multiple (a note says so)."""
    seed: int = 0
    """Seed of PPO (torch, numpy, action space) and of the training worlds (world b: seed + b)."""
    n_worlds: int = 16
    """Worlds stepped together; the VecEnv has n_worlds * n_robots slots."""
    n_steps: int = 128
    """Rollout length per slot between PPO updates (buffer = n_steps * n_worlds * n_robots)."""
    batch_size: int = 2048
    """PPO minibatch size."""
    n_epochs: int = 10
    """PPO epochs per update."""
    learning_rate: float = 3e-4
    """Adam learning rate (at the start, see lr_schedule)."""
    lr_schedule: str = "constant"
    """constant, or linear: decays to 0 at the end of the run (of this learn() call when resuming)."""
    gamma: float = 0.99
    """Discount factor of PPO and of vcs_potential shaping (Ng et al.'s policy-invariant form)."""
    gae_lambda: float = 0.95
    """GAE lambda."""
    clip_range: float = 0.2
    """PPO clipping parameter."""
    ent_coef: float = 0.0
    """Entropy bonus coefficient."""
    vf_coef: float = 0.5
    """Value loss coefficient."""
    max_grad_norm: float = 0.5
    """Gradient norm clip."""
    target_kl: float | None = None
    """Stop an update's epochs early when the approximate KL exceeds this (None: never)."""
    init: str | None = None
    """Checkpoint (e.g. from vcs-env bc) whose policy weights start the run (same net_arch)."""
    out: str = "runs/ppo"
    """Run directory (model.zip, model.json, checkpoints/, eval.jsonl, tb/)."""
    eval_freq: int = 100_000
    """Evaluate every this many timesteps (0: only at the end)."""
    eval_episodes: int = 20
    """Episodes (worlds) per periodic evaluation."""
    eval_seed: int = 100_000
    """First seed of the fixed evaluation list (disjoint from the suites' 1000..)."""
    eval_suite: str | None = None
    """Also score the policy on this named suite (e.g. crowd-5-v0-smoke) with the evaluation
    harness at every periodic evaluation (logged as suite/*; not used to pick best_model)."""
    mixture: tuple[str, ...] = ()
    """Train on a mixture instead of one scenario: entries PRESET[:FIELD=VALUE|LO-HI[/STEP],...] with
    FIELD in n_robots, n_obstacles, jitter, layout_radius, obstacle_speed, e.g. circle:n_robots=4-16/4,jitter=0-0.4
    crowd:n_obstacles=3-19/8,obstacle_speed=0.5-1.5 (agents.config.parse_mixture_entry). Every grid point
    is one scenario with a fixed share of the worlds (agents.vec_env.MixtureVecEnv); the other scenario
    flags (max_steps, on_collision, rewards, shaping) apply to all."""
    mixture_balance: str = "worlds"
    """How a mixture's worlds are shared: ``worlds`` (the same number per scenario) or ``robots``
    (worlds in proportion to 1 / robot count, so every scenario steps about the same number of
    robots; agents.vec_env.mixture_world_counts)."""
    start_states: str | None = None
    """Start-state file (vcs-env collect-states): a training world of a scenario with a pool there
    starts, with probability start_prob, from one of its states (vcs_env.start_states); periodic
    evaluation always starts fresh."""
    start_prob: float = 0.5
    """Probability that a training world with a start-state pool starts from it."""
    checkpoint_freq: int = 500_000
    """Save a resumable checkpoint every this many timesteps (0: never)."""
    progress_bar: bool = True
    """Show SB3's progress bar (needs tqdm and rich, the train extra)."""
    tensorboard: bool = True
    """Write TensorBoard logs under <out>/tb."""


def ppo_kwargs(cfg: TrainConfig, n_neighbors: int) -> dict[str, Any]:
    """Keyword arguments of ``stable_baselines3.PPO`` from a config (``n_neighbors``: the
    observation's neighbour slots, read by ``cfg.features``)."""
    return dict(
        n_steps=cfg.n_steps,
        batch_size=cfg.batch_size,
        n_epochs=cfg.n_epochs,
        learning_rate=learning_rate(cfg),
        gamma=cfg.gamma,
        gae_lambda=cfg.gae_lambda,
        clip_range=cfg.clip_range,
        ent_coef=cfg.ent_coef,
        vf_coef=cfg.vf_coef,
        max_grad_norm=cfg.max_grad_norm,
        target_kl=cfg.target_kl,
        policy_kwargs=policy_kwargs(cfg, n_neighbors),
    )


def learning_rate(cfg: TrainConfig):
    """SB3 learning rate: a number, or a function of the remaining progress (1 -> 0)."""
    if cfg.lr_schedule == "constant":
        return cfg.learning_rate
    if cfg.lr_schedule == "linear":
        lr0 = cfg.learning_rate
        return lambda progress_remaining: lr0 * progress_remaining
    raise ValueError(f"lr_schedule must be constant or linear, got {cfg.lr_schedule!r}")


def policy_kwargs(cfg: PolicyConfig, n_neighbors: int) -> dict[str, Any]:
    """Keyword arguments of SB3's ``MlpPolicy`` for ``cfg``, on observations with ``n_neighbors`` slots."""
    from .features import extractor_kwargs

    return dict(
        net_arch=dict(pi=list(cfg.net_arch), vf=list(cfg.net_arch)),
        log_std_init=cfg.log_std_init,
        **extractor_kwargs(cfg.features, n_neighbors),
    )


def scalar_results(res: dict[str, Any]) -> dict[str, float]:
    return {k: v for k, v in res.items() if isinstance(v, (int, float))}


BEST_KEY = ((1, "episode_success"), (1, "robot_success"), (-1, "robot_collision"), (-1, "time_to_goal"))
"""best_model.zip: most successful episodes, then robots, then fewest collisions, then fastest."""


def check_ppo_settings(cfg: TrainConfig) -> None:
    """Raise ``ValueError`` naming the field for PPO settings SB3 would crash on or silently misuse."""
    from vcs_env.checks import check_int, check_positive, check_range

    for name in ("n_steps", "batch_size", "n_epochs"):
        check_int(name, getattr(cfg, name), 1, 10**9)
    if not cfg.net_arch or any(isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in cfg.net_arch):
        raise ValueError(f"net_arch must be one or more layer sizes >= 1, got {cfg.net_arch!r}")
    for name in ("learning_rate", "clip_range"):
        check_positive(name, getattr(cfg, name))
    for name in ("ent_coef", "vf_coef", "max_grad_norm"):
        check_positive(name, getattr(cfg, name), allow_zero=True)
    check_range("gae_lambda", cfg.gae_lambda, 0.0, 1.0)
    check_range("log_std_init", cfg.log_std_init, -20.0, 2.0)
    if cfg.target_kl is not None:
        check_positive("target_kl", cfg.target_kl)
    for name in ("eval_freq", "checkpoint_freq"):
        check_int(name, getattr(cfg, name), 0, 10**12)


def _callbacks(cfg: TrainConfig, scenarios, out: Path, t_start: float):
    from stable_baselines3.common.callbacks import BaseCallback

    from .checkpoint import jsonable, save_model, scenario_family
    from .evaluate import evaluate as score_on_suite
    from .evaluate import score_scenarios
    from .policies import predictor_controller

    scenario, family = scenarios[0], scenario_family(scenarios)
    eval_seeds = list(range(cfg.eval_seed, cfg.eval_seed + cfg.eval_episodes))

    class RunCallback(BaseCallback):
        """Robot-level rates of the training episodes, periodic evaluation, checkpoints."""

        def __init__(self):
            super().__init__()
            self.last_eval = self.last_ckpt = None
            self.best: tuple | None = None
            self.history: list[dict[str, Any]] = []

        def _on_training_start(self) -> None:
            self.last_eval = self.last_ckpt = self.num_timesteps

        def restore(self, timesteps: int) -> None:
            """Resuming at ``timesteps`` in ``out``: the run's evaluations up to there stay its
            history (later ones, of a branch the resume abandons, leave eval.jsonl) and the best
            of them stays the one to beat."""
            log = out / "eval.jsonl"
            if not log.exists():
                return
            rows = [json.loads(line) for line in log.read_text().splitlines() if line.strip()]
            self.history = [r for r in rows if r.get("timesteps", 0) <= timesteps]
            log.write_text("".join(json.dumps(r, allow_nan=False) + "\n" for r in self.history))
            for r in self.history:
                key = tuple(-math.inf if r.get(k) is None else s * r[k] for s, k in BEST_KEY)
                self.best = key if self.best is None or key > self.best else self.best

        def _on_rollout_end(self) -> None:
            buf = [e for e in self.model.ep_info_buffer if "success" in e]
            if buf:
                n = len(buf)
                self.logger.record("rollout/robot_success_rate", sum(e["success"] for e in buf) / n)
                self.logger.record("rollout/robot_collision_rate", sum(e["collision"] for e in buf) / n)

        def evaluate(self) -> dict[str, Any]:
            t0 = time.time()
            res = scalar_results(score_scenarios(predictor_controller(self.model.policy), scenarios, eval_seeds))
            suite = ""
            if cfg.eval_suite:
                summary = score_on_suite(self.model, cfg.eval_suite, progress=False).summary
                res["suite"] = {k: summary[k]["mean"] for k in ("success", "collision", "time_to_goal")}
                for k, v in res["suite"].items():
                    self.logger.record(f"suite/{k}", v)
                s = res["suite"]
                suite = f"; {cfg.eval_suite}: success {s['success']:.2f} collision {s['collision']:.2f}"
            res.update(
                timesteps=int(self.num_timesteps),
                wall_time=round(time.time() - t_start, 1),
                eval_seconds=round(time.time() - t0, 2),
            )
            for k in ("episode_success", "episode_collision", "robot_success", "robot_collision", "time_to_goal"):
                self.logger.record(f"eval/{k}", res[k])
            self.history.append(res)
            with open(out / "eval.jsonl", "a") as f:  # strict JSON: NaN (no episode solved) as null
                f.write(json.dumps(jsonable(res), allow_nan=False) + "\n")
            print(
                f"[eval @ {res['timesteps']:>9d}] success {res['episode_success']:.2f} (robots "
                f"{res['robot_success']:.3f}) collision {res['episode_collision']:.2f} (robots "
                f"{res['robot_collision']:.3f}) time-to-goal {res['time_to_goal']:.2f} s{suite}  "
                f"[{res['wall_time']:.0f} s]",
                flush=True,
            )
            key = tuple(s * res[k] for s, k in BEST_KEY)
            if self.best is None or key > self.best:
                self.best = key
                save_model(self.model, out / "best_model.zip", "ppo", cfg, scenario, family, evaluation=res)
            return res

        def _on_rollout_start(self) -> None:
            # Called after the previous update, so the evaluated policy includes it.
            self.num_timesteps = self.model.num_timesteps
            if cfg.eval_freq > 0 and self.num_timesteps - self.last_eval >= cfg.eval_freq:
                self.last_eval = self.num_timesteps
                self.evaluate()
            if cfg.checkpoint_freq > 0 and self.num_timesteps - self.last_ckpt >= cfg.checkpoint_freq:
                self.last_ckpt = self.num_timesteps
                save_model(
                    self.model,
                    out / "checkpoints" / f"model_{self.num_timesteps}.zip",
                    "ppo",
                    cfg,
                    scenario,
                    family,
                    wall_time=round(time.time() - t_start, 1),
                )

        def _on_step(self) -> bool:
            return True

    return RunCallback()


def start_states(cfg: TrainConfig, scenarios) -> StartStates | None:
    """The start-state pools of a run (None without ``--start-states``); a ``ValueError`` when
    none fits a training scenario (pools are keyed by the whole scenario but its rewards)."""
    if cfg.start_states is None:
        return None
    from vcs_env.start_states import StartStates

    starts = StartStates.load(cfg.start_states, cfg.start_prob)
    hit = starts.matching(scenarios)
    if not any(len(pool) for pool in starts.pools.values()):
        raise ValueError(f"{cfg.start_states!r} holds no start states (vcs-env collect-states found none)")
    if not hit:
        raise ValueError(
            f"no start-state pool of {cfg.start_states!r} fits a training scenario ({len(starts.pools)} pools; collect "
            "them with the training's scenario flags and mixture, e.g. the same --on-collision and --max-steps)"
        )
    states = sum(len(starts.pool(s)) for s in hit)
    print(
        f"start states: {len(hit)} of {len(scenarios)} scenarios start from {cfg.start_states} with "
        f"p={cfg.start_prob} ({states} states)"
    )
    return starts


def train(cfg: TrainConfig, resume: str | None = None) -> dict[str, Any]:
    """Train (or resume) a shared PPO policy; returns the final evaluation and paths."""
    from .checkpoint import resolve

    scenarios = mixture_scenarios(cfg, cfg.mixture) if cfg.mixture else [build_scenario(cfg)]
    scenario = scenarios[0]
    print_suite_differences(scenarios)
    if cfg.timesteps < 0 or cfg.n_worlds < 1 or cfg.eval_episodes < 1:
        raise ValueError("timesteps must be >= 0, n_worlds and eval_episodes >= 1")
    check_ppo_settings(cfg)
    if cfg.mixture_balance not in ("worlds", "robots"):
        raise ValueError(f"mixture_balance must be worlds or robots, got {cfg.mixture_balance!r}")
    starts = start_states(cfg, scenarios)
    for path in (cfg.init, resume):  # fail fast, before the slow torch import
        if path:
            resolve(path)
    if cfg.eval_suite:
        from vcs_env.suites import get_suite

        get_suite(cfg.eval_suite)  # an unknown name raises here, not after the first rollouts

    import torch

    torch.set_num_threads(1)
    from stable_baselines3 import PPO

    from .checkpoint import jsonable, load_model, load_policy_weights, save_model, scenario_family
    from .vec_env import MixtureVecEnv, NavVecEnv

    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.time()
    if len(scenarios) == 1:
        venv = NavVecEnv(scenario, cfg.n_worlds, gamma=cfg.gamma, start_states=starts)
    else:
        venv = MixtureVecEnv(scenarios, cfg.n_worlds, gamma=cfg.gamma, balance=cfg.mixture_balance, start_states=starts)
    tb = str(out / "tb") if cfg.tensorboard else None
    if resume:  # the weights, PPO settings and network are the checkpoint's; cfg.init only records the start
        model = load_model(resume, scenario, env=venv)
        model.tensorboard_log = tb
        model.set_random_seed(cfg.seed + model.num_timesteps)  # fresh, reproducible worlds after resuming
        print(f"resumed {resume} at {model.num_timesteps} timesteps")
    else:
        kwargs = ppo_kwargs(cfg, scenario.n_neighbors)
        model = PPO("MlpPolicy", venv, seed=cfg.seed, device="cpu", tensorboard_log=tb, verbose=0, **kwargs)
        if cfg.init:
            meta = load_policy_weights(model, cfg.init, scenario)
            print(f"initialised the policy from {cfg.init} ({meta.get('kind', 'unknown')} checkpoint)")
    (out / "config.json").write_text(json.dumps(jsonable(cfg), indent=2) + "\n")
    remaining = cfg.timesteps - model.num_timesteps
    callback = _callbacks(cfg, scenarios, out, t_start)
    if resume:
        callback.restore(model.num_timesteps)
    what = ", ".join(f"{s.kind} (n={s.n_robots}, m={s.n_obstacles})" for s in scenarios[:6])
    what += f" and {len(scenarios) - 6} more" if len(scenarios) > 6 else ""
    print(
        f"training {what} shaping={cfg.shaping}: {venv.num_envs} slots, {remaining} timesteps -> {out}",
        flush=True,
    )
    rollout = model.n_steps * venv.num_envs
    if remaining > 0 and remaining % rollout:
        print(
            f"note: PPO learns in whole rollouts of {rollout} timesteps (n_steps x slots): this run stops at "
            f"{model.num_timesteps + -(-remaining // rollout) * rollout} timesteps, not {cfg.timesteps}",
            flush=True,
        )
    if remaining > 0:
        model.learn(
            total_timesteps=remaining,
            callback=callback,
            progress_bar=cfg.progress_bar,
            tb_log_name="ppo",
            reset_num_timesteps=not resume,
        )
    if getattr(callback, "model", None) is None:  # learn() did not run (budget already reached)
        if not hasattr(model, "_logger"):
            from stable_baselines3.common.logger import configure

            model.set_logger(configure(None, []))
        callback.init_callback(model)
    callback.num_timesteps = model.num_timesteps
    if starts is not None:
        fresh, pooled = sum(g.engine.sim.start_counts for g in getattr(venv, "groups", [venv]))
        print(f"start states: {pooled} of {fresh + pooled} training world resets started from a pool")
    final = callback.evaluate()
    model.logger.dump(model.num_timesteps)
    wall = round(time.time() - t_start, 1)
    path = save_model(
        model,
        out / "model.zip",
        "ppo",
        cfg,
        scenario,
        scenario_family(scenarios),
        evaluation=final,
        wall_time=wall,
        history=callback.history,
    )
    print(f"saved {path} ({model.num_timesteps} timesteps, {wall:.0f} s)")
    print(f"reproduce: {config_command('train', cfg)}")
    return {"model": str(path), "evaluation": final, "wall_time": wall}


def cmd_train(args: argparse.Namespace) -> int:
    from . import rllib_train

    if args.backend == "rllib":
        return rllib_train.cmd_train(args)
    rllib_train.reject_rllib_flags(args)
    base = None
    if args.resume:
        from .resume import resume_base

        base = resume_base(args)
    cfg = config_from_args(TrainConfig, args, base)
    train(cfg, resume=args.resume)
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser(
        "train",
        help="train a PPO policy shared by all robots",
        description=__doc__.split("\n\n")[0],
    )
    add_config_args(p, TrainConfig)
    p.add_argument("--backend", choices=["sb3", "rllib"], default="sb3", help="sb3 (one process) or rllib (Ray)")
    from .rllib_train import add_rllib_args

    add_rllib_args(p)
    p.add_argument(
        "--resume",
        default=None,
        help="continue a PPO run from this checkpoint, in its run directory unless --out is given (its config "
        "JSON is reused: --timesteps sets the new total, evaluation, checkpoint and scenario flags may change; the "
        "network and PPO settings stay the checkpoint's)",
    )
    p.set_defaults(func=cmd_train)
