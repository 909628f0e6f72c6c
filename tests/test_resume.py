"""``vcs-env train --resume``: where it writes, what it keeps, what it refuses; PPO settings checks."""

import json
import math

import pytest

import vcs_cli as cli
from agents.checkpoint import attach_shield
from agents.shield import Shield

pytest.importorskip("stable_baselines3")

TINY = ["--n-robots", "4", "--n-worlds", "4", "--eval-episodes", "2", "--no-progress-bar"]


def _timesteps(path):
    return [r["timesteps"] for r in map(json.loads, path.read_text().splitlines())]


@pytest.mark.slow
def test_resume_continues_its_own_run_and_refuses_what_it_cannot_apply(tmp_path, monkeypatch, capsys):
    run = tmp_path / "run"
    args = ["train", *TINY, "--timesteps", "6144", "--eval-freq", "2048", "--checkpoint-freq", "2048"]
    assert cli.main([*args, "--out", str(run)]) == 0
    assert _timesteps(run / "eval.jsonl") == [2048, 4096, 6144]
    assert "note: PPO learns in whole rollouts" not in capsys.readouterr().out  # 6144 = 3 rollouts
    # From another directory and an earlier checkpoint, without --out: the run's own directory
    # (it wrote to the saved relative `out`, i.e. a new directory here); the evaluations after the
    # checkpoint belong to the branch the resume leaves, and go.
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    ckpt = run / "checkpoints" / "model_2048.zip"
    assert cli.main(["train", "--resume", str(ckpt), "--timesteps", "8000", "--no-progress-bar"]) == 0
    assert "this run stops at 8192 timesteps, not 8000" in capsys.readouterr().out
    assert not any(elsewhere.iterdir())
    assert _timesteps(run / "eval.jsonl") == [2048, 4096, 6144, 8192]
    record = json.loads((run / "model.json").read_text())
    assert [h["timesteps"] for h in record["history"]] == [2048, 4096, 6144, 8192]
    # The record says the weights went on from the checkpoint (its command alone does not rebuild them).
    assert record["resumed_from"] == {"checkpoint": str(ckpt), "timesteps": 2048}
    capsys.readouterr()
    # Flags the checkpoint fixes, --init, and checkpoints that are not a PPO run's are refused.
    for extra, message in (
        (["--n-steps", "16"], "keeps its network and PPO settings; --n-steps"),
        (["--net-arch", "32"], "--net-arch"),
        (["--init", str(ckpt)], "--init and --resume exclude each other"),
    ):
        assert cli.main(["train", "--resume", str(run), "--timesteps", "10000", *extra]) == 2
        assert message in capsys.readouterr().err
    meta = json.loads((run / "model.json").read_text())
    (run / "bc.zip").write_bytes((run / "model.zip").read_bytes())
    (run / "bc.json").write_text(json.dumps({**meta, "kind": "bc"}))
    assert cli.main(["train", "--resume", str(run / "bc.zip"), "--timesteps", "10000"]) == 2
    assert "a bc checkpoint, not a PPO run's" in capsys.readouterr().err
    # A budget below the checkpoint's, and a backend that is not the run's, are refused (the first trained minus
    # steps and saved a copy; the second trained with the run's backend without a word).
    assert cli.main(["train", "--resume", str(run), "--timesteps", "4096"]) == 2
    assert "new total: above the checkpoint's 8192 (got 4096)" in capsys.readouterr().err
    # A log whose last line a killed run left half written is named with its line (a bare JSON error before).
    log = (run / "eval.jsonl").read_text()
    (run / "eval.jsonl").write_text(log[:-40])
    assert cli.main(["train", "--resume", str(run), "--timesteps", "10000", "--no-progress-bar"]) == 2
    assert f"{run / 'eval.jsonl'} line 4 is not JSON" in capsys.readouterr().err
    (run / "eval.jsonl").write_text(log)
    assert cli.main(["train", "--resume", str(run)]) == 2  # the run's own total, reached
    assert "new total: above the checkpoint's 8192 (the run's own is 8000)" in capsys.readouterr().err
    assert cli.main(["train", "--resume", str(run), "--timesteps", "10000", "--backend", "rllib"]) == 2
    assert "with --backend rllib: it is an sb3 run's" in capsys.readouterr().err
    # The reproduce line of a resumed run carries the flags it changed (here the scenario's robots).
    out = tmp_path / "branch"
    args = ["train", "--resume", str(run), "--timesteps", "10240", "--n-robots", "6", "--out", str(out)]
    assert cli.main([*args, "--no-progress-bar"]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("reproduce:")][0]
    assert "--n-robots 6" in line and f"--resume {run / 'model.zip'}" in line and f"--out {out}" in line
    # Into a directory that holds another run: refused (it replaced that run's model and cut its evaluations).
    kept = (out / "eval.jsonl").read_text()
    assert cli.main(["train", "--resume", str(run), "--timesteps", "12288", "--out", str(out)]) == 2
    assert f"--out {str(out)!r} already holds a run" in capsys.readouterr().err
    assert (out / "eval.jsonl").read_text() == kept


@pytest.mark.slow
def test_a_run_killed_before_its_end_resumes_from_its_newest_checkpoint(tmp_path, capsys):
    """No model.zip (killed mid-way): --resume RUN_DIR takes checkpoints/model_<newest>.zip and says so."""
    run = tmp_path / "run"
    args = ["train", *TINY, "--timesteps", "4096", "--eval-freq", "0", "--checkpoint-freq", "2048"]
    assert cli.main([*args, "--out", str(run)]) == 0
    for name in ("model.zip", "model.json", "best_model.zip", "best_model.json"):
        (run / name).unlink()
    newest = run / "checkpoints" / "model_2048.zip"
    attach_shield(newest, Shield())  # vcs-env shield on the checkpoint: the resumed run's records go without it
    capsys.readouterr()
    assert cli.main(["train", "--resume", str(run), "--timesteps", "6144", "--no-progress-bar"]) == 0
    out = capsys.readouterr().out
    assert f"its newest checkpoint is {newest} (2048 timesteps)" in out and f"resumed {newest} at 2048" in out
    assert f"note: {newest} carries a shield in its run record" in out
    record = json.loads((run / "model.json").read_text())
    assert record["num_timesteps"] == 6144 and "shield" not in record


def test_a_new_run_into_another_runs_directory_is_refused(tmp_path, capsys):
    """train, bc and distil into an --out that holds a run (its model.zip, its eval.jsonl): refused before anything
    is written (the new model replaced the old one and its evaluations were appended to the old run's)."""
    run = tmp_path / "run"
    args = ["train", *TINY, "--timesteps", "1000", "--eval-freq", "0"]
    assert cli.main([*args, "--out", str(run)]) == 0
    before = {p.name: p.stat().st_mtime_ns for p in run.iterdir()}
    data = tmp_path / "expert.npz"
    assert cli.main(["collect", "--n-robots", "4", "--episodes", "2", "--out", str(data)]) == 0
    capsys.readouterr()
    for argv, hint in (
        ([*args, "--out", str(run)], "--resume"),
        (["bc", "--data", str(data), "--epochs", "1", "--out", str(run)], "remove that one first"),
        (["distil", "--scenario", "circle", "--teacher", str(run / "model.zip"), "--out", str(run)], "remove that one"),
    ):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and f"--out {str(run)!r} already holds a run (model.zip, model.json" in err, err
        assert hint in err
    assert {p.name: p.stat().st_mtime_ns for p in run.iterdir()} == before
    # A run stopped (Ctrl-C) before its first checkpoint left its config.json only: no --resume to suggest
    stopped = tmp_path / "stopped"
    stopped.mkdir()
    (stopped / "config.json").write_text((run / "config.json").read_text())
    assert cli.main([*args, "--out", str(stopped)]) == 2
    err = capsys.readouterr().err
    assert "already holds a run (config.json)" in err and "nothing to resume" in err and "--resume" not in err


def test_training_among_walls_it_cannot_see_warns(tmp_path, recwarn):
    """A run on a map with no wall sensing warns that its policy cannot learn the walls (it warned only when
    evaluated); with wall points it does not."""
    from agents.policies import BlindWarning

    base = ["train", "--scenario", "corridor", "--n-robots", "2", "--n-worlds", "2", "--timesteps", "256"]
    base += ["--n-steps", "64", "--batch-size", "64", "--eval-freq", "0", "--eval-episodes", "1", "--no-progress-bar"]
    assert cli.main([*base, "--out", str(tmp_path / "blind")]) == 0
    said = [str(w.message) for w in recwarn if issubclass(w.category, BlindWarning)]
    assert len(said) == 1 and "trains on corridor, whose walls its observation does not show" in said[0]
    recwarn.clear()
    assert cli.main([*base, "--n-wall-points", "2", "--out", str(tmp_path / "sees")]) == 0
    assert not [w for w in recwarn if issubclass(w.category, BlindWarning)]


@pytest.mark.parametrize("backend", ["sb3", "rllib"])
def test_a_run_of_zero_timesteps_is_refused(backend, tmp_path, capsys):
    out = tmp_path / "x"
    assert cli.main(["train", *TINY, "--backend", backend, "--timesteps", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--timesteps must be >= 1" in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--n-steps", "0"], "n_steps must be an integer"),
        (["--batch-size", "0"], "batch_size must be an integer"),
        (["--n-epochs", "0"], "n_epochs must be an integer"),
        (["--net-arch", "0"], "net_arch must be"),
        (["--clip-range", "-1"], "clip_range must be"),
        (["--target-kl", "-1"], "target_kl must be"),
        (["--eval-freq", "-5"], "eval_freq must be"),
        (["--log-std-init", "nan"], "log_std_init must be"),
    ],
)
def test_ppo_settings_are_checked_by_name(flags, message, tmp_path, capsys):
    # They crashed in SB3 (n_steps, batch_size), after a whole rollout (n_epochs), or trained on.
    assert cli.main(["train", *TINY, "--timesteps", "10", *flags, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_resuming_a_finished_run_keeps_the_checkpoint_it_goes_on_from(tmp_path, capsys):
    """--resume RUN picked RUN/model.zip and the resumed run wrote over it: its resumed_from named weights that no
    longer existed."""
    run = tmp_path / "run"
    args = ["train", *TINY, "--timesteps", "2048", "--eval-freq", "0", "--checkpoint-freq", "0", "--out", str(run)]
    assert cli.main(args) == 0
    first = (run / "model.zip").read_bytes()
    assert cli.main(["train", "--resume", str(run), "--timesteps", "4096", "--no-progress-bar"]) == 0
    kept = run / "checkpoints" / "model_2048.zip"
    assert kept.read_bytes() == first and (run / "checkpoints" / "model_2048.json").is_file()
    record = json.loads((run / "model.json").read_text())
    assert record["resumed_from"] == {"checkpoint": str(kept), "timesteps": 2048} and record["num_timesteps"] == 4096
    assert "then vcs-env train" in capsys.readouterr().out


def test_init_log_std_sets_the_loaded_policys_std_and_is_refused_where_it_cannot_apply(tmp_path, capsys):
    """A run from --init explores with --init-log-std (one update at a negligible learning rate keeps it); without
    --init and on --resume it is refused, and so is --log-std-init with --init (the checkpoint's std replaced it)."""
    import torch

    from agents.checkpoint import load_model
    from vcs_env import make_scenario

    first, quiet = tmp_path / "first", tmp_path / "quiet"
    assert cli.main(["train", *TINY, "--timesteps", "2048", "--eval-freq", "0", "--out", str(first)]) == 0
    args = ["train", *TINY, "--timesteps", "2048", "--eval-freq", "0", "--init", str(first / "model.zip")]
    assert cli.main([*args, "--learning-rate", "1e-9", "--init-log-std", "-2.3", "--out", str(quiet)]) == 0
    std, init_std = (load_model(p / "model.zip", make_scenario("circle")).policy.log_std.exp() for p in (quiet, first))
    assert torch.allclose(std, torch.full_like(std, math.exp(-2.3)), atol=1e-4) and (init_std > 0.15).all()
    capsys.readouterr()
    for argv, message in (
        (["train", *TINY, "--init-log-std", "-2"], "--init-log-std sets the log std of the --init checkpoint"),
        ([*args, "--log-std-init", "-2"], "--init loads the checkpoint's (give --init-log-std"),
        (["train", "--resume", str(first), "--timesteps", "4096", "--init-log-std", "-2"], "would not apply"),
    ):
        assert cli.main([*argv, "--out", str(tmp_path / "x")]) == 2
        assert message in capsys.readouterr().err


def test_an_eval_suite_is_observed_as_the_run_observes(tmp_path, capsys):
    """A suite without wall points beside a run that senses them: the run trained to its end, then its first suite
    evaluation failed on the observation size, and no model.zip was saved (its config.json then blocked the out dir)."""
    from agents.evaluate import evaluate
    from vcs_cli import main

    out = tmp_path / "run"
    args = "train --scenario room --n-wall-points 4 --eval-suite circle-8-v0-smoke --timesteps 64 --n-worlds 1"
    args += " --n-steps 64 --batch-size 64 --n-epochs 1 --eval-freq 0 --eval-episodes 1 --no-progress-bar"
    assert main([*args.split(), "--out", str(out)]) == 0, capsys.readouterr().err
    logged = json.loads((out / "model.json").read_text())["history"][-1]["suite"]
    assert logged["success"] == evaluate(str(out / "model.zip"), "circle-8-v0-smoke").summary["success"]["mean"]


def test_ctrl_c_saves_a_checkpoint_to_go_on_from_and_a_half_saved_one_is_passed_over(tmp_path, monkeypatch, capsys):
    """Ctrl-C during training printed a long traceback and kept nothing since the last periodic checkpoint; and a run
    stopped while saving left a half-written newest checkpoint (or a zip without its record) that --resume stopped
    on. Now the interrupt saves one and says how to go on; a save writes its files under other names, then renames
    them; --resume passes over an incomplete newest checkpoint with a warning; evaluate names what a run kept."""
    import warnings

    from stable_baselines3 import PPO

    from agents.checkpoint import latest_checkpoint

    run = tmp_path / "run"
    real_learn = PPO.learn

    def learn_then_interrupt(self, total_timesteps, **kw):
        real_learn(self, 2048, **kw)  # one rollout of 4 worlds x 4 robots x 128 steps, then Ctrl-C
        raise KeyboardInterrupt

    monkeypatch.setattr(PPO, "learn", learn_then_interrupt)
    args = ["train", *TINY, "--timesteps", "8192", "--eval-freq", "0", "--checkpoint-freq", "0", "--out", str(run)]
    assert cli.main(args) == 130
    out, err = capsys.readouterr()
    kept = run / "checkpoints" / "model_2048.zip"
    assert f"interrupted at 2048 timesteps: saved {kept}; go on with: vcs-env train --resume {run}" in out
    assert "vcs-env train: interrupted" in err and "Traceback" not in err
    assert sorted(p.name for p in kept.parent.iterdir()) == ["model_2048.json", "model_2048.zip"]  # no .part left
    assert cli.main(["evaluate", "--suite", "circle-8-v0-smoke", "--policy", str(run)]) == 2
    assert f"holds no final model (a run stopped before its end?); pass one of what it kept: {str(kept)!r}" in (
        capsys.readouterr().err
    )
    # A newer checkpoint cut short by a stop while it was saved: --resume goes on from the whole one.
    (run / "checkpoints" / "model_4096.zip").write_bytes(kept.read_bytes()[:1000])
    record = json.loads((run / "checkpoints" / "model_2048.json").read_text())
    (run / "checkpoints" / "model_4096.json").write_text(json.dumps({**record, "num_timesteps": 4096}))
    assert (
        max(c.timesteps for c in [latest_checkpoint(kept), latest_checkpoint(kept.with_name("model_4096.zip"))]) == 4096
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert latest_checkpoint(run).path == kept
    assert any("model_4096.zip' is incomplete" in str(w.message) for w in caught)
