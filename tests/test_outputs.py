"""What the commands write and read is checked before their work (``agents.outputs``): found by a fuzz of the command
line (2026-12-08), each case refused before with a wrong reason, or not at all."""

from __future__ import annotations

import json

import pytest

import vcs_cli
from agents.checkpoint import CheckpointError
from agents.export import check_out_path
from vcs_env.start_states import StartStates

COMPARE = ["compare", "--suite", "swap-v0-smoke", "--policies", "vcs", "--no-plots", "--no-progress"]


def refused(argv, capsys) -> str:
    assert vcs_cli.main(argv) == 2
    return capsys.readouterr().err


def test_report_directories_hold_only_the_commands_own_reports(tmp_path, capsys):
    """``compare --out D`` replaced any ``results.md`` / ``results.json`` in D, ``probe --out D`` any ``probes.md``,
    ``bench --out F`` any file F and the ``.json`` beside it; ``--out ''`` wrote into the working directory."""
    d = tmp_path / "d"
    d.mkdir()
    (d / "results.md").write_text("precious")
    assert "holds results.md, and results.json there is not an earlier compare's report" in refused(
        [*COMPARE, "--out", str(d)], capsys
    )
    assert (d / "results.md").read_text() == "precious"
    assert "--out is empty; give a directory" in refused([*COMPARE, "--out", ""], capsys)
    (d / "probes.md").write_text("precious")
    probe = ["probe", "--policies", "vcs", "--families", "crowd", "--episodes", "1", "--no-progress", "--out", str(d)]
    assert "holds probes.md, and probes.json there is not an earlier probe table" in refused(probe, capsys)
    (d / "keep.txt").write_text("precious")
    bench = ["bench", "--quick", "--sections", "env", "--out"]
    assert "must end in .md" in refused([*bench, str(d / "keep.txt")], capsys)
    assert "is no earlier results of python -m benchmarks" in refused([*bench, str(d / "results.md")], capsys)
    assert {f.name: f.read_text() for f in d.iterdir()} == dict.fromkeys(
        ("results.md", "probes.md", "keep.txt"), "precious"
    )
    own = tmp_path / "own"  # a compare's own report is replaced by the next
    for _ in range(2):
        assert vcs_cli.main([*COMPARE, "--out", str(own)]) == 0
    assert json.loads((own / "results.json").read_text())["suite"] == "swap-v0-smoke"


@pytest.mark.parametrize(
    "argv, message",
    [
        (["rollout", "--max-steps", "5", "--json", ""], "--json is empty; give a file name"),
        (["compare", "--suite", "swap-v0-smoke", "--policies", "vcs,,orca", "--out", "X"], "has an empty entry"),
        (["probe", "--policies", "vcs", "--families", "crowd,", "--out", "X"], "'crowd,' has an empty entry"),
        (["evaluate", "--suite", "swap-v0-smoke", "--policy", "vcs", "--no-shield"], "--no-shield applies to checkp"),
        (["select", "policies/circle8", "--validation", "swap-v0:7000:7001", "--from-step", "-5", "--out", "S"],
         "--from-step must be an integer in [0,"),
    ],
)  # fmt: skip
def test_flags_that_cannot_work_are_refused_by_name(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path) if "X" in argv or "S" in argv else None
    assert message in refused(argv, capsys)
    assert not (tmp_path / "X").exists() and not (tmp_path / "S").exists()


def test_file_names_that_cannot_be_written_or_read_say_why(tmp_path):
    with pytest.raises(CheckpointError, match="has no name before .onnx"):
        check_out_path(tmp_path / ".onnx")
    with pytest.raises(CheckpointError, match=r"'/proc/x\.onnx' cannot be written"):
        check_out_path("/proc/x.onnx")  # not "the checkpoint could not be exported at opset 17"
    (tmp_path / "notes.txt").write_text("not start states")
    with pytest.raises(ValueError, match="is not a .npz start-state file") as err:
        StartStates.load(tmp_path / "notes.txt")
    assert "pickle" not in str(err.value)  # numpy's advice to load a pickle unsafely, for a text file
