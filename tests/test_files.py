"""Outputs are written whole or not at all (``vcs_env.files``): a write stopped half way leaves the earlier file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import vcs_cli
from vcs_env.files import replacing, write_text


class Stopped(Exception):
    pass


def test_replacing_renames_a_whole_file_and_keeps_the_earlier_one_otherwise(tmp_path):
    f = tmp_path / "sub" / "a.txt"
    assert write_text(f, "one") == f and f.read_text() == "one"  # the parent made
    with pytest.raises(Stopped), replacing(f) as part:
        part.write_text("tw")  # half of the new content, then the run stops
        raise Stopped
    assert f.read_text() == "one" and sorted(p.name for p in f.parent.iterdir()) == ["a.txt"]
    with replacing(f) as part:
        part.write_text("two")
    assert f.read_text() == "two" and sorted(p.name for p in f.parent.iterdir()) == ["a.txt"]


def half_then_stop(self, text, *args, **kw):
    """``Path.write_text`` cut short: half the text lands, then the write fails (a full disk, a killed job)."""
    with open(self, "w") as out:
        out.write(text[: len(text) // 2])
    raise Stopped


def test_a_json_output_stopped_half_way_leaves_the_earlier_one(tmp_path, monkeypatch):
    """``vcs-env evaluate --json F`` wrote F in place: a write cut short left a truncated F instead of the earlier
    results (and ``train``'s ``eval.jsonl``, rewritten at every evaluation, lost the run's history the same way)."""
    out = tmp_path / "res.json"
    argv = ["evaluate", "--scenario", "swap", "--n-robots", "2", "--seeds", "0:1", "--policy", "vcs", "--no-progress"]
    assert vcs_cli.main([*argv, "--json", str(out)]) == 0
    before = out.read_text()
    monkeypatch.setattr(Path, "write_text", half_then_stop)
    with pytest.raises(Stopped):
        vcs_cli.main([*argv, "--max-steps", "3", "--json", str(out)])
    assert out.read_text() == before and json.loads(before)["episodes"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res.json"]


def test_a_dataset_stopped_half_way_leaves_no_file_under_its_name(tmp_path, monkeypatch):
    """``collect`` wrote the dataset under its name as it compressed it: a run stopped then left a truncated ``.npz``
    that the next ``collect --out`` refused as existing data and ``bc`` took for a dataset."""
    import agents.imitation.data as data

    def half_then_stop_npz(file, **arrays):
        file.write(b"PK\x03\x04 part of a zip")
        raise Stopped

    monkeypatch.setattr(data.np, "savez_compressed", half_then_stop_npz)
    with pytest.raises(Stopped):
        data.save_dataset(tmp_path / "d", {"obs": np.zeros((2, 3))}, {"note": 1})
    assert list(tmp_path.iterdir()) == []
