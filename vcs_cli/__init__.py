"""The ``vcs-env`` command line: the top layer, above ``vcs_env``, ``baselines``, ``agents`` and
``benchmarks`` (it imports them; none of them imports it).

Each module of :data:`COMMAND_MODULES` adds its subcommands with ``add_commands(subparsers)``.
Building the parser imports those modules but not torch or stable-baselines3: they import heavy
packages inside the command functions, so ``pip install vcs-env`` without extras gives a working
``vcs-env rollout``, and a command whose extra is missing ends with a one-line error.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
import warnings

COMMAND_MODULES = (
    "vcs_cli.rollout",
    "vcs_cli.evaluate",
    "vcs_cli.train",
    "vcs_cli.export",
    "benchmarks.run",
)
"""Modules that add subcommands: each has ``add_commands(subparsers)``, which adds its parsers
and sets ``func``. They must not import torch or stable-baselines3 at module level (the CLI
imports them all to build ``--help``); heavy imports go inside the command functions."""


COMPILING = (
    "rollout",
    "evaluate",
    "compare",
    "probe",
    "train",
    "collect",
    "bc",
    "distil",
    "collect-states",
    "select",
    "bench",
)
"""Commands that run the simulator (and the planners), whose kernels numba compiles on first use."""


def compile_note() -> None:
    """One line on stderr when the simulator and VCS planner kernels are not in numba's on-disk
    cache yet, so that the first command's pause is explained."""
    from baselines.vcs.kernel import plan_batch
    from vcs_env import kernels

    if not kernels.on_disk(kernels.integrate, kernels.observe, plan_batch):
        print(
            "vcs-env: compiling the simulator and planner kernels once (about a minute; numba caches them on disk)",
            file=sys.stderr,
        )


def plain(text: str | None) -> str | None:
    """Help text without reST markup: ``x`` and :role:`x` become x (docstrings serve as descriptions)."""
    if not text:
        return text
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"\1", text)
    return re.sub(r"``([^`]+)``", r"\1", text)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vcs-env", description="Multi-robot navigation with a VCS expert planner.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {package_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_commands(sub)
    for command in sub.choices.values():
        command.description = plain(command.description)
        for action in command._actions:
            action.help = plain(action.help)
    return parser


def package_version() -> str:
    """The installed distribution's version (``vcs-env``), or ``unknown`` when run from a bare checkout."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vcs-env")
    except PackageNotFoundError:
        return "unknown"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)  # the command line, for the reports that record it
    if getattr(args, "episodes", 1) is not None and getattr(args, "episodes", 1) < 1:
        print(f"vcs-env {args.command}: error: --episodes must be >= 1, got {args.episodes}", file=sys.stderr)
        return 2
    for name, value in sorted(vars(args).items()):  # --seed, --eval-seed, --dagger-seed, ...: numpy's seeds are >= 0
        if name.endswith("seed") and isinstance(value, int) and not isinstance(value, bool) and value < 0:
            flag = "--" + name.replace("_", "-")
            print(f"vcs-env {args.command}: error: {flag} must be >= 0, got {value}", file=sys.stderr)
            return 2
    if args.command in COMPILING:
        compile_note()
    shown = warnings.formatwarning  # a warning is one line of the command's, not a file, line and source line

    def one_line(message, category, filename, lineno, line=None):
        return f"vcs-env {args.command}: warning: {message} ({category.__name__})\n"

    warnings.formatwarning = one_line
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:  # Ctrl-C: a line, not the traceback of wherever the work was
        print(f"vcs-env {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which has closed: stop quietly
        sys.stdout = None
        return 0
    except (ValueError, ImportError) as e:  # bad parameters, unknown names, a missing extra: a message
        from vcs_env.checks import missing_extra  # late: the package's import is not needed for --help

        print(
            f"vcs-env {args.command}: error: {missing_extra(e) if isinstance(e, ImportError) else e}", file=sys.stderr
        )
        return 2
    except (FileExistsError, IsADirectoryError, NotADirectoryError) as e:  # an output path in the way
        print(
            f"vcs-env {args.command}: error: {e.strerror}: {e.filename!r} (an output path is in the way)",
            file=sys.stderr,
        )
        return 2
    finally:
        warnings.formatwarning = shown
