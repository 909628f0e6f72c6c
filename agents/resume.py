"""What ``vcs-env train --resume`` continues: the saved config of the run, its directory, and the
flags it refuses (:data:`FIXED_ON_RESUME`)."""

from __future__ import annotations

import argparse
import dataclasses

from .config import config_from_dict
from .train import TrainConfig

FIXED_ON_RESUME = (
    "net_arch", "features", "log_std_init", "n_steps", "batch_size", "n_epochs", "learning_rate", "lr_schedule",
    "gamma", "gae_lambda", "clip_range", "ent_coef", "vf_coef", "max_grad_norm", "target_kl",
)  # fmt: skip
"""Fields a resumed run keeps from its checkpoint (the network and the PPO settings in the model)."""


def resume_base(args: argparse.Namespace) -> TrainConfig:
    """The saved config of the run ``args.resume`` continues, with ``out`` its run directory
    unless ``--out`` is given; ``ValueError`` for a checkpoint that is not a PPO run's, for
    ``--init``, and for flags that would change what the checkpoint fixes (:data:`FIXED_ON_RESUME`)."""
    from .checkpoint import read_metadata, resolve

    if args.init is not None:
        raise ValueError("--init and --resume exclude each other (resume continues a PPO run)")
    meta = read_metadata(args.resume)
    saved = meta.get("config")
    if saved is None:
        raise ValueError(f"cannot resume {args.resume!r}: no config JSON beside it (expected a vcs-env checkpoint)")
    if meta.get("kind") != "ppo":
        raise ValueError(
            f"cannot resume {args.resume!r}: a {meta.get('kind', 'unknown')} checkpoint, not a PPO run's "
            "(--init starts a PPO run from its weights)"
        )
    base = config_from_dict(TrainConfig, saved)
    changed = []
    for name in FIXED_ON_RESUME:
        given = getattr(args, name, None)
        given = tuple(given) if isinstance(given, list) else given
        if given is not None and given != getattr(base, name):
            changed.append(f"--{name.replace('_', '-')} (run: {getattr(base, name)!r}, given: {given!r})")
    if changed:
        raise ValueError(
            f"a resumed run keeps its network and PPO settings; {', '.join(changed)} would not apply. "
            "Start a new run from the checkpoint's weights with --init to change them"
        )
    if getattr(args, "out", None) is None:
        path = resolve(args.resume)
        run = path.parent.parent if path.parent.name == "checkpoints" else path.parent
        base = dataclasses.replace(base, out=str(run))
    return base
