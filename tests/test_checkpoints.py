"""Checkpoints in the evaluation harness: bad paths, formats that find themselves, a run record that is no
checkpoint, and SB3 checkpoints checked against the scenario's observation space."""

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import vcs_cli as cli
from agents.evaluate import evaluate
from vcs_env.scenario import make_scenario
from vcs_env.spaces import observation_space
from vcs_env.suites import SMOKE_SEEDS, get_suite


def test_bad_checkpoint_paths_give_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="not found"):
        evaluate(tmp_path / "missing.zip", "swap-v0-smoke", progress=False)
    pytest.importorskip("stable_baselines3")
    bad = tmp_path / "bad.zip"
    bad.write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="corrupt"):
        evaluate(str(bad), "swap-v0-smoke", progress=False)
    # A directory with no checkpoint in it is named as such (it was read as an unknown planner's name).
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="checkpoint not found: .*empty"):
        evaluate(str(tmp_path / "empty"), "swap-v0-smoke", progress=False)
    # A checkpoint without its run record, whose sensing then differs from the scenario's: the message says why.
    (tmp_path / "nojson").mkdir()
    shutil.copy("policies/circle8/model.zip", tmp_path / "nojson" / "model.zip")
    with pytest.raises(ValueError, match="observation space Box\\(75,\\).*\\(no run record beside it: .*model.json"):
        evaluate(str(tmp_path / "nojson"), "crowd-5-v0-smoke", progress=False)


def test_checkpoint_formats_detect_themselves_and_a_run_resumes_from_its_newest(tmp_path):
    """Each format finds itself once (the checkpoint, or its run directory); latest_checkpoint takes
    a run directory's newest checkpoint by timesteps, the final one on a tie."""
    from agents.checkpoint import RLlibCheckpoint, SB3Checkpoint, latest_checkpoint, open_checkpoint

    run = tmp_path / "rllib"
    for name, steps in (
        ("checkpoints/checkpoint_128", 128),
        ("checkpoints/checkpoint_1024", 1024),
        ("checkpoint", 1024),
    ):
        (run / name).mkdir(parents=True)
        (run / name / "vcs_env.json").write_text(json.dumps({"num_timesteps": steps}))
    assert open_checkpoint(run).path == run / "checkpoint" and open_checkpoint(run).format == "rllib"
    assert latest_checkpoint(run).path == run / "checkpoint"
    shutil.rmtree(run / "checkpoint")  # killed before its end
    assert latest_checkpoint(run).path == run / "checkpoints" / "checkpoint_1024"
    assert [c.timesteps for c in RLlibCheckpoint.in_run(run)] == [128, 1024]
    sb3 = tmp_path / "sb3"
    (sb3 / "checkpoints").mkdir(parents=True)
    (sb3 / "checkpoints" / "model_2048.zip").write_bytes(b"")
    ckpt = latest_checkpoint(sb3)
    assert isinstance(ckpt, SB3Checkpoint) and ckpt.timesteps == 2048 and ckpt.run_dir == sb3
    with pytest.raises(ValueError, match="holds no final model .* pass one of what it kept: .*model_2048.zip"):
        open_checkpoint(sb3)  # a run directory is evaluated by its final model.zip only


def test_a_missing_checkpoint_names_every_accepted_form_and_a_run_record_is_not_one(tmp_path, capsys):
    from agents.checkpoint import CheckpointError, open_checkpoint

    with pytest.raises(CheckpointError) as err:
        open_checkpoint(tmp_path / "missing")
    for form in ("SB3 .zip", "run directory with model.zip", "RLlib checkpoint directory", "RLlib run directory"):
        assert form in str(err.value)
    # A run's model.json is its record, not a checkpoint: said in one line, not called corrupt.
    base = ["evaluate", "--suite", "swap-v0-smoke", "--no-progress", "--policy", "policies/circle8/model.json"]
    assert cli.main(base) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "model.json is the run record; pass model.zip or the run directory" in err, err


def test_sb3_checkpoint_is_loaded_and_checked(tmp_path):
    pytest.importorskip("stable_baselines3")
    import gymnasium
    from stable_baselines3 import PPO

    class SpacesOnly(gymnasium.Env):
        def __init__(self, obs_space):
            self.observation_space = obs_space
            self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)

    suite = get_suite("crowd-5-v0-smoke")
    good = PPO("MlpPolicy", SpacesOnly(observation_space(suite.scenario)), n_steps=8, batch_size=8, device="cpu")
    good.save(tmp_path / "good.zip")
    res = evaluate(str(tmp_path / "good.zip"), suite, progress=False)
    assert res.policy == "good" and len(res.rows) == SMOKE_SEEDS

    other = gymnasium.spaces.Box(-1.0, 1.0, (19,), dtype=np.float32)
    PPO("MlpPolicy", SpacesOnly(other), n_steps=8, batch_size=8, device="cpu").save(tmp_path / "other.zip")
    with pytest.raises(ValueError, match=r"observation space Box\(19,\)"):
        evaluate(tmp_path / "other.zip", suite, progress=False)

    # Sampled actions: the same suite gives the same episodes (torch's global generator moves on
    # in between), and they are not the deterministic ones.
    runs = [evaluate(str(tmp_path / "good.zip"), suite, deterministic=False, progress=False) for _ in range(2)]

    def played(res):  # every metric but the compute time, NaN equal to NaN
        return np.array([[v for k, v in sorted(r.items()) if k != "compute_per_decision"] for r in res.rows])

    np.testing.assert_array_equal(played(runs[0]), played(runs[1]))
    assert not np.array_equal(played(res), played(runs[0]), equal_nan=True)  # they are samples

    # Another SB3 algorithm's checkpoint is named, not loaded as PPO (A2C shares PPO's policy class).
    from stable_baselines3 import A2C

    A2C("MlpPolicy", SpacesOnly(observation_space(suite.scenario)), n_steps=8, device="cpu").save(tmp_path / "a2c.zip")
    with pytest.raises(ValueError, match="another SB3 algorithm than PPO.*ActorCriticPolicy"):
        evaluate(tmp_path / "a2c.zip", suite, progress=False)


def test_a_save_that_fails_leaves_the_checkpoint_before_it_and_no_part(tmp_path):
    """save_model writes under other names and renames into place: a save stopped midway (Ctrl-C, a full disk) left a
    half-written zip, or a zip without its record, that --resume stopped on."""
    from agents.runs import save_model

    class Model:
        num_timesteps = 10

        def __init__(self, fail):
            self.fail = fail

        def save(self, path):
            Path(path).write_bytes(b"PK half")
            if self.fail:
                raise KeyboardInterrupt

    scenario, config = make_scenario("circle", n_robots=2), dataclasses.make_dataclass("Config", [])()
    done = save_model(Model(False), tmp_path / "model.zip", "ppo", config, scenario)
    before = done.read_bytes(), (tmp_path / "model.json").read_text()
    with pytest.raises(KeyboardInterrupt):
        save_model(Model(True), tmp_path / "model.zip", "ppo", config, scenario)
    assert (done.read_bytes(), (tmp_path / "model.json").read_text()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json", "model.zip"]
