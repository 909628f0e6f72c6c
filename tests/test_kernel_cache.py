"""numba's disk cache and edits to a kernel's callee in another file (:mod:`vcs_env.kernel_cache`).

numba checks a cached kernel against its own file only: a caller keeps the old code of a callee
edited in another file. The test builds a two-file package in a temporary directory, compiles the
caller in one process, edits the callee (the caller's file unchanged), and runs the
caller in fresh processes: without :func:`~vcs_env.kernel_cache.refresh` it returns the old value
(numba's behaviour this module works around), after it the new one.
"""

import os
import subprocess
import sys
import textwrap

import pytest

from vcs_env.kernel_cache import STAMP, cache_dir, digest, kernel_sources, package_roots, sources

RUN = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    sys.path.insert(0, {root!r})
    cleared = None
    if {refresh}:
        from vcs_env.kernel_cache import refresh
        cleared = refresh([Path({root!r}) / "pkg"])
    from pkg.caller import f
    print(cleared, f())
    """
)


def _run(root, refresh_first: bool, cache_dir) -> str:
    """The caller's value in a new process (after :func:`refresh` of the package), and whether
    refresh deleted cached kernels (None: not run), as ``"<deleted> <value>"``."""
    code = RUN.format(root=str(root), refresh=refresh_first)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}  # None: the cache beside the sources
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@pytest.mark.parametrize("where", ["beside the sources", "NUMBA_CACHE_DIR"])
def test_a_callee_edited_in_another_file_reaches_the_cached_caller(tmp_path, where):
    cache = tmp_path / "numba-cache" if where == "NUMBA_CACHE_DIR" else None
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    callee = pkg / "callee.py"
    callee.write_text("from numba import njit\n\n\n@njit(cache=True)\ndef value():\n    return 1\n")
    (pkg / "caller.py").write_text(
        "from numba import njit\n\nfrom .callee import value\n\n\n@njit(cache=True)\ndef f():\n    return value()\n"
    )
    assert _run(tmp_path, True, cache) == "True 1"  # compiled and cached; the digest stored
    assert _run(tmp_path, True, cache) == "False 1"  # unchanged sources: nothing deleted, loaded from the cache
    callee.write_text(callee.read_text().replace("return 1", "return 2"))
    assert _run(tmp_path, False, cache) == "None 1", "numba now tracks callees in other files: kernel_cache may go"
    assert _run(tmp_path, True, cache) == "True 2"
    assert _run(tmp_path, False, cache) == "None 2"  # compiled again and cached
    consts = pkg / "consts.py"  # a constant a kernel reads from a module without kernels
    consts.write_text("STEP = 10\n")
    callee.write_text(
        callee.read_text()
        .replace("return 2", "return 2 + STEP")
        .replace("njit\n", "njit\n\nfrom .consts import STEP\n", 1)
    )
    assert _run(tmp_path, True, cache) == "True 12"
    (pkg / ".#callee.py").symlink_to(tmp_path / "nowhere")  # an editor's lock file: a dangling link
    consts.write_text("STEP = 20\n")
    assert _run(tmp_path, True, cache) == "True 22"
    for stamp in (cache or pkg).rglob(STAMP):
        stamp.write_bytes(b"\xff\xfe")  # a corrupt digest counts as a different one
    assert _run(tmp_path, True, cache) == "True 22"
    assert any(cache.rglob("*.nbi")) if cache is not None else any((pkg / "__pycache__").glob("*.nbi"))


def test_the_project_kernels_are_found_and_their_digest_is_stored():
    roots = package_roots()
    assert len(roots) == 2 and all(r.is_dir() for r in roots)
    files = sources(roots)
    found = {p.relative_to(roots[0].parent).as_posix() for p in kernel_sources(files)}
    assert {"vcs_env/kernels.py", "baselines/vcs/kernel/search.py", "baselines/vcs/kernel/fallback.py"} <= found
    assert "baselines/vcs/kernel/records.py" in {p.relative_to(roots[0].parent).as_posix() for p in files}
    for d in {cache_dir(p) for p in kernel_sources(files)}:  # importing vcs_env stored the digest there
        assert (d / STAMP).read_text().strip() == digest(files)


def test_vcs_env_refreshes_before_any_of_its_modules_is_imported():
    """``vcs_env/__init__.py`` imports :mod:`vcs_env.kernel_cache` before any other module of the
    package (importing those loads or compiles kernels)."""
    import ast
    import pathlib

    import vcs_env

    tree = ast.parse(pathlib.Path(vcs_env.__file__).read_text())
    own = [n for n in tree.body if isinstance(n, ast.ImportFrom) and n.level == 1]
    assert own and [a.name for a in own[0].names] == ["kernel_cache"]
