"""``vcs-env export``: a checkpoint's deterministic actor as an ONNX file, with its observation layout
and run record beside it as JSON (:mod:`agents.export`), to run without torch::

    vcs-env export runs/circle8 --onnx circle8.onnx

The checkpoint format (SB3 ``.zip``, RLlib checkpoint, or a run directory of either) is found by
:func:`agents.checkpoint.open_checkpoint`; the format builds and exports its actor.
"""

from __future__ import annotations

from agents import export
from agents.checkpoint import open_checkpoint


def cmd_export(args) -> int:
    export.check_out_path(args.onnx)  # before the slow load
    ckpt = open_checkpoint(args.checkpoint)
    onnx_path, json_path = ckpt.export_onnx(args.onnx, args.opset)
    print(f"wrote {onnx_path} (opset {args.opset}, {ckpt.format} checkpoint {ckpt.path}) and {json_path}")
    return 0


def add_commands(sub) -> None:
    """Add ``export`` to the ``vcs-env`` subcommands."""
    p = sub.add_parser(
        "export",
        help="export a checkpoint's deterministic actor to ONNX (observation in, action out) with its layout as JSON",
        description=export.__doc__.split("\n\n")[0],
    )
    p.add_argument(
        "checkpoint", help="SB3 .zip, RLlib checkpoint directory, BenchMARL actor.pt, or a run directory of any"
    )
    p.add_argument("--onnx", required=True, help="output file ending in .onnx (OUT.json is written beside it)")
    p.add_argument("--opset", type=int, default=export.OPSET, help=f"ONNX opset (default {export.OPSET})")
    p.set_defaults(func=cmd_export)
