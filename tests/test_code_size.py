"""Code stays readable at a glance: no source file over 500 lines, and no function of the VCS
kernel (:mod:`baselines.vcs.kernel`) over 80 lines (docstring included)."""

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]
MAX_FILE_LINES = 500
MAX_KERNEL_FUNCTION_LINES = 80
KERNEL = ROOT / "baselines" / "vcs" / "kernel"


def _sources() -> list[pathlib.Path]:
    skip = {".git", ".venv", "venv", "build", "dist", "__pycache__"}
    return [p for p in ROOT.rglob("*.py") if not skip & set(p.relative_to(ROOT).parts)]


def long_functions(source: str, limit: int) -> list[tuple[str, int]]:
    """``(name, lines)`` of every function in ``source`` longer than ``limit`` lines."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            lines = node.end_lineno - node.lineno + 1
            if lines > limit:
                out.append((node.name, lines))
    return out


def test_no_source_file_over_500_lines():
    files = _sources()
    assert len(files) > 50  # the scan sees the repository
    too_long = {str(p.relative_to(ROOT)): n for p in files if (n := len(p.read_text().splitlines())) > MAX_FILE_LINES}
    assert too_long == {}


def test_no_kernel_function_over_80_lines():
    files = sorted(KERNEL.glob("*.py"))
    assert len(files) >= 6
    too_long = {p.name: f for p in files if (f := long_functions(p.read_text(), MAX_KERNEL_FUNCTION_LINES))}
    assert too_long == {}


def test_the_length_check_sees_a_long_function():
    body = "\n".join(f"    x{k} = {k}" for k in range(MAX_KERNEL_FUNCTION_LINES))
    assert long_functions(f"def f():\n{body}\n", MAX_KERNEL_FUNCTION_LINES) == [("f", MAX_KERNEL_FUNCTION_LINES + 1)]
    assert long_functions(f"def f():\n{body}\n", MAX_KERNEL_FUNCTION_LINES + 1) == []
