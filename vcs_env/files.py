"""Files written whole or not at all: every output is written beside its name and then renamed onto it.

A run stopped while it writes (Ctrl-C, a killed job, a full disk) leaves the file that was there before whole, or no
file, never a truncated one that replaced it: a run log that ``--resume`` reads, a dataset that took an hour, a
results file a README figure comes from.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

PART = ".part"
"""The suffix of a file being written; renamed away when the file is whole."""


@contextmanager
def replacing(path: str | os.PathLike) -> Iterator[Path]:
    """Yield the path to write ``path``'s new content to (``path`` with ``.part`` added); when the block ends without
    an error it is renamed onto ``path`` (an atomic replace on one file system), otherwise it is removed and ``path``
    is left as it was. The parent directory is made."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_name(path.name + PART)
    try:
        yield part
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` whole or not at all (:func:`replacing`); returns ``path``."""
    with replacing(path) as part:
        part.write_text(text)
    return Path(path)
