"""Argument checks shared by the config dataclasses: each raises ``ValueError`` naming the field,
the allowed values and the value it got, so bad input never reaches numpy."""

from __future__ import annotations

import math
import os
import sys
import warnings
from collections.abc import Sequence

import numpy as np

# Reference scales used to normalize observations into [-1, 1]; limits are validated against them.
V_REF = 3.0
"""Largest allowed robot or obstacle speed [m/s]."""
A_REF = 10.0
"""Largest allowed robot acceleration [m/s^2]."""
OMEGA_REF = 2.0 * math.pi
"""Largest allowed robot turn rate [rad/s]."""
R_REF = 2.0
"""Largest allowed robot or obstacle radius [m]."""
LEAST_LIMIT = 1e-3
"""Least ``RobotSpec.a_max`` [m/s^2] and ``omega_max`` [rad/s], and least ``Scenario.dt`` [s] (the same reason)."""


def install_hint(extra: str) -> str:
    """How to install the optional ``extra``, as the README installs the package: from a checkout of the repository."""
    return f"pip install -e '.[{extra}]' in the vcs-env checkout"


EXTRA_OF = {
    "torch": "train", "stable_baselines3": "train", "sb3_contrib": "train", "tqdm": "train", "rich": "train",
    "tensorboard": "train", "matplotlib": "render", "pygame": "render", "PIL": "render", "imageio": "render",
    "onnx": "export", "onnxruntime": "export", "ray": "rllib", "torchrl": "torchrl", "tensordict": "torchrl",
    "benchmarl": "benchmarl", "hydra": "benchmarl", "pyrvo": "orca", "mpe2": "bench", "vmas": "bench",
    "nbformat": "dev", "nbclient": "dev", "pytest": "dev", "hypothesis": "dev",
}  # fmt: skip
"""The extra (``pyproject.toml``) that installs each optional package, by its import name."""


def missing_extra(err: ImportError, extra: str | None = None) -> str:
    """``err``'s message, with the extra to install when it is a missing optional package (:data:`EXTRA_OF`, or
    ``extra`` for a module that needs that one) and the message does not name one already (a bare ``No module named
    'torch'``)."""
    name = (getattr(err, "name", None) or "").split(".")[0]
    extra = EXTRA_OF.get(name) if extra is None or name not in EXTRA_OF else extra
    if extra is None or "pip install" in str(err):
        return str(err)
    first = f" {TORCH_FIRST}" if extra in TORCH_EXTRAS else ""
    return f"{err}; install it with: {install_hint(extra)}{first}"


TORCH_EXTRAS = ("train", "torchrl", "benchmarl", "rllib")
"""The extras that need torch, which the README installs first (``pip install torch==...``)."""
TORCH_FIRST = "(after torch, see the README: else pip pulls a CUDA build of it)"
"""What an install line of one of :data:`TORCH_EXTRAS` adds."""


def check_flag(name: str, value) -> bool:
    """``value`` as a bool if it is one (numpy's too, kept as Python's: JSON takes it); ``ValueError`` naming ``name``
    otherwise."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_range(name: str, value: float, lo: float, hi: float, lo_open: bool = False, hi_open=False) -> None:
    """Raise ``ValueError`` unless ``value`` is a finite number (not a bool) with ``lo <(=) value <(=) hi``."""
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    ok = ok and math.isfinite(value)
    if ok:
        ok = (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)
    if not ok:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        raise ValueError(f"{name} must be a finite number in {left}{lo}, {hi}{right}, got {value!r}")


def check_positive(name: str, value: float, allow_zero: bool = False) -> None:
    """Raise ``ValueError`` unless ``value`` is a finite number (not a bool) > 0, or >= 0 with ``allow_zero``."""
    check_range(name, value, 0.0, math.inf, lo_open=not allow_zero, hi_open=True)


def check_int(name: str, value: int, lo: int, hi: int) -> None:
    """Raise ``ValueError`` unless ``value`` is an integer (not a bool) in ``[lo, hi]``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


def check_interval(name: str, value: Sequence[float], lo: float, hi: float) -> None:
    """Raise ``ValueError`` unless ``value`` is a ``(low, high)`` pair in ``[lo, hi]`` with low <= high."""
    if isinstance(value, (str, bytes)) or np.ndim(value) != 1 or len(value) != 2:
        raise ValueError(f"{name} must be a (low, high) pair, got {value!r}")
    check_range(f"{name}[0]", value[0], lo, hi)
    check_range(f"{name}[1]", value[1], lo, hi)
    if value[0] > value[1]:
        raise ValueError(f"{name} must satisfy low <= high, got {value!r}")


def check_choice(name: str, value: str, choices: Sequence[str]) -> None:
    """Raise ``ValueError`` unless ``value`` is one of ``choices``, naming them."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {list(choices)}, got {value!r}")


def check_reset_options(options, known: Sequence[str] = (), warn: bool = False, made: str = "gym.make(id, n_robots=4)"):
    """Return ``options`` (``None`` as ``{}``) if it is a dict whose keys are all in ``known``.

    A scenario is set when its env is made (``made``: how, for the message), not by ``reset``: an option the env does
    not read is refused (``ValueError`` naming it), never silently ignored; with ``warn`` (PettingZoo, whose API test
    resets with an arbitrary option) it is ignored with a ``UserWarning`` naming it.
    """
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"reset options must be a dict or None, got {type(options).__name__}")
    unknown = sorted(str(k) for k in options if k not in known)
    if unknown:
        reads = f"reads only {list(known)}" if known else "reads no options"
        text = f"reset {reads}, got {unknown}: the scenario is set when the env is made ({made})"
        if not warn:
            raise ValueError(text)
        warnings.warn(text + "; ignored", UserWarning, stacklevel=user_stacklevel())
    return options


def user_stacklevel() -> int:
    """The ``stacklevel`` for a warning raised by this function's caller that points at the user's line: the first
    frame outside this project's packages and the front ends' libraries (Gymnasium's ``make``, PettingZoo's
    wrappers, TorchRL's env metaclass, BenchMARL), however many constructors lie between (a fixed level named a
    line inside them)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ours = [os.path.join(root, p) for p in ("vcs_env", "agents", "baselines", "vcs_cli")]
    fronts = [sys.modules.get(m) for m in ("gymnasium", "pettingzoo", "torchrl", "benchmarl")]  # loaded if they made it
    fronts = [os.path.dirname(m.__file__) for m in fronts if getattr(m, "__file__", None)]
    inside = tuple(d + os.sep for d in ours + fronts)
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and os.path.abspath(frame.f_code.co_filename).startswith(inside):
        frame, level = frame.f_back, level + 1
    return level
