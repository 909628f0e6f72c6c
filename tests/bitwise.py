"""Fixtures that hash floats bit for bit, kept per float platform.

numpy picks its float64 ``sin``, ``cos``, ``exp``, ... at run time: Intel SVML's AVX-512 kernels
where the CPU has AVX512_SKX, the C library's elsewhere. The two differ in the last bits, and so
do layouts and rollouts built on them, so a fixture of hashes holds one entry per platform
(``{"svml": {...}, "libm": {...}}``). Bit-for-bit claims are per platform and library versions;
a platform without an entry fails with the command that writes it (never a skip).
"""

from __future__ import annotations

import json
import pathlib

import pytest
from numpy._core._multiarray_umath import __cpu_features__

PLATFORMS = ("svml", "libm")


def float_platform() -> str:
    """``"svml"`` where numpy runs SVML's AVX-512 transcendental kernels, else ``"libm"``."""
    return "svml" if __cpu_features__.get("AVX512_SKX") else "libm"


def expected(fixture: pathlib.Path, regenerate: str) -> dict:
    """This platform's entry of ``fixture``; a clear failure when it has none."""
    entries = json.loads(fixture.read_text())
    platform = float_platform()
    if platform not in entries:
        pytest.fail(
            f"{fixture.name} has no entry for the float platform {platform!r} of this machine (it has "
            f"{sorted(entries)}); after checking the code is unchanged, write it with `{regenerate}`"
        )
    return entries[platform]


def write(fixture: pathlib.Path, values: dict) -> None:
    """Write ``values`` as this platform's entry of ``fixture``, keeping the other platforms' entries."""
    entries = json.loads(fixture.read_text()) if fixture.exists() else {}
    entries[float_platform()] = values
    fixture.write_text(json.dumps(entries, indent=1, sort_keys=True) + "\n")
    print(f"wrote the {float_platform()!r} entry of {fixture}")
