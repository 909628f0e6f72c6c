"""Expert guidance for PPO beside the shaping terms: an auxiliary imitation loss (``--guide imitation_loss``)
and jump-start rollouts (``--guide jump_start``).

:class:`ImitationLoss` is expert-regularised PPO in the manner of DAPG (Rajeswaran et al., 2018): every
gradient step of PPO's update on a rollout also descends

    weight(t) * mean over a minibatch of the rollout's live slots of |mu(o) - a_expert(o)|^2

with ``mu(o)`` the policy's mean action and ``a_expert(o)`` the VCS expert's action for the state the
slot observed (:meth:`agents.vec_env.NavVecEnv.expert_actions`, recorded as the rollout is collected,
padding slots left out), and ``weight(t)`` falling linearly to zero at ``--guide-anneal`` timesteps
(:func:`annealed`). The two gradients are summed, each clipped to PPO's ``max_grad_norm``, before the
optimiser's step (DAPG clips the sum once): while the weighted imitation gradient is longer than the clip,
its share of the step is that of PPO's clipped gradient whatever the weight, so the weight and its anneal
act as that gradient falls below the clip. Once the weight is zero the run is plain PPO. (Imitation steps
of their own before PPO's update do not hold: PPO's clipped ratios pull the policy back to the rollout's actions, and on
circle-16 the error on the rollout's states came back from 0.45 to 1.74 of 1.86; summed into PPO's steps
it ends at 0.46.)

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
        self.losses: list[float] = []
        self._optimizer = None

    def rollout_start(self, venv, timesteps: int) -> None:
        """A rollout starts from ``venv``'s current observations: PPO's update is over, so the loss
        leaves its optimiser; record the new observations' expert actions."""
        self.finish()
        self.expert, self.live = [venv.expert_actions()], [venv.live_mask()]

    def step(self, venv) -> None:
        """``venv`` stepped: record the expert actions of its new observations."""
        self.expert.append(venv.expert_actions())
        self.live.append(venv.live_mask())

    def finish(self) -> None:
        """Take the loss out of PPO's optimiser (after its update on a rollout, or at the end of training)."""
        if self._optimizer is not None:
            del self._optimizer.step  # the instance attribute; the class's step is back
            self._optimizer = None

    def update(self, model, timesteps: int) -> dict[str, Any]:
        """At a rollout's end, before PPO's update on it: every step of ``model``'s optimiser until
        :meth:`finish` also descends the weighted loss on a minibatch of the rollout's live states, at the weight
        annealed to ``timesteps``, the step count at the rollout's start (the first rollout has the full weight;
        with the count at its end, an anneal within one rollout never applied the loss).
        Returns the weight and the mean loss over the previous update's steps."""
        import torch

        self.finish()
        mean = float(np.mean(self.losses)) if self.losses else float("nan")
        done = {"weight": annealed(self.weight, self.anneal, timesteps), "loss": mean}
        self.losses = []
        buffer, weight = model.rollout_buffer, done["weight"]
        steps = buffer.buffer_size
        live = np.flatnonzero(np.stack(self.live[:steps]).reshape(-1)) if len(self.expert) >= steps else []
        if weight == 0.0 or len(live) == 0:
            return done
        obs = torch.as_tensor(buffer.observations.reshape(steps * buffer.n_envs, -1)[live], device=model.device)
        expert = torch.as_tensor(np.stack(self.expert[:steps]).reshape(-1, 2)[live], device=model.device)
        rng = np.random.default_rng([self.seed, timesteps])
        order, at = rng.permutation(len(live)), 0
        policy, optimizer = model.policy, model.policy.optimizer
        params = [p for p in policy.parameters() if p.requires_grad]
        ppo_step = optimizer.step

        def step(*args, **kwargs):
            nonlocal order, at
            if at + self.batch_size > len(order):
                order, at = np.concatenate([order[at:], rng.permutation(len(live))]), 0
            rows = torch.as_tensor(order[at : at + self.batch_size])
            at += self.batch_size
            ppo_grads = [p.grad for p in params]
            for p in params:
                p.grad = None
            loss = ((policy.get_distribution(obs[rows]).distribution.mean - expert[rows]) ** 2).sum(-1).mean()
            (weight * loss).backward()
            torch.nn.utils.clip_grad_norm_(params, model.max_grad_norm)
            for p, g in zip(params, ppo_grads):
                p.grad = g if p.grad is None else p.grad if g is None else p.grad + g
            self.losses.append(float(loss.detach()))
            return ppo_step(*args, **kwargs)

        optimizer.step, self._optimizer = step, optimizer
        return done


class JumpStart:
    """Jump-start rollouts (module docstring).

    Args:
        share: the share of half the step limit the expert may drive at step 0 (at most 1).
        anneal: timesteps at which the share reaches 0.
    """

    def __init__(self, share: float, anneal: int):
        if anneal <= 0:
            raise ValueError("--guide jump_start needs --guide-anneal, the step at which the expert stops driving")
        if not 0.0 < float(share) <= 1.0:  # a share; above 1 it was capped silently, the record saying otherwise
            raise ValueError(f"--guide-weight of jump_start is a share of half the step limit, in (0, 1], got {share}")
        self.share, self.anneal, self.current = float(share), int(anneal), 0.0

    def rollout_start(self, venv, timesteps: int) -> None:
        """Set the share of the episodes that start from now on in every group of ``venv``."""
        self.current = annealed(self.share, self.anneal, timesteps)
        for group in venv.groups:
            group.jump_share = self.current

    def step(self, venv) -> None:
        """Nothing to record per step."""

    def finish(self) -> None:
        """Nothing to take out after PPO's update."""

    def update(self, model, timesteps: int) -> dict[str, Any]:
        """The share the rollout ran with."""
        return {"share": self.current}
