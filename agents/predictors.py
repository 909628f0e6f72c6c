"""Networks of other libraries as SB3-style ``PolicyPredictor`` objects for :mod:`agents.evaluate`:
``predict(obs (N, D)) -> (actions (N, 2) in [-1, 1], state)``, and one action ``(2,)`` for one observation
``(D,)``, as SB3. :mod:`agents.checkpoint` builds them when it loads an RLlib or a BenchMARL checkpoint. torch is
imported when one predicts, not before."""

from __future__ import annotations

from typing import Any

import numpy as np


class RLlibPolicy:
    """An RLlib RLModule as an SB3-style ``PolicyPredictor`` for :mod:`agents.evaluate`.

    ``predict(obs (N, D)) -> (actions (N, 2) in [-1, 1], None)``: the Gaussian's mean with
    ``deterministic=True``, else a sample drawn from ``rng``.
    """

    def __init__(self, module, name: str = "rllib", rng: np.random.Generator | None = None):
        self.module = module
        self.name = name
        self.observation_space = module.observation_space
        self.action_space = module.action_space
        self.rng = rng if rng is not None else np.random.default_rng(0)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False):
        import torch

        observation = np.asarray(observation, dtype=np.float32)
        obs = torch.as_tensor(observation).reshape(-1, self.observation_space.shape[0])
        with torch.no_grad():
            out = self.module.forward_inference({"obs": obs})["action_dist_inputs"].numpy()
        mean, log_std = np.split(out.astype(np.float64), 2, axis=-1)
        actions = mean if deterministic else mean + np.exp(log_std) * self.rng.standard_normal(mean.shape)
        return np.clip(actions, -1.0, 1.0).astype(np.float32).reshape(*observation.shape[:-1], 2), state


class BenchMARLPolicy:
    """A BenchMARL policy network (:class:`BenchMARLCheckpoint`) as an SB3-style ``PolicyPredictor``.

    ``predict(obs (N, D)) -> (actions (N, 2) in [-1, 1], None)``: ``tanh(loc)`` with ``deterministic=True``
    (BenchMARL's deterministic action), else ``tanh(loc + scale * z)`` with ``z`` drawn from ``rng``.
    """

    def __init__(self, net, layout: dict[str, Any], name: str = "benchmarl", rng: np.random.Generator | None = None):
        import gymnasium as gym

        self.net = net.eval()
        self.scale = layout["scale"]
        self.name = name
        self.observation_space = gym.spaces.Box(
            np.asarray(layout["low"], dtype=np.float32), np.asarray(layout["high"], dtype=np.float32)
        )
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.rng = rng if rng is not None else np.random.default_rng(0)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False):
        import torch

        observation = np.asarray(observation, dtype=np.float32)
        obs = torch.as_tensor(observation).reshape(-1, self.observation_space.shape[0])
        with torch.no_grad():
            out = self.net(obs).numpy().astype(np.float64)
        loc, raw = out[:, :2], out[:, 2:]
        if not deterministic:  # BenchMARL's scale: softplus(raw + bias) + min
            scale = np.logaddexp(0.0, raw + self.scale["bias"]) + self.scale["min"]
            loc = loc + scale * self.rng.standard_normal(loc.shape)
        return np.tanh(loc).astype(np.float32).reshape(*observation.shape[:-1], 2), state
