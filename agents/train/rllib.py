"""PPO with Ray RLlib (``vcs-env train --backend rllib``): the same policy on a laptop or a cluster.

The run is configured by :class:`~agents.runs.RLlibConfig`, the SB3 :class:`~agents.runs.TrainConfig` plus
where to run (``num_env_runners``, ``address``) and which env adapter to sample with. It maps onto
RLlib's new API stack: one shared RLModule (``"shared"``, MLP ``net_arch`` with separate policy
and value networks, state-independent log std starting at ``log_std_init``, as SB3's
``MlpPolicy``; RLlib's weight initialization, see :func:`set_log_std`) acts for every robot;
``num_env_runners`` env runners each own ``n_worlds`` worlds (:mod:`agents.train.rllib_env`); one PPO
update per ``n_steps * n_worlds * n_robots`` robot slot steps (whatever the number of runners),
in minibatches of ``batch_size`` for ``n_epochs`` epochs, with SB3's loss (no KL penalty, no
value clipping) and SB3's update (:mod:`agents.train.rllib_learner`: the batch shuffled before every
epoch, the first included, advantages normalized per minibatch, Adam eps 1e-5; RLlib's own
learner took the first epoch's minibatches in episode order, and from scratch on circle-8 about
half its runs learned to stand still). ``timesteps`` counts slot steps as SB3 does: a
robot that finished early still fills its slot until its world ends (SB3 feeds it padding, RLlib
skips it), so a budget buys the same number of world steps on both backends. Runs are seeded: a
toy run sampling in the driver (``num_env_runners=0``) repeats bit for bit
(tests/test_rllib_learner.py), and so did one with one env runner on a quiet machine; under heavy
load, runs with env runners have diverged (RLlib's sampling loop, cause not found).

A run directory holds::

    <out>/config.json            the RLlibConfig
    <out>/eval.jsonl             one line per periodic evaluation (agents.train.periodic, as the SB3 backend)
    <out>/checkpoint/            RLlib checkpoint (Algorithm.save_to_path) + vcs_env.json (the run record)
    <out>/checkpoints/checkpoint_<steps>/  periodic checkpoints (every checkpoint_freq steps), resumable

``vcs-env evaluate --policy <out>/checkpoint`` scores it like an SB3 checkpoint
(:class:`agents.checkpoint.RLlibCheckpoint`); ``vcs-env train --resume <out>`` continues it from its
newest checkpoint.

Example::

    vcs-env train --backend rllib --scenario circle --n-robots 8 --jitter 0.1 --num-env-runners 2
    vcs-env train --backend rllib --num-env-runners 8 --address 10.0.0.1:6379   # a running cluster
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Any

from vcs_env.files import write_text
from vcs_env.scenario import Scenario
from vcs_env.suites import get_suite

from ..checkpoint import Checkpoint, RLlibCheckpoint, RLlibPolicy, import_ray, open_checkpoint
from ..config import build_scenario
from ..policies import warn_blind_training
from ..runs import (
    ADAPTERS,
    RLlibConfig,
    check_fresh_out,
    check_run,
    jsonable,
    kept_start,
    print_reproduce,
    resumed_from,
    run_command,
    run_record,
)
from . import check_ppo_settings
from .periodic import PeriodicEval
from .rllib_cluster import init_ray

MODULE_ID = RLlibCheckpoint.MODULE_ID


# --------------------------------------------------------------------------- PPO
def ppo_config(cfg: RLlibConfig):
    """RLlib ``PPOConfig`` of a run (see the module docstring for the mapping)."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.tune.registry import register_env

    from .rllib_env import make_env  # Ray
    from .rllib_learner import SB3PPOLearner  # Ray, torch

    scenario = build_scenario(cfg)
    register_env("vcs_nav_rllib", make_env)
    slots = slots_per_env_step(cfg, scenario)
    if cfg.lr_schedule == "constant":
        lr: Any = cfg.learning_rate
    elif cfg.lr_schedule == "linear":  # RLlib's schedules count env steps
        lr = [[0, cfg.learning_rate], [max(1, cfg.timesteps // slots), 0.0]]
    else:
        raise ValueError(f"lr_schedule must be constant or linear, got {cfg.lr_schedule!r}")
    model = {
        "fcnet_hiddens": list(cfg.net_arch),
        "fcnet_activation": "tanh",
        "vf_share_layers": False,
        "free_log_std": True,
    }
    config = (
        PPOConfig()
        .framework("torch")
        .environment("vcs_nav_rllib", env_config={"config": dataclasses.asdict(cfg)}, disable_env_checking=True)
        .env_runners(
            num_env_runners=cfg.num_env_runners,
            num_envs_per_env_runner=1 if cfg.env_adapter == "batched" else cfg.n_worlds,
            num_cpus_per_env_runner=1,
            rollout_fragment_length="auto",
            gym_env_vectorize_mode="sync",
        )
        .learners(num_learners=0, learner_class=SB3PPOLearner)
        .multi_agent(
            policies={MODULE_ID},
            policy_mapping_fn=lambda agent_id, episode, **kw: MODULE_ID,
        )
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={MODULE_ID: RLModuleSpec(model_config=model)}))
        .training(
            lr=lr,
            gamma=cfg.gamma,
            lambda_=cfg.gae_lambda,
            clip_param=cfg.clip_range,
            entropy_coeff=cfg.ent_coef,
            vf_loss_coeff=cfg.vf_coef,
            grad_clip=cfg.max_grad_norm,
            grad_clip_by="global_norm",
            train_batch_size_per_learner=cfg.n_steps * cfg.n_worlds * scenario.n_robots // slots,
            minibatch_size=cfg.batch_size,
            num_epochs=cfg.n_epochs,
            use_kl_loss=False,
            vf_clip_param=float("inf"),
        )
        .debugging(seed=cfg.seed, log_level="ERROR")
    )
    # RLlib checks minibatch_size (robot steps of the one module) against the train batch in env
    # steps (one env step holds many robots): check the rest, then set the real minibatch.
    config.minibatch_size = min(cfg.batch_size, config.train_batch_size_per_learner)
    config.validate()
    config.minibatch_size = cfg.batch_size
    return config.experimental(_validate_config=False)


def learner_module(algo):
    """The shared RLModule the (local) learner updates: always the newest weights."""
    return algo.learner_group._learner.module[MODULE_ID]


def set_log_std(algo, value: float) -> None:
    """Start the free log std of the shared module at ``value`` (RLlib starts it at 0), then copy
    the module to every env runner. The weights keep RLlib's (torch's) initialization: SB3's
    orthogonal one (gains sqrt(2), 0.01 on the action mean, 1 on the value) made 2 of 2 seeds on
    circle-8 learn to stand still, against 1 of 3 with RLlib's (batched adapter, RLlib's own learner
    before :mod:`agents.train.rllib_learner`; policies/README.md)."""
    import torch

    with torch.no_grad():
        learner_module(algo).pi.log_std.fill_(value)
    algo.env_runner_group.sync_weights(from_worker_or_learner_group=algo.learner_group, inference_only=True)


# --------------------------------------------------------------------------- training
def slots_per_env_step(cfg: RLlibConfig, scenario) -> int:
    """Robot slots of one RLlib env step: ``n_worlds * n`` (batched) or ``n`` (pettingzoo)."""
    return scenario.n_robots * (cfg.n_worlds if cfg.env_adapter == "batched" else 1)


def sampled_env_steps(result: dict[str, Any]) -> int:
    """Env steps sampled so far (lifetime) from an ``Algorithm.train()`` result."""
    return int(result.get("env_runners", {}).get("num_env_steps_sampled_lifetime", 0))


def sampled_agent_steps(result: dict[str, Any]) -> int:
    """Robot steps sampled so far (lifetime; robots that finished early take none)."""
    steps = result.get("env_runners", {}).get("num_agent_steps_sampled_lifetime", 0)
    return int(sum(steps.values()) if isinstance(steps, dict) else steps)


def save(algo, path: Path, cfg: RLlibConfig, scenario: Scenario, steps: int, **extra: Any) -> Path:
    """Save ``algo`` to the checkpoint directory ``path`` with its run record (``vcs_env.json``)."""
    ckpt = Path(algo.save_to_path(path.resolve().as_posix()))
    meta = run_record("rllib_ppo", cfg, scenario, None, steps, **extra)
    write_text(ckpt / RLlibCheckpoint.record_name, json.dumps(meta, indent=2, allow_nan=False) + "\n")
    return ckpt


def check_config(cfg: RLlibConfig) -> None:
    """A one-line ``ValueError`` for settings an RLlib run cannot take (SB3-only flags among them)."""
    check_run(cfg)
    if cfg.num_env_runners < 0:
        raise ValueError(f"num_env_runners must be >= 0, got {cfg.num_env_runners}")
    if cfg.env_adapter not in ADAPTERS:
        raise ValueError(f"env_adapter must be one of {list(ADAPTERS)}, got {cfg.env_adapter!r}")
    if cfg.init:
        raise ValueError("--init is not supported with --backend rllib (it loads SB3 weights)")
    if cfg.mixture or cfg.mixture_balance != "worlds":
        raise ValueError("--mixture and --mixture-balance apply to the SB3 backend only (RLlib runs one scenario)")
    if cfg.target_kl is not None:
        raise ValueError("--target-kl applies to the SB3 backend only (RLlib's PPO adapts a KL coefficient instead)")
    if cfg.start_states is not None:
        raise ValueError("--start-states applies to the SB3 backend only (the RLlib env runners start fresh)")
    if cfg.residual is not None or cfg.residual_gate:
        flag = f"--residual {cfg.residual}" if cfg.residual is not None else "--residual-gate"
        raise ValueError(f"{flag} applies to the SB3 backend only (train it with --backend sb3)")
    if cfg.guide != "none" or cfg.guide_anneal:
        raise ValueError("--guide and --guide-anneal apply to the SB3 backend only (train it with --backend sb3)")
    if cfg.features != "flat":
        raise ValueError(
            f"--backend rllib reads the flat observation only (--features flat), got --features {cfg.features!r} "
            "(contact is SB3 only)"
        )
    if cfg.eval_suite:
        get_suite(cfg.eval_suite)
    check_ppo_settings(cfg)  # after the SB3-only refusals: --target-kl is named as one of them


def train(cfg: RLlibConfig, resume: str | Checkpoint | None = None) -> dict[str, Any]:
    """Train a shared PPO policy with RLlib, or continue the RLlib checkpoint ``resume``; returns
    the final evaluation, paths and throughput."""
    scenario = build_scenario(cfg)
    check_config(cfg)
    warn_blind_training([scenario])
    resume = open_checkpoint(resume) if resume is not None else None
    check_fresh_out(cfg.out, resume_hint=resume is None, resume=resume)
    if resume is not None:
        if not isinstance(resume, RLlibCheckpoint):
            raise ValueError(f"--backend rllib continues RLlib checkpoints; {resume.describe()} is an SB3 one")
        resume = kept_start(resume, cfg.out)
    ours = not import_ray().is_initialized()  # a Ray the caller started stays up after the run
    ray = init_ray(cfg)
    import torch

    torch.set_num_threads(1)
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "config.json", json.dumps(jsonable(cfg), indent=2) + "\n")
    t_start = time.time()
    algo = ppo_config(cfg).build_algo()
    try:
        steps = 0
        if resume is None:
            set_log_std(algo, cfg.log_std_init)
        else:  # weights, optimizer and step counters (RLlib's metrics) are the checkpoint's
            algo.restore_from_path(resume.path.resolve().as_posix())
            steps = resume.timesteps
            print(f"resumed {resume.path} at {steps} timesteps", flush=True)
        module = learner_module(algo)
        print(
            f"training {scenario.kind} (n={scenario.n_robots}, m={scenario.n_obstacles}) with RLlib: "
            f"{cfg.num_env_runners} env runners x {cfg.n_worlds} worlds ({cfg.env_adapter}), "
            f"{cfg.timesteps - steps} timesteps -> {out}",
            flush=True,
        )
        periodic = PeriodicEval(cfg, [scenario], out, t_start)
        if resume is not None:
            periodic.restore(steps)
        last_eval = last_ckpt = steps
        slots = slots_per_env_step(cfg, scenario)
        while steps < cfg.timesteps:
            result = algo.train()
            steps = sampled_env_steps(result) * slots  # timesteps as SB3 counts them: slot steps
            if cfg.eval_freq > 0 and steps - last_eval >= cfg.eval_freq and steps < cfg.timesteps:
                last_eval = steps
                periodic(RLlibPolicy(module), steps)
            if cfg.checkpoint_freq > 0 and steps - last_ckpt >= cfg.checkpoint_freq and steps < cfg.timesteps:
                last_ckpt = steps
                save(algo, out / "checkpoints" / f"checkpoint_{steps}", cfg, scenario, steps)
        final = periodic(RLlibPolicy(module), steps)
        wall = round(time.time() - t_start, 1)
        ckpt = save(
            algo, out / "checkpoint", cfg, scenario, steps, evaluation=final, wall_time=wall, history=periodic.history,
            **resumed_from(resume, resume.timesteps if resume is not None else 0),
        )  # fmt: skip
    finally:
        algo.stop()
        if ours:
            ray.shutdown()
    print(f"saved {ckpt} ({steps} timesteps, {wall:.0f} s)")
    print_reproduce(run_command("rllib_ppo", cfg), resume, resume.timesteps if resume is not None else 0)
    return {"checkpoint": str(ckpt), "evaluation": final, "wall_time": wall, "timesteps": steps}
