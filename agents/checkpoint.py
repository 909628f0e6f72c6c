"""What a checkpoint is: one object per format, each detecting, loading and describing itself once.

Three formats (:data:`FORMATS`), each with a run record (:func:`agents.runs.run_record`):

* :class:`SB3Checkpoint`: an SB3 PPO ``.zip`` with its record beside it under the same stem
  (``runs/x/model.zip`` + ``runs/x/model.json``), from ``vcs-env train`` and ``vcs-env bc``; given
  as the zip (suffix optional) or its run directory (``model.zip`` in it);
* :class:`RLlibCheckpoint`: the checkpoint directory of ``vcs-env train --backend rllib``
  (``Algorithm.save_to_path`` with ``vcs_env.json`` in it), given as itself or its run directory;
* :class:`BenchMARLCheckpoint`: the policy network of ``vcs-env train --backend benchmarl``
  (``actor.pt`` with ``actor.json`` beside it), given as the file or its run directory; loads with torch alone.

:func:`open_checkpoint` finds the format of a path once; callers then ask the object (its
:attr:`~Checkpoint.record`, :meth:`~Checkpoint.load`, :meth:`~Checkpoint.describe`), never the path
again. Every failure is a :class:`CheckpointError` naming the file and the problem: not found (with
every accepted form), a run record given instead of its checkpoint, not a zip / truncated /
unreadable, a policy made for observation v0 (before the fixed physical scales of v1), or for
another observation config (e.g. another ``n_neighbors``). Using a policy on a scenario family it
was not trained on is allowed, with a :class:`FamilyWarning` naming both. :func:`latest_checkpoint`
is what ``vcs-env train --resume RUN_DIR`` continues: the newest checkpoint of a run directory.

Each format also exports its deterministic actor to ONNX (:meth:`~Checkpoint.export_onnx`, built by
:mod:`agents.export`). Whether a checkpoint fits a scenario is checked by :mod:`agents.fits`.

stable-baselines3, torch and Ray are imported when a checkpoint is loaded or exported, not before.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import warnings
import zipfile
from functools import cached_property
from pathlib import Path
from typing import Any, ClassVar

from vcs_env.checks import TORCH_FIRST, install_hint, user_stacklevel
from vcs_env.files import write_text
from vcs_env.scenario import Scenario
from vcs_env.spaces import observation_space

from .export import OPSET, export_onnx, mlp_network, rllib_actor, sb3_actor, tanh_actor
from .fits import SIZE_HINT as SIZE_HINT
from .fits import CheckpointError as CheckpointError
from .fits import FamilyWarning as FamilyWarning
from .fits import UncheckedWarning as UncheckedWarning
from .fits import cause
from .fits import check_checkpoint_fits as check_checkpoint_fits
from .fits import check_observation_space as check_observation_space
from .predictors import BenchMARLPolicy as BenchMARLPolicy
from .predictors import RLlibPolicy as RLlibPolicy
from .runs import config_path as config_path
from .runs import network_of
from .runs import save_model as save_model

RAY_HINT = f"{install_hint('rllib')} {TORCH_FIRST}"
"""How to install Ray RLlib, for error messages."""
ACCEPTED = (
    "an SB3 .zip file (the suffix may be left out), a run directory with model.zip, an RLlib checkpoint "
    "directory (with vcs_env.json), an RLlib run directory (with checkpoint/), a BenchMARL actor.pt or its run "
    "directory"
)
"""Every form a checkpoint may be given in, for error messages."""


def import_ray():
    """``ray`` with RLlib, or a one-line ImportError naming the extra."""
    try:
        import ray
        import ray.rllib  # noqa: F401
    except ImportError as e:
        raise ImportError(f"--backend rllib needs Ray RLlib; install it with: {RAY_HINT} ({e})") from None
    return ray


# --------------------------------------------------------------------------- formats
class Checkpoint:
    """A checkpoint found on disk; a subclass per format (:data:`FORMATS`)."""

    format: ClassVar[str]
    """``sb3``, ``rllib`` or ``benchmarl``."""
    record_name: ClassVar[str]
    """File name of the run record."""
    periodic: ClassVar[re.Pattern]
    """Name of a periodic checkpoint in ``<run>/checkpoints/``, its step count as group 1."""
    periodic_name: ClassVar[str]
    """That name for a step count (``periodic_name.format(steps)``)."""

    def __init__(self, path: Path, record_path: Path):
        self.path = path
        """The checkpoint itself (the ``.zip`` file, the RLlib checkpoint directory)."""
        self.record_path = record_path
        """Its run record (may be missing for a plain SB3 zip)."""

    @classmethod
    def find(cls, path: Path) -> Checkpoint | None:
        """The checkpoint of this format that ``path`` names, or None."""
        raise NotImplementedError

    @classmethod
    def final(cls, run: Path) -> Path:
        """Where a run directory of this format keeps its final checkpoint."""
        raise NotImplementedError

    @classmethod
    def in_run(cls, run: Path) -> list[Checkpoint]:
        """The checkpoints of this format a run directory holds: periodic ones by step, then the final one."""
        steps = sorted((int(m[1]), p) for p in run.glob("checkpoints/*") if (m := cls.periodic.fullmatch(p.name)))
        found = [cls.find(p) for _, p in steps] + [cls.find(cls.final(run)) if cls.final(run).exists() else None]
        return [c for c in found if c is not None]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({str(self.path)!r})"

    def __str__(self) -> str:
        return str(self.path)

    def describe(self) -> str:
        """How error messages name it (``checkpoint 'runs/x/model.zip'``)."""
        return f"checkpoint {str(self.path)!r}"

    @cached_property
    def record(self) -> dict[str, Any]:
        """The run record; ``{}`` if there is none (a plain SB3 zip is still loadable); a ``CheckpointError`` if it
        is not valid JSON, or not a JSON object (every door reads it as one)."""
        if not self.record_path.is_file():
            return {}
        try:
            record = json.loads(self.record_path.read_text())
        except (OSError, json.JSONDecodeError) as e:
            raise CheckpointError(f"checkpoint metadata {self.record_path} is not valid JSON: {e}") from None
        if not isinstance(record, dict):
            what = f"checkpoint metadata {self.record_path} is a JSON {type(record).__name__}"
            raise CheckpointError(f"{what}, not a run record (an object): remove it, or put the run's model.json there")
        return record

    @property
    def run_dir(self) -> Path:
        """The run directory the checkpoint belongs to (periodic ones sit in its ``checkpoints/``)."""
        parent = self.path.parent
        return parent.parent if parent.name == "checkpoints" else parent

    @property
    def timesteps(self) -> int:
        """Environment steps it was trained for (its record, else its periodic name, else 0)."""
        steps = self.record.get("num_timesteps")
        match = self.periodic.fullmatch(self.path.name)
        return int(steps) if steps is not None else int(match[1]) if match else 0

    def load(self, scenario: Scenario | None = None, env=None, device: str = "cpu"):
        """The policy, checked against ``scenario`` if given (:func:`check_checkpoint_fits`).

        ``env`` (a VecEnv) attaches an SB3 model to continue training it.
        """
        raise NotImplementedError

    def actor(self):
        """``(module, observation_space)``: the deterministic actor as a ``torch.nn.Module``, observations
        ``(N, D)`` float32 to actions ``(N, 2)`` in ``[-1, 1]``, as ``load().predict(obs, deterministic=True)``."""
        raise NotImplementedError

    def export_onnx(self, out: str | os.PathLike, opset: int = OPSET) -> tuple[Path, Path]:
        """Write :meth:`actor` to ``out`` (``.onnx``) and its layout beside it (:func:`agents.export.export_onnx`)."""
        return export_onnx(self, out, opset)


class SB3Checkpoint(Checkpoint):
    """An SB3 PPO ``.zip`` of ``vcs-env train`` or ``vcs-env bc``, its record beside it (``model.json``)."""

    format = "sb3"
    record_name = "model.json"
    periodic = re.compile(r"model_(\d+)\.zip")
    periodic_name = "model_{}.zip"

    @classmethod
    def find(cls, path: Path) -> SB3Checkpoint | None:
        for p in (path, path.with_name(path.name + ".zip") if path.suffix != ".zip" else None, path / "model.zip"):
            if p is not None and p.is_file():
                return cls(p, config_path(p))
        return None

    @classmethod
    def final(cls, run: Path) -> Path:
        return run / "model.zip"

    def load(self, scenario: Scenario | None = None, env=None, device: str = "cpu"):
        """The ``stable_baselines3.PPO`` model, checked first."""
        from stable_baselines3 import PPO
        from stable_baselines3.common.save_util import load_from_zip_file

        path = str(self.path)
        if not zipfile.is_zipfile(self.path) and self.path.suffix != ".zip":
            known = ", ".join(f.format for f in FORMATS)
            raise CheckpointError(f"{path!r} is not a checkpoint of a known format ({known}): expected {ACCEPTED}")
        if not zipfile.is_zipfile(self.path):
            raise CheckpointError(f"checkpoint {path!r} is corrupt: not a zip archive (an SB3 .zip is expected)")
        try:
            data, params, _ = load_from_zip_file(path, device=device, print_system_info=False)
        except Exception as e:  # truncated members, bad pickles, bad tensors ...
            raise CheckpointError(f"checkpoint {path!r} is corrupt or unreadable: {type(e).__name__}: {e}") from None
        if not data or "observation_space" not in data or not params or "policy" not in params:
            raise CheckpointError(
                f"checkpoint {path!r} is not an SB3 policy checkpoint (no observation space or policy weights)"
            )
        if "clip_range" not in data:  # A2C shares PPO's policy class; SAC, TD3, DQN have their own
            cls = getattr(data.get("policy_class"), "__name__", "unknown")
            raise CheckpointError(
                f"checkpoint {path!r} was saved by another SB3 algorithm than PPO (policy class {cls}, no "
                "clip_range): vcs-env loads the PPO checkpoints of `vcs-env train` and `vcs-env bc`"
            )
        if scenario is not None:
            check_checkpoint_fits(self.record, data["observation_space"], scenario, self.describe())
        try:
            return PPO.load(path, env=env, device=device)
        except Exception as e:
            raise CheckpointError(f"checkpoint {path!r} could not be loaded: {type(e).__name__}: {e}") from None

    def actor(self):
        model = self.load()
        return sb3_actor(model), model.observation_space


class RLlibCheckpoint(Checkpoint):
    """The checkpoint directory of ``vcs-env train --backend rllib``: RLlib's files and ``vcs_env.json``."""

    format = "rllib"
    record_name = "vcs_env.json"
    periodic = re.compile(r"checkpoint_(\d+)")
    periodic_name = "checkpoint_{}"
    MODULE_ID: ClassVar[str] = "shared"
    """The RLModule every robot's policy is."""

    @classmethod
    def find(cls, path: Path) -> RLlibCheckpoint | None:
        for p in (path, path / "checkpoint"):
            if (p / cls.record_name).is_file():
                return cls(p, p / cls.record_name)
        return None

    @classmethod
    def final(cls, run: Path) -> Path:
        return run / "checkpoint"

    def describe(self) -> str:
        return f"RLlib checkpoint {str(self.path)!r}"

    @property
    def module_dir(self) -> Path:
        """Where the shared RLModule's state is."""
        return self.path / "learner_group" / "learner" / "rl_module" / self.MODULE_ID

    def load(self, scenario: Scenario | None = None, env=None, device: str = "cpu") -> RLlibPolicy:
        """The shared module as an :class:`RLlibPolicy` (``predict`` only; SB3 cannot continue it)."""
        if env is not None:
            raise CheckpointError(f"{str(self.path)!r} is an RLlib checkpoint; SB3 training cannot continue it")
        meta = self.record
        if not self.module_dir.is_dir():
            raise CheckpointError(f"{self.describe()} has no module {self.MODULE_ID!r} (expected {self.module_dir})")
        if scenario is not None:  # before the slow import: the observation size is in the record
            dim, want = meta.get("observation_dim"), observation_space(scenario).shape[0]
            if dim != want:
                raise CheckpointError(
                    f"{self.describe()} was made for observations of size {dim}, but scenario "
                    f"kind={scenario.kind!r} with n_neighbors={scenario.n_neighbors} gives {want} "
                    f"{SIZE_HINT}; use a policy trained for this observation layout"
                )
        import_ray()
        import torch
        from ray.rllib.core.rl_module.rl_module import RLModule

        torch.set_num_threads(1)
        try:
            module = RLModule.from_checkpoint(self.module_dir.resolve().as_posix())
        except Exception as e:
            raise CheckpointError(f"{self.describe()} could not be loaded: {type(e).__name__}: {e}") from None
        if scenario is not None:
            check_checkpoint_fits(meta, module.observation_space, scenario, self.describe())
        module.eval()
        return RLlibPolicy(module, name=Path(meta.get("config", {}).get("out", self.path.parent.name)).name)

    def actor(self):
        policy = self.load()
        return rllib_actor(policy.module), policy.observation_space


class BenchMARLCheckpoint(Checkpoint):
    """The policy network of ``vcs-env train --backend benchmarl`` (``actor.pt``, its record ``actor.json``).

    ``actor.pt`` (``torch.save``, tensors and plain values only) holds the MLP every robot shares: ``layers``
    (``[in, out]`` per linear layer), ``activation`` (a ``torch.nn`` name, between the linear layers),
    ``state_dict`` (of that ``torch.nn.Sequential``) and ``scale`` (``bias``, ``min``: BenchMARL's biased
    softplus of the scale half), ``low`` and ``high`` (the observation bounds). The network maps an observation
    ``(N, D)`` to ``(N, 4)``: the loc and scale parameters of a TanhNormal over ``[-1, 1]^2``; the deterministic
    action is ``tanh(loc)``.
    """

    format = "benchmarl"
    record_name = "actor.json"
    periodic = re.compile(r"actor_(\d+)\.pt")
    periodic_name = "actor_{}.pt"

    @classmethod
    def find(cls, path: Path) -> BenchMARLCheckpoint | None:
        for p in (path, path / "actor.pt"):  # ours: actor.pt, actor_<steps>.pt, or any .pt with its record beside
            ours = p.name == "actor.pt" or cls.periodic.fullmatch(p.name) or p.with_suffix(".json").is_file()
            if p.suffix == ".pt" and p.is_file() and ours:
                return cls(p, p.with_suffix(".json"))
        return None

    @classmethod
    def final(cls, run: Path) -> Path:
        return run / "actor.pt"

    def describe(self) -> str:
        return f"BenchMARL checkpoint {str(self.path)!r}"

    def saved(self) -> dict[str, Any]:
        """The contents of ``actor.pt``, checked."""
        import torch

        try:
            data = torch.load(self.path, map_location="cpu", weights_only=True)
        except Exception as e:
            raise CheckpointError(f"{self.describe()} is corrupt or unreadable: {cause(e)}") from None
        keys = ("layers", "activation", "state_dict", "scale", "low", "high")
        missing = [k for k in keys if not isinstance(data, dict) or k not in data]
        if missing:
            raise CheckpointError(f"{self.describe()} is not a vcs-env BenchMARL actor (no {', '.join(missing)})")
        return data

    def load(self, scenario: Scenario | None = None, env=None, device: str = "cpu") -> BenchMARLPolicy:
        """The policy as a :class:`BenchMARLPolicy` (``predict`` only; no SB3 training can continue it)."""
        if env is not None:
            raise CheckpointError(f"{self.describe()} is a BenchMARL policy; SB3 training cannot continue it")
        import torch

        torch.set_num_threads(1)
        data = self.saved()
        try:
            net = mlp_network(data)
            if net[0].in_features != len(data["low"]):
                raise ValueError(f"its network takes {net[0].in_features} inputs, its bounds {len(data['low'])}")
        except (RuntimeError, ValueError, KeyError, TypeError, IndexError) as e:
            raise CheckpointError(f"{self.describe()} could not be loaded: {cause(e)}") from None
        policy = BenchMARLPolicy(net, data, name=self.path.parent.name)
        if scenario is not None:
            check_checkpoint_fits(self.record, policy.observation_space, scenario, self.describe())
        return policy

    def actor(self):
        policy = self.load()
        return tanh_actor(policy.net), policy.observation_space


FORMATS: tuple[type[Checkpoint], ...] = (BenchMARLCheckpoint, SB3Checkpoint, RLlibCheckpoint)
"""Every checkpoint format, in the order they are tried (a BenchMARL actor first: SB3 takes any other file)."""


def find_checkpoint(spec: str | os.PathLike | Checkpoint) -> Checkpoint | None:
    """The checkpoint ``spec`` names (an object of its format), or None."""
    if isinstance(spec, Checkpoint):
        return spec
    path = Path(spec)
    if path.suffix in (".json", ".npz"):  # a run record, a dataset (vcs-env collect's): not checkpoints
        return None
    return next((c for fmt in FORMATS if (c := fmt.find(path)) is not None), None)


def open_checkpoint(spec: str | os.PathLike | Checkpoint) -> Checkpoint:
    """The checkpoint ``spec`` names, or a one-line :class:`CheckpointError` naming every accepted form."""
    p = Path(spec) if not isinstance(spec, Checkpoint) else None
    if p is not None and re.fullmatch(r"checkpoint_\d+\.pt", p.name) and p.parent.name == "checkpoints":
        run = p.parents[3] if len(p.parents) > 3 and p.parents[2].name == "benchmarl" else Path("<run>")
        raise CheckpointError(  # BenchMARL's folder, kept in <run>/benchmarl/<experiment>/checkpoints/
            f"{str(p)!r} is BenchMARL's own checkpoint of its experiment; pass the run's policy "
            f"{str(run / 'actor.pt')!r} (or checkpoints/actor_<steps>.pt beside it) or the run directory {str(run)!r}"
        )
    found = find_checkpoint(spec)
    if found is not None:
        return found
    path = Path(spec)
    for fmt in FORMATS:
        if path.name == fmt.record_name and path.is_file():
            holder = {SB3Checkpoint: "model.zip", BenchMARLCheckpoint: "actor.pt"}.get(fmt, "the checkpoint directory")
            raise CheckpointError(f"{str(path)!r}: {path.name} is the run record; pass {holder} or the run directory")
    if path.suffix == ".json" and path.with_suffix(".zip").is_file():
        raise CheckpointError(
            f"{str(path)!r} is the run record; pass {path.with_suffix('.zip').name} or the run directory"
        )
    if path.suffix == ".npz" and path.is_file():
        raise CheckpointError(f"{str(path)!r} is a dataset (vcs-env collect's .npz), not a checkpoint ({ACCEPTED})")
    if path.suffix == ".json" and path.is_file():  # an exported policy's layout, say: it exists, so not "not found"
        raise CheckpointError(f"{str(path)!r} is a JSON file, not a checkpoint (expected {ACCEPTED})")
    kept = [c.path for fmt in FORMATS for c in fmt.in_run(path)] if path.is_dir() else []
    kept += [p for p in [path / "best_model.zip"] if p.is_file()]
    if kept:  # a run stopped before its final model (Ctrl-C, a time limit): name what it left
        raise CheckpointError(
            f"{str(path)!r} holds no final model (a run stopped before its end?); pass one of what it kept: "
            f"{', '.join(repr(str(p)) for p in kept[-3:])} (or vcs-env train --resume {str(path)!r} to finish it)"
        )
    raise CheckpointError(f"checkpoint not found: {str(path)!r} (expected {ACCEPTED})")


def latest_checkpoint(spec: str | os.PathLike) -> Checkpoint:
    """What a resumed run continues: a checkpoint as given, or the newest checkpoint of a run
    directory (its final one or a periodic one in ``checkpoints/``, by timesteps; the final one on
    a tie), so a run killed before its end resumes from its last periodic checkpoint."""
    path = Path(spec)
    given = find_checkpoint(path)
    if not path.is_dir() or (given is not None and given.path == path):  # a file, or a checkpoint directory
        return open_checkpoint(path)
    found = [c for fmt in FORMATS for c in fmt.in_run(path)]
    if not found:
        return open_checkpoint(path)  # the run directory's own error: not found, with every form
    ranked = sorted(reversed(found), key=lambda c: c.timesteps, reverse=True)  # stable: the final one on a tie
    whole = next((c for c in ranked if _whole(c)), ranked[0])  # none whole: the newest, for its own error
    if whole is not ranked[0]:
        warnings.warn(
            f"{ranked[0].describe()} is incomplete (a run stopped while saving it?): going on from {whole}",
            stacklevel=user_stacklevel(),
        )
    return whole


def _whole(ckpt: Checkpoint) -> bool:
    """Does ``ckpt`` have a run record that is a JSON object, and (SB3) a zip that is a zip archive?"""
    try:
        zipped = ckpt.format != "sb3" or zipfile.is_zipfile(ckpt.path)
        return ckpt.record_path.is_file() and bool(ckpt.record) and zipped
    except CheckpointError:
        return False


# --------------------------------------------------------------------------- checks
def attach_shield(checkpoint: str | os.PathLike, shield: Any | None) -> dict[str, Any] | None:
    """Write ``shield`` (an :class:`agents.shield.Shield`) into the run record of ``checkpoint`` (None removes
    it); return the shield the record held before (its JSON object), or None."""
    ckpt = open_checkpoint(checkpoint)
    if ckpt.format != "sb3":
        raise ValueError(
            f"{str(checkpoint)!r} is a {ckpt.format} checkpoint; shields are kept in the run records of SB3 ones"
        )
    record = ckpt.record  # an object (Checkpoint.record refuses any other JSON)
    if not record:
        raise ValueError(
            f"{str(ckpt.path)!r} has no run record to keep the shield in ({ckpt.record_path.name} is missing or empty)"
        )
    before = record.pop("shield", None)
    if shield is not None:
        record["shield"] = dataclasses.asdict(shield)
    write_text(ckpt.record_path, json.dumps(record, indent=2) + "\n")
    return before


# --------------------------------------------------------------------------- SB3 and RLlib
def load_model(checkpoint: str | os.PathLike | Checkpoint, scenario: Scenario | None = None, env=None, device="cpu"):
    """Load a checkpoint of any format (:func:`open_checkpoint`), checking it first.

    Args:
        checkpoint: an SB3 ``.zip`` (suffix optional), a run directory, or an RLlib checkpoint
            (gives an :class:`RLlibPolicy`, ``predict`` only).
        scenario: if given, the policy must fit this scenario (:func:`check_checkpoint_fits`:
            same observation config, else :class:`CheckpointError`; another scenario family
            gives a :class:`FamilyWarning`).
        env, device: a VecEnv to attach (to continue SB3 training), the torch device.

    Raises:
        CheckpointError: missing, corrupt, not PPO, made for observation v0 or another observation config.
    """
    return open_checkpoint(checkpoint).load(scenario, env, device)


def load_policy_weights(model, checkpoint: str | os.PathLike, scenario: Scenario) -> dict[str, Any]:
    """Copy the policy weights of ``checkpoint`` into ``model.policy`` (``train --init``) and return its run record;
    the architecture must match (a :class:`CheckpointError` names the differing tensors and the checkpoint's flags)."""
    ckpt = open_checkpoint(checkpoint)
    src = ckpt.load(scenario)
    if not hasattr(src, "policy"):
        raise CheckpointError(f"{ckpt.describe()} holds no SB3 policy to copy weights from (--init takes SB3 ones)")
    theirs, ours = src.policy.state_dict(), model.policy.state_dict()
    diff = sorted(
        k for k in set(theirs) | set(ours) if k not in theirs or k not in ours or theirs[k].shape != ours[k].shape
    )
    if diff:
        shapes = [tuple(d[k].shape) if k in d else "missing" for k in diff[:4] for d in (theirs, ours)]
        detail, net = ", ".join(f"{k}: {a} vs {b}" for k, a, b in zip(diff, shapes[::2], shapes[1::2])), network_of(src)
        raise CheckpointError(
            f"checkpoint {str(checkpoint)!r} has another policy architecture than this run "
            f"(checkpoint vs run: {detail}); use the same --net-arch and --features (the checkpoint's: "
            f"--features {net['features']} --net-arch {' '.join(map(str, net['net_arch']))})"
        )
    model.policy.load_state_dict(theirs)
    return ckpt.record
