"""Distillation (``vcs-env distil``): several teacher policies, each labelling its own mixture entries, into one
student network, by DAgger with network teachers or the VCS expert (the teacher named :data:`EXPERT`).

Why: a PPO stage that weights some families up (the maps) gains there and loses elsewhere, and per-family
fine-tunes of one network are each better on their family than any single network trained on the whole mixture
(``docs/experiments.md``, "Distilling teachers by family"). Distillation keeps each family's best teacher: every
round plays ``robots`` robot trajectories per entry (an entry listed k times in ``--mixture`` gets k times as
many), each robot executing the teacher's action with probability ``beta_k`` and the student's deterministic
action otherwise (``beta_k = beta * 0.5**k``, 0 in the last round, which the student plays alone), labels every
acting robot-step with the deterministic action of the entry's teacher (its network alone, or with
``--teacher-shield`` through the shield its record names; for :data:`EXPERT`, the expert's action as ``vcs-env
collect`` labels it), and
fits the student's action mean to the labels of all rounds so far (squared error, :func:`agents.imitation.bc_fit`
with ``loss="mse"``: the student's ``log_std`` and value head are left as they were, so PPO can continue from it).

Teachers should share the student's conventions (which side to pass on, who yields): teachers fine-tuned from
one parent distil into one network cleanly; specialists imitated from the expert from scratch each learned their
own, and a student taught by both collides where their families look alike (measured, ``docs/experiments.md``).

A network teacher trained on fewer observation fields than the run has (wall points without their segment fields,
``--wall-segments``) reads its own fields from the run's observations (:func:`load_teacher`); ``--read-wall-segments``
makes a student trained without those fields read them (:func:`agents.wall_segments.read_wall_segments`, weights kept).

Files: ``<out>/model.zip`` (+ ``model.json``: the teachers, per-round losses and row counts) and
``<out>/checkpoints/model_<rows>.zip`` after each round (``rows`` = labelled robot-steps so far), so that
``vcs-env select`` chooses among the rounds on validation episodes.

Example (the maps-stage checkpoint teaches the map entries, the checkpoint before it everything else)::

    vcs-env distil --mixture circle-16-v0 corridor-narrow-v0 corridor-narrow-v0 --n-wall-points 6 --stall-clock \\
        --teacher runs/before/model.zip --teacher-for corridor-narrow-v0=runs/maps/model.zip --out runs/distil
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.checks import check_int, check_range
from vcs_env.observations import observation_config, observation_layout, with_sensors

from ..checkpoint import load_model, open_checkpoint, save_model
from ..config import ScenarioConfig, config_command
from ..mixture import mixture_scenarios
from ..policies import load_checkpoint
from ..residual import refuse_residual
from ..runs import check_fresh_out, network_of, scenario_family, start_states
from ..shield import ShieldedPredictor
from ..wall_segments import read_wall_segments
from . import bc_fit
from .data import concat_datasets, play

FIRST_SEED = 900_000
"""First episode seed of the rounds (past the suites', validation's, probes' and collect's seeds); each round's
episodes take consecutive seeds from ``FIRST_SEED + ROUND_SEEDS * round``, entry by entry and grid point by point."""
ROUND_SEEDS = 10_000_000
"""Seeds set aside per round."""
EXPERT = "vcs"
"""The teacher name of the VCS expert, for --teacher or in --teacher-for (``ENTRY=vcs``); it is no checkpoint."""


@dataclass
class DistilConfig(ScenarioConfig):
    """``vcs-env distil``: teacher policies, each on its mixture entries, into one student (module docstring)."""

    mixture: tuple[str, ...] = ()
    """Entries to play (train's --mixture syntax); an entry listed k times gets k times the episodes."""
    teacher: str = ""
    """Checkpoint that labels every entry --teacher-for does not name (``vcs``: the VCS expert)."""
    teacher_for: tuple[str, ...] = ()
    """ENTRY=CHECKPOINT pairs: that checkpoint (``vcs``: the VCS expert) labels the states of that mixture entry (the
    entry as written in --mixture)."""
    teacher_shield: bool = False
    """Network teachers act through the shield their run record names (:mod:`agents.shield`), so the student learns
    the shielded actions (False: the network alone)."""
    init: str | None = None
    """The student's starting checkpoint, an SB3 one (None: --teacher, which must then be a checkpoint); its network
    is the student's."""
    widen_fine: bool = False
    """Give the student (a ``slots`` network) the ``slots-fine`` inputs before the first round, with zero weights
    (:func:`agents.features.widen_fine`): it starts acting as --init does and learns to read contacts at millimetre
    resolution."""
    read_wall_segments: bool = False
    """The student (its --init), trained on wall points without their segment fields, reads them, and so each wall
    point's time to contact from its segment (needs --wall-segments; :mod:`agents.wall_segments`)."""
    rounds: int = 4
    """DAgger rounds (the last one plays the student alone)."""
    beta: float = 1.0
    """Probability of executing the teacher's action in the first round (halved every round, 0 in the last)."""
    robots: int = 128
    """Robot trajectories per entry and round (episodes = robots / the entry's robot count, at least one per grid
    point of the entry)."""
    epochs: int = 3
    """Passes over all rounds' labels after each round."""
    batch_size: int = 512
    """Minibatch size."""
    learning_rate: float = 1e-4
    """Adam learning rate."""
    seed: int = 0
    """Seed of the beta mixing and the minibatch order (episode seeds: FIRST_SEED)."""
    start_states: str | None = None
    """Start-state file (vcs-env collect-states, e.g. where the student comes close to a contact): an episode of an
    entry with a pool there starts, with probability start_prob, from one of its states (vcs_env.start_states), so
    the rounds label more of the moments that decide a contact."""
    start_prob: float = 0.5
    """Probability that an episode of an entry with a start-state pool starts from it."""
    out: str = "runs/distil"
    """Run directory."""

    def __post_init__(self):
        for name, lo in (("rounds", 1), ("robots", 1), ("epochs", 1), ("batch_size", 1)):
            check_int(f"DistilConfig.{name}", getattr(self, name), lo, 10**7)
        check_range("DistilConfig.beta", self.beta, 0.0, 1.0)
        check_range("DistilConfig.learning_rate", self.learning_rate, 0.0, 1.0, lo_open=True)
        check_range("DistilConfig.start_prob", self.start_prob, 0.0, 1.0)
        if self.start_states is None and self.start_prob != DistilConfig.start_prob:  # as train refuses it
            raise ValueError("--start-prob is the share of episodes begun from --start-states: give those too")
        if self.rounds == 1 and self.beta != DistilConfig.beta:
            raise ValueError(
                "--beta mixes the teachers' actions into the rounds before the last; with --rounds 1 the "
                "one round plays the student alone: give more rounds, or leave --beta out"
            )
        for flag, value in (("--shaping", self.shaping != "none"), ("--rewards", self.rewards is not None)):
            if value:
                raise ValueError(
                    f"{flag} sets a reward, and distillation reads none (the student learns the "
                    f"teachers' actions): leave {flag} out"
                )


def teachers_of(cfg: DistilConfig) -> dict[str, str]:
    """Each distinct mixture entry -> its teacher checkpoint; ``ValueError`` for a --teacher-for pair that is
    malformed or names no entry of --mixture, and when --mixture or --teacher is missing."""
    if not cfg.mixture:
        raise ValueError("vcs-env distil needs --mixture (the entries to play)")
    if not cfg.teacher:
        raise ValueError("vcs-env distil needs --teacher (the checkpoint that labels the entries --teacher-for leaves)")
    out = dict.fromkeys(cfg.mixture, cfg.teacher)
    named: set[str] = set()
    for pair in cfg.teacher_for:
        # The longest mixture entry the pair starts with, then "=": entries and paths may hold "=" themselves.
        entry = max((e for e in out if pair.startswith(e + "=")), key=len, default=None)
        if entry is None:
            entry, sep, ckpt = pair.rpartition("=")
            if not sep or not entry or not ckpt:
                raise ValueError(f"--teacher-for takes ENTRY=CHECKPOINT pairs, got {pair!r}")
            raise ValueError(f"--teacher-for {pair!r}: no entry of --mixture ({list(out)}) followed by '='")
        ckpt = pair[len(entry) + 1 :]
        if not ckpt:
            raise ValueError(f"--teacher-for takes ENTRY=CHECKPOINT pairs, got {pair!r}")
        if entry in named:
            raise ValueError(f"--teacher-for names {entry!r} twice; give each entry one teacher")
        named.add(entry)
        out[entry] = ckpt
    if cfg.init is None and cfg.teacher == EXPERT:
        raise ValueError(f"with --teacher {EXPERT} (the expert, no network) the student needs --init CHECKPOINT")
    return out


class ColumnsPredictor:
    """An SB3-style ``PolicyPredictor`` reading only the columns ``cols`` of each observation (:func:`load_teacher`)."""

    def __init__(self, inner: Any, cols: np.ndarray):
        self.inner, self.cols = inner, cols
        self.observation_space = getattr(inner, "observation_space", None)
        self.action_space = getattr(inner, "action_space", None)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False):
        obs = np.asarray(observation)[..., self.cols]
        return self.inner.predict(obs, state=state, episode_start=episode_start, deterministic=deterministic)


def narrower(record: Any, scenario):
    """The scenario observed as a run record names (its ``observation``) when that observation is ``scenario``'s with
    fewer fields (the same version and scales; wall points without their segment fields), else None: such a
    checkpoint reads its own columns of ``scenario``'s observations (:meth:`vcs_env.observations.Layout.columns_of`)."""
    config = record.get("observation") if isinstance(record, dict) else None
    mine = observation_config(scenario)
    if not isinstance(config, dict) or config == mine:
        return None
    if config.get("version") != mine["version"] or config.get("scales") != mine["scales"]:
        return None
    own = with_sensors(scenario, config)
    try:
        observation_layout(scenario).columns_of(observation_layout(own))
    except ValueError:
        return None
    return own


def load_teacher(path: str, scenario, shield: bool):
    """The network teacher ``path`` for ``scenario``: as :func:`agents.policies.load_checkpoint` loads it, or, when its
    run record names an observation with fewer fields than ``scenario``'s (wall points without their segment fields),
    a :class:`ColumnsPredictor` reading its own fields from ``scenario``'s observations (:func:`narrower`). Any other
    observation is refused as ``load_checkpoint`` refuses it (:class:`agents.checkpoint.CheckpointError`, naming the
    block)."""
    own = narrower(open_checkpoint(path).record, scenario)
    if own is None:
        return load_checkpoint(path, scenario, shield=shield)
    cols = observation_layout(scenario).columns_of(observation_layout(own))
    return ColumnsPredictor(load_checkpoint(path, own, shield=shield), cols)


def load_student(cfg: DistilConfig, scenario):
    """The student's network (an SB3 model): --init (or --teacher), for ``scenario``; with --read-wall-segments, made to
    read ``scenario``'s wall segments (:func:`agents.wall_segments.read_wall_segments`)."""
    src = cfg.init or cfg.teacher
    refuse_residual(open_checkpoint(src).record, src, "distil --init")
    if not cfg.read_wall_segments:
        model = load_model(src, scenario)
    else:
        if not scenario.wall_segments:
            raise ValueError("--read-wall-segments reads the wall points' segment fields: add --wall-segments")
        # the run's observation is the student's, or the student's with the segment fields (else load_model refuses)
        own = narrower(open_checkpoint(src).record, scenario) or scenario
        model = load_model(src, own)
        if hasattr(model, "policy"):
            read_wall_segments(model, observation_layout(scenario))
    if not hasattr(model, "policy"):
        raise ValueError(f"the student {src!r} must be an SB3 checkpoint (--init), to be trained")
    return model


def distil(cfg: DistilConfig) -> dict[str, Any]:
    """Run the distillation of the module docstring; returns the report (paths, rows, losses)."""
    check_fresh_out(cfg.out)
    import torch

    torch.set_num_threads(1)
    t_start = time.time()
    counts = Counter(cfg.mixture)
    teacher_of = teachers_of(cfg)
    first = mixture_scenarios(cfg, tuple(counts))[0]  # every entry, one observation config (else a ValueError)
    groups = [(entry, mixture_scenarios(cfg, (entry,))) for entry in counts]
    played = [s for _, scenarios in groups for s in scenarios]
    family = scenario_family(played)
    starts = start_states(cfg, played, "distillation")
    # Each network teacher loaded for each entry it labels: checked against that entry's scenario, its shield too.
    loaded = {
        entry: load_teacher(c, scenarios[0], shield=cfg.teacher_shield)
        for entry, scenarios in groups
        if (c := teacher_of[entry]) != EXPERT
    }
    bare = [
        teacher_of[e]
        for e, t in loaded.items()
        if cfg.teacher_shield and not isinstance(getattr(t, "inner", t), ShieldedPredictor)
    ]
    if cfg.teacher_shield and not loaded:
        raise ValueError(
            "--teacher-shield puts network teachers behind their shield; the VCS expert labels every "
            "entry here: leave --teacher-shield out"
        )
    if bare:
        raise ValueError(f"--teacher-shield: the run record of {bare[0]!r} names no shield (vcs-env shield adds one)")
    model = load_student(cfg, first)
    if cfg.widen_fine:
        from ..features import widen_fine

        widen_fine(model)
    policy = model.policy

    def actor_of(predictor):
        return lambda o: predictor.predict(o, deterministic=True)[0]

    student = actor_of(model)
    rng = np.random.default_rng(cfg.seed)
    data: dict[str, np.ndarray] | None = None
    # The student's network as trained (--init's, widened or not): what a later --init must give.
    report: dict[str, Any] = {"teachers": teacher_of, "student": network_of(model), "rounds": []}
    for k in range(cfg.rounds):
        beta = 0.0 if k == cfg.rounds - 1 else cfg.beta * 0.5**k
        t0, next_seed, parts = time.time(), FIRST_SEED + ROUND_SEEDS * k, [] if data is None else [data]
        for entry, scenarios in groups:
            mean_n = np.mean([s.n_robots for s in scenarios])
            per_point = max(1, int(np.ceil(counts[entry] * cfg.robots / mean_n / len(scenarios))))
            teacher = None if teacher_of[entry] == EXPERT else actor_of(loaded[entry])  # None: the expert
            for sc in scenarios:
                seeds, next_seed = range(next_seed, next_seed + per_point), next_seed + per_point
                parts.append(play(sc, seeds, actor=student, beta=beta, rng=rng, teacher=teacher, start_states=starts))
        data = concat_datasets(*parts)  # one copy per round, not one per grid point
        losses = bc_fit(
            policy,
            data["observations"],
            data["actions"],
            None,
            epochs=cfg.epochs,
            batch_size=cfg.batch_size,
            lr=cfg.learning_rate,
            loss="mse",
            seed=cfg.seed + k,
        )
        rows = len(data["actions"])
        report["rounds"].append({"beta": beta, "rows": rows, "losses": losses, "wall_time": round(time.time() - t0, 1)})
        print(
            f"[round {k + 1}/{cfg.rounds}] beta {beta:.3f}: {rows} labelled robot-steps, loss {losses[0]:.4f} -> "
            f"{losses[-1]:.4f} ({time.time() - t0:.0f} s)",
            flush=True,
        )
        model.num_timesteps = rows
        paths = [Path(cfg.out) / "checkpoints" / f"model_{rows}.zip"]
        if k == cfg.rounds - 1:
            paths.append(Path(cfg.out) / "model.zip")
        for path in paths:
            saved = save_model(
                model, path, "distil", cfg, first, family, report=report, wall_time=round(time.time() - t_start, 1)
            )
    print(f"saved {saved} ({time.time() - t_start:.0f} s)")
    print(f"reproduce: {config_command('distil', cfg)}")
    return {"model": str(saved), **report}
