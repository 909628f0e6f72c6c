"""What a run is: the typed configs of ``vcs-env train`` (SB3 and RLlib backends) and the run
record written beside every checkpoint.

:class:`PolicyConfig` is the actor-critic shared by ``train`` and ``bc`` (so a BC checkpoint can
seed PPO), :class:`TrainConfig` a whole ``vcs-env train`` run, :class:`RLlibConfig` the same plus
where an RLlib run executes. :func:`run_record` is the one JSON record of a checkpoint of any
backend: what kind of run wrote it, the observation it reads (:func:`vcs_env.observations.observation_config`),
the scenario family, the config and the command that rebuilds it. No torch import here.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.checks import check_choice, check_positive
from vcs_env.files import replacing
from vcs_env.observations import observation_config, observation_layout
from vcs_env.scenario import Scenario
from vcs_env.spaces import observation_space
from vcs_env.start_states import StartStates

from .config import FEATURES, ScenarioConfig, config_command
from .outputs import check_out_dir


@dataclass
class PolicyConfig:
    """The PPO actor-critic shared by ``train`` and ``bc`` (so a BC checkpoint can seed PPO)."""

    net_arch: tuple[int, ...] = (128, 128)
    """Hidden layer sizes of the (separate) policy and value MLPs."""
    log_std_init: float = -0.5
    """Initial log standard deviation of the Gaussian policy (state independent); actions are
    in [-1, 1], so std 0.6 explores without saturating most actions."""
    features: str = "flat"
    """What the MLPs read (:data:`FEATURES`): flat (the observation), contact (the observation plus per-neighbour
    contact-time and nearness features computed from it) or slots (a learned encoder shared by the
    neighbour slots, pooled), slots-fine (slots that also read contacts at millimetre resolution);
    agents.features. SB3 only."""


def check_net_arch(net_arch) -> None:
    """``ValueError`` unless ``net_arch`` is one or more layer sizes >= 1 (``train`` and ``bc`` alike)."""
    if not net_arch or any(isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in net_arch):
        raise ValueError(f"net_arch must be one or more layer sizes >= 1, got {net_arch!r}")


def network_of(model) -> dict[str, Any]:
    """The ``--features`` and ``--net-arch`` of an SB3 ``model``'s policy (its actor's layers), read from the policy
    itself: a checkpoint's run record may not say them (a distil student's, widened to ``slots-fine`` or not). The
    inverse of :func:`policy_kwargs` (extractors by class name: :mod:`agents.features` needs torch)."""
    policy = model.policy
    cls, kwargs = policy.features_extractor_class.__name__, policy.features_extractor_kwargs or {}
    features = {"ContactFeatures": "contact", "SlotEncoder": "slots-fine" if kwargs.get("fine") else "slots"}
    arch = policy.net_arch
    return {"features": features.get(cls, "flat"), "net_arch": list(arch["pi"] if isinstance(arch, dict) else arch)}


def policy_kwargs(cfg: PolicyConfig, scenario: Scenario) -> dict[str, Any]:
    """Keyword arguments of SB3's ``MlpPolicy`` for ``cfg``, on the observations of ``scenario``."""
    from .features import extractor_kwargs  # torch

    return dict(
        net_arch=dict(pi=list(cfg.net_arch), vf=list(cfg.net_arch)),
        log_std_init=cfg.log_std_init,
        **extractor_kwargs(cfg.features, observation_layout(scenario)),
    )


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
    """constant, or linear: decays to 0 over the run's budget ``timesteps`` (a resumed run goes on from its
    checkpoint's step) and holds there (a run that ends past its budget, in whole rollouts, makes its last
    update at 0)."""
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
    init_log_std: float | None = None
    """With ``init``: the policy's log standard deviation once the checkpoint's weights are loaded (None keeps the
    checkpoint's). A distilled network keeps the std of the PPO run it descends from (about 0.3 in the action box),
    and PPO from it learns from actions that far from its mean, which in tight spaces are another policy than the
    deterministic one that is evaluated (docs/training.md, "Exploration noise after distillation")."""
    residual: str | None = None
    """A residual policy: the network's action is a bounded correction added to this planner's
    (vcs, or another registered planner): clip(planner + residual_scale * network, -1, 1). Its action
    head starts at zero, so the untrained policy is the planner; evaluate, compare and export run the
    two together (agents.residual.Residual). SB3 only."""
    residual_scale: float = 0.5
    """Largest correction of a residual policy per action component (units of the action range)."""
    residual_gate: bool = False
    """A residual over vcs holds its correction while the expert falls back (nothing admissible): the
    expert alone drives its escapes (agents.residual.Residual.gate)."""
    guide: str = "none"
    """Guidance from the VCS expert beside --shaping: none; imitation_loss (every step of PPO's update
    on a rollout also descends guide_weight x |policy mean - expert action|^2 on a minibatch of the
    rollout's states, the DAPG-style auxiliary loss); or jump_start (the expert drives the first steps of each training
    episode, up to a share guide_weight of half the step limit, annealed to 0 at guide_anneal, which
    it needs); agents.train.guide."""
    guide_weight: float = 1.0
    """Weight of the --guide loss at step 0 (jump_start: its share of half the step limit, at most 1)."""
    guide_anneal: int = 0
    """Anneal the expert's guidance: the --guide loss's weight and the --shaping term's fall linearly from
    their values at step 0 to 0 at this many timesteps and stay 0 after (set before each rollout); 0
    keeps them constant."""
    out: str = "runs/ppo"
    """Run directory (model.zip, model.json, checkpoints/, eval.jsonl, tb/; runs/rllib with --backend rllib,
    runs/benchmarl with --backend benchmarl)."""
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
    FIELD in n_robots, n_obstacles, jitter, layout_radius, obstacle_speed, corridor_width, door_width, n_walls, e.g.
    circle:n_robots=4-16/4,jitter=0-0.4 crowd:n_obstacles=3-11/4,obstacle_speed=0.5-1.5
    (agents.mixture.parse_mixture_entry). Every grid point is one scenario with a fixed share of the worlds
    (agents.vec_env.MixtureVecEnv); the other scenario flags (max_steps, on_collision, rewards, shaping) apply to
    all."""
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
    """Show SB3's progress bar (needs tqdm and rich, the train extra; RLlib shows none, BenchMARL its own)."""
    tensorboard: bool = True
    """Write TensorBoard logs under <out>/tb (the SB3 backend only)."""


ADAPTERS = ("batched", "pettingzoo")
"""Env adapters of :mod:`agents.train.rllib_env`."""


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
    """Run directory (config.json, eval.jsonl, checkpoint/, checkpoints/)."""
    env_adapter: str = "pettingzoo"
    """Env adapter for --backend rllib: pettingzoo (RLlib's ParallelPettingZooEnv over
    vcs_env.parallel_env, n_worlds of them per runner, each restarting on its own as in the SB3
    path) or batched (n_worlds worlds in one numpy call per runner, restarting together). batched
    samples 1.2x faster (benchmarks/RESULTS.md) but learns later and less steadily: its finished
    worlds wait for the slowest one, so a few slow worlds fill the train batch. On circle-8 from
    scratch pettingzoo learns like SB3, batched gets there by 1 M steps (results/rllib-circle8)."""


RLLIB_ONLY = tuple(f.name for f in dataclasses.fields(RLlibConfig) if f.name not in TrainConfig.__dataclass_fields__)
"""Fields (flags) of an RLlib run only."""

BENCHMARL_ALGORITHMS = ("mappo", "ippo", "masac")
"""Algorithms of ``vcs-env train --backend benchmarl`` (BenchMARL's, continuous actions)."""


@dataclass
class BenchMARLConfig(TrainConfig):
    """A ``vcs-env train --backend benchmarl`` run: :class:`TrainConfig` plus the algorithm."""

    algorithm: str = "mappo"
    """BenchMARL algorithm for --backend benchmarl: mappo (PPO, centralised critic over every robot of a
    world), ippo (PPO, each robot's critic reads its own observation) or masac (SAC, centralised critics;
    off-policy). From scratch, give mappo and ippo --ent-coef 0.01 (results/benchmarl-circle8)."""
    out: str = "runs/benchmarl"
    """Run directory (config.json, eval.jsonl, actor.pt + actor.json, benchmarl/: BenchMARL's own folder)."""


BENCHMARL_ONLY = ("algorithm",)
"""Fields (flags) of a BenchMARL run only."""
UNHONOURED = {
    "rllib": {
        "progress_bar": (True, "RLlib prints its own lines"),
        "tensorboard": (True, "TensorBoard logs: SB3 only"),
    },
    "benchmarl": {
        "progress_bar": (False, "BenchMARL shows its own progress bar"),
        "tensorboard": (True, "TensorBoard logs: SB3 only"),
    },
}
"""Per backend, the SB3 display flags it cannot honour: ``{flag: (value asked, why)}`` (asking for what it does anyway
is fine: no bar from RLlib, BenchMARL's own bar)."""

FIXED_ON_RESUME = (
    "net_arch", "features", "log_std_init", "n_steps", "batch_size", "n_epochs", "learning_rate", "lr_schedule",
    "gamma", "gae_lambda", "clip_range", "ent_coef", "vf_coef", "max_grad_norm", "target_kl", "residual",
    "residual_scale", "residual_gate", "init_log_std",
)  # fmt: skip
"""Fields a resumed run keeps from its checkpoint (the network, the PPO settings in the model and what
its actions mean)."""


def check_run(cfg: TrainConfig) -> None:
    """A one-line ``ValueError`` for a run that would train nothing or evaluate on no episode."""
    if isinstance(cfg.timesteps, bool) or not isinstance(cfg.timesteps, int) or cfg.timesteps < 1:
        raise ValueError(
            f"--timesteps must be >= 1 (a run of 0 steps would save an untrained model), got {cfg.timesteps}"
        )
    if cfg.n_worlds < 1 or cfg.eval_episodes < 1:
        raise ValueError(f"n_worlds and eval_episodes must be >= 1, got {cfg.n_worlds} and {cfg.eval_episodes}")
    for name, high in (("seed", 2**32 - 1), ("eval_seed", 2**63 - 1)):  # numpy's and torch's seeds; world seeds
        value = getattr(cfg, name)
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= high:
            raise ValueError(f"--{name.replace('_', '-')} must be an integer in [0, {high}], got {value!r}")
    check_choice("features", cfg.features, FEATURES)
    check_positive("max_grad_norm", cfg.max_grad_norm)  # the gradients' norm is clipped to it: 0 would learn nothing
    if cfg.init is not None and cfg.log_std_init != PolicyConfig.log_std_init:
        raise ValueError(
            "--log-std-init is a new policy's log std; --init loads the checkpoint's (give --init-log-std to change it)"
        )
    if cfg.init_log_std is not None and cfg.init is None:
        raise ValueError(
            "--init-log-std sets the log std of the --init checkpoint's policy; a new policy's is --log-std-init"
        )
    default = TrainConfig()
    check_partners(cfg, {name for name, *_ in PARTNERS if getattr(cfg, name) != getattr(default, name)})


PARTNERS = (
    ("residual_scale", "residual", "scales a residual policy's correction"),
    ("guide_weight", "guide", "weighs the --guide term"),
    ("mixture_balance", "mixture", "balances the entries of a --mixture"),
    ("start_prob", "start_states", "is the share of episodes started from the --start-states file"),
)
"""Settings of another flag's feature, ``(setting, the flag it needs, what it does)``: alone it would change nothing."""


def check_partners(cfg: TrainConfig, given) -> None:
    """A one-line ``ValueError`` for a setting of :data:`PARTNERS` in ``given`` (flag names set on the command line, or
    the fields that differ from their defaults) whose partner flag is off in ``cfg``."""
    for name, partner, what in PARTNERS:
        if name in given and getattr(cfg, partner) in (None, (), "none"):
            flag, needs = "--" + name.replace("_", "-"), "--" + partner.replace("_", "-")
            raise ValueError(f"{flag} {what}: give {needs} too, or leave {flag} out")


RUN_FILES = ("model.zip", "model.json", "actor.pt", "config.json", "eval.jsonl", "checkpoints")
"""What a training run (``vcs-env train`` of every backend, ``bc``, ``distil``) writes into its ``--out``."""


def check_fresh_out(out: str | os.PathLike, resume_hint: bool = False, resume=None) -> None:
    """A one-line ``ValueError`` when ``out`` is a file or cannot be written (:func:`~agents.config.check_out_dir`), or
    already holds a run's files: a new run there would replace its model and append its evaluations to the other
    run's (``resume_hint``: name ``--resume``, for a run that can go on). A run resumed from the checkpoint ``resume``
    may go on in that checkpoint's own run directory, nowhere else that holds a run."""
    check_out_dir(out, "--out", "the run")  # a file, or a path under one, found only when the model was saved
    if resume is not None and Path(out).resolve() == resume.run_dir.resolve():
        return
    held = [f for f in RUN_FILES if (Path(out) / f).exists()]
    if held:
        ckpts = Path(out) / "checkpoints"
        resumable = (Path(out) / "model.zip").exists() or (ckpts.is_dir() and any(ckpts.iterdir()))
        other = f", or --resume {str(out)!r} to continue that run" if resume_hint and resumable else ""
        other += " (it stopped before its first checkpoint: nothing to resume)" if resume_hint and not resumable else ""
        raise ValueError(
            f"--out {str(out)!r} already holds a run ({', '.join(held)}): a new run there would replace its model and "
            f"mix its logs with this one's; give another --out, or remove that one first{other}"
        )


def config_path(checkpoint: str | os.PathLike) -> Path:
    """The run record beside an SB3 zip (``model.zip`` -> ``model.json``)."""
    p = Path(checkpoint)
    return p.with_suffix(".json") if p.suffix == ".zip" else p.with_name(p.name + ".json")


def save_model(
    model,
    path: str | os.PathLike,
    kind: str,
    config: Any,
    scenario: Scenario,
    family: list[str] | None = None,
    **extra: Any,
) -> Path:
    """Save ``model`` (an SB3 PPO) to ``path`` (``.zip``) and its run record beside it
    (:func:`run_record`; ``extra``: more JSON-able entries). Returns the ``.zip`` path. Both are written under
    another name and then renamed into place, the record first: a run stopped while it saves (Ctrl-C, a killed job)
    leaves the checkpoint before it whole, and at most a record without its zip, which no one takes for a
    checkpoint (a half-written zip, or one without its record, stopped ``--resume``)."""
    path = Path(path)
    if path.suffix != ".zip":
        path = path.with_name(path.name + ".zip")
    # the inner block ends first, so the record is renamed into place first; a save that failed (a full disk, a record
    # that is no JSON) leaves no part behind
    with replacing(path) as part, replacing(config_path(path)) as record_part:
        model.save(str(part))  # SB3 keeps a name's own suffix
        meta = run_record(kind, config, scenario, family, getattr(model, "num_timesteps", 0), **extra)
        record_part.write_text(json.dumps(meta, indent=2, sort_keys=False, allow_nan=False) + "\n")
    return path


def run_command(kind: str, cfg: Any) -> str:
    """The ``vcs-env`` line that rebuilds ``cfg`` for a run of ``kind`` (``ppo``, ``rllib_ppo``, ``bc``)."""
    if kind == "rllib_ppo" or kind.startswith("benchmarl_"):
        head, _, rest = config_command("train", cfg).partition(" train")
        return f"{head} train --backend {'rllib' if kind == 'rllib_ppo' else 'benchmarl'}{rest}"
    return config_command({"ppo": "train"}.get(kind, kind), cfg)


def scenario_family(scenarios: Scenario | list[Scenario] | tuple[Scenario, ...]) -> list[str]:
    """The scenario family of a run: the sorted layout kinds it trains on (``["circle", "crowd"]``)."""
    if isinstance(scenarios, Scenario):
        scenarios = [scenarios]
    return sorted({s.kind for s in scenarios})


def jsonable(x: Any) -> Any:
    """Nested copy for strict JSON: dataclasses as dicts, numpy scalars and arrays as Python
    numbers and lists, NaN and inf as ``None``, paths as strings."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return jsonable(dataclasses.asdict(x))
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, os.PathLike):
        return os.fspath(x)
    return x


def run_record(
    kind: str, config: Any, scenario: Scenario, family: list[str] | None, timesteps: int, **extra: Any
) -> dict[str, Any]:
    """The run record of a checkpoint (``model.json`` of an SB3 zip, ``vcs_env.json`` of an RLlib run).

    Args:
        kind: what produced it (``"ppo"`` from ``vcs-env train``, ``"rllib_ppo"`` from ``--backend
            rllib``, ``"bc"`` from ``vcs-env bc``).
        config: the run's config dataclass (saved field by field, with the command that rebuilds it).
        scenario: the scenario the policy observes (defines the observation config); for a
            mixture, its first scenario (all share one observation config).
        family: the layout kinds it was trained on (default: ``[scenario.kind]``).
        timesteps: environment steps trained so far (slot steps).
        extra: more JSON-able entries (evaluation results, wall time, history ...).
    """
    return {
        "kind": kind,
        "observation_dim": int(observation_space(scenario).shape[0]),
        "observation": jsonable(observation_config(scenario)),
        "scenario_family": list(family) if family is not None else scenario_family(scenario),
        "num_timesteps": int(timesteps),
        "config": jsonable(config),
        "command": run_command(kind, config),
        "scenario": jsonable(scenario),
        **jsonable(extra),
    }


def kept_start(resume, out: str | os.PathLike):
    """The checkpoint (an :class:`agents.checkpoint.Checkpoint`) a run resumed into ``out`` goes on from, kept: when
    it is the final checkpoint of ``out`` (which the resumed run overwrites), its copy under ``out/checkpoints/`` by
    its timesteps (the one already there, if any), so that the run's ``resumed_from`` names weights that still
    exist."""
    final = type(resume).final(Path(out))
    if not final.exists() or resume.path.resolve() != final.resolve():
        return resume
    dst = Path(out) / "checkpoints" / type(resume).periodic_name.format(resume.timesteps)
    if not dst.exists():
        dst.parent.mkdir(parents=True, exist_ok=True)
        if resume.path.is_dir():
            shutil.copytree(resume.path, dst)
        else:
            shutil.copy(resume.path, dst)
            if resume.record_path.is_file():  # model.json beside model.zip, actor.json beside actor.pt
                shutil.copy(resume.record_path, dst.with_suffix(".json"))
        print(f"kept {resume.path} as {dst} (this run overwrites the first)")
    return type(resume).find(dst)


def resumed_from(resume, steps: int) -> dict[str, Any]:
    """The run record's entry of a run resumed from checkpoint ``resume`` at ``steps`` timesteps (nothing for a new
    run): its command alone does not rebuild its weights, which come from that checkpoint."""
    return {"resumed_from": {"checkpoint": str(resume.path), "timesteps": steps}} if resume is not None else {}


def print_reproduce(command: str, resume=None, steps: int = 0) -> None:
    """Print how to rebuild a run: ``command``, or for a run resumed from ``resume`` (at ``steps`` timesteps) the run
    of that checkpoint, then ``command`` going on from it."""
    if resume is None:
        print(f"reproduce: {command}")
    else:
        print(f"reproduce: the run of {resume.path} ({steps} timesteps), then {command} --resume {resume.path}")


def start_states(cfg, scenarios, what: str = "training") -> StartStates | None:
    """The start-state pools of a run whose config has ``start_states`` (a file of ``vcs-env collect-states``, or
    None) and ``start_prob`` (``vcs-env train`` and ``distil``): None without a file; a ``ValueError`` when the file
    holds no state or no pool fits one of the run's ``scenarios`` (pools are keyed by the whole scenario but its
    rewards and sensing, :func:`vcs_env.start_states.scenario_key`); ``what`` names the run in the messages."""
    if cfg.start_states is None:
        return None
    starts = StartStates.load(cfg.start_states, cfg.start_prob)
    hit = starts.matching(scenarios)
    if not any(len(pool) for pool in starts.pools.values()):
        raise ValueError(f"{cfg.start_states!r} holds no start states (vcs-env collect-states found none)")
    if not hit:
        raise ValueError(
            f"no start-state pool of {cfg.start_states!r} fits a {what} scenario ({len(starts.pools)} pools; collect "
            f"them with the {what}'s scenario flags and mixture, e.g. the same --on-collision and --max-steps)"
        )
    states = sum(len(starts.pool(s)) for s in hit)
    print(
        f"start states: {len(hit)} of {len(scenarios)} scenarios start from {cfg.start_states} with "
        f"p={cfg.start_prob} ({states} states)"
    )
    return starts
