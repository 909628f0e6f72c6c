"""``vcs-env train``, ``collect``, ``bc``, ``distil``, ``collect-states`` and ``wall-segments``: the training and
imitation layers of ``agents`` (:mod:`agents.train`, :mod:`agents.train.rllib`, :mod:`agents.imitation`,
:mod:`agents.train.collect_states`, :func:`agents.wall_segments.wall_segments_copy`) on the command line.

The flags are the fields of the run configs (:mod:`agents.runs`, :func:`agents.config.add_config_args`).
``train --resume`` continues a checkpoint of an SB3 or RLlib PPO run, or the newest checkpoint of a run
directory (:func:`agents.checkpoint.latest_checkpoint`).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import agents.train
import agents.train.rllib
from agents import imitation
from agents.checkpoint import Checkpoint, latest_checkpoint
from agents.config import add_config_args, config_command, config_from_args, config_from_dict
from agents.imitation import distil
from agents.runs import (
    BENCHMARL_ONLY,
    FIXED_ON_RESUME,
    PARTNERS,
    RLLIB_ONLY,
    UNHONOURED,
    BenchMARLConfig,
    RLlibConfig,
    TrainConfig,
    check_partners,
)
from agents.train import collect_states

KINDS = {"ppo": TrainConfig, "rllib_ppo": RLlibConfig}
"""Run kinds ``--resume`` continues, with their config."""


def resume_base(args: argparse.Namespace) -> tuple[TrainConfig, Checkpoint]:
    """The checkpoint ``args.resume`` names (the newest one of a run directory) and the saved config
    of its run, with ``out`` its run directory unless ``--out`` is given; ``ValueError`` for a
    checkpoint that is not a PPO run's, for ``--init``, and for flags that would change what the
    checkpoint fixes (:data:`agents.runs.FIXED_ON_RESUME`)."""
    if args.init is not None:
        raise ValueError("--init and --resume exclude each other (resume continues a PPO run)")
    ckpt = latest_checkpoint(args.resume)
    if Path(args.resume).is_dir() and Path(args.resume).resolve() != ckpt.path.resolve():
        print(f"resuming {args.resume}: its newest checkpoint is {ckpt.path} ({ckpt.timesteps} timesteps)")
    meta = ckpt.record
    saved = meta.get("config")
    if saved is None:
        raise ValueError(f"cannot resume {args.resume!r}: no run record beside it (expected a vcs-env checkpoint)")
    if meta.get("kind") not in KINDS:
        hint = (
            "--init starts a PPO run from its weights"
            if ckpt.format == "sb3"
            else "--resume continues the PPO runs of the sb3 and rllib backends; --init takes SB3 checkpoints"
        )
        raise ValueError(
            f"cannot resume {args.resume!r}: a {meta.get('kind', 'unknown')} checkpoint, not a PPO run's ({hint})"
        )
    base = config_from_dict(KINDS[meta["kind"]], saved)
    total = args.timesteps if args.timesteps is not None else base.timesteps
    if total <= ckpt.timesteps:  # nothing to train: it would evaluate and save the checkpoint again
        given = f"got {total}" if args.timesteps is not None else f"the run's own is {total}"
        raise ValueError(
            f"--timesteps is the resumed run's new total: above the checkpoint's {ckpt.timesteps} ({given})"
        )
    changed = []
    for name in FIXED_ON_RESUME:
        given = getattr(args, name, None)
        given = tuple(given) if isinstance(given, list) else given
        if given is not None and given != getattr(base, name):
            changed.append(f"--{name.replace('_', '-')} (run: {getattr(base, name)!r}, given: {given!r})")
    if changed:
        raise ValueError(
            f"a resumed run keeps its network and PPO settings; {', '.join(changed)} would not apply. "
            "Start a new run from the checkpoint's weights with --init to change them (a residual run's with the same "
            "--residual flags)"
        )
    if getattr(args, "out", None) is None:
        base = dataclasses.replace(base, out=str(ckpt.run_dir))
    return base, ckpt


def check_backend_flags(args: argparse.Namespace, backend: str, names: tuple[str, ...]) -> None:
    """``ValueError`` naming the flags of ``names`` given while the backend is not ``backend``."""
    given = [f"--{name.replace('_', '-')}" for name in names if getattr(args, name, None) is not None]
    if given:
        raise ValueError(f"{', '.join(given)} {'applies' if len(given) == 1 else 'apply'} only to --backend {backend}")


def check_display_flags(args: argparse.Namespace, backend: str) -> None:
    """``ValueError`` naming an SB3 display flag (``--progress-bar``, ``--tensorboard``) ``backend`` cannot honour."""
    for name, (value, why) in UNHONOURED[backend].items():
        if getattr(args, name, None) is value:
            flag = "--" + ("" if value else "no-") + name.replace("_", "-")
            raise ValueError(f"{flag} is not available with --backend {backend} ({why})")


def cmd_train(args: argparse.Namespace) -> int:
    given = {name for name, *_ in PARTNERS if getattr(args, name, None) is not None}  # a default given counts too
    if args.backend == "benchmarl":  # None: sb3, or a resumed run's own backend
        check_backend_flags(args, "rllib", RLLIB_ONLY)
        check_display_flags(args, "benchmarl")
        if args.resume:
            raise ValueError("--resume is not available with --backend benchmarl (start a new run)")
        from agents.train import benchmarl

        cfg = config_from_args(BenchMARLConfig, args)
        check_partners(cfg, given)
        benchmarl.train(cfg)
        return 0
    check_backend_flags(args, "benchmarl", BENCHMARL_ONLY)
    base, ckpt = resume_base(args) if args.resume else (None, None)
    run_backend = None if ckpt is None else "rllib" if isinstance(base, RLlibConfig) else "sb3"
    if args.backend is not None and run_backend is not None and args.backend != run_backend:
        raise ValueError(f"cannot resume {args.resume!r} with --backend {args.backend}: it is an {run_backend} run's")
    rllib = (args.backend or run_backend) == "rllib"
    if not rllib:
        check_backend_flags(args, "rllib", RLLIB_ONLY)
        cfg = config_from_args(TrainConfig, args, base)
        check_partners(cfg, given)
        agents.train.train(cfg, resume=ckpt)
        return 0
    check_display_flags(args, "rllib")
    cfg = config_from_args(RLlibConfig, args, base)
    check_partners(cfg, given)
    try:
        agents.train.rllib.train(cfg, resume=ckpt)
    except (RuntimeError, ConnectionError) as e:  # a cluster that cannot run it: one line
        print(f"vcs-env train: error: {e}", file=sys.stderr)
        return 2
    return 0


def cmd_collect(args: argparse.Namespace) -> int:
    imitation.collect(config_from_args(imitation.CollectConfig, args))
    return 0


def cmd_bc(args: argparse.Namespace) -> int:
    imitation.behaviour_clone(config_from_args(imitation.BCConfig, args))
    return 0


def cmd_distil(args: argparse.Namespace) -> int:
    distil.distil(config_from_args(distil.DistilConfig, args))
    return 0


def cmd_collect_states(args: argparse.Namespace) -> int:
    cfg = config_from_args(collect_states.StatesConfig, args)
    states = collect_states.collect_states(cfg)
    states.command = config_command("collect-states", cfg)
    path = states.save(cfg.out)
    total = sum(len(p) for p in states.pools.values())
    print(f"saved {total} states of {len(states.pools)} scenarios -> {path}")
    if not total:
        print(
            "warning: no states: the policy touched nothing and no obstacle came close in these episodes "
            "(more --episodes, or a harder mixture); vcs-env train refuses a file without states",
            file=sys.stderr,
        )
    print(f"reproduce: {states.command}")
    return 0


def cmd_wall_segments(args) -> int:
    from agents.wall_segments import wall_segments_copy

    path = wall_segments_copy(args.checkpoint, args.out)
    print(f"{path}: the network of {args.checkpoint}, reading each wall point's segment (--wall-segments)")
    return 0


def add_commands(sub) -> None:
    """Add ``train``, ``collect``, ``bc``, ``distil``, ``collect-states`` and ``wall-segments`` to the ``vcs-env``
    subcommands."""
    p = sub.add_parser(
        "train",
        help="train a PPO policy shared by all robots",
        description=agents.train.__doc__.split("\n\n")[0],
    )
    add_config_args(p, TrainConfig)
    p.add_argument(
        "--backend",
        choices=["sb3", "rllib", "benchmarl"],
        default=None,
        help="sb3 (one process; the default), rllib (Ray) or benchmarl (MAPPO, IPPO, MASAC; docs/torchrl.md); a "
        "resumed run keeps its own",
    )
    add_config_args(p, RLlibConfig, skip=tuple(TrainConfig.__dataclass_fields__))
    add_config_args(p, BenchMARLConfig, skip=tuple(RLlibConfig.__dataclass_fields__))
    p.add_argument(
        "--resume",
        default=None,
        help="continue a PPO run (of the sb3 or rllib backend) from this checkpoint, or from the newest checkpoint "
        "of this run directory, in its run directory unless --out is given (its config JSON is reused: --timesteps "
        "sets the new total, evaluation, checkpoint and scenario flags may change; the network and PPO settings stay "
        "the checkpoint's)",
    )
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("collect", help="record VCS expert rollouts into a dataset (.npz)")
    add_config_args(p, imitation.CollectConfig)
    p.set_defaults(func=cmd_collect)
    p = sub.add_parser("bc", help="behaviour cloning (and DAgger) of the expert into a PPO policy")
    add_config_args(p, imitation.BCConfig)
    p.set_defaults(func=cmd_bc)
    p = sub.add_parser(
        "distil",
        help="distil teacher policies, each on its mixture entries, into one student network",
        description=distil.__doc__.split("\n\n")[0],
    )
    add_config_args(p, distil.DistilConfig)
    p.set_defaults(func=cmd_distil)

    p = sub.add_parser(
        "collect-states",
        help="pools of a policy's pre-contact and danger states, for train --start-states",
        description=collect_states.__doc__.split("\n\n")[0],
    )
    add_config_args(p, collect_states.StatesConfig)
    p.set_defaults(func=cmd_collect_states)

    p = sub.add_parser(
        "wall-segments",
        help="a copy of a slots checkpoint that reads the wall points' segments (--wall-segments), weights kept",
        description="Copy an SB3 slots checkpoint over wall points into OUT as a network that reads each wall "
        "point's segment and takes its time to contact from it (agents.wall_segments.wall_segments_copy).",
    )
    p.add_argument("checkpoint", help="checkpoint .zip (with its run record .json beside it) or run directory")
    p.add_argument("--out", required=True, help="directory for model.zip and model.json")
    p.set_defaults(func=cmd_wall_segments)
