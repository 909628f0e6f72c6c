"""The ``vcs-env`` command line as a user meets it: its version, help texts without markup, the
planner names it accepts, and the note before the first compilation of the kernels."""

import re
import sys
import textwrap

import pytest

import vcs_cli
from vcs_env import kernels
from vcs_env.planning import PLANNERS


def test_version_flag_prints_the_installed_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        vcs_cli.build_parser().parse_args(["--version"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out.strip()
    assert out == f"vcs-env {vcs_cli.package_version()}"
    assert re.fullmatch(r"vcs-env \d+\.\d+\.\d+.*", out)


def test_help_texts_have_no_rest_markup():
    parser = vcs_cli.build_parser()
    sub = next(a for a in parser._actions if a.choices and "rollout" in a.choices)
    for name, command in sub.choices.items():
        text = command.format_help()
        assert "``" not in text and not re.search(r":[a-z]+:`", text), f"reST markup in `vcs-env {name} --help`"


def test_plain_strips_roles_and_literals():
    assert (
        vcs_cli.plain("``vcs-env select``: see :func:`~agents.x.f` and :class:`A`")
        == "vcs-env select: see agents.x.f and A"
    )


def test_rollout_help_lists_the_planner_names():
    command = vcs_cli.build_parser()._subparsers._group_actions[0].choices["rollout"]
    text = " ".join(command.format_help().split())
    assert len(PLANNERS) >= 6
    for name in PLANNERS:
        assert re.search(rf"\b{name}\b", text), name


def test_on_disk_tells_a_compiled_kernel_from_a_new_one(tmp_path, monkeypatch):
    # A fresh module with a cached kernel: not on disk before its first call, on disk after it.
    (tmp_path / "fresh_kernel_mod.py").write_text(
        textwrap.dedent(
            """
            from numba import njit

            @njit(cache=True)
            def twice(x):
                return 2.0 * x
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    import fresh_kernel_mod

    assert not kernels.on_disk(fresh_kernel_mod.twice)
    assert fresh_kernel_mod.twice(2.0) == 4.0
    assert kernels.on_disk(fresh_kernel_mod.twice)
    assert not kernels.on_disk(fresh_kernel_mod.twice, lambda x: x)  # not a cached kernel: not on disk


def test_first_command_says_it_compiles(monkeypatch, capsys):
    monkeypatch.setattr(kernels, "on_disk", lambda *k: False)
    vcs_cli.compile_note()
    assert "compiling the simulator and planner kernels once" in capsys.readouterr().err
    monkeypatch.setattr(kernels, "on_disk", lambda *k: True)
    vcs_cli.compile_note()
    assert capsys.readouterr().err == ""


def test_a_list_flag_given_twice_adds_to_the_first():
    """``--mixture a --mixture b`` (any tuple field's flag) and ``select --validation`` twice keep every value given;
    the last one alone was kept (a mixture or a validation set silently dropped)."""
    from agents.config import config_from_args
    from agents.imitation import CollectConfig
    from vcs_cli import build_parser

    args = build_parser().parse_args(["collect", "--mixture", "circle:n_robots=4", "--mixture", "crowd", "--out", "x"])
    assert config_from_args(CollectConfig, args).mixture == ("circle:n_robots=4", "crowd")
    sets = ["--validation", "circle:0:2", "--validation", "crowd:0:2"]
    assert build_parser().parse_args(["select", "c", *sets, "--out", "o"]).validation == ["circle:0:2", "crowd:0:2"]


def test_a_commands_warnings_are_one_line_each_naming_the_command():
    """A warning on the command line reads as the command's (``vcs-env evaluate: warning: ... (BlindWarning)``), not
    as Python's file, line and source line (which looked like a trace); the Python API keeps Python's format."""
    import subprocess
    import sys

    cmd = ["evaluate", "--policy", "policies/generalist/model.zip", "--scenario", "doorway", "--seeds", "0:1"]
    done = subprocess.run([sys.executable, "-m", "vcs_cli", *cmd], capture_output=True, text=True, check=True)
    said = [line for line in done.stderr.splitlines() if "Warning" in line]
    assert len(said) == 2 and all(line.startswith("vcs-env evaluate: warning: ") for line in said), done.stderr
    assert "BlindWarning)" in said[0] + said[1] and "resolve_policy(" not in done.stderr  # no source line
    import warnings

    shown = warnings.formatwarning
    assert vcs_cli.main(["rollout", "--scenario", "swap", "--n-robots", "2", "--max-steps", "5"]) == 0
    assert warnings.formatwarning is shown  # put back for the rest of the process


def test_evaluate_writes_its_json_even_when_the_reader_of_its_table_has_gone(tmp_path, monkeypatch):
    """``vcs-env evaluate ... --json F | head -1``: the table's printing meets a closed pipe (the command stops quietly,
    as command-line tools do), and F was not written though the command exited 0."""
    import json
    import sys

    import vcs_cli.evaluate as cli_evaluate

    def closed(res):
        raise BrokenPipeError

    monkeypatch.setattr(cli_evaluate, "_print_summary", closed)
    monkeypatch.setattr(sys, "stdout", sys.stdout)  # main() drops stdout after a closed pipe: restored after the test
    out = tmp_path / "res.json"
    argv = ["evaluate", "--scenario", "circle", "--seeds", "1000:1002", "--policy", "vcs", "--no-progress"]
    assert vcs_cli.main([*argv, "--json", str(out)]) == 0
    assert out.is_file() and len(json.loads(out.read_text())["episodes"]) == 2


def test_a_missing_optional_package_names_its_extra_before_the_work(monkeypatch, capsys, tmp_path):
    """Without torch, `vcs-env train` said only "No module named 'torch'"; `compare` ran every episode before it
    found no matplotlib for its plots, `rollout --gif` compiled for half a minute before it found no pygame; the
    Python modules of the other libraries failed on a bare import."""
    import builtins
    import importlib
    import importlib.util

    from vcs_env import rollout

    real_find, real_import = importlib.util.find_spec, builtins.__import__
    absent = ("torch", "matplotlib", "pygame", "stable_baselines3", "torchrl", "tensordict", "benchmarl")

    def find(name, *a, **k):
        return None if name.split(".")[0] in absent else real_find(name, *a, **k)

    def imp(name, *a, **k):
        if name.split(".")[0] in absent:
            raise ModuleNotFoundError(f"No module named {name.split('.')[0]!r}", name=name.split(".")[0])
        return real_import(name, *a, **k)

    monkeypatch.setattr(importlib.util, "find_spec", find)
    monkeypatch.setattr(builtins, "__import__", imp)
    monkeypatch.setattr(rollout, "play", lambda *a, **k: pytest.fail("episodes were run"))
    for args, extra in (
        (["train", "--n-robots", "2", "--timesteps", "10", "--out", str(tmp_path / "run")], "train"),
        (["compare", "--suite", "circle-8-v0-smoke", "--policies", "vcs", "--out", str(tmp_path / "cmp")], "render"),
        (["rollout", "--scenario", "circle", "--n-robots", "2", "--gif", str(tmp_path / "a.gif")], "render"),
    ):
        assert vcs_cli.main(args) == 2
        assert f"install it with: pip install -e '.[{extra}]'" in capsys.readouterr().err, args
    modules = (("agents.gym_vec", "train"), ("vcs_env.torchrl", "torchrl"), ("vcs_env.benchmarl", "benchmarl"))
    for module, extra in modules:
        monkeypatch.delitem(sys.modules, module, raising=False)
        with pytest.raises(ImportError, match=re.escape(f"install it with: pip install -e '.[{extra}]'")):
            importlib.import_module(module)


def test_json_outputs_replace_only_their_own_kind(tmp_path, capsys):
    """``evaluate --json`` and ``rollout --json`` replaced any JSON without a word (an ONNX file's layout, a compare
    report), and rollout let two flags name one file (the plot, then the JSON over it): refused before the work."""
    import json

    layout = tmp_path / "policy.json"
    layout.write_text(json.dumps({"format": "vcs-env-onnx", "version": 1}))
    evaluate = [
        "evaluate",
        "--scenario",
        "circle",
        "--n-robots",
        "2",
        "--seeds",
        "0:1",
        "--policy",
        "vcs",
        "--no-progress",
    ]
    rollout = ["rollout", "--scenario", "swap", "--n-robots", "2", "--max-steps", "5"]
    for argv in (evaluate, rollout):
        assert vcs_cli.main([*argv, "--json", str(layout)]) == 2
        assert "exists and is not an earlier" in capsys.readouterr().err
        assert json.loads(layout.read_text())["format"] == "vcs-env-onnx"
    assert vcs_cli.main([*rollout, "--plot", str(tmp_path / "o.png"), "--json", str(tmp_path / "o.png")]) == 2
    assert "--plot and --json name the same file" in capsys.readouterr().err
    for argv, name in ((evaluate, "e.json"), (rollout, "r.json")):  # an earlier output of the same command: rewritten
        for _ in range(2):
            assert vcs_cli.main([*argv, "--json", str(tmp_path / name)]) == 0
