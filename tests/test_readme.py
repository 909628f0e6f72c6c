"""The README tells the truth: its install, run and test commands are what CI runs, every `vcs-env`
command in it parses, the short ones run as written, and its Python snippets run."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
BLOCKS = re.findall(r"```(\w+)\n(.*?)```", README, flags=re.S)
COMMANDS = [line.strip() for lang, body in BLOCKS if lang == "bash" for line in body.splitlines() if line.strip()]
PYTHON = [body for lang, body in BLOCKS if lang == "python"]
CLI = [c for c in COMMANDS if c.startswith("vcs-env ")]
# Run as written (seconds each); the others (full suites, training) only have to parse.
SHORT = ("vcs-env rollout", "vcs-env evaluate --suite circle-8-v0-smoke")


def _without_marker_selection(cmd: str) -> list[str]:
    """``cmd``'s words without a ``-m EXPR`` selection: a quick subset is the command it narrows."""
    words = shlex.split(cmd)
    i = words.index("-m", 3) if "-m" in words[3:] else None
    return words if i is None else words[:i] + words[i + 2 :]


def test_ci_runs_the_readme_install_and_test_commands():
    """Every README ``pip`` line is in .ci/run as written, and so is the full test command; a README
    test command that selects a subset by marker (``-m "not slow"``) is covered by the full one."""
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    ci_pytest = [shlex.split(line) for line in ci if line.startswith("python -m pytest")]
    for cmd in COMMANDS:
        if cmd.startswith("pip "):
            assert cmd in ci, f"README command not in .ci/run: {cmd}"
        if cmd.startswith("python -m pytest"):
            assert _without_marker_selection(cmd) in ci_pytest, f"README command not covered by .ci/run: {cmd}"
    assert "python -m pytest -q" in COMMANDS and "python -m pytest -q" in ci  # the full suite
    assert _without_marker_selection('python -m pytest -m "not slow" -q') == ["python", "-m", "pytest", "-q"]


def test_ci_runs_the_readme_rollout_after_the_light_install():
    ci = (ROOT / ".ci" / "run").read_text()
    rollout = next(c for c in COMMANDS if c.startswith("vcs-env rollout"))
    light = next(c for c in COMMANDS if c.startswith("pip install") and "[render]" in c)
    assert light in ci and rollout in ci and ci.index(light) < ci.index(rollout) < ci.index("[all]")


@pytest.mark.parametrize("cmd", CLI)
def test_cli_commands_parse(cmd):
    from vcs_cli import build_parser

    args = build_parser().parse_args(shlex.split(cmd)[1:])
    assert callable(args.func)


@pytest.mark.slow
@pytest.mark.parametrize("cmd", [c for c in CLI if c.startswith(SHORT)])
def test_short_cli_commands_run(cmd, tmp_path):
    import os

    from vcs_cli import main

    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(shlex.split(cmd)[1:]) == 0
    finally:
        os.chdir(cwd)
    assert any(tmp_path.iterdir())  # the command wrote its file


@pytest.mark.slow
@pytest.mark.parametrize("code", PYTHON, ids=[f"snippet{i}" for i in range(len(PYTHON))])
def test_python_snippets_run(code, tmp_path):
    # Snippets that use the released policies run where the README's commands do: the repository root.
    cwd = ROOT if "policies/" in code else tmp_path
    proc = subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
