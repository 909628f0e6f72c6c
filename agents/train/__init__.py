"""PPO with one policy shared by all robots (``vcs-env train``), cleanrl style.

The training package: the SB3 backend (here) and the RLlib one (:mod:`agents.train.rllib`), both on
one typed :class:`~agents.runs.TrainConfig` (a docstring per field = the ``--help`` of its flag),
one periodic evaluation (:mod:`agents.train.periodic`) and the checkpoint formats of
:mod:`agents.checkpoint`. :func:`train` is one flat function. A run directory holds::

    <out>/model.zip, model.json           final policy + config/scenario/results (JSON)
    <out>/best_model.zip, best_model.json policy of the best periodic evaluation
    <out>/checkpoints/model_<steps>.zip   periodic checkpoints (+ JSON), resumable (--resume)
    <out>/eval.jsonl                      one line per periodic evaluation
    <out>/tb/                             TensorBoard logs (rollout/*, train/*, eval/*)

Periodic evaluation (:class:`agents.train.periodic.PeriodicEval`) logs episode and robot
success and collision rates and the mean time to goal on fixed seeds, and with ``--eval-suite``
the scores on a named suite. With ``--mixture`` the run trains on several scenarios at once
(:class:`agents.vec_env.MixtureVecEnv`). Before training, the
run prints how its scenario differs from the evaluation suite of its family (jitter, collision
handling, spacing ...).

Example::

    vcs-env train --scenario circle --n-robots 8 --jitter 0.1 --timesteps 2000000 --seed 0
    vcs-env train --scenario crowd --timesteps 1000000 --shaping vcs_potential
    vcs-env train --scenario crowd --init runs/bc_crowd/model.zip   # warm start from behaviour cloning
    vcs-env train --mixture circle:n_robots=4-16/4,jitter=0-0.4 crowd:n_obstacles=3-11/4 --n-worlds 64
    vcs-env train --resume runs/ppo_circle/checkpoints/model_500000.zip --timesteps 3000000
    vcs-env train --resume runs/ppo_circle --timesteps 3000000   # its newest checkpoint
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import time
from pathlib import Path
from typing import Any

from vcs_env.checks import check_int, check_positive, check_range
from vcs_env.files import write_text
from vcs_env.rewards import TERMS
from vcs_env.scenario import Scenario
from vcs_env.suites import get_suite

from ..checkpoint import Checkpoint, load_policy_weights, open_checkpoint, save_model
from ..config import build_scenario, config_command, print_suite_differences
from ..mixture import mixture_scenarios
from ..policies import warn_blind_training
from ..residual import Residual
from ..runs import (
    TrainConfig,
    check_fresh_out,
    check_net_arch,
    check_run,
    jsonable,
    kept_start,
    policy_kwargs,
    print_reproduce,
    resumed_from,
    scenario_family,
    start_states,
)
from .guide import GUIDES, ImitationLoss, JumpStart, annealed
from .periodic import PeriodicEval


def ppo_kwargs(cfg: TrainConfig, scenario: Scenario) -> dict[str, Any]:
    """Keyword arguments of ``stable_baselines3.PPO`` from a config, on the observations of ``scenario``
    (read by ``cfg.features``)."""
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
        policy_kwargs=policy_kwargs(cfg, scenario),
    )


def learning_rate(cfg: TrainConfig):
    """SB3 learning rate: a number, or a function of the remaining progress (1 -> 0).

    ``linear`` holds at 0 once the progress runs out: PPO learns in whole rollouts, so a run whose budget
    is not a multiple of the rollout ends past it, and SB3 then passes a negative remaining progress to
    the last update. A negative rate there ran gradient ascent on the PPO loss (one such update took a
    policy from 1.00 to 0.00 on the corridor suites, docs/training.md)."""
    if cfg.lr_schedule == "constant":
        return cfg.learning_rate
    if cfg.lr_schedule == "linear":
        lr0 = cfg.learning_rate
        return lambda progress_remaining: lr0 * max(progress_remaining, 0.0)
    raise ValueError(f"lr_schedule must be constant or linear, got {cfg.lr_schedule!r}")


LOG_STD_RANGE = (-20.0, 2.0)
"""Bounds of a Gaussian policy's log std (std 2e-9 to 7.4), new or set on a loaded policy."""


def check_ppo_settings(cfg: TrainConfig) -> None:
    """Raise ``ValueError`` naming the field for PPO settings a backend would crash on or silently misuse (every
    backend runs it)."""
    for name in ("n_steps", "batch_size", "n_epochs"):
        check_int(name, getattr(cfg, name), 1, 10**9)
    check_net_arch(cfg.net_arch)
    for name in ("learning_rate", "clip_range"):
        check_positive(name, getattr(cfg, name))
    for name in ("ent_coef", "vf_coef"):
        check_positive(name, getattr(cfg, name), allow_zero=True)
    check_range("gae_lambda", cfg.gae_lambda, 0.0, 1.0)
    check_range("gamma", cfg.gamma, 0.0, 1.0)  # the env checks it too, but RLlib's runners would meet it late
    check_range("log_std_init", cfg.log_std_init, *LOG_STD_RANGE)
    if cfg.init_log_std is not None:  # the log std set on an --init policy: the same bounds
        check_range("init_log_std", cfg.init_log_std, *LOG_STD_RANGE)
    if cfg.target_kl is not None:
        check_positive("target_kl", cfg.target_kl)
    for name in ("eval_freq", "checkpoint_freq"):
        check_int(name, getattr(cfg, name), 0, 10**12)


def _callback(cfg: TrainConfig, scenarios, out: Path, t_start: float, periodic: PeriodicEval, anneal=None, guide=None):
    """SB3's callback of a run: robot-level rates of the training episodes, periodic evaluation
    (``periodic``, and ``best_model.zip`` when it improves), periodic checkpoints, the annealed
    shaping weight (``anneal``, :func:`shaping_schedule`) set before each rollout, and the ``--guide``
    loss (``guide``, :mod:`agents.train.guide`) fed with the rollout and summed into PPO's update on it."""
    from stable_baselines3.common.callbacks import BaseCallback

    scenario, family = scenarios[0], scenario_family(scenarios)

    class RunCallback(BaseCallback):
        def __init__(self):
            super().__init__()
            self.last_eval = self.last_ckpt = None
            self.rollout_began = 0  # the step count at the current rollout's start

        def _on_training_start(self) -> None:
            self.last_eval = self.last_ckpt = self.num_timesteps

        def _on_training_end(self) -> None:
            if guide is not None:
                guide.finish()

        def _on_rollout_end(self) -> None:
            if guide is not None:  # the guide's weight of the rollout's first step: annealed from there
                for k, v in guide.update(self.model, self.rollout_began).items():
                    self.logger.record(f"guide/{k}", v)
            buf = [e for e in self.model.ep_info_buffer if "success" in e]
            if buf:
                n = len(buf)
                self.logger.record("rollout/robot_success_rate", sum(e["success"] for e in buf) / n)
                self.logger.record("rollout/robot_collision_rate", sum(e["collision"] for e in buf) / n)

        def evaluate(self) -> dict[str, Any]:
            res = periodic(self.model, self.num_timesteps, self.logger.record)
            if periodic.improved:
                save_model(self.model, out / "best_model.zip", "ppo", cfg, scenario, family, evaluation=res)
            return res

        def _on_rollout_start(self) -> None:
            # Called after the previous update, so the evaluated policy includes it.
            self.num_timesteps = self.rollout_began = self.model.num_timesteps
            if anneal is not None:
                self.logger.record("train/shaping_weight", anneal(self.training_env, self.num_timesteps))
            if guide is not None:
                guide.rollout_start(self.training_env, self.num_timesteps)
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
            if guide is not None:
                guide.step(self.training_env)
            return True

    return RunCallback()


def expert_terms(scenarios) -> list[str]:
    """The reward terms weighted in some of ``scenarios`` that need the VCS expert (``vcs_imitation``,
    ``vcs_potential``: from ``--shaping`` or from their weights in ``--rewards``, the same thing given two ways)."""
    needs = {t.name for t in TERMS if t.needs_expert}
    return sorted({k for s in scenarios for k, w in s.rewards.as_dict().items() if w and k in needs})


def residual_of(cfg: TrainConfig, scenarios=()) -> Residual | None:
    """The residual a run trains (``--residual``), or None; a one-line ``ValueError`` when its
    planner cannot give what the run's shaping needs (the VCS expert: ``--shaping``, or such a term weighted in
    ``--rewards`` of the run's ``scenarios``), or with a ``--guide`` (the imitation loss pulls the network's action,
    here a correction, towards the expert's action; jump-start lets the expert drive, where the planner already
    does), or with ``--residual-gate`` and no residual to gate."""
    residual = Residual.of(cfg)
    if residual is None and cfg.residual_gate:
        raise ValueError("--residual-gate holds a residual policy's correction; it needs --residual vcs")
    shaping = [cfg.shaping] if cfg.shaping != "none" else expert_terms(scenarios)
    if residual is not None and shaping and residual.planner != "vcs":
        given = f"--shaping {cfg.shaping}" if cfg.shaping != "none" else f"the reward term {shaping[0]} (--rewards)"
        raise ValueError(
            f"{given} needs the VCS expert, and a residual's expert is its planner: "
            f"--residual {residual.planner} would attach {residual.planner}"
        )
    if residual is not None and cfg.guide == "imitation_loss":
        raise ValueError(
            "--guide imitation_loss pulls the policy to the expert's actions; a residual already adds them"
        )
    if residual is not None and cfg.guide != "none":
        raise ValueError(
            f"--guide {cfg.guide} lets the expert drive the episodes' starts; a residual's planner always drives"
        )
    return residual


def guide_of(cfg: TrainConfig) -> ImitationLoss | JumpStart | None:
    """The ``--guide`` method of a run, or None; a one-line ``ValueError`` for an unknown one."""
    if cfg.guide not in GUIDES:
        raise ValueError(f"--guide must be one of {', '.join(GUIDES)}, got {cfg.guide!r}")
    check_positive("guide_weight", cfg.guide_weight)
    if cfg.guide == "jump_start":
        return JumpStart(cfg.guide_weight, cfg.guide_anneal)
    return None if cfg.guide == "none" else ImitationLoss(cfg.guide_weight, cfg.guide_anneal, cfg.batch_size, cfg.seed)


def shaping_schedule(cfg: TrainConfig, scenario):
    """``set(venv, timesteps) -> weight`` that sets the annealed shaping weight (:func:`annealed`) in every
    engine of ``venv``, or None when the run anneals no shaping term; a one-line ``ValueError`` for an
    anneal with nothing to anneal."""
    check_int("guide_anneal", cfg.guide_anneal, 0, 10**12)
    names = [cfg.shaping] if cfg.shaping != "none" else expert_terms([scenario])  # --shaping, or --rewards' weight
    if cfg.guide_anneal == 0 or not names:
        if cfg.guide_anneal and cfg.guide == "none":
            raise ValueError(
                "--guide-anneal anneals the expert's guidance; give --shaping (or an expert term's weight in "
                "--rewards) or --guide"
            )
        return None
    weights = {name: scenario.rewards.as_dict()[name] for name in names}

    def set_weight(venv, timesteps: int) -> float:
        for name, weight in weights.items():
            w = annealed(weight, cfg.guide_anneal, timesteps)
            for group in venv.groups:
                group.engine.weights[name] = w
        return w

    return set_weight


def zero_action_head(model) -> None:
    """Zero the weights and bias of an SB3 policy's action head: its mean action is then exactly 0
    for every observation (an untrained residual is its planner, bit for bit); the gradients still
    flow (they scale with the features)."""
    import torch

    with torch.no_grad():
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.zero_()


def check_init_residual(init: Checkpoint, residual: Residual | None) -> None:
    """``--init`` from a network whose actions mean what this run's mean: a residual's correction of the same planner
    (same scale and gate), or plain actions on both sides; a ``ValueError`` otherwise (the weights were taken either
    way, and a residual's correction network drove as if it were a policy: no robot arrived)."""
    theirs = Residual.of(init.record.get("config", {}) if isinstance(init.record, dict) else {})
    if theirs == residual:
        return
    if theirs is None:
        raise ValueError(
            f"--init {init.describe()} is no residual policy (its network's actions are actions), but this run is a "
            f"residual over {residual.planner}: start it without --init, or from a residual run with the same rule"
        )
    flags = f"--residual {theirs.planner} --residual-scale {theirs.scale}" + (" --residual-gate" if theirs.gate else "")
    raise ValueError(
        f"--init {init.describe()} is a residual policy ({flags}): its network's actions correct that planner's; give "
        f"this run the same {flags}"
    )


def train(cfg: TrainConfig, resume: str | Checkpoint | None = None) -> dict[str, Any]:
    """Train (or resume from the checkpoint ``resume``) a shared PPO policy; returns the final
    evaluation and paths."""
    check_run(cfg)
    init, resume = (open_checkpoint(p) if p else None for p in (cfg.init, resume))  # fail fast, before torch
    check_fresh_out(cfg.out, resume_hint=resume is None, resume=resume)
    scenarios = mixture_scenarios(cfg, cfg.mixture) if cfg.mixture else [build_scenario(cfg)]
    scenario = scenarios[0]
    print_suite_differences(scenarios)
    warn_blind_training(scenarios)
    check_ppo_settings(cfg)
    residual, anneal, guide = residual_of(cfg, scenarios), shaping_schedule(cfg, scenario), guide_of(cfg)
    expert = "vcs" if guide is not None else None
    if cfg.mixture_balance not in ("worlds", "robots"):
        raise ValueError(f"mixture_balance must be worlds or robots, got {cfg.mixture_balance!r}")
    starts = start_states(cfg, scenarios)
    resume = kept_start(resume, cfg.out) if resume is not None else None
    if init is not None and resume is None:  # a resumed run's --init only records where it started
        check_init_residual(init, residual)
    if cfg.eval_suite:
        get_suite(cfg.eval_suite)  # an unknown name raises here, not after the first rollouts

    import torch

    torch.set_num_threads(1)
    from stable_baselines3 import PPO

    from ..vec_env import MixtureVecEnv, NavVecEnv

    out = Path(cfg.out)
    made, wrote = not out.exists(), False
    out.mkdir(parents=True, exist_ok=True)
    try:  # a run refused while it is set up leaves no directory (or config.json) of its own behind
        t_start = time.time()
        if len(scenarios) == 1:
            venv = NavVecEnv(
                scenario, cfg.n_worlds, expert=expert, gamma=cfg.gamma, start_states=starts, residual=residual
            )
        else:
            venv = MixtureVecEnv(
                scenarios, cfg.n_worlds, expert=expert, gamma=cfg.gamma, balance=cfg.mixture_balance,
                start_states=starts, residual=residual,
            )  # fmt: skip
        tb = str(out / "tb") if cfg.tensorboard else None
        if resume:  # the weights, PPO settings and network are the checkpoint's; cfg.init only records the start
            model = resume.load(scenario, env=venv)
            model.tensorboard_log = tb
            model.set_random_seed(cfg.seed + model.num_timesteps)  # fresh, reproducible worlds after resuming
            print(f"resumed {resume} at {model.num_timesteps} timesteps")
            if resume.record.get("shield"):  # attached after that run by vcs-env shield; PPO trains the network
                print(
                    f"note: {resume.path} carries a shield in its run record (vcs-env shield); this run's checkpoints "
                    f"are saved without it: vcs-env shield {out / 'model.zip'} adds it again"
                )
        else:
            kwargs = ppo_kwargs(cfg, scenario)
            model = PPO("MlpPolicy", venv, seed=cfg.seed, device="cpu", tensorboard_log=tb, verbose=0, **kwargs)
            if residual is not None:
                zero_action_head(model)
            if init:
                meta = load_policy_weights(model, init, scenario)
                print(f"initialised the policy from {cfg.init} ({meta.get('kind', 'unknown')} checkpoint)")
                if cfg.init_log_std is not None:
                    with torch.no_grad():
                        model.policy.log_std.fill_(cfg.init_log_std)
        start_steps = int(model.num_timesteps)  # the checkpoint's for a resumed run, 0 for a new one
        write_text(out / "config.json", json.dumps(jsonable(cfg), indent=2) + "\n")
        wrote = True
        remaining = cfg.timesteps - model.num_timesteps
        periodic = PeriodicEval(cfg, scenarios, out, t_start)
        if resume:
            periodic.restore(model.num_timesteps)
        callback = _callback(cfg, scenarios, out, t_start, periodic, anneal, guide)
        what = ", ".join(f"{s.kind} (n={s.n_robots}, m={s.n_obstacles})" for s in scenarios[:6])
        what += f" and {len(scenarios) - 6} more" if len(scenarios) > 6 else ""
        print(
            f"training {what} shaping={cfg.shaping}"
            + (f" guide={cfg.guide} (weight {cfg.guide_weight})" if guide else "")
            + (f" residual={residual.planner} (scale {residual.scale})" if residual else "")
            + f": {venv.num_envs} slots, {remaining} timesteps -> {out}",
            flush=True,
        )
    except BaseException:
        if made:
            shutil.rmtree(out, ignore_errors=True)
        elif wrote and resume is None:
            (out / "config.json").unlink(missing_ok=True)
        raise
    rollout = model.n_steps * venv.num_envs
    if remaining > 0 and remaining % rollout:
        print(
            f"note: PPO learns in whole rollouts of {rollout} timesteps (n_steps x slots): this run stops at "
            f"{model.num_timesteps + -(-remaining // rollout) * rollout} timesteps, not {cfg.timesteps}",
            flush=True,
        )
    if isinstance(guide, JumpStart):  # SB3 resets the worlds before the first rollout starts: guide those too
        guide.rollout_start(venv, start_steps)
    if remaining > 0:
        try:
            model.learn(
                total_timesteps=remaining,
                callback=callback,
                progress_bar=cfg.progress_bar,
                tb_log_name="ppo",
                reset_num_timesteps=not resume,
            )
        except KeyboardInterrupt:  # Ctrl-C: keep the weights of the last update, and say how to go on
            steps = model.num_timesteps
            family = scenario_family(scenarios)
            kept = save_model(model, out / "checkpoints" / f"model_{steps}.zip", "ppo", cfg, scenario, family)
            print(f"interrupted at {steps} timesteps: saved {kept}; go on with: vcs-env train --resume {out}")
            raise
    if getattr(callback, "model", None) is None:  # learn() did not run (budget already reached)
        if not hasattr(model, "_logger"):
            from stable_baselines3.common.logger import configure

            model.set_logger(configure(None, []))
        callback.init_callback(model)
    callback.num_timesteps = model.num_timesteps
    if starts is not None:
        fresh, pooled = sum(g.engine.sim.start_counts for g in venv.groups)
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
        history=periodic.history,
        **resumed_from(resume, start_steps),
    )
    print(f"saved {path} ({model.num_timesteps} timesteps, {wall:.0f} s)")
    # A resumed run's scenario and evaluation flags too; its --init only records where the first run started.
    print_reproduce(
        config_command("train", dataclasses.replace(cfg, init=None) if resume else cfg), resume, start_steps
    )
    return {"model": str(path), "evaluation": final, "wall_time": wall}
