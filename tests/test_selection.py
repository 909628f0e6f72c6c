"""``vcs-env select``: the kept checkpoint is the best on the validation sets, scored as
``vcs-env evaluate`` scores them; run directories expand to their checkpoints; bad input is named."""

import json
import shlex
import shutil
import zipfile
from pathlib import Path

import pytest

from agents.evaluate import evaluate
from agents.evaluate.selection import candidates_of, select_checkpoint, validation_suite
from vcs_cli import main

# Each policy also plays the other family (that is the point); its family warning is expected.
pytestmark = pytest.mark.filterwarnings("ignore::agents.checkpoint.FamilyWarning")

CIRCLE8, CROWD5 = "policies/circle8/model.zip", "policies/crowd5/model.zip"
GENERALIST, GENERALIST_V2 = "policies/generalist/model.zip", "policies/generalist-v2/model.zip"


def _run_dir(tmp_path, files):
    """A run directory with ``checkpoints/model_<step>.zip`` for each ``{step: source}`` (None: final)."""
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    for step, src in files.items():
        dst = run / "model.zip" if step is None else run / "checkpoints" / f"model_{step}.zip"
        shutil.copy(src, dst)
        shutil.copy(src.replace(".zip", ".json"), dst.with_suffix(".json"))
    return run


def test_run_directory_expands_by_step_and_from_step_leaves_out_early_checkpoints(tmp_path):
    run = _run_dir(tmp_path, {1000: CIRCLE8, 200: GENERALIST, 30: CROWD5, None: GENERALIST_V2})
    shutil.copy(CIRCLE8, run / "checkpoints" / "model_old.zip")  # not a periodic checkpoint: not a candidate
    names = [c.name for c in candidates_of([run])]
    assert names == ["model_30.zip", "model_200.zip", "model_1000.zip", "model.zip"]
    assert [c.name for c in candidates_of([run], from_step=200)] == ["model_200.zip", "model_1000.zip", "model.zip"]
    with pytest.raises(ValueError, match="no candidate checkpoint from step 5000"):
        candidates_of([run / "checkpoints" / "model_30.zip"], from_step=5000)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="holds no model.zip"):
        candidates_of([tmp_path / "empty"])
    # A file named twice (directly and through its run) is one candidate, at its first place.
    twice = candidates_of([run / "model.zip", run], from_step=1000)
    assert [c.name for c in twice] == ["model.zip", "model_1000.zip"]
    # The same bytes under two names (a distil run's last round and its model.zip) are one candidate, the later.
    # Saved twice a few seconds apart: the same entries, stamped with other times (other bytes).
    with zipfile.ZipFile(run / "model.zip") as src, zipfile.ZipFile(run / "checkpoints" / "model_2000.zip", "w") as dst:
        for info in src.infolist():
            dst.writestr(zipfile.ZipInfo(info.filename, date_time=(2030, 1, 1, 0, 0, 2)), src.read(info))
    assert (run / "checkpoints" / "model_2000.zip").read_bytes() != (run / "model.zip").read_bytes()
    shutil.copy(run / "model.json", run / "checkpoints" / "model_2000.json")
    for suffix in (".zip", ".json"):
        shutil.copy(CIRCLE8.replace(".zip", suffix), tmp_path / f"copy{suffix}")
    assert [c.name for c in candidates_of([run], from_step=1000)] == ["model_1000.zip", "model.zip"]
    both = candidates_of([tmp_path / "copy.zip", run], from_step=1000)
    assert [c.name for c in both] == ["model_1000.zip", "model.zip"]
    # The same bytes with another run record (a shield attached to one) are two candidates.
    record = json.loads((tmp_path / "copy.json").read_text())
    (tmp_path / "copy.json").write_text(json.dumps({**record, "shield": {"margin": 0.2}}))
    assert len(candidates_of([tmp_path / "copy.zip", run], from_step=1000)) == 3
    # A candidate made for other observations stops the selection before any scoring.
    k2 = tmp_path / "k2"
    k2.mkdir()
    shutil.copy(CIRCLE8, k2 / "model.zip")
    meta = json.loads(Path(CIRCLE8).with_suffix(".json").read_text())
    meta["observation"]["n_neighbors"] = 2
    (k2 / "model.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match=r"made for observation space Box\(75,\)"):  # its record says 2 slots
        select_checkpoint(
            [run / "model.zip", k2 / "model.zip"], [validation_suite("crowd-5-v0:7000:7001")], tmp_path / "o"
        )
    assert not (tmp_path / "o").exists()
    # Writing the kept checkpoint into a candidate's run directory would overwrite it.
    with pytest.raises(ValueError, match="holds candidate .*model.zip'"):
        select_checkpoint(twice, [validation_suite("crowd-5-v0:7000:7001")], run)


def test_a_checkpoint_of_another_format_is_refused(tmp_path):
    """A BenchMARL actor.pt was copied to <out>/model.zip, a run nothing could load."""
    actor = tmp_path / "bm" / "actor.pt"
    actor.parent.mkdir()
    actor.write_bytes(b"not loaded: the format is told by the name")
    with pytest.raises(ValueError, match="is a benchmarl checkpoint: select keeps an SB3 policy"):
        candidates_of([actor])
    with pytest.raises(ValueError, match="RLlib and BenchMARL runs are compared with vcs-env compare"):
        candidates_of([actor.parent])


def test_bad_validation_sets_are_named():
    with pytest.raises(ValueError, match="SCENARIO:START:STOP"):
        validation_suite("dynamic-v0")
    with pytest.raises(ValueError, match="START:STOP"):
        validation_suite("dynamic-v0:7000:x")
    with pytest.raises(ValueError, match="unknown"):
        validation_suite("nosuch-v0:1:3")


def test_keeps_the_best_on_validation_and_the_later_of_equals(tmp_path):
    # The circle policy loses crowd episodes; the crowd policy solves both sets: it is kept, and
    # of two equal ones (the same network in two files that differ by a zip entry SB3 ignores) the later one.
    (tmp_path / "variant").mkdir()
    variant = str(tmp_path / "variant" / "model.zip")
    shutil.copy(CROWD5, variant)
    shutil.copy(CROWD5.replace(".zip", ".json"), variant.replace(".zip", ".json"))
    with zipfile.ZipFile(variant, "a") as z:
        z.writestr("note.txt", "another file, the same network")
    run = _run_dir(tmp_path, {100: CROWD5, 200: CIRCLE8, None: variant})
    sets = ["crowd-5-v0:7000:7020", "circle-8-v0:7000:7004"]
    out = tmp_path / "release"
    res = select_checkpoint(candidates_of([run]), [validation_suite(s) for s in sets], out)
    # The scores are those of evaluate on the same seeds.
    crowd = evaluate(CIRCLE8, validation_suite(sets[0])).summary["success"]["mean"]
    assert res["candidates"][1]["sets"][validation_suite(sets[0]).name]["success"] == crowd < 1.0
    assert [c["success"] for c in res["candidates"]] == [1.0, (crowd + 1.0) / 2, 1.0]
    assert res["chosen"] == str(run / "model.zip")
    assert (out / "model.zip").read_bytes() == (run / "model.zip").read_bytes()
    assert json.loads((out / "model.json").read_text()) == json.loads((run / "model.json").read_text())
    assert json.loads((out / "selection.json").read_text()) == res


def test_cli_select(tmp_path, capsys):
    run = _run_dir(tmp_path, {100: CROWD5, 200: CIRCLE8})
    out = tmp_path / "release"
    argv = ["select", str(run), "--from-step", "150", "--validation", "crowd-5-v0:7000:7010", "--out", str(out)]
    assert main(argv) == 0
    assert f"kept {run / 'checkpoints' / 'model_200.zip'}" in capsys.readouterr().out
    kept = json.loads((out / "selection.json").read_text())
    assert kept["chosen"].endswith("model_200.zip")
    assert shlex.split(kept["command"]) == ["vcs-env", *argv]  # the selection says how it was made
    # The same --out again: refused (the kept model.zip and its record would be replaced, another run's files kept).
    assert main(argv) == 2
    assert "already holds a run (model.zip, model.json)" in capsys.readouterr().err


def test_select_says_which_shield_each_candidate_ran_with_and_can_score_the_networks_alone(tmp_path, capsys):
    shielded = tmp_path / "s"
    shielded.mkdir()
    for suffix in (".zip", ".json"):
        shutil.copy(CROWD5.replace(".zip", suffix), shielded / f"model{suffix}")
    assert main(["shield", str(shielded / "model.zip"), "--margin", "0.2"]) == 0
    base = ["select", CROWD5, str(shielded / "model.zip"), "--validation", "crowd-5-v0:7000:7002", "--no-progress"]
    assert main([*base, "--out", str(tmp_path / "a")]) == 0
    rows = json.loads((tmp_path / "a" / "selection.json").read_text())["candidates"]
    assert rows[0]["shield"] is None and rows[1]["shield"]["margin"] == 0.2
    assert main([*base, "--no-shield", "--out", str(tmp_path / "b")]) == 0
    rows = json.loads((tmp_path / "b" / "selection.json").read_text())["candidates"]
    assert rows[0]["shield"] is None and rows[1]["shield"] is None
