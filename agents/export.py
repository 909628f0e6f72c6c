"""ONNX export of a checkpoint's deterministic actor (``vcs-env export CHECKPOINT --onnx OUT.onnx``).

Each checkpoint format (:mod:`agents.checkpoint`) builds its actor as a ``torch.nn.Module`` (its
``actor()``): observations ``(N, D)`` float32 in, actions ``(N, 2)`` float32 in ``[-1, 1]`` out,
exactly what its ``predict(obs, deterministic=True)`` returns:

* SB3 PPO: the policy's features extractor (``flat``, ``contact`` or the learned ``slots``/``slots-fine`` encoder of
  :mod:`agents.features`, the actor's own one when actor and critic have separate ones), its
  ``mlp_extractor`` actor branch and ``action_net`` (the Gaussian's mean), clipped to the action space as
  SB3's ``predict`` clips (:func:`sb3_actor`);
* RLlib: the shared RLModule's encoder and policy head (what its ``forward_inference`` runs), the mean
  half of its ``action_dist_inputs``, clipped to ``[-1, 1]`` as :class:`agents.checkpoint.RLlibPolicy`
  clips (:func:`rllib_actor`);
* BenchMARL: the shared policy MLP (:func:`mlp_network`), ``tanh`` of its loc half, BenchMARL's
  deterministic action of a TanhNormal over ``[-1, 1]`` (:func:`tanh_actor`).

:func:`export_onnx` traces it into ``OUT.onnx`` at opset :data:`OPSET` (one input ``observation``
``(batch, D)``, one output ``action`` ``(batch, 2)``, the batch size free) and writes ``OUT.json`` beside
it (:func:`layout`): the observation config (version, sizes, scales), the action's meaning, the opset and
the checkpoint's run record, scenario included. A residual policy's file holds the network's correction
and the JSON its rule (``residual``: planner, scale, how the two add up, :mod:`agents.residual`). A safety
shield named by the record (:mod:`agents.shield`) is not in the ONNX file: the file holds the network
alone, the JSON says so and a note is printed.

torch, onnx and onnxruntime are imported when a checkpoint is exported, not before.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.checks import install_hint
from vcs_env.files import replacing, write_text

from .fits import CheckpointError, cause
from .outputs import check_writable
from .residual import GATE_RULE, RULE, Residual
from .shield import shield_from_record

OPSET = 17
"""The ONNX opset every export uses (recorded in the JSON beside the file)."""
EXPORT_HINT = install_hint("export")
"""How to install onnx and onnxruntime, for error messages."""
LAYOUT_FORMAT = "vcs-env-onnx"
LAYOUT_VERSION = 1
"""Name and version of the JSON layout written beside an ONNX file."""
INPUT, OUTPUT = "observation", "action"
"""Names of the ONNX graph's input and output."""
CHECK_ROWS = 64
"""Random observations on which the written file is checked against the torch actor."""
TOLERANCE = 1e-5
"""Largest difference allowed between the ONNX file's actions and the actor's."""


def import_onnx():
    """``(onnx, onnxruntime)``, or a one-line ImportError naming the extra."""
    try:
        import onnx
        import onnxruntime
    except ImportError as e:
        raise ImportError(f"ONNX export needs onnx and onnxruntime; install them with: {EXPORT_HINT} ({e})") from None
    return onnx, onnxruntime


def check_out_path(out: str | os.PathLike) -> Path:
    """``out`` as a Path if it ends in ``.onnx`` and can be written; a one-line :class:`CheckpointError` otherwise."""
    path = Path(out)
    if path.name == ".onnx":
        raise CheckpointError(f"--onnx {str(path)!r} has no name before .onnx; give a file name such as policy.onnx")
    if path.suffix != ".onnx":
        raise CheckpointError(f"--onnx {str(path)!r} must end in .onnx (the layout is written beside it as .json)")
    if path.is_dir():
        raise CheckpointError(f"--onnx {str(path)!r} is a directory; give a file name ending in .onnx")
    side = path.with_suffix(".json")
    if side.exists() and not _is_layout(side):
        raise CheckpointError(
            f"--onnx {str(path)!r} writes its layout to {str(side)!r}, which holds another file (a run record?); "
            "give the ONNX file another name"
        )
    try:  # a file that cannot be made there fails now, not as an export error of the checkpoint
        check_writable(str(path), "--onnx")
    except ValueError as e:
        raise CheckpointError(str(e)) from None
    return path


def _is_layout(path: Path) -> bool:
    """``path`` holds a layout that :func:`export_onnx` wrote (it may be replaced)."""
    try:
        return json.loads(path.read_text()).get("format") == LAYOUT_FORMAT
    except (OSError, ValueError, AttributeError):
        return False


def sb3_actor(model):
    """The deterministic actor of an SB3 PPO ``model`` as a ``torch.nn.Module``: ``(N, D)`` float32
    observations to ``(N, 2)`` actions, the Gaussian's mean clipped to the action space, as
    ``model.predict(obs, deterministic=True)`` gives (no ``squash_output`` in vcs-env's policies)."""
    import torch
    from stable_baselines3.common.distributions import DiagGaussianDistribution

    policy = model.policy
    if not isinstance(policy.action_dist, DiagGaussianDistribution) or policy.squash_output:
        raise CheckpointError(
            f"only PPO policies with a Gaussian action (no squashing) export to ONNX, got "
            f"{type(policy.action_dist).__name__}"
        )
    space = policy.action_space
    low, high = np.asarray(getattr(space, "low", np.nan)), np.asarray(getattr(space, "high", np.nan))
    if getattr(space, "shape", None) != (2,) or not ((low == -1.0).all() and (high == 1.0).all()):
        raise CheckpointError(f"the policy acts in {space}, not in vcs-env's Box(-1, 1, (2,)): a policy of another env")

    class SB3Actor(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.features = policy.pi_features_extractor
            self.mlp = policy.mlp_extractor
            self.action_net = policy.action_net
            self.register_buffer("low", torch.as_tensor(space.low, dtype=torch.float32))
            self.register_buffer("high", torch.as_tensor(space.high, dtype=torch.float32))

        def forward(self, observation: torch.Tensor) -> torch.Tensor:
            latent = self.mlp.forward_actor(self.features(observation.float()))
            return torch.minimum(torch.maximum(self.action_net(latent), self.low), self.high)

    return SB3Actor().eval()


def rllib_actor(module):
    """The deterministic actor of an RLlib PPO RLModule (Gaussian, action size 2) as a ``torch.nn.Module``:
    ``(N, D)`` float32 observations to the mean half of ``action_dist_inputs`` clipped to ``[-1, 1]``
    ``(N, 2)``, as ``RLlibPolicy.predict(obs, deterministic=True)`` gives.

    The module's actor encoder, then its policy head; with ``free_log_std`` (vcs-env's runs) the head's own
    mean network, since the head appends the log std repeated ``len(mean)`` times, which tracing would fix
    to the example's batch size.
    """
    import torch
    from ray.rllib.core.models.base import ACTOR, ENCODER_OUT

    size = int(np.prod(module.action_space.shape))
    free_log_std = hasattr(module.pi, "net") and hasattr(module.pi, "log_std")

    class RLlibActor(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.encoder = module.encoder
            self.head = module.pi.net if free_log_std else module.pi

        def forward(self, observation: torch.Tensor) -> torch.Tensor:
            latent = self.encoder({"obs": observation})[ENCODER_OUT][ACTOR]
            return torch.clamp(self.head(latent)[:, :size], -1.0, 1.0)

    return RLlibActor().eval()


def mlp_network(saved: dict[str, Any]):
    """The ``torch.nn.Sequential`` a BenchMARL actor file describes (:class:`agents.checkpoint.BenchMARLCheckpoint`):
    linear layers of sizes ``saved["layers"]`` with ``saved["activation"]`` between them, weights loaded."""
    import torch

    if not saved["layers"]:
        raise ValueError("the network has no layers")
    act = getattr(torch.nn, str(saved["activation"]), None)
    if act is None or not isinstance(act, type) or not issubclass(act, torch.nn.Module):
        raise ValueError(f"unknown activation {saved['activation']!r} (a torch.nn module name is expected)")
    layers: list[Any] = []
    for k, (n_in, n_out) in enumerate(saved["layers"]):
        layers += ([act()] if k else []) + [torch.nn.Linear(int(n_in), int(n_out))]
    net = torch.nn.Sequential(*layers)
    net.load_state_dict(saved["state_dict"])
    if net[-1].out_features != 4:
        raise ValueError(f"the network gives {net[-1].out_features} outputs, not 4 (loc and scale of 2 actions)")
    return net.eval()


def tanh_actor(net):
    """The deterministic actor of a BenchMARL policy network ``net`` (``(N, D)`` to the loc and scale of a
    TanhNormal, ``(N, 4)``) as a ``torch.nn.Module``: observations ``(N, D)`` to ``tanh(loc)`` ``(N, 2)``."""
    import torch

    class TanhActor(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.net = net

        def forward(self, observation: torch.Tensor) -> torch.Tensor:
            return torch.tanh(self.net(observation.float())[:, :2])

    return TanhActor().eval()


def _shield(record: dict[str, Any]) -> dict[str, Any] | None:
    """The shield the record names with every parameter spelled out (a record written before a parameter
    existed keeps the rule it ran with, :func:`agents.shield.shield_from_record`), or None."""
    shield = shield_from_record(record)
    return None if shield is None else asdict(shield)


ACTION_MEANING = (
    "the deterministic action of each row's robot, in the env's action units (action_mode 'delta': acceleration and "
    "turn rate as fractions of a_max and omega_max)"
)
"""The output of an exported policy."""
CORRECTION_MEANING = (
    "the deterministic correction of each row's robot to {planner}'s action (not the action itself: the robot's action "
    "is residual.action), in the env's action units (action_mode 'delta')"
)
"""The output of an exported residual policy's network."""


def layout(checkpoint, dim: int, opset: int, note: str | None, residual: Residual | None = None) -> dict[str, Any]:
    """The JSON written beside the ONNX file: what goes in and out, and the run record it came from.

    Args:
        checkpoint: the exported checkpoint (its ``format``, ``path`` and ``record``).
        dim: the observation size ``D`` of the network's input.
        opset: the ONNX opset of the file.
        note: what the ONNX file leaves out (the record's safety shield), or None.
        residual: the rule of a residual policy (:class:`agents.residual.Residual`), or None.
    """
    import onnx
    import torch

    record = checkpoint.record
    return {
        "format": LAYOUT_FORMAT,
        "version": LAYOUT_VERSION,
        "opset": opset,
        "input": {"name": INPUT, "shape": ["batch", dim], "dtype": "float32"},
        "output": {
            "name": OUTPUT,
            "shape": ["batch", 2],
            "dtype": "float32",
            "range": [-1.0, 1.0],
            "meaning": ACTION_MEANING if residual is None else CORRECTION_MEANING.format(planner=residual.planner),
        },
        "observation": record.get("observation"),
        "observation_dim": dim,
        "shield": _shield(record),
        "shield_note": note,
        "residual": None
        if residual is None
        else {
            "planner": residual.planner,
            "scale": residual.scale,
            "gate": GATE_RULE if residual.gate else None,
            "action": RULE,
            "network_action": OUTPUT,
        },
        "checkpoint": {"format": checkpoint.format, "path": str(checkpoint.path)},
        "exported_with": {"torch": torch.__version__, "onnx": onnx.__version__},
        "record": record,
    }


def opset_range() -> tuple[int, int] | None:
    """The ONNX opsets the installed torch's TorchScript exporter writes (7 to 20 in torch 2.13), or None where
    that torch does not say (then the exporter's own error names a bad opset).

    Checked before exporting: that exporter prints the whole traced graph to the process's stderr
    before it refuses an opset it cannot write.
    """
    try:
        from torch.onnx import _constants  # private, but the exporter's own bounds

        return int(_constants.ONNX_MIN_OPSET), int(_constants.ONNX_TORCHSCRIPT_EXPORTER_MAX_OPSET)
    except (ImportError, AttributeError):
        return None


@contextlib.contextmanager
def _stdout_dropped():
    """Drop what is written to the process's standard output (file descriptor 1) inside the block: the TorchScript
    exporter turns its ONNX log on whatever it is told (torch 2.13) and writes the whole traced graph there when an
    operator cannot be exported (hundreds of lines before our one-line error)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def export_onnx(checkpoint, out: str | os.PathLike, opset: int = OPSET) -> tuple[Path, Path]:
    """Write the deterministic actor of ``checkpoint`` (an :class:`agents.checkpoint.Checkpoint`) to
    ``out`` (``.onnx``) and its :func:`layout` to ``out`` with suffix ``.json``; return both paths.

    The observation size is that of the checkpoint's own space and must match its run record's
    ``observation_dim`` (else :class:`CheckpointError`); the written file is run with onnxruntime on
    :data:`CHECK_ROWS` observations and must agree with the actor to :data:`TOLERANCE`. A shield named by
    the record is left out, with a note on stderr and in the JSON; a checkpoint without a run record is
    exported with a note that the JSON lacks its observation config.
    """
    path = check_out_path(out)
    onnx, ort = import_onnx()
    import torch

    if isinstance(opset, bool) or not isinstance(opset, int):
        raise CheckpointError(f"the ONNX opset must be an integer, got {opset!r}")
    bounds = opset_range()
    if bounds is not None and not bounds[0] <= opset <= bounds[1]:
        raise CheckpointError(f"torch {torch.__version__} exports ONNX opsets {bounds[0]} to {bounds[1]}, got {opset}")
    torch.set_num_threads(1)
    actor, space = checkpoint.actor()
    dim = int(space.shape[0])
    want = checkpoint.record.get("observation_dim")
    if want is not None and int(want) != dim:
        raise CheckpointError(
            f"{checkpoint.describe()} takes observations of size {dim}, but its run record "
            f"{str(checkpoint.record_path)!r} says {want}: the record belongs to another policy"
        )
    if not checkpoint.record:
        print(
            f"note: {checkpoint.describe()} has no run record ({str(checkpoint.record_path)!r} is missing): the JSON "
            "beside the ONNX file has no observation config or scenario",
            file=sys.stderr,
        )
    note = None
    if checkpoint.record.get("shield"):
        note = (
            f"the run record names a safety shield ({json.dumps(checkpoint.record['shield'])}); the ONNX file holds "
            "the network only: apply the shield (agents.shield) yourself to get the shielded policy"
        )
        print(f"note: {note}", file=sys.stderr)
    residual = Residual.of(checkpoint.record.get("config", {}))
    if residual is not None:
        print(
            f"note: a residual policy: the ONNX file's action corrects the {residual.planner} planner's; the robot's "
            f"action is {RULE} with scale {residual.scale} (the JSON's 'residual')",
            file=sys.stderr,
        )
    example = torch.zeros(2, dim, dtype=torch.float32)  # not 1: no size-1 broadcast baked into the graph
    obs = np.random.default_rng(0).uniform(space.low, space.high, size=(CHECK_ROWS, dim)).astype(np.float32)
    with replacing(path) as part:  # moved onto ``path`` once checked: a failure leaves ``path`` as it was
        try:
            with warnings.catch_warnings(), torch.no_grad(), _stdout_dropped():
                warnings.simplefilter("ignore")  # the TorchScript exporter's deprecation and tracer warnings
                torch.onnx.export(
                    actor,
                    (example,),
                    str(part),
                    dynamo=False,
                    opset_version=opset,
                    input_names=[INPUT],
                    output_names=[OUTPUT],
                    dynamic_axes={INPUT: {0: "batch"}, OUTPUT: {0: "batch"}},
                )
                expected = actor(torch.as_tensor(obs)).numpy()
            onnx.checker.check_model(onnx.load(str(part)))
            quiet = ort.SessionOptions()
            quiet.log_severity_level = 4  # a file it cannot load raises below; its own log line said it first
            session = ort.InferenceSession(str(part), quiet, providers=["CPUExecutionProvider"])
            got = session.run([OUTPUT], {INPUT: obs})[0]
        except Exception as e:  # an opset torch cannot write, an operator it cannot export, a file onnx refuses ...
            raise CheckpointError(
                f"{checkpoint.describe()} could not be exported at opset {opset}: {cause(e)}"
            ) from None
        if not np.allclose(got, expected, atol=TOLERANCE, rtol=0):
            raise CheckpointError(
                f"the ONNX file of {checkpoint.describe()} differs from the network by up to "
                f"{float(np.abs(got - expected).max()):.2g} (more than {TOLERANCE}); not exported"
            )
    side = path.with_suffix(".json")
    write_text(side, json.dumps(layout(checkpoint, dim, opset, note, residual), indent=2, allow_nan=False) + "\n")
    return path, side
