"""Keep numba's disk cache of the kernels in step with their sources.

numba checks a cached function against its own source file only (numba issue #1833): a kernel
compiled from one file keeps the machine code of every function it calls from another file, so
after an edit, a ``git pull`` or an upgrade that changes only the callee, the caller silently
runs the old code.

:func:`refresh_packages` runs when :mod:`vcs_env` is imported, before any kernel is compiled or
loaded: it compares a digest of every kernel source (the ``.py`` files of ``vcs_env`` and
``baselines`` that compile with ``cache=True``) with the one it stored beside numba's cache last
time; when they differ it deletes the cached kernels of those source directories where numba keeps
them in this process (beside the sources, under ``NUMBA_CACHE_DIR`` or in the user-wide cache; each
such directory holds its own digest), and numba compiles them again on first use. Edits to other
files cost nothing.
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


def kernel_sources(roots: Iterable[Path]) -> list[Path]:
    """The ``.py`` files under ``roots`` that compile a kernel with ``cache=True``, in a fixed order."""
    return [p for root in roots for p in sorted(Path(root).rglob("*.py")) if MARK in p.read_bytes()]


def digest(files: Iterable[Path]) -> str:
    """SHA-256 over each file's name and bytes."""
    h = hashlib.sha256()
    for p in files:
        h.update(p.name.encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def cache_dir(source: Path) -> Path | None:
    """The directory where numba keeps the cached kernels of ``source`` (a ``.py`` file) in this
    process: as numba chooses, its first cache locator that applies (``NUMBA_CACHE_DIR``, beside the
    source, the user-wide cache) and can write there; beside the source if numba's locators cannot
    be asked; None when none can be written."""

    def anchor():  # a function for the locators' constructor (only its line number is read)
        pass

    try:
        from numba.core.caching import FunctionCache

        locators = FunctionCache._impl_class._locator_classes
    except Exception:  # numba's private API moved: the in-tree cache, numba's default
        return source.parent / "__pycache__"
    for cls in locators:
        try:
            loc = cls.from_function(anchor, str(source))
            if loc is not None:
                loc.ensure_cache_path()
                return Path(loc.get_cache_path())
        except Exception:
            continue
    return None


def refresh(roots: Iterable[Path]) -> bool:
    """For each directory where numba keeps the cached kernels of the sources under ``roots``
    (:func:`cache_dir`): when the digest stored there differs from the sources' digest, delete its
    cached kernels (``*.nbi``, ``*.nbc``), then store the digest. Returns whether it deleted any. A
    directory it cannot read or write is left alone (numba cannot cache there either)."""
    try:
        files = kernel_sources(roots)
        new = digest(files)
    except OSError:  # a source it cannot read: nothing to compare (numba reads them itself)
        return False
    cleared = False
    for d in sorted({cache_dir(f) for f in files} - {None}):
        stamp = d / STAMP
        try:
            if stamp.is_file() and stamp.read_text().strip() == new:
                continue
            for f in (*d.glob("*.nbi"), *d.glob("*.nbc")):
                f.unlink(missing_ok=True)
            tmp = d / f"{STAMP}.{os.getpid()}"
            tmp.write_text(new + "\n")
            os.replace(tmp, stamp)
            cleared = True
        except OSError:
            continue
    return cleared


def package_roots() -> list[Path]:
    """The directory of ``vcs_env`` and, beside it (a source checkout, or both installed), ``baselines``."""
    here = Path(__file__).parent
    return [here] + [d for d in (here.parent / "baselines",) if (d / "__init__.py").is_file()]


def refresh_packages() -> bool:
    """:func:`refresh` of this project's kernels (:func:`package_roots`)."""
    return refresh(package_roots())


refresh_packages()  # on import, before any kernel is compiled or loaded (vcs_env imports this first)
