"""Checks of the files and directories a command will write, made before its work: an output never replaces a
checkpoint, a dataset, a run record or another command's file, and one that cannot be written fails at once, not after
an hour of work (the writing itself: :mod:`vcs_env.files`)."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vcs_env.start_states import npz_path


def _is_run_record(path: Path) -> bool:
    """``path`` holds a checkpoint's run record (a JSON object with its ``kind`` and ``config``)."""
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(record, dict) and "kind" in record and "config" in record


def _replaceable(path: Path, replaces: Callable[[Any], bool]) -> bool:
    """``path`` is empty, or a JSON file whose content ``replaces`` accepts."""
    try:
        text = path.read_text()
        return not text.strip() or bool(replaces(json.loads(text)))
    except (OSError, ValueError):
        return False


def check_out_file(
    path: str | None,
    flag: str,
    suffixes: tuple[str, ...] = (),
    new: bool = False,
    writable: bool = False,
    replaces: tuple[str, Callable[[Any], bool]] | None = None,
) -> None:
    """Before any work: ``ValueError`` if the output file ``path`` of ``flag`` is an existing
    directory, an existing checkpoint, dataset or run record (never overwritten), or lacks one of ``suffixes``
    (``new``: or exists at all, also with ``.npz`` added, as numpy adds it; for data that took long to make;
    ``writable``: or cannot be written; ``replaces = (what, accepts)``: or exists and is not an earlier output of
    the command, ``what``, a JSON file whose parsed content ``accepts`` takes, e.g. an ONNX file's layout or a
    report); its parent directory is made."""
    if path is None:
        return
    if not str(path).strip():
        raise ValueError(f"{flag} is empty; give a file name")
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{flag} {path!r} is a directory; give a file name")
    if new and (p.exists() or npz_path(p).exists()):
        there = "" if p.exists() else f" (as {str(npz_path(p))!r}, the file it names)"
        raise ValueError(
            f"{flag} {path!r} exists{there}: the new data would replace it; give another name or remove it first"
        )
    if p.is_file() and p.suffix.lower() in (".zip", ".pt", ".npz", ".onnx"):
        raise ValueError(f"{flag} {path!r} is a {p.suffix} file (a checkpoint or data) that this would overwrite")
    if p.is_file() and _is_run_record(p):
        raise ValueError(f"{flag} {path!r} is a checkpoint's run record that this would overwrite; give another file")
    if suffixes and p.suffix.lower() not in suffixes:
        raise ValueError(f"{flag} must end in {' or '.join(suffixes)}, got {path!r}")
    if replaces is not None and p.is_file() and not _replaceable(p, replaces[1]):
        raise ValueError(
            f"{flag} {path!r} exists and is not {replaces[0]} (this would overwrite it); give another name or remove "
            "it first"
        )
    check_writable(path, flag, probe=writable)


def check_writable(path: str, flag: str, probe: bool = True) -> None:
    """A ``ValueError`` naming ``flag`` if the file ``path`` cannot be written: its parent directory is made, and with
    ``probe`` the file is made and removed (or, if it exists, found writable), so a file that cannot be made fails
    before the work, not after it."""
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        if probe and not p.exists():
            p.touch()
            p.unlink()
        elif probe and not os.access(p, os.W_OK):
            raise PermissionError(f"{path!r} is not writable")
    except OSError as e:
        raise ValueError(f"{flag} {path!r} cannot be written ({e.strerror or e})") from None


def check_out_dir(path: str | os.PathLike, flag: str = "--out", what: str = "the report") -> None:
    """Before any work: a one-line ``ValueError`` if the output directory ``path`` of ``flag`` is a file, lies under
    a file, or cannot be written in (a file cannot be made in the nearest directory on its path that exists; that
    is where the directory will be made). Nothing is left behind: the test file is removed, no directory made."""
    if not str(path).strip():
        raise ValueError(f"{flag} is empty; give a directory for {what}")
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{flag} {str(path)!r} is a file: give a directory for {what}")
    blocked = next((q for q in p.parents if q.exists() and not q.is_dir()), None)
    if blocked is not None:
        raise ValueError(f"{flag} {str(path)!r} lies under {str(blocked)!r}, a file: give a directory for {what}")
    base = next(q for q in (p, *p.parents) if q.exists())
    try:
        with tempfile.TemporaryFile(dir=base):
            pass
    except OSError as e:
        where = "" if base == p else f" (nothing can be made in {str(base)!r})"
        raise ValueError(f"{flag} {str(path)!r} cannot be written{where}: {e.strerror or e}") from None


def check_report_dir(
    out: str | os.PathLike, names: tuple[str, str], earlier: tuple[str, Callable[[Any], bool]]
) -> None:
    """Before any work: :func:`check_out_dir`, and a ``ValueError`` if ``out`` holds a file of ``names`` (the report's
    Markdown and JSON) while the JSON is not ``earlier = (what, accepts)``, an earlier report of the command that
    ``accepts`` takes: the command replaces its own report, never files of the same name that are not one."""
    check_out_dir(out)
    md, js = (Path(out) / name for name in names)
    held = [f for f in (md, js) if f.exists()]
    if held and not (js.is_file() and _replaceable(js, earlier[1])):
        raise ValueError(
            f"--out {str(out)!r} holds {held[0].name}, and {js.name} there is not {earlier[0]}: this would overwrite "
            "it; give another directory or remove the file first"
        )
