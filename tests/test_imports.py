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
ADAPTERS = {"__init__.py", "parallel.py", "gym_env.py", "spaces.py", "render.py", "registry.py"}
"""API adapters of ``vcs_env`` that may use Gymnasium and PettingZoo types."""
TORCH = {"torch", "torchrl", "tensordict", "benchmarl"}
TORCH_ADAPTERS = {"torchrl.py", "benchmarl.py"}
"""The modules of ``vcs_env`` that may import torch (the ``torchrl`` and ``benchmarl`` extras); ``import vcs_env``
loads none of them."""


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
    assert not bad, (
        f"{path.name} imports {sorted(bad)}: torch belongs in vcs_env/torchrl.py, vcs_env/benchmarl.py or agents"
    )


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


# --------------------------------------------------------------------------- inside agents/
PROJECT = {"vcs_env", "baselines", "agents", "benchmarks", "vcs_cli"}
MAX_LAZY_PROJECT_IMPORTS = 10
"""Project imports inside functions in ``agents/``: only those of modules that import torch,
stable-baselines3 or Ray at their top (the SB3 env and features, the RLlib env and learner),
where building the ``vcs-env`` parser must not load them."""


def _agents_modules() -> dict[str, pathlib.Path]:
    """``{dotted name: path}`` of every module of ``agents`` (a package by its ``__init__``)."""
    out = {}
    for path in sorted((ROOT / "agents").rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def module_imports(name: str, source: str, is_package: bool, known: set[str]) -> list[tuple[str, bool]]:
    """``(module, inside a function)`` of every import of ``known`` modules in a module's source:
    relative imports resolved against ``name``, ``from X import y`` naming module ``X.y`` when it
    is one, and an import of ``a.b.c`` also importing ``a`` and ``a.b`` unless they hold ``name``
    (Python loads a module's own packages before it, whatever they import)."""
    here = name if is_package else name.rpartition(".")[0]
    out = []

    def visit(node, in_function: bool) -> None:
        in_function = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(here.split(".")[: len(here.split(".")) - node.level + 1] + ([base] if base else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        for target in targets:
            parts = target.split(".")
            outer = [".".join(parts[:k]) for k in range(1, len(parts))]
            out.extend((m, in_function) for m in [*outer, target] if m == target or not name.startswith(m + "."))
        for child in ast.iter_child_nodes(node):
            visit(child, in_function)

    visit(ast.parse(source), False)
    return [(m, f) for m, f in out if m in known and m != name]


def _agents_graph() -> dict[str, set[str]]:
    modules = _agents_modules()
    graph = {}
    for name, path in modules.items():
        found = module_imports(name, path.read_text(), path.name == "__init__.py", set(modules))
        graph[name] = {m for m, _ in found}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A cycle of ``graph`` (``[a, b, ..., a]``), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt) :] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    return next((c for node in sorted(graph) if node not in state and (c := visit(node))), None)


def test_the_graph_checker_sees_relative_imports_and_cycles():
    known = {"agents", "agents.a", "agents.p", "agents.p.b"}
    src = "from .. import a\nfrom .b import x\ndef f():\n    from ..a import y\n    import numpy\n"
    assert module_imports("agents.p", src, True, known) == [
        ("agents.a", False),
        ("agents.p.b", False),
        ("agents.a", True),
    ]
    assert module_imports("agents.p.b", "from . import x\nimport agents.a", False, known) == [
        ("agents.p", False),
        ("agents.a", False),
    ]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_agents_has_no_import_cycle():
    graph = _agents_graph()
    assert len(graph) > 20 and "agents.checkpoint" in graph["agents.policies"]  # the scan sees the package
    assert find_cycle(graph) is None, f"import cycle in agents/: {' -> '.join(find_cycle(graph))}"


def test_agents_imports_its_project_modules_at_the_top():
    modules = _agents_modules()
    lazy = []
    for name, path in modules.items():
        source = path.read_text()
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for inner in ast.walk(node):
                    if isinstance(inner, ast.ImportFrom) and (inner.level or inner.module.split(".")[0] in PROJECT):
                        lazy.append(f"{name}:{inner.lineno}")
                    elif isinstance(inner, ast.Import) and any(a.name.split(".")[0] in PROJECT for a in inner.names):
                        lazy.append(f"{name}:{inner.lineno}")
    assert len(set(lazy)) <= MAX_LAZY_PROJECT_IMPORTS, f"{len(set(lazy))} project imports inside functions: {lazy}"


def test_agents_does_not_import_the_layers_above_it():
    for path in _agents_modules().values():
        bad = imported_names(path.read_text(), "agents") & {"benchmarks", "vcs_cli"}
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}: agents/ is below them"
