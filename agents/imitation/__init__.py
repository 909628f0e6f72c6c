"""Imitation of the VCS expert: expert datasets, behaviour cloning and DAgger (``vcs-env collect``,
``vcs-env bc``), into the same SB3 PPO actor-critic that ``vcs-env train --init`` fine-tunes.

The dataset format and the episodes that fill it are :mod:`agents.imitation.data`.

**Behaviour cloning** (:func:`bc_fit`) maximises the Gaussian log-likelihood of the expert
actions under the PPO policy (``loss="nll"``, default). The policy's std is state independent,
so the optimal mean is the same as with MSE; the likelihood also fits ``log_std`` to the
residual error, which is the right exploration scale for PPO fine-tuning afterwards (floored
at ``min_log_std``). ``loss="mse"`` fits only the mean and leaves ``log_std`` at its initial
value. The value head is fitted at the same time to the discounted returns of the dataset's
trajectories (``value_coef``), so PPO does not start from a random critic. Both heads are
separate MLPs, so the value fit does not disturb the actor.

**DAgger** (``--dagger-iters K``): after BC, K rounds of: play ``dagger_episodes`` episodes
where each robot executes the expert's action with probability ``beta_k = dagger_beta *
0.5**k`` and the learner's deterministic action otherwise, label every visited state with the
expert action (``NavEngine.expert_action``; the expert is the planner that collected the
dataset, ``vcs-env collect --planner``), add the states to the dataset and continue
training on the union. With ``--init CHECKPOINT`` the policy starts from a trained one (a
``bc`` or ``train`` checkpoint of the same ``--net-arch``) instead of a fresh one; with
``--epochs 0`` the DAgger rounds then start from it as it is, so the expert labels the states
that *that* policy visits (e.g. a PPO policy's own mistakes).

Example::

    vcs-env collect --scenario crowd --episodes 200 --seed 0 --out data/crowd_expert.npz
    vcs-env bc --data data/crowd_expert.npz --epochs 30 --dagger-iters 3 --out runs/bc_crowd
    vcs-env train --scenario crowd --init runs/bc_crowd/model.zip
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.checks import check_choice, check_int, check_range
from vcs_env.observations import observation_config, observation_dim

from ..checkpoint import load_policy_weights, open_checkpoint, save_model
from ..config import ScenarioConfig, config_command, config_from_dict, print_suite_differences
from ..evaluate import scalar_results, score_scenarios
from ..mixture import scenarios_of
from ..outputs import check_out_file
from ..policies import predictor_controller
from ..residual import refuse_residual
from ..runs import PolicyConfig, check_fresh_out, check_net_arch, policy_kwargs, scenario_family
from .data import (
    DATASET_FORMAT,
    check_rows,
    concat_datasets,
    discounted_returns,
    load_dataset,
    play_mixture,
    save_dataset,
)

LOSSES = ("nll", "mse")
"""Behaviour-cloning losses: Gaussian log-likelihood, or squared error of the mean."""


# ----------------------------------------------------------------------------- data
@dataclass
class CollectConfig(ScenarioConfig):
    """``vcs-env collect``: expert rollouts into a dataset."""

    episodes: int = 100
    """Number of episodes (seeds seed, seed + 1, ...)."""
    seed: int = 0
    """First episode seed."""
    n_worlds: int = 32
    """Worlds stepped together."""
    planner: str = "vcs"
    """Expert planner name."""
    out: str = "data/expert.npz"
    """Dataset path (.npz)."""
    mixture: tuple[str, ...] = ()
    """Collect on a mixture instead of one scenario (the entries of train's --mixture): episode j
    plays grid point j % S; vcs-env bc then clones on it and plays its DAgger rounds on it."""


def collect(cfg: CollectConfig) -> Path:
    """Run the expert on ``cfg.episodes`` seeds and save the dataset; returns its path."""
    if cfg.episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {cfg.episodes}")
    check_int("n_worlds", cfg.n_worlds, 1, 10**6)
    if cfg.shaping != "none":
        raise ValueError(
            f"--shaping {cfg.shaping} shapes PPO's reward; a dataset keeps the scenario's own reward (vcs-env bc "
            "rebuilds its scenario without shaping): collect without it"
        )
    check_out_file(cfg.out, "--out", new=True, writable=True)
    scenarios = scenarios_of(cfg, cfg.mixture)
    if cfg.episodes < len(scenarios):
        raise ValueError(
            f"--episodes {cfg.episodes} is fewer than the mixture's {len(scenarios)} scenarios (one episode each, at "
            "least)"
        )
    scenario = scenarios[0]
    print_suite_differences(scenarios, "collecting on")
    seeds = list(range(cfg.seed, cfg.seed + cfg.episodes))
    t0 = time.time()
    data = play_mixture(scenarios, seeds, n_worlds=cfg.n_worlds, expert=cfg.planner)
    meta = {
        "format": DATASET_FORMAT,
        "config": dataclasses.asdict(cfg),
        "scenario": json.loads(json.dumps(dataclasses.asdict(scenario), default=repr)),
        "seeds": seeds,
        "planner": cfg.planner,
        "executed": "expert",
        "action_mode": "delta",
        "observation_dim": observation_dim(scenario),
        "observation": observation_config(scenario),
        "command": config_command("collect", cfg),
    }
    path = save_dataset(cfg.out, data, meta)
    K = len(data["traj_seed"])
    print(
        f"collected {len(data['actions'])} robot-steps, {K} robot trajectories from {len(seeds)} episodes "
        f"(arrived {data['traj_reached'].mean():.3f}, collided {data['traj_collided'].mean():.3f}) "
        f"in {time.time() - t0:.1f} s -> {path}"
    )
    return path


# ------------------------------------------------------------------------------- BC
def bc_fit(
    policy,
    obs: np.ndarray,
    actions: np.ndarray,
    returns: np.ndarray | None = None,
    epochs: int = 20,
    batch_size: int = 256,
    lr: float = 1e-3,
    loss: str = "nll",
    value_coef: float = 0.5,
    seed: int = 0,
) -> list[float]:
    """Fit an SB3 ``ActorCriticPolicy`` to expert pairs (module docstring).

    Args:
        policy: the PPO policy (trained in place).
        obs: ``(N, D)`` observations.
        actions: ``(N, 2)`` expert actions in [-1, 1].
        returns: ``(N,)`` discounted returns for the value head (None: actor only).
        loss: ``"nll"`` (Gaussian log-likelihood) or ``"mse"`` (squared error of the mean).

    Returns:
        Mean training loss per epoch.
    """
    import torch as th

    check_choice("loss", loss, LOSSES)
    check_rows({"observations": np.asarray(obs), "actions": np.asarray(actions), "traj_start": [0, len(obs)]}, "bc_fit")
    if returns is not None and np.shape(returns) != (len(obs),):
        raise ValueError(f"bc_fit: returns has shape {np.shape(returns)}, expected ({len(obs)},)")
    g = th.Generator().manual_seed(seed)
    obs_t = th.as_tensor(obs, dtype=th.float32)
    act_t = th.as_tensor(actions, dtype=th.float32)
    ret_t = None if returns is None else th.as_tensor(returns, dtype=th.float32)
    opt = th.optim.Adam(policy.parameters(), lr=lr)
    fit_values = ret_t is not None and value_coef > 0
    policy.set_training_mode(True)
    history = []
    for _ in range(epochs):
        perm = th.randperm(len(obs_t), generator=g)
        total = 0.0
        for k in range(0, len(perm), batch_size):
            idx = perm[k : k + batch_size]
            if loss == "nll":
                values, log_prob, _ = policy.evaluate_actions(obs_t[idx], act_t[idx])
                actor_loss = -log_prob.mean()
            else:  # the critic is run only when its loss counts (without returns its output is in no loss)
                dist = policy.get_distribution(obs_t[idx])
                actor_loss = ((dist.distribution.mean - act_t[idx]) ** 2).sum(-1).mean()
                values = policy.predict_values(obs_t[idx]) if fit_values else None
            total_loss = actor_loss
            if fit_values:
                total_loss = total_loss + value_coef * ((values.flatten() - ret_t[idx]) ** 2).mean()
            opt.zero_grad()
            total_loss.backward()
            opt.step()
            total += total_loss.item() * len(idx)
        history.append(total / len(obs_t))
    policy.set_training_mode(False)
    return history


def action_error(policy, obs: np.ndarray, actions: np.ndarray) -> float:
    """Mean Euclidean distance between the policy's deterministic actions and ``actions``."""
    pred = policy.predict(obs, deterministic=True)[0]
    return float(np.linalg.norm(pred - actions, axis=-1).mean())


DAGGER_FLAGS = ("dagger_episodes", "dagger_beta", "dagger_epochs", "dagger_seed")
"""The settings of DAgger's rounds, read only with ``dagger_iters`` > 0."""


@dataclass
class BCConfig:
    """``vcs-env bc``: behaviour cloning (and optional DAgger) into a PPO actor-critic."""

    data: str = "data/expert.npz"
    """Expert dataset from vcs-env collect (its scenario is the policy's scenario)."""
    out: str = "runs/bc"
    """Run directory (model.zip + model.json)."""
    seed: int = 0
    """Seed of the policy initialisation, minibatch order and DAgger mixing."""
    net_arch: tuple[int, ...] = (128, 128)
    """Hidden layer sizes of the policy and value MLPs (must match train's --net-arch for --init)."""
    log_std_init: float = -0.5
    """Initial log std of the Gaussian policy (kept as is by loss=mse)."""
    features: str = "flat"
    """What the MLPs read: flat, contact, slots or slots-fine (agents.features; must match train's --features for
    --init)."""
    loss: str = "nll"
    """nll (Gaussian log-likelihood, also fits log_std) or mse (mean only)."""
    min_log_std: float = -1.6
    """Floor on log_std after training (std 0.2) so PPO fine-tuning still explores."""
    epochs: int = 20
    """Passes over the (initial) dataset."""
    batch_size: int = 256
    """Minibatch size."""
    learning_rate: float = 1e-3
    """Adam learning rate."""
    value_coef: float = 0.5
    """Weight of the value-head regression on discounted returns (0: actor only)."""
    gamma: float = 0.99
    """Discount of those returns (use PPO's)."""
    val_fraction: float = 0.1
    """Fraction of episodes held out to report the action error on unseen states."""
    dagger_iters: int = 0
    """DAgger rounds after BC (0: plain BC)."""
    dagger_episodes: int = 50
    """Episodes played per DAgger round."""
    dagger_beta: float = 0.5
    """Probability of executing the expert in the first round (halved every round)."""
    dagger_epochs: int = 5
    """Passes over the aggregated dataset after each round."""
    dagger_seed: int = 50_000
    """First episode seed of the DAgger rounds (disjoint from collect's)."""
    eval_episodes: int = 20
    """Episodes of the closed-loop evaluation after BC and each DAgger round (0: none)."""
    eval_seed: int = 100_000
    """First seed of that evaluation (the same list as train's periodic evaluation)."""
    init: str | None = None
    """Start from this checkpoint's policy (bc or ppo, same --net-arch) instead of a fresh one."""

    def __post_init__(self):
        for name in ("epochs", "batch_size", "dagger_iters", "dagger_episodes", "dagger_epochs", "eval_episodes"):
            lo = 1 if name in ("batch_size", "dagger_episodes") else 0
            check_int(f"BCConfig.{name}", getattr(self, name), lo, 10**7)
        check_net_arch(self.net_arch)  # 0 made a network of one constant action, -3 a torch traceback
        check_range("BCConfig.learning_rate", self.learning_rate, 0.0, 1.0, lo_open=True)
        check_range("BCConfig.value_coef", self.value_coef, 0.0, 1e3)
        check_range("BCConfig.gamma", self.gamma, 0.0, 1.0)
        check_range("BCConfig.val_fraction", self.val_fraction, 0.0, 1.0, hi_open=True)
        check_range("BCConfig.dagger_beta", self.dagger_beta, 0.0, 1.0)
        check_range("BCConfig.log_std_init", self.log_std_init, -20.0, 5.0)
        check_range("BCConfig.min_log_std", self.min_log_std, -20.0, 5.0)
        check_choice("BCConfig.loss", self.loss, LOSSES)
        if self.epochs == 0 and self.dagger_iters == 0:
            raise ValueError("BCConfig: epochs 0 and dagger_iters 0 would train nothing")
        unread = [f"--{f.replace('_', '-')}" for f in DAGGER_FLAGS if getattr(self, f) != getattr(BCConfig, f)]
        if unread and self.dagger_iters == 0:  # accepted, and the run was the same without them
            raise ValueError(f"{', '.join(unread)} set DAgger's rounds: give --dagger-iters too (0: plain BC)")
        if self.init and self.log_std_init != BCConfig.log_std_init:  # the checkpoint's std is kept
            raise ValueError("--log-std-init sets a fresh policy's std; --init keeps the checkpoint's: leave it out")


def _split(data: dict[str, np.ndarray], frac: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Row masks (train, held-out), holding out whole episodes (seeds)."""
    seeds = np.unique(data["traj_seed"])
    n_val = min(int(round(frac * len(seeds))), len(seeds) - 1)  # at least one episode to train on
    val_seeds = np.random.default_rng(seed).permutation(seeds)[:n_val]
    lengths = np.diff(data["traj_start"])
    row_seed = np.repeat(data["traj_seed"], lengths)
    val = np.isin(row_seed, val_seeds)
    return ~val, val


def behaviour_clone(cfg: BCConfig) -> dict[str, Any]:
    """BC (+ DAgger) per ``cfg``; saves ``<out>/model.zip``; returns errors, evaluations, paths."""
    check_fresh_out(cfg.out)
    import torch

    torch.set_num_threads(1)
    from stable_baselines3 import PPO

    from ..vec_env import NavVecEnv

    t_start = time.time()
    data, meta = load_dataset(cfg.data)
    scen_cfg = config_from_dict(ScenarioConfig, meta["config"])
    scen_cfg = dataclasses.replace(scen_cfg, shaping="none", shaping_weight=None)
    scenarios = scenarios_of(scen_cfg, meta["config"].get("mixture", ()))
    scenario = scenarios[0]
    if meta.get("observation_dim") != data["observations"].shape[1]:
        raise ValueError(f"dataset {cfg.data!r}: observation_dim in meta does not match the arrays")
    if data["observations"].shape[1] != observation_dim(scenario):
        raise ValueError(
            f"dataset {cfg.data!r} holds observations of size {data['observations'].shape[1]}, but the scenario its "
            f"record names observes {observation_dim(scenario)} numbers: the file was changed by hand; collect it again"
        )
    if meta.get("observation") != observation_config(scenario):
        raise ValueError(
            f"dataset {cfg.data!r} was collected with observation config {meta.get('observation')} (None: "
            f"observation v0), this vcs-env observes with {observation_config(scenario)}; collect it again"
        )
    venv = NavVecEnv(scenario, 1)  # spaces only
    pcfg = PolicyConfig(net_arch=cfg.net_arch, log_std_init=cfg.log_std_init, features=cfg.features)
    kwargs = policy_kwargs(pcfg, scenario)
    model = PPO("MlpPolicy", venv, seed=cfg.seed, device="cpu", gamma=cfg.gamma, policy_kwargs=kwargs)
    policy = model.policy
    if cfg.init:
        refuse_residual(open_checkpoint(cfg.init).record, cfg.init, "bc --init")
        init_meta = load_policy_weights(model, cfg.init, scenario)
        print(f"initialised the policy from {cfg.init} ({init_meta.get('kind', 'unknown')} checkpoint)")
    train_rows, val_rows = _split(data, cfg.val_fraction, cfg.seed)
    returns = discounted_returns(data["rewards"], data["traj_start"], cfg.gamma)
    X, Y, R = data["observations"], data["actions"], returns
    Xv, Yv = X[val_rows], Y[val_rows]
    report: dict[str, Any] = {"rows": int(train_rows.sum()), "held_out_rows": int(val_rows.sum())}
    if len(Xv):
        report["held_out_error_init"] = action_error(policy, Xv, Yv)
    elif cfg.val_fraction > 0:
        episodes = len(np.unique(data["traj_seed"]))
        print(
            f"note: val_fraction {cfg.val_fraction} of the dataset's {episodes} episode(s) holds out none (whole "
            "episodes are held out, and one is kept to train on): no held-out action error (collect more --episodes)"
        )

    def fit(rows: np.ndarray, epochs: int, seed: int) -> list[float]:
        hist = bc_fit(
            policy,
            X[rows],
            Y[rows],
            R[rows] if cfg.value_coef > 0 else None,
            epochs=epochs,
            batch_size=cfg.batch_size,
            lr=cfg.learning_rate,
            loss=cfg.loss,
            value_coef=cfg.value_coef,
            seed=seed,
        )
        with torch.no_grad():
            policy.log_std.clamp_(min=cfg.min_log_std)
        return hist

    eval_seeds = list(range(cfg.eval_seed, cfg.eval_seed + cfg.eval_episodes))

    def closed_loop(tag: str) -> dict[str, float] | None:
        if not eval_seeds:
            return None
        res = scalar_results(score_scenarios(predictor_controller(policy), scenarios, eval_seeds))
        print(
            f"[{tag}] closed loop on {len(eval_seeds)} episodes: success {res['episode_success']:.2f} "
            f"(robots {res['robot_success']:.3f}) collision {res['episode_collision']:.2f} "
            f"time-to-goal {res['time_to_goal']:.2f} s",
            flush=True,
        )
        return res

    losses = fit(train_rows, cfg.epochs, cfg.seed)
    report["bc_losses"] = losses
    if len(Xv) and losses:
        report["held_out_error"] = action_error(policy, Xv, Yv)
        print(
            f"[bc] {cfg.epochs} epochs on {report['rows']} rows: loss {losses[0]:.3f} -> {losses[-1]:.3f}, "
            f"held-out action error {report['held_out_error_init']:.3f} -> {report['held_out_error']:.3f}"
        )
    stage = "bc" if cfg.epochs else "init"
    report["evaluations"] = [{"stage": stage, **(closed_loop(stage) or {})}]

    rng = np.random.default_rng(cfg.seed)
    labeller = meta.get("planner", "vcs")  # DAgger labels with the planner that made the dataset
    dagger_steps = 0
    for k in range(cfg.dagger_iters):
        beta = cfg.dagger_beta * 0.5**k
        seeds = range(cfg.dagger_seed + k * cfg.dagger_episodes, cfg.dagger_seed + (k + 1) * cfg.dagger_episodes)
        actor = lambda o: policy.predict(o, deterministic=True)[0]  # noqa: E731
        new = play_mixture(scenarios, seeds, actor=actor, beta=beta, rng=rng, expert=labeller)
        dagger_steps += len(new["actions"])
        new_ret = discounted_returns(new["rewards"], new["traj_start"], cfg.gamma)
        data = concat_datasets(data, new)
        X, Y, R = data["observations"], data["actions"], np.concatenate((R, new_ret))
        train_rows = np.concatenate((train_rows, np.ones(len(new["actions"]), dtype=bool)))
        fit(train_rows, cfg.dagger_epochs, cfg.seed + k + 1)
        msg = f"[dagger {k + 1}/{cfg.dagger_iters}] beta {beta:.3f}: +{len(new['actions'])} rows"
        msg += f" ({train_rows.sum()} total)"
        if len(Xv):
            msg += f", held-out action error {action_error(policy, Xv, Yv):.3f}"
        print(msg, flush=True)
        res = closed_loop(f"dagger {k + 1}") or {}
        report["evaluations"].append({"stage": f"dagger{k + 1}", "beta": beta, **res})
    report["dagger_env_steps"] = dagger_steps
    if len(Xv):
        report["held_out_error"] = action_error(policy, Xv, Yv)
    report["log_std"] = policy.log_std.detach().numpy().tolist()
    wall = round(time.time() - t_start, 1)
    path = save_model(
        model,
        Path(cfg.out) / "model.zip",
        "bc",
        cfg,
        scenario,
        scenario_family(scenarios),
        dataset=str(cfg.data),
        dataset_meta={k: meta[k] for k in ("config", "planner", "executed") if k in meta},
        report=report,
        wall_time=wall,
    )
    print(f"saved {path} ({wall:.0f} s)")
    print(f"reproduce: {config_command('bc', cfg)} (with the dataset of: {meta.get('command', 'vcs-env collect')})")
    return {"model": str(path), **report, "wall_time": wall}
