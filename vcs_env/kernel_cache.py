"""Keep numba's disk cache of the kernels in step with their sources.

numba checks a cached function against its own source file only (numba issue #1833): a kernel
compiled from one file keeps the machine code of every function it calls from another file, and
the constants it reads from another module, so after an edit, a ``git pull`` or an upgrade that
changes only those, the caller silently runs the old code.

:func:`refresh_packages` runs when :mod:`vcs_env` is imported, before any kernel is compiled or
loaded: it compares a digest of every ``.py`` file of ``vcs_env`` and ``baselines`` with the one it
stored beside numba's cache last time; when they differ it deletes the cached kernels of those
source directories in the directory numba uses for each in this process (beside the sources, under
``NUMBA_CACHE_DIR`` or in the user-wide cache, as numba's locators choose; each such directory
holds its own digest), and numba compiles them again on first use. A process that imported the
package before an edit keeps the old code and may still write it to the cache: stop such processes
(notebooks, workers) before an edit or a pull.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterable
from pathlib import Path

MARK = b"cache=True"
"""What a kernel source contains (``@njit(cache=True)``, ``@twin_kernel(cache=True, ...)``)."""
STAMP = "vcs-kernel-sources.sha256"
"""The stored digest's file name, in each directory where numba keeps cached kernels of ours."""


def sources(roots: Iterable[Path]) -> list[Path]:
    """The ``.py`` files under ``roots`` that can be read, in a fixed order (a dangling link such as an
    editor's lock file is left out)."""
    return [p for root in roots for p in sorted(Path(root).rglob("*.py")) if p.is_file()]


def kernel_sources(files: Iterable[Path]) -> list[Path]:
    """Of ``files``, those that compile a kernel with ``cache=True``."""
    return [p for p in files if MARK in p.read_bytes()]


def digest(files: Iterable[Path]) -> str:
    """SHA-256 over each file's name and bytes."""
    h = hashlib.sha256()
    for p in files:
        h.update(p.name.encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def cache_dir(source: Path) -> Path | None:
    """The directory where numba keeps the cached kernels of ``source`` (a ``.py`` file) in this
    process: numba's own choice for a function of that file (its cache locators, in its order or
    as ``NUMBA_CACHE_LOCATOR_CLASSES`` gives them: ``NUMBA_CACHE_DIR``, beside the source, the
    user-wide cache); beside the source if numba cannot be asked; None if it has no place."""
    try:
        from numba.core.caching import FunctionCache

        scope: dict = {}
        exec(compile("def anchor():\n    pass\n", str(source), "exec"), scope)  # a function "of" that file
        return Path(FunctionCache._impl_class(scope["anchor"]).locator.get_cache_path())
    except RuntimeError:  # no locator can cache there
        return None
    except Exception:  # numba's private API moved: the in-tree cache, numba's default
        return source.parent / "__pycache__"


def refresh(roots: Iterable[Path]) -> bool:
    """For each directory where numba keeps the cached kernels of the sources under ``roots``
    (:func:`cache_dir`): when the digest stored there differs from the digest of every source,
    delete its cached kernels (``*.nbi``, ``*.nbc``), then store the digest. Returns whether it
    deleted any. Never raises: a directory it cannot read or write is left alone (numba cannot
    cache there either)."""
    try:
        files = sources(roots)
        new = digest(files)
        one_per_dir = {f.parent: f for f in kernel_sources(files)}.values()  # numba caches per source directory
        dirs = sorted({cache_dir(f) for f in one_per_dir} - {None})
    except Exception:  # a file vanished meanwhile: the next import compares again
        return False
    cleared = False
    for d in dirs:
        stamp = d / STAMP
        try:
            if stamp.is_file() and stamp.read_text(errors="replace").strip() == new:
                continue
            for f in (*d.glob("*.nbi"), *d.glob("*.nbc")):
                f.unlink(missing_ok=True)
            tmp = d / f"{STAMP}.{os.getpid()}"
            tmp.write_text(new + "\n")
            os.replace(tmp, stamp)
            cleared = True
        except Exception:
            continue
    return cleared


def package_roots() -> list[Path]:
    """The directory of ``vcs_env`` and, beside it (a source checkout, or both installed), this
    project's ``baselines`` (the one with the VCS planner, not another package of that name)."""
    here = Path(__file__).parent
    return [here] + [d for d in (here.parent / "baselines",) if (d / "vcs" / "kernel" / "__init__.py").is_file()]


def refresh_packages() -> bool:
    """:func:`refresh` of this project's kernels (:func:`package_roots`)."""
    return refresh(package_roots())


refresh_packages()  # on import, before any kernel is compiled or loaded (vcs_env imports this first)
