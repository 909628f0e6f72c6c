"""Expert guidance for PPO beside the shaping terms: an auxiliary imitation loss (``--guide imitation_loss``)
and jump-start rollouts (``--guide jump_start``).

:class:`ImitationLoss` is expert-regularised PPO in the manner of DAPG (Rajeswaran et al., 2018): after
every rollout, before PPO's own update, as many epochs of minibatch gradient steps as PPO's on

    weight(t) * mean over live slots of |mu(o) - a_expert(o)|^2

with ``mu(o)`` the policy's mean action and ``a_expert(o)`` the VCS expert's action for the state the
slot observed (:meth:`agents.vec_env.NavVecEnv.expert_actions`, recorded as the rollout is collected,
padding slots left out), and ``weight(t)`` falling linearly to zero at ``--guide-anneal`` timesteps
(:func:`annealed`). Once the weight is zero the run is plain PPO.

:class:`JumpStart` is jump-start RL (Uchendu et al., 2023): the expert drives the first steps of each
training episode, up to a share of half the step limit that falls linearly from ``--guide-weight``
(at most 1) to zero at ``--guide-anneal`` timesteps, and the policy takes over from the state the
expert left (:class:`agents.vec_env.NavVecEnv`, ``jump_share``): a curriculum that starts near the
goal and moves back to the start.
"""

from __future__ import annotations

from typing import Any

import numpy as np

GUIDES = ("none", "imitation_loss", "jump_start")
"""Guidance methods of ``--guide``."""


def annealed(weight: float, anneal: int, timesteps: int) -> float:
    """``weight`` falling linearly to 0 at ``anneal`` timesteps, 0 after; ``weight`` itself when
    ``anneal`` is 0 (no annealing)."""
    return weight if anneal <= 0 else weight * max(0.0, 1.0 - timesteps / anneal)


class ImitationLoss:
    """The auxiliary imitation loss (module docstring).

    Args:
        weight: its weight at step 0.
        anneal: timesteps at which the weight reaches 0 (0: constant).
        batch_size: minibatch size of its gradient steps (PPO's).
        seed: seeds the minibatch order (with the timestep, so a run is reproducible).
    """

    def __init__(self, weight: float, anneal: int, batch_size: int, seed: int):
        self.weight, self.anneal, self.batch_size, self.seed = float(weight), int(anneal), int(batch_size), int(seed)
        self.expert: list[np.ndarray] = []
        self.live: list[np.ndarray] = []

    def rollout_start(self, venv, timesteps: int) -> None:
        """A rollout starts from ``venv``'s current observations: record their expert actions."""
        self.expert, self.live = [venv.expert_actions()], [venv.live_mask()]

    def step(self, venv) -> None:
        """``venv`` stepped: record the expert actions of its new observations."""
        self.expert.append(venv.expert_actions())
        self.live.append(venv.live_mask())

    def update(self, model, timesteps: int) -> dict[str, Any]:
        """PPO's ``n_epochs`` epochs of imitation steps on ``model``'s rollout buffer; the weight and the mean loss."""
        import torch

        weight = annealed(self.weight, self.anneal, timesteps)
        buffer = model.rollout_buffer
        steps = buffer.buffer_size
        if weight == 0.0 or len(self.expert) < steps:
            return {"weight": weight, "loss": float("nan")}
        obs = buffer.observations.reshape(steps * buffer.n_envs, -1)
        expert = np.stack(self.expert[:steps]).reshape(-1, 2)
        live = np.flatnonzero(np.stack(self.live[:steps]).reshape(-1))
        rng = np.random.default_rng([self.seed, timesteps])
        order = np.concatenate([rng.permutation(live) for _ in range(model.n_epochs)])
        policy, losses = model.policy, []
        policy.set_training_mode(True)
        for start in range(0, len(order), self.batch_size):
            rows = order[start : start + self.batch_size]
            o = torch.as_tensor(obs[rows], device=policy.device)
            mean = policy.get_distribution(o).distribution.mean
            loss = ((mean - torch.as_tensor(expert[rows], device=policy.device)) ** 2).sum(-1).mean()
            policy.optimizer.zero_grad()
            (weight * loss).backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), model.max_grad_norm)
            policy.optimizer.step()
            losses.append(float(loss.detach()))
        return {"weight": weight, "loss": float(np.mean(losses)) if losses else float("nan")}


class JumpStart:
    """Jump-start rollouts (module docstring).

    Args:
        share: the share of half the step limit the expert may drive at step 0 (at most 1).
        anneal: timesteps at which the share reaches 0.
    """

    def __init__(self, share: float, anneal: int):
        if anneal <= 0:
            raise ValueError("--guide jump_start needs --guide-anneal, the step at which the expert stops driving")
        self.share, self.anneal, self.current = min(1.0, float(share)), int(anneal), 0.0

    def rollout_start(self, venv, timesteps: int) -> None:
        """Set the share of the episodes that start from now on in every group of ``venv``."""
        self.current = annealed(self.share, self.anneal, timesteps)
        for group in venv.groups:
            group.jump_share = self.current

    def step(self, venv) -> None:
        """Nothing to record per step."""

    def update(self, model, timesteps: int) -> dict[str, Any]:
        """The share the rollout ran with."""
        return {"share": self.current}
