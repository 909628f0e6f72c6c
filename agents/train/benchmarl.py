"""Multi-agent RL with BenchMARL (``vcs-env train --backend benchmarl --algorithm mappo|ippo|masac``).

The run is configured by :class:`~agents.runs.BenchMARLConfig` (the SB3 :class:`~agents.runs.TrainConfig` plus
the algorithm). It maps onto a BenchMARL ``Experiment`` over :class:`vcs_env.benchmarl.VcsNavClass` (the
batched TorchRL env :class:`vcs_env.torchrl.VcsNavEnv`, every robot an agent of the group ``"agents"``):

* ``net_arch``: the MLP of the policy (shared by every robot) and of the critic, tanh activations;
* ``n_worlds`` worlds in one env; ``n_steps * n_worlds`` world steps per batch (on- and off-policy);
* PPO (mappo, ippo): ``n_epochs`` passes over each batch in minibatches of ``batch_size`` robot steps
  (``batch_size / n_robots`` world steps: a BenchMARL frame is one world step of every robot), ``clip_range``,
  ``gae_lambda``, ``ent_coef``; SAC (masac): minibatches of ``batch_size`` robot steps, one gradient step per 6
  world steps collected (BenchMARL's default ratio), from a replay memory of 100 k world steps;
* ``learning_rate`` (constant), ``gamma``, ``max_grad_norm`` (gradient norm clip), ``seed``;
* ``timesteps`` counts robot slot steps as the SB3 backend does (world steps x robots), so a budget buys the
  same world steps on every backend.

A run directory holds::

    <out>/config.json       the BenchMARLConfig
    <out>/eval.jsonl        one line per periodic evaluation (agents.train.periodic, as the other backends)
    <out>/actor.pt          the policy network (agents.checkpoint.BenchMARLCheckpoint), actor.json its record
    <out>/benchmarl/        BenchMARL's own experiment folder (csv logs, its checkpoint for its own tools)

``vcs-env evaluate --policy <out>``, ``compare`` and ``export --onnx`` load ``actor.pt`` with torch alone.
"""

from __future__ import annotations

import copy
import json
import math
import time
from pathlib import Path
from typing import Any

from vcs_env.observations import observation_bounds

from ..checkpoint import BenchMARLCheckpoint, BenchMARLPolicy
from ..config import build_scenario
from ..runs import BENCHMARL_ALGORITHMS, BenchMARLConfig, check_run, jsonable, run_command, run_record
from .periodic import PeriodicEval

INSTALL = (
    'pip install "vcs-env[benchmarl]" && pip install --no-deps benchmarl==1.5.2 (after torch, see docs/torchrl.md)'
)
"""How to install BenchMARL, for error messages."""


def import_benchmarl():
    """``benchmarl``, or a one-line ImportError naming how to install it."""
    try:
        import benchmarl
        import benchmarl.experiment  # noqa: F401
    except ImportError as e:
        raise ImportError(f"--backend benchmarl needs BenchMARL; install it with: {INSTALL} ({e})") from None
    return benchmarl


def check_config(cfg: BenchMARLConfig, n_robots: int) -> None:
    """A one-line ``ValueError`` for a setting the BenchMARL backend does not have."""
    check_run(cfg)
    if cfg.algorithm not in BENCHMARL_ALGORITHMS:
        raise ValueError(f"--algorithm must be one of {', '.join(BENCHMARL_ALGORITHMS)}, got {cfg.algorithm!r}")
    unsupported = {
        "--residual": cfg.residual is not None,
        "--guide": cfg.guide != "none",
        "--init": cfg.init is not None,
        "--mixture": bool(cfg.mixture),
        "--start-states": cfg.start_states is not None,
        "--features slots": cfg.features != "flat",
        "--lr-schedule linear": cfg.lr_schedule != "constant",
        "--target-kl": cfg.target_kl is not None,
        "--shaping": cfg.shaping != "none",
    }
    given = [flag for flag, on in unsupported.items() if on]
    if given:
        raise ValueError(f"{', '.join(given)} not available with --backend benchmarl (the SB3 backend has them)")
    if cfg.batch_size < n_robots:
        raise ValueError(f"--batch-size must be at least the robots of a world ({n_robots}), got {cfg.batch_size}")


def experiment_config(cfg: BenchMARLConfig, n_robots: int, folder: Path):
    """BenchMARL's ``ExperimentConfig`` of a run (see the module docstring for the mapping)."""
    from benchmarl.experiment import ExperimentConfig

    e = ExperimentConfig.get_from_yaml()
    per_batch = cfg.n_steps * cfg.n_worlds  # world steps
    e.max_n_frames = max(per_batch, math.ceil(cfg.timesteps / n_robots / per_batch) * per_batch)
    e.lr, e.gamma, e.clip_grad_norm, e.clip_grad_val = cfg.learning_rate, cfg.gamma, True, cfg.max_grad_norm
    e.on_policy_collected_frames_per_batch = e.off_policy_collected_frames_per_batch = per_batch
    e.on_policy_n_envs_per_worker = e.off_policy_n_envs_per_worker = cfg.n_worlds
    e.on_policy_minibatch_size = e.off_policy_train_batch_size = max(1, cfg.batch_size // n_robots)
    e.on_policy_n_minibatch_iters = cfg.n_epochs
    e.off_policy_n_optimizer_steps = max(1, math.ceil(per_batch / 6))  # BenchMARL's ratio: 1000 per 6000 frames
    e.off_policy_memory_size = 100_000
    e.sampling_device = e.train_device = e.buffer_device = "cpu"
    e.share_policy_params, e.prefer_continuous_actions = True, True
    e.evaluation, e.render, e.create_json = False, False, False  # evaluation: ours (PeriodicEval)
    e.loggers = ["csv"]
    e.save_folder = str(folder)
    e.checkpoint_interval = 0
    e.checkpoint_at_end = True
    e.keep_checkpoints_num = 1
    return e


def algorithm_config(cfg: BenchMARLConfig):
    """BenchMARL's algorithm config of a run (its defaults, with the PPO settings of ``cfg``)."""
    from benchmarl.algorithms import IppoConfig, MappoConfig, MasacConfig

    if cfg.algorithm == "masac":
        return MasacConfig.get_from_yaml()
    a = {"mappo": MappoConfig, "ippo": IppoConfig}[cfg.algorithm].get_from_yaml()
    a.clip_epsilon, a.lmbda, a.entropy_coef = cfg.clip_range, cfg.gae_lambda, cfg.ent_coef
    return a


def actor_network(policy, scenario) -> tuple[Any, dict[str, Any]]:
    """The shared policy MLP of a BenchMARL policy (continuous actions, TanhNormal over [-1, 1], parameters
    shared by the group) as a plain ``torch.nn.Sequential`` and its layout (:class:`BenchMARLCheckpoint`), with
    the observation bounds of ``scenario`` (the env's observation space)."""
    import torch
    from tensordict.nn import NormalParamExtractor
    from torchrl.modules import MultiAgentMLP, TanhNormal

    mlps = [m for m in policy.modules() if isinstance(m, MultiAgentMLP)]
    extractors = [m for m in policy.modules() if isinstance(m, NormalParamExtractor)]
    dists = [m for m in policy.modules() if getattr(m, "distribution_class", None) is not None]
    if len(mlps) != 1 or len(extractors) != 1 or len(dists) != 1 or dists[0].distribution_class is not TanhNormal:
        raise ValueError("expected one shared MLP, a NormalParamExtractor and a TanhNormal action (BenchMARL's MLP)")
    mlp, mapping = mlps[0], extractors[0].scale_mapping
    low, high = observation_bounds(scenario)
    if not mlp.share_params:
        raise ValueError("the policy's parameters are not shared by the robots (share_policy_params=False)")
    layers, sizes, activation = [], [], None
    for m in mlp._empty_net:
        if isinstance(m, torch.nn.Linear):
            layers.append(torch.nn.Linear(m.in_features, m.out_features))
            sizes.append([m.in_features, m.out_features])
        else:
            name = type(m).__name__
            if activation not in (None, name) or not hasattr(torch.nn, name):
                raise ValueError(f"unsupported layer {name} in the policy MLP (one torch.nn activation expected)")
            activation = name
            layers.append(getattr(torch.nn, name)())
    net = torch.nn.Sequential(*layers)
    net.load_state_dict({k: v.detach().clone() for k, v in mlp.params.flatten_keys(".").items(True, True)})
    layout = {
        "layers": sizes,
        "activation": activation,
        "scale": {"bias": float(getattr(mapping, "bias", 0.0)), "min": float(getattr(mapping, "min_val", 0.0))},
        "low": [float(x) for x in low],
        "high": [float(x) for x in high],
    }
    return net, layout


def save_actor(policy, scenario, path: Path, record: dict[str, Any]) -> BenchMARLCheckpoint:
    """Write the policy network to ``path`` (``actor.pt``) and its run record beside it (``actor.json``)."""
    import torch

    net, layout = actor_network(policy, scenario)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({**layout, "state_dict": net.state_dict()}, path)
    ckpt = BenchMARLCheckpoint(path, path.with_suffix(".json"))
    ckpt.record_path.write_text(json.dumps(jsonable(record), indent=2, allow_nan=False) + "\n")
    return ckpt


def make_experiment(cfg: BenchMARLConfig, scenario, folder: Path, callbacks=()):
    """The BenchMARL ``Experiment`` of a run on ``scenario`` (checked), logging into ``folder``."""
    import_benchmarl()
    import torch
    from benchmarl.experiment import Experiment
    from benchmarl.models import MlpConfig

    from vcs_env.benchmarl import VcsNavClass

    torch.set_num_threads(1)
    check_config(cfg, scenario.n_robots)
    folder.mkdir(parents=True, exist_ok=True)
    model = MlpConfig(num_cells=list(cfg.net_arch), activation_class=torch.nn.Tanh, layer_class=torch.nn.Linear)
    task = VcsNavClass(name=scenario.kind.upper(), config={"scenario": scenario, "max_steps": cfg.max_steps})
    return Experiment(
        task,
        algorithm_config(cfg),
        model,
        seed=cfg.seed,
        config=experiment_config(cfg, scenario.n_robots, folder),
        critic_model_config=copy.deepcopy(model),
        callbacks=list(callbacks),
    )


def train(cfg: BenchMARLConfig) -> Path:
    """Run a BenchMARL experiment, evaluate it every ``eval_freq`` timesteps, save ``<out>/actor.pt``."""
    import_benchmarl()
    from .benchmarl_callback import Evaluate  # BenchMARL

    scenario = build_scenario(cfg)
    n = scenario.n_robots
    check_config(cfg, n)
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.json").write_text(json.dumps(jsonable(cfg), indent=2) + "\n")
    kind = f"benchmarl_{cfg.algorithm}"
    t0 = time.time()
    evaluator = PeriodicEval(cfg, [scenario], out, t0)
    exp = make_experiment(cfg, scenario, out / "benchmarl", [Evaluate(evaluator, scenario, out.name, actor_network)])
    print(f"BenchMARL {cfg.algorithm}: {exp.config.max_n_frames} world steps ({exp.config.max_n_frames * n} robot "
          f"steps), {cfg.n_worlds} worlds, folder {exp.folder_name}", flush=True)  # fmt: skip
    exp.run()
    steps = exp.total_frames * n
    if cfg.eval_freq > 0 and (not evaluator.history or evaluator.history[-1]["timesteps"] != steps):
        net, layout = actor_network(exp.policy, scenario)
        evaluator(BenchMARLPolicy(net, layout, name=out.name), steps)
    last = evaluator.history[-1] if evaluator.history else None
    record = run_record(
        kind, cfg, scenario, None, steps, wall_time=round(time.time() - t0, 1), final_eval=last,
        history=evaluator.history,
    )  # fmt: skip
    ckpt = save_actor(exp.policy, scenario, out / "actor.pt", record)
    print(f"saved {ckpt.path} ({steps} timesteps, {time.time() - t0:.0f} s)")
    print(f"reproduce: {run_command(kind, cfg)}")
    return ckpt.path
