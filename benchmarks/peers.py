"""Imports of the peer packages (extra ``bench``). A peer that cannot be imported raises
:class:`~benchmarks.timing.Missing` with the reason, and is reported as missing."""

from __future__ import annotations

import importlib

from vcs_env.checks import EXTRA_OF, install_hint

from .timing import Missing

PEERS = {
    "mpe2": "PettingZoo MPE (simple_spread, parallel API, continuous actions)",
    "vmas": "VMAS (navigation scenario, CPU, torch threads = 1)",
    "pyrvo": "RVO2 2.0.3 ORCA through pyrvo",
    "stable_baselines3": "SB3 PPO (training throughput)",
}


def require(module: str):
    """Import ``module`` or raise :class:`Missing` naming the error and the install hint."""
    try:
        return importlib.import_module(module)
    except Exception as e:  # ImportError, or a broken install that fails while importing
        hint = install_hint("train" if EXTRA_OF.get(module.split(".")[0]) == "train" else "bench")  # [bench]: the rest
        raise Missing(f"cannot import {module} ({type(e).__name__}: {e}); {hint}") from None


def status() -> dict[str, str]:
    """``module -> "ok <version>"`` or ``"missing: <reason>"`` for every peer."""
    out = {}
    for module in PEERS:
        try:
            mod = require(module)
            out[module] = f"ok {getattr(mod, '__version__', '')}".strip()
        except Missing as e:
            out[module] = f"missing: {e}"
    return out


def torch_single_thread() -> str:
    """Set torch to one intra-op and one inter-op thread (fair against single-threaded numpy);
    returns what was set, or why not."""
    try:
        import torch
    except Exception as e:
        return f"torch not importable ({type(e).__name__})"
    torch.set_num_threads(1)
    try:
        torch.set_num_interop_threads(1)
    except RuntimeError:  # only allowed before any parallel work started
        pass
    return f"torch.set_num_threads(1): {torch.get_num_threads()} thread"
