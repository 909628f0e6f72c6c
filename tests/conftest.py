"""Shared test setup: headless rendering, one torch thread, small helpers."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def pytest_ignore_collect(collection_path, config):
    """With ``-m "not slow"``, a test module marked slow as a whole (``pytestmark = pytest.mark.slow``) is
    not even imported: its tests would all be deselected, and importing Ray or the notebook runner costs
    seconds of the quick subset."""
    if " ".join(config.getoption("markexpr", "").split()) != "not slow" or collection_path.suffix != ".py":
        return None
    return True if "\npytestmark = pytest.mark.slow" in collection_path.read_text() else None
