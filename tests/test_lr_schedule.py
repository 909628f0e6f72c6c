"""The learning-rate schedule of SB3 runs (``--lr-schedule``)."""

import dataclasses
import json
import zipfile

import pytest

pytest.importorskip("stable_baselines3")
import torch  # noqa: E402

torch.set_num_threads(1)


def test_linear_lr_holds_at_zero_when_a_run_ends_past_its_budget(tmp_path):
    """PPO learns in whole rollouts, so a budget that is not a multiple of the rollout ends past it and SB3
    hands the last update a negative remaining progress; the linear schedule must give 0 there, not a
    negative rate (gradient ascent on the loss: it wrecked a policy on the maps)."""
    from agents.train import TrainConfig, learning_rate, train

    cfg = TrainConfig(learning_rate=1e-3, lr_schedule="linear")
    assert learning_rate(cfg)(1.0) == 1e-3 and learning_rate(cfg)(0.25) == 2.5e-4
    assert learning_rate(cfg)(-0.3) == 0.0
    # 3 robots x 2 worlds x 8 steps = 48 per rollout: 100 timesteps end at 144, progress -0.44 at the last update.
    run = dataclasses.replace(
        cfg, scenario="circle", n_robots=3, n_worlds=2, n_steps=8, batch_size=16, n_epochs=1, timesteps=100,
        eval_freq=0, eval_episodes=1, progress_bar=False, out=str(tmp_path / "ppo"),
    )  # fmt: skip
    train(run)
    with zipfile.ZipFile(tmp_path / "ppo/model.zip") as z:
        state = torch.load(z.open("policy.optimizer.pth"), map_location="cpu")
    assert json.loads((tmp_path / "ppo/model.json").read_text())["num_timesteps"] == 144
    assert state["param_groups"][0]["lr"] == 0.0
