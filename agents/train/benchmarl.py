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
* ``learning_rate`` (constant, or ``lr_schedule`` linear to 0 at the end of the budget), ``gamma``,
  ``max_grad_norm`` (gradient norm clip), ``seed``;
* ``timesteps`` counts robot slot steps as the SB3 backend does (world steps x robots), so a budget buys the
  same world steps on every backend.

A run directory holds::

    <out>/config.json       the BenchMARLConfig
    <out>/eval.jsonl        one line per periodic evaluation (agents.train.periodic, as the other backends)
    <out>/actor.pt          the policy network (agents.checkpoint.BenchMARLCheckpoint), actor.json its record
    <out>/checkpoints/actor_<steps>.pt  periodic ones (every checkpoint_freq timesteps), each with its record
    <out>/benchmarl/        BenchMARL's own experiment folder (csv logs, its checkpoint for its own tools)

``vcs-env evaluate --policy <out>``, ``compare`` and ``export --onnx`` load ``actor.pt`` with torch alone.
"""

from __future__ import annotations

import copy
import json
import math
import time
from functools import partial
from pathlib import Path
from typing import Any

from vcs_env.checks import install_hint
from vcs_env.files import replacing, write_text
from vcs_env.observations import observation_bounds
from vcs_env.suites import get_suite

from ..checkpoint import BenchMARLCheckpoint, BenchMARLPolicy
from ..config import build_scenario
from ..export import mlp_network
from ..policies import warn_blind_training
from ..runs import BENCHMARL_ALGORITHMS, BenchMARLConfig, check_fresh_out, check_run, jsonable, run_command, run_record
from . import check_ppo_settings
from .periodic import PeriodicEval

INSTALL = f"{install_hint('benchmarl')}, then pip install --no-deps benchmarl==1.5.2 (after torch, see docs/torchrl.md)"
"""How to install BenchMARL, for error messages."""


def import_benchmarl():
    """``benchmarl``, or a one-line ImportError naming how to install it."""
    try:
        import benchmarl
        import benchmarl.experiment  # noqa: F401
    except ImportError as e:
        raise ImportError(f"--backend benchmarl needs BenchMARL; install it with: {INSTALL} ({e})") from None
    return benchmarl


PPO_ONLY = {
    "n_epochs": "--n-epochs",
    "clip_range": "--clip-range",
    "gae_lambda": "--gae-lambda",
    "ent_coef": "--ent-coef",
}
"""PPO settings (flags) that SAC does not have."""


def check_config(cfg: BenchMARLConfig, n_robots: int) -> None:
    """A one-line ``ValueError`` for a bad setting or one the BenchMARL backend does not have."""
    check_run(cfg)
    check_ppo_settings(cfg)
    if cfg.algorithm not in BENCHMARL_ALGORITHMS:
        raise ValueError(f"--algorithm must be one of {', '.join(BENCHMARL_ALGORITHMS)}, got {cfg.algorithm!r}")
    if cfg.eval_suite is not None:
        get_suite(cfg.eval_suite)  # an unknown name fails now, not after the first update
    default = BenchMARLConfig()
    unsupported = {
        "--residual": cfg.residual is not None,
        "--residual-gate": cfg.residual_gate,
        "--guide": cfg.guide != "none",
        "--init": cfg.init is not None,
        "--mixture": bool(cfg.mixture),
        "--start-states": cfg.start_states is not None,
        f"--features {cfg.features}": cfg.features != "flat",
        f"--lr-schedule {cfg.lr_schedule}": cfg.lr_schedule not in ("constant", "linear"),
        "--target-kl": cfg.target_kl is not None,
        "--shaping": cfg.shaping != "none",
        "--guide-anneal": cfg.guide_anneal != default.guide_anneal,  # it anneals --shaping or --guide
        "--vf-coef": cfg.vf_coef != default.vf_coef,  # BenchMARL's critic_coef 1.0
        "--log-std-init": cfg.log_std_init != default.log_std_init,  # BenchMARL's scale starts at 1
    }
    if cfg.algorithm == "masac":
        unsupported.update({flag: getattr(cfg, k) != getattr(default, k) for k, flag in PPO_ONLY.items()})
    given = [flag for flag, on in unsupported.items() if on]
    if given:
        where = "with --algorithm masac" if cfg.algorithm == "masac" else "with --backend benchmarl"
        raise ValueError(f"{', '.join(given)} not available {where}")
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
    e.evaluation_episodes = 1  # BenchMARL builds a test env of this many worlds even without evaluation
    e.loggers = ["csv"]
    e.save_folder = str(folder)
    e.checkpoint_interval = 0  # ours: actor_<steps>.pt every checkpoint_freq (agents.train.benchmarl_callback)
    e.checkpoint_at_end = True
    e.keep_checkpoints_num = 1
    e.exclude_buffer_from_checkpoint = True  # MASAC's replay memory would make it hundreds of MB
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
    """The shared policy MLP of a BenchMARL policy as a plain ``torch.nn.Sequential`` (built by
    :func:`agents.export.mlp_network`, as a loaded checkpoint is) and its layout (:class:`BenchMARLCheckpoint`),
    with the observation bounds of ``scenario``. ``ValueError`` unless the policy is what vcs-env's runs build:
    one MLP (linear layers, one activation between them) shared by every robot, a biased softplus scale and a
    TanhNormal over [-1, 1] without ``tanh_loc``."""
    import torch
    from tensordict.nn import NormalParamExtractor
    from tensordict.nn.utils import biased_softplus
    from torchrl.modules import MultiAgentMLP, TanhNormal

    mlps = [m for m in policy.modules() if isinstance(m, MultiAgentMLP)]
    extractors = [m for m in policy.modules() if isinstance(m, NormalParamExtractor)]
    dists = [m for m in policy.modules() if getattr(m, "distribution_class", None) is not None]
    if len(mlps) != 1 or len(extractors) != 1 or len(dists) != 1 or dists[0].distribution_class is not TanhNormal:
        raise ValueError("expected one shared MLP, a NormalParamExtractor and a TanhNormal action (BenchMARL's MLP)")
    mlp, mapping, kwargs = mlps[0], extractors[0].scale_mapping, dists[0].distribution_kwargs
    if not mlp.share_params:
        raise ValueError("the policy's parameters are not shared by the robots (share_policy_params=False)")
    if not isinstance(mapping, biased_softplus):
        raise ValueError(f"the action scale mapping is {type(mapping).__name__}, not the biased softplus saved")
    bounds = [torch.as_tensor(kwargs.get(k, 0.0)) for k in ("low", "high")]
    if kwargs.get("tanh_loc", False) or not (torch.all(bounds[0] == -1.0) and torch.all(bounds[1] == 1.0)):
        raise ValueError("the TanhNormal action must span [-1, 1] without tanh_loc")
    sizes, activations = [], set()
    for k, m in enumerate(mlp._empty_net):
        if isinstance(m, torch.nn.Linear) == (k % 2 == 1):
            raise ValueError("the policy MLP must alternate linear layers and activations, linear first and last")
        if isinstance(m, torch.nn.Linear):
            sizes.append([m.in_features, m.out_features])
        else:
            activations.add(type(m).__name__)
    if len(activations) > 1 or len(mlp._empty_net) % 2 == 0:
        raise ValueError(f"the policy MLP must use one activation and end in a linear layer, got {sorted(activations)}")
    low, high = observation_bounds(scenario)
    state = {k: v.detach().clone() for k, v in mlp.params.flatten_keys(".").items(True, True)}
    layout = {
        "layers": sizes,
        "activation": activations.pop() if activations else "Identity",
        "scale": {"bias": float(mapping.bias), "min": float(mapping.min_val)},
        "low": [float(x) for x in low],
        "high": [float(x) for x in high],
    }
    return mlp_network({**layout, "state_dict": state}), layout


def save_actor(policy, scenario, path: Path, record: dict[str, Any]) -> BenchMARLCheckpoint:
    """Write the policy network to ``path`` (``actor.pt``) and its run record beside it (``actor.json``)."""
    import torch

    net, layout = actor_network(policy, scenario)
    ckpt = BenchMARLCheckpoint(path, path.with_suffix(".json"))
    with replacing(path) as part, replacing(ckpt.record_path) as record_part:  # the record renamed first
        torch.save({**layout, "state_dict": net.state_dict()}, part)
        record_part.write_text(json.dumps(jsonable(record), indent=2, allow_nan=False) + "\n")
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
    config = {"scenario": scenario, "max_steps": cfg.max_steps, "gamma": cfg.gamma}  # gamma: vcs_potential's too
    task = VcsNavClass(name=scenario.kind.upper(), config=config)
    return Experiment(
        task,
        algorithm_config(cfg),
        model,
        seed=cfg.seed,
        config=experiment_config(cfg, scenario.n_robots, folder),
        critic_model_config=copy.deepcopy(model),
        callbacks=list(callbacks),
    )


def evaluate(evaluator: PeriodicEval, scenario, name: str, policy, timesteps: int) -> dict[str, Any]:
    """One evaluation of a BenchMARL policy's network (:class:`PeriodicEval`, a line of ``eval.jsonl``)."""
    net, layout = actor_network(policy, scenario)
    return evaluator(BenchMARLPolicy(net, layout, name=name), timesteps)


def checkpoint(cfg: BenchMARLConfig, scenario, t0: float, policy, timesteps: int) -> None:
    """A periodic checkpoint ``<out>/checkpoints/actor_<timesteps>.pt`` with its record."""
    path = Path(cfg.out) / "checkpoints" / f"actor_{timesteps}.pt"
    save_actor(policy, scenario, path, run_record(
        f"benchmarl_{cfg.algorithm}", cfg, scenario, None, timesteps, wall_time=round(time.time() - t0, 1)
    ))  # fmt: skip


def train(cfg: BenchMARLConfig) -> Path:
    """Run a BenchMARL experiment, evaluate it every ``eval_freq`` timesteps and at the end, keep a checkpoint
    every ``checkpoint_freq`` timesteps, save ``<out>/actor.pt``."""
    import_benchmarl()
    from .benchmarl_callback import LinearLR, Periodic  # BenchMARL

    scenario = build_scenario(cfg)
    check_fresh_out(cfg.out)
    warn_blind_training([scenario])
    n = scenario.n_robots
    out = Path(cfg.out)
    kind = f"benchmarl_{cfg.algorithm}"
    t0 = time.time()
    evaluator = PeriodicEval(cfg, [scenario], out, t0)
    periodic = Periodic(n, [
        (cfg.eval_freq, partial(evaluate, evaluator, scenario, out.name)),
        (cfg.checkpoint_freq, partial(checkpoint, cfg, scenario, t0)),
    ])  # fmt: skip
    callbacks = [periodic] + ([LinearLR(cfg.learning_rate)] if cfg.lr_schedule == "linear" else [])
    exp = make_experiment(cfg, scenario, out / "benchmarl", callbacks)
    write_text(out / "config.json", json.dumps(jsonable(cfg), indent=2) + "\n")
    print(f"BenchMARL {cfg.algorithm}: {exp.config.max_n_frames} world steps ({exp.config.max_n_frames * n} robot "
          f"steps), {cfg.n_worlds} worlds, folder {exp.folder_name}", flush=True)  # fmt: skip
    exp.run()
    steps = exp.total_frames * n
    done = [r for r in evaluator.history if r["timesteps"] == steps]
    final = done[-1] if done else evaluate(evaluator, scenario, out.name, exp.policy, steps)
    record = run_record(
        kind, cfg, scenario, None, steps, evaluation=final, wall_time=round(time.time() - t0, 1),
        history=evaluator.history,
    )  # fmt: skip
    ckpt = save_actor(exp.policy, scenario, out / "actor.pt", record)
    print(f"saved {ckpt.path} ({steps} timesteps, {time.time() - t0:.0f} s)")
    print(f"reproduce: {run_command(kind, cfg)}")
    return ckpt.path
