"""The notebooks execute top to bottom without error (they hold no logic of their own)."""

import sys
from pathlib import Path

import pytest

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
sys.path.insert(0, str(NOTEBOOKS))
from execute import execute, notebooks  # noqa: E402

pytestmark = pytest.mark.slow  # notebooks / Ray clusters / training: minutes, not seconds


@pytest.mark.parametrize("path", notebooks(), ids=lambda p: p.name)
def test_notebook_runs(path):
    nb = execute(path, write=False)
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors
    assert any(c.get("outputs") for c in nb.cells if c.cell_type == "code")
