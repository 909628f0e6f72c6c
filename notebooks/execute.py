"""Execute the notebooks in place, keeping their outputs: ``python notebooks/execute.py [names]``.

The test suite runs the same notebooks (tests/test_notebooks.py) without writing them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

HERE = Path(__file__).resolve().parent
TIMEOUT = 900
"""Seconds allowed per cell."""


def execute(path: Path, write: bool = True) -> nbformat.NotebookNode:
    """Run one notebook top to bottom in its own folder; raise on the first failing cell."""
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    # Figures inline even where MPLBACKEND=Agg is set for headless tests (as in .ci/run).
    os.environ["MPLBACKEND"] = "module://matplotlib_inline.backend_inline"
    nb = nbformat.read(path, as_version=4)
    NotebookClient(
        nb, timeout=TIMEOUT, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    ).execute()
    if write:
        nbformat.write(nb, path)
    return nb


def notebooks() -> list[Path]:
    return sorted(HERE.glob("[0-9][0-9]_*.ipynb"))


if __name__ == "__main__":
    wanted = sys.argv[1:]
    names = [p.name for p in notebooks()]
    if any(w.startswith("-") for w in wanted) or any(not any(w in n for n in names) for w in wanted):
        # --help, or a name that matches no notebook: it ran nothing and said nothing
        print(f"usage: python notebooks/execute.py [NAME ...]  (parts of notebook names: {', '.join(names)})")
        sys.exit(0 if wanted in (["-h"], ["--help"]) else 2)
    for nb_path in notebooks():
        if not wanted or any(w in nb_path.name for w in wanted):
            print("executing", nb_path.name, flush=True)
            execute(nb_path)
