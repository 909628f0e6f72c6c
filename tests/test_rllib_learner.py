"""The PPO update of ``--backend rllib`` (:mod:`agents.train.rllib_learner`): SB3's advantage
normalization, a train batch shuffled before the first epoch, and a toy run that repeats bit for
bit (sampling in the driver)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("ray.rllib", reason="the rllib extra (pip install -e '.[rllib]')")

import torch  # noqa: E402

from agents.train import rllib_learner  # noqa: E402
from agents.train.rllib_learner import normalized_advantages  # noqa: E402

pytestmark = pytest.mark.slow  # notebooks / Ray clusters / training: minutes, not seconds


def test_advantages_are_normalized_over_the_real_steps_of_the_minibatch():
    adv = torch.tensor([1.0, 2.0, 3.0, 100.0, 6.0])
    mask = torch.tensor([True, True, True, False, True])
    out = normalized_advantages(adv, mask)
    real = np.array([1.0, 2.0, 3.0, 6.0])
    np.testing.assert_allclose(out[mask].numpy(), (real - real.mean()) / real.std(ddof=1), rtol=1e-5)
    assert out[mask].mean().abs() < 1e-6  # the masked bootstrap step (100) does not shift them
    np.testing.assert_allclose(normalized_advantages(adv[mask], None).numpy(), out[mask].numpy(), rtol=1e-6)
    one = torch.tensor([True, False, False, False, False])  # one real row: no std, left as is (SB3)
    np.testing.assert_array_equal(normalized_advantages(adv, one).numpy(), adv.numpy())


def test_first_epoch_minibatches_are_shuffled_and_a_toy_run_repeats(monkeypatch):
    """RLlib's iterator shuffles only from the second epoch on: its first epoch took minibatches
    of whole episode chunks (consecutive steps of a few robots). Here the first minibatch of
    every update must mix robots and times: consecutive rows are far apart (in the unshuffled
    batch 73 % of them differ by < 0.1 in every feature, 22 % here). Two runs with one seed
    (sampling in the driver) end with identical weights."""
    from ray.rllib.core.columns import Columns

    from agents.runs import RLlibConfig
    from agents.train.rllib import init_ray, learner_module, ppo_config, set_log_std

    torch.set_num_threads(1)
    first_minibatches: list[np.ndarray] = []
    calls = {"updates": 0, "new_update": False}
    make_batch = rllib_learner.SB3PPOLearner._make_batch_if_necessary
    loss = rllib_learner.SB3PPOLearner.compute_loss_for_module

    def new_update(self, training_data):
        calls["updates"] += 1
        calls["new_update"] = True
        return make_batch(self, training_data)

    def recording(self, *, module_id, config, batch, fwd_out):
        if calls["new_update"]:  # the first minibatch of the first epoch
            first_minibatches.append(batch[Columns.OBS].numpy().copy())
            calls["new_update"] = False
        return loss(self, module_id=module_id, config=config, batch=batch, fwd_out=fwd_out)

    monkeypatch.setattr(rllib_learner.SB3PPOLearner, "_make_batch_if_necessary", new_update)
    monkeypatch.setattr(rllib_learner.SB3PPOLearner, "compute_loss_for_module", recording)
    cfg = RLlibConfig(
        scenario="circle",
        n_robots=4,
        n_worlds=2,
        n_steps=32,
        batch_size=64,
        n_epochs=2,
        seed=3,
        num_env_runners=0,
        env_adapter="batched",
    )
    ray = init_ray(cfg)
    weights = []
    try:
        for _ in range(2):
            algo = ppo_config(cfg).build_algo()
            try:
                set_log_std(algo, cfg.log_std_init)
                for _ in range(2):
                    algo.train()
                weights.append(torch.cat([p.detach().flatten() for p in learner_module(algo).parameters()]))
            finally:
                algo.stop()
    finally:
        ray.shutdown()
    assert calls["updates"] == 4 and len(first_minibatches) == 4
    for obs in first_minibatches:
        assert obs.shape[0] == 64
        near = np.abs(np.diff(obs, axis=0)).max(axis=1) < 0.1
        assert near.mean() < 0.5, near.mean()
    assert torch.equal(weights[0], weights[1])


def test_train_uses_a_ray_its_caller_started_and_leaves_it_running(tmp_path):
    """A script or notebook that started Ray itself: ``train`` called ``ray.init`` again (Ray's "called ray.init
    twice" error, nothing trained), and would have shut the caller's Ray down at the end."""
    import ray

    from agents.runs import RLlibConfig
    from agents.train.rllib import train

    torch.set_num_threads(1)
    cfg = RLlibConfig(
        scenario="circle", n_robots=4, n_worlds=2, n_steps=16, batch_size=64, n_epochs=1, eval_freq=0,
        eval_episodes=1, checkpoint_freq=0, num_env_runners=0, timesteps=128, seed=5, out=str(tmp_path / "run"),
    )  # fmt: skip
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1")
    try:
        out = train(cfg)
        assert ray.is_initialized()  # the caller's Ray is the caller's to stop
        assert out["timesteps"] >= 128 and (tmp_path / "run" / "checkpoint").is_dir()
        with pytest.raises(ValueError, match="already runs Ray; --address 127.0.0.1:1 would join another"):
            train(dataclasses.replace(cfg, address="127.0.0.1:1", out=str(tmp_path / "other")))
    finally:
        ray.shutdown()
