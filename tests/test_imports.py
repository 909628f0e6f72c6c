"""Imports flow one way: ``vcs_env`` never imports ``baselines``, ``agents`` or ``benchmarks``
(at module level, inside functions, or by a string given to ``importlib``), and the simulator
core has no Gymnasium or PettingZoo types (only the API adapters do)."""

import ast
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
UPPER = {"baselines", "agents", "benchmarks"}
PENDING_MOVE: set[str] = set()
"""Modules being moved out of ``vcs_env`` on another branch (the CLI, which drives training and
benchmarks); the lead empties this set when that move is merged."""
ADAPTERS = {"__init__.py", "parallel.py", "gym_env.py", "spaces.py", "render.py"}
"""API adapters of ``vcs_env`` that may use Gymnasium and PettingZoo types."""
TORCH = {"torch", "torchrl", "tensordict"}
TORCH_ADAPTERS = {"torchrl.py"}
"""The modules of ``vcs_env`` that may import torch (the ``torchrl`` extra); ``import vcs_env`` loads none of them."""


def imported_names(source: str, package: str = "vcs_env") -> set[str]:
    """Top-level package names a module's source imports: ``import``/``from`` statements at any
    depth, relative imports resolved against ``package``, and string constants passed to
    ``importlib.import_module``, ``__import__`` or ``importlib.util.find_spec``."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                names.add(node.module.split(".")[0])
            elif node.level == 1:
                names.add(package)
            else:
                names.add("<beyond the package>")
        elif isinstance(node, ast.Call):
            f = node.func
            fname = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if fname in ("import_module", "__import__", "find_spec") and node.args:
                arg = node.args[0]
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    names.add(arg.value.split(".")[0])
                else:
                    names.add("<computed module name>")
    return names


def test_the_checker_sees_every_kind_of_import():
    src = (
        "import os\nfrom agents import x\ndef f():\n    import benchmarks.run\n    from .. import y\n"
        "import importlib\nimportlib.import_module('baselines.vcs')\ndef g(name):\n    __import__(name)\n"
    )
    assert imported_names(src) == {
        "os",
        "agents",
        "benchmarks",
        "<beyond the package>",
        "importlib",
        "baselines",
        "<computed module name>",
    }


def _modules():
    return sorted(p for p in (ROOT / "vcs_env").rglob("*.py"))


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.name)
def test_vcs_env_does_not_import_upper_layers(path):
    rel = path.relative_to(ROOT).as_posix()
    bad = imported_names(path.read_text()) & (UPPER | {"<beyond the package>", "<computed module name>"})
    if rel in PENDING_MOVE:
        assert bad, f"{rel} no longer imports upper layers: remove it from PENDING_MOVE"
    else:
        assert not bad, f"{rel} imports {sorted(bad)}: vcs_env must not depend on them (use the planner registry)"


def test_pending_moves_are_still_in_vcs_env():
    gone = [rel for rel in PENDING_MOVE if not (ROOT / rel).exists()]
    assert not gone, f"{gone} moved out of vcs_env: remove them from PENDING_MOVE"


@pytest.mark.parametrize("path", [p for p in _modules() if p.name not in ADAPTERS], ids=lambda p: p.name)
def test_core_modules_have_no_api_types(path):
    bad = imported_names(path.read_text()) & {"gymnasium", "pettingzoo"}
    assert not bad, f"{path.name} imports {sorted(bad)}: spaces and API types belong in the adapters (spaces.py)"


@pytest.mark.parametrize("path", [p for p in _modules() if p.name not in TORCH_ADAPTERS], ids=lambda p: p.name)
def test_only_the_torchrl_adapter_imports_torch(path):
    bad = imported_names(path.read_text()) & TORCH
    assert not bad, f"{path.name} imports {sorted(bad)}: torch belongs in vcs_env/torchrl.py (torchrl extra) or agents"


def test_importing_vcs_env_does_not_load_torch():
    code = f"import sys, vcs_env\nprint(sorted({{m.split('.')[0] for m in sys.modules}} & set({sorted(TORCH)})))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


def test_an_env_runs_without_loading_upper_layers():
    code = (
        "import sys, numpy as np, vcs_env\n"
        "env = vcs_env.parallel_env(scenario='dynamic')\n"
        "env.reset(seed=0)\n"
        "env.step({a: np.zeros(2, np.float32) for a in env.agents})\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'baselines', 'agents', 'benchmarks'}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"
