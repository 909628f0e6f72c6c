"""PPO with Ray RLlib (``vcs-env train --backend rllib``): the same policy on a laptop or a cluster.

The run is configured by :class:`RLlibConfig`, the SB3 :class:`~agents.train.TrainConfig` plus
where to run (``num_env_runners``, ``address``) and which env adapter to sample with. It maps onto
RLlib's new API stack: one shared RLModule (``"shared"``, MLP ``net_arch`` with separate policy
and value networks, state-independent log std starting at ``log_std_init``, as SB3's
``MlpPolicy``; RLlib's weight initialization, see :func:`set_log_std`) acts for every robot;
``num_env_runners`` env runners each own ``n_worlds`` worlds (:mod:`agents.rllib_env`); one PPO
update per ``n_steps * n_worlds * n_robots`` robot slot steps (whatever the number of runners),
in minibatches of ``batch_size`` for ``n_epochs`` epochs, with SB3's loss (no KL penalty, no
value clipping) and SB3's update (:mod:`agents.rllib_learner`: the batch shuffled before every
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
    <out>/eval.jsonl             one line per periodic evaluation (same metrics as vcs-env train)
    <out>/checkpoint/            RLlib checkpoint (Algorithm.save_to_path) + vcs_env.json
    <out>/checkpoint/vcs_env.json  kind, observation size, config, scenario, rebuild command, results

``vcs-env evaluate --policy <out>/checkpoint`` scores it like an SB3 checkpoint (:func:`load_policy`).

Example::

    vcs-env train --backend rllib --scenario circle --n-robots 8 --jitter 0.1 --num-env-runners 2
    vcs-env train --backend rllib --num-env-runners 8 --address 10.0.0.1:6379   # a running cluster
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .config import add_config_args, build_scenario, config_command, config_from_args
from .rllib_cluster import INSTALL_HINT, LOCAL_NODE_IP, import_ray, init_ray  # noqa: F401  (re-exported)
from .train import TrainConfig, scalar_results

MODULE_ID = "shared"
METADATA = "vcs_env.json"
"""Name of the metadata file inside an RLlib checkpoint directory."""
ADAPTERS = ("batched", "pettingzoo")
"""Env adapters of :mod:`agents.rllib_env`."""


@dataclass
class RLlibConfig(TrainConfig):
    """A ``vcs-env train --backend rllib`` run: :class:`TrainConfig` plus where it runs."""

    num_env_runners: int = 1
    """RLlib env runners (sampling processes) for --backend rllib; each owns n_worlds worlds and
    takes one CPU of the cluster (0: sample in the driver)."""
    address: str | None = None
    """Ray cluster to join for --backend rllib (host:port of a `ray start --head`, or auto);
    None: start a local Ray instance for this run."""
    out: str = "runs/rllib"
    """Run directory (config.json, eval.jsonl, checkpoint/)."""
    env_adapter: str = "pettingzoo"
    """Env adapter for --backend rllib: pettingzoo (RLlib's ParallelPettingZooEnv over
    vcs_env.parallel_env, n_worlds of them per runner, each restarting on its own as in the SB3
    path) or batched (n_worlds worlds in one numpy call per runner, restarting together). batched
    samples 1.2x faster (benchmarks/RESULTS.md) but learns later and less steadily: its finished
    worlds wait for the slowest one, so a few slow worlds fill the train batch. On circle-8 from
    scratch pettingzoo learns like SB3, batched gets there by 1 M steps (results/rllib-circle8)."""


RLLIB_ONLY = tuple(f.name for f in dataclasses.fields(RLlibConfig) if f.name not in TrainConfig.__dataclass_fields__)


def add_rllib_args(parser) -> None:
    """The ``--num-env-runners``, ``--address``, ``--env-adapter`` flags of ``vcs-env train``."""
    add_config_args(parser, RLlibConfig, skip=tuple(TrainConfig.__dataclass_fields__))


def reject_rllib_flags(args) -> None:
    """A ``ValueError`` if a flag of :data:`RLLIB_ONLY` was given without ``--backend rllib``."""
    given = [f"--{name.replace('_', '-')}" for name in RLLIB_ONLY if getattr(args, name, None) is not None]
    if given:
        raise ValueError(f"{', '.join(given)} only apply to --backend rllib")


def rebuild_command(cfg: RLlibConfig) -> str:
    """The ``vcs-env train --backend rllib ...`` line that rebuilds ``cfg``."""
    head, _, rest = config_command("train", cfg).partition(" train")
    return f"{head} train --backend rllib{rest}"


# --------------------------------------------------------------------------- PPO
def ppo_config(cfg: RLlibConfig):
    """RLlib ``PPOConfig`` of a run (see the module docstring for the mapping)."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.tune.registry import register_env

    from .rllib_env import make_env
    from .rllib_learner import SB3PPOLearner

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
    before :mod:`agents.rllib_learner`; policies/README.md)."""
    import torch

    with torch.no_grad():
        learner_module(algo).pi.log_std.fill_(value)
    algo.env_runner_group.sync_weights(from_worker_or_learner_group=algo.learner_group, inference_only=True)


# --------------------------------------------------------------------------- policy
class RLlibPolicy:
    """An RLlib RLModule as an SB3-style ``PolicyPredictor`` for :mod:`agents.evaluate`.

    ``predict(obs (N, D)) -> (actions (N, 2) in [-1, 1], None)``: the Gaussian's mean with
    ``deterministic=True``, else a sample drawn from ``rng``.
    """

    def __init__(self, module, name: str = "rllib", rng: np.random.Generator | None = None):
        self.module = module
        self.name = name
        self.observation_space = module.observation_space
        self.action_space = module.action_space
        self.rng = rng if rng is not None else np.random.default_rng(0)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False):
        import torch

        obs = torch.as_tensor(np.asarray(observation, dtype=np.float32)).reshape(-1, self.observation_space.shape[0])
        with torch.no_grad():
            out = self.module.forward_inference({"obs": obs})["action_dist_inputs"].numpy()
        mean, log_std = np.split(out.astype(np.float64), 2, axis=-1)
        actions = mean if deterministic else mean + np.exp(log_std) * self.rng.standard_normal(mean.shape)
        return np.clip(actions, -1.0, 1.0).astype(np.float32), state


def is_rllib_checkpoint(path: str | os.PathLike) -> bool:
    """True for a directory written by :func:`train` (or its run directory)."""
    p = Path(path)
    return (p / METADATA).is_file() or (p / "checkpoint" / METADATA).is_file()


def load_policy(path: str | os.PathLike, scenario=None) -> RLlibPolicy:
    """The shared module of an RLlib checkpoint as an :class:`RLlibPolicy`.

    Args:
        path: the checkpoint directory (``<out>/checkpoint``) or its run directory ``<out>``.
        scenario: if given, the policy's observation space must be this scenario's.

    Raises:
        agents.checkpoint.CheckpointError: not such a checkpoint, unreadable, or made for
            another observation space.
        ImportError: Ray RLlib is not installed.
    """
    from .checkpoint import CheckpointError, check_checkpoint_fits

    p = Path(path)
    if not (p / METADATA).is_file() and (p / "checkpoint" / METADATA).is_file():
        p = p / "checkpoint"
    if not (p / METADATA).is_file():
        raise CheckpointError(f"{str(path)!r} is not an RLlib checkpoint of vcs-env train (no {METADATA} in it)")
    try:
        meta = json.loads((p / METADATA).read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise CheckpointError(f"RLlib checkpoint metadata {str(p / METADATA)!r} is not valid JSON: {e}") from None
    module_dir = p / "learner_group" / "learner" / "rl_module" / MODULE_ID
    if not module_dir.is_dir():
        raise CheckpointError(f"RLlib checkpoint {str(p)!r} has no module {MODULE_ID!r} (expected {module_dir})")
    if scenario is not None:  # before the slow import: the observation size is in the metadata
        from vcs_env.spaces import observation_space

        from .checkpoint import SIZE_HINT

        dim, want = meta.get("observation_dim"), observation_space(scenario).shape[0]
        if dim != want:
            raise CheckpointError(
                f"RLlib checkpoint {str(p)!r} was made for observations of size {dim}, but scenario "
                f"kind={scenario.kind!r} with n_neighbors={scenario.n_neighbors} gives {want} "
                f"{SIZE_HINT}; use a policy trained for this observation layout"
            )
    import_ray()
    import torch
    from ray.rllib.core.rl_module.rl_module import RLModule

    torch.set_num_threads(1)
    try:
        module = RLModule.from_checkpoint(module_dir.resolve().as_posix())
    except Exception as e:
        raise CheckpointError(f"RLlib checkpoint {str(p)!r} could not be loaded: {type(e).__name__}: {e}") from None
    if scenario is not None:
        check_checkpoint_fits(meta, module.observation_space, scenario, f"RLlib checkpoint {str(p)!r}")
    module.eval()
    return RLlibPolicy(module, name=Path(meta.get("config", {}).get("out", p.parent.name)).name)


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


def evaluate_module(module, cfg: RLlibConfig, scenario) -> dict[str, Any]:
    """The periodic evaluation of ``vcs-env train`` (:func:`agents.evaluate.score_seeds` on the
    training scenario, and the harness on ``cfg.eval_suite``) for an RLModule."""
    from .evaluate import evaluate as score_on_suite
    from .evaluate import score_seeds
    from .policies import predictor_controller

    policy = RLlibPolicy(module)
    seeds = list(range(cfg.eval_seed, cfg.eval_seed + cfg.eval_episodes))
    res = scalar_results(score_seeds(predictor_controller(policy), scenario, seeds))
    if cfg.eval_suite:
        summary = score_on_suite(policy, cfg.eval_suite, progress=False).summary
        res["suite"] = {k: summary[k]["mean"] for k in ("success", "collision", "time_to_goal")}
    return res


def train(cfg: RLlibConfig) -> dict[str, Any]:
    """Train a shared PPO policy with RLlib; returns the final evaluation, paths and throughput."""
    from vcs_env.observations import observation_config

    from .checkpoint import jsonable, scenario_family

    scenario = build_scenario(cfg)
    if cfg.timesteps < 0 or cfg.n_worlds < 1 or cfg.eval_episodes < 1 or cfg.num_env_runners < 0:
        raise ValueError("timesteps and num_env_runners must be >= 0, n_worlds and eval_episodes >= 1")
    if cfg.env_adapter not in ADAPTERS:
        raise ValueError(f"env_adapter must be one of {list(ADAPTERS)}, got {cfg.env_adapter!r}")
    if cfg.init:
        raise ValueError("--init is not supported with --backend rllib (it loads SB3 weights)")
    if cfg.mixture or cfg.mixture_balance != "worlds":
        raise ValueError("--mixture and --mixture-balance apply to the SB3 backend only (RLlib runs one scenario)")
    if cfg.target_kl is not None:
        raise ValueError("--target-kl applies to the SB3 backend only (RLlib's PPO adapts a KL coefficient instead)")
    if cfg.checkpoint_freq != TrainConfig.checkpoint_freq:
        raise ValueError("--checkpoint-freq applies to the SB3 backend only (RLlib saves one checkpoint at the end)")
    if cfg.start_states is not None:
        raise ValueError("--start-states applies to the SB3 backend only (the RLlib env runners start fresh)")
    if cfg.features != "flat":
        raise ValueError(
            f"--backend rllib reads the flat observation only (--features flat), got --features {cfg.features!r} "
            "(contact is SB3 only)"
        )
    if cfg.eval_suite:
        from vcs_env.suites import get_suite

        get_suite(cfg.eval_suite)
    ray = init_ray(cfg)
    import torch

    torch.set_num_threads(1)
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(jsonable(cfg), indent=2) + "\n")
    t_start = time.time()
    algo = ppo_config(cfg).build_algo()
    try:
        set_log_std(algo, cfg.log_std_init)
        module = learner_module(algo)
        print(
            f"training {scenario.kind} (n={scenario.n_robots}, m={scenario.n_obstacles}) with RLlib: "
            f"{cfg.num_env_runners} env runners x {cfg.n_worlds} worlds ({cfg.env_adapter}), "
            f"{cfg.timesteps} timesteps -> {out}",
            flush=True,
        )
        history: list[dict[str, Any]] = []
        steps, last_eval, slots = 0, 0, slots_per_env_step(cfg, scenario)

        def evaluate() -> dict[str, Any]:
            t0 = time.time()
            res = evaluate_module(module, cfg, scenario)
            res.update(
                timesteps=steps, wall_time=round(time.time() - t_start, 1), eval_seconds=round(time.time() - t0, 2)
            )
            history.append(res)
            with open(out / "eval.jsonl", "a") as f:
                f.write(json.dumps(jsonable(res)) + "\n")
            suite = ""
            if "suite" in res:
                s = res["suite"]
                suite = f"; {cfg.eval_suite}: success {s['success']:.2f} collision {s['collision']:.2f}"
            print(
                f"[eval @ {steps:>9d}] success {res['episode_success']:.2f} (robots {res['robot_success']:.3f}) "
                f"collision {res['episode_collision']:.2f} time-to-goal {res['time_to_goal']:.2f} s{suite}  "
                f"[{res['wall_time']:.0f} s]",
                flush=True,
            )
            return res

        while steps < cfg.timesteps:
            result = algo.train()
            steps = sampled_env_steps(result) * slots  # timesteps as SB3 counts them: slot steps
            if cfg.eval_freq > 0 and steps - last_eval >= cfg.eval_freq and steps < cfg.timesteps:
                last_eval = steps
                evaluate()
        final = evaluate()
        ckpt = Path(algo.save_to_path((out / "checkpoint").resolve().as_posix()))
    finally:
        algo.stop()
        ray.shutdown()
    wall = round(time.time() - t_start, 1)
    meta = {
        "kind": "rllib_ppo",
        "observation_dim": int(np.prod(module.observation_space.shape)),
        "observation": jsonable(observation_config(scenario)),
        "scenario_family": scenario_family(scenario),
        "num_timesteps": steps,
        "config": jsonable(cfg),
        "command": rebuild_command(cfg),
        "scenario": jsonable(scenario),
        "evaluation": jsonable(final),
        "wall_time": wall,
        "history": jsonable(history),
    }
    (ckpt / METADATA).write_text(json.dumps(meta, indent=2, allow_nan=False) + "\n")
    print(f"saved {ckpt} ({steps} timesteps, {wall:.0f} s)")
    print(f"reproduce: {rebuild_command(cfg)}")
    return {"checkpoint": str(ckpt), "evaluation": final, "wall_time": wall, "timesteps": steps}


def cmd_train(args) -> int:
    """``vcs-env train --backend rllib``: one-line errors for a missing extra or a bad cluster."""
    if getattr(args, "resume", None):
        raise ValueError("--resume is not supported with --backend rllib")
    cfg = config_from_args(RLlibConfig, args)
    try:
        train(cfg)
    except (ImportError, RuntimeError, ConnectionError) as e:
        print(f"vcs-env train: error: {e}", file=sys.stderr)
        return 2
    return 0
