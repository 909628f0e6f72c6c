"""RLlib's torch PPO learner with SB3's update (imported by the learner of ``--backend rllib``).

Two differences from RLlib's ``PPOTorchLearner``, both SB3's choices:

* advantages are normalized per minibatch over its real robot steps (RLlib normalizes once over
  the whole train batch, including the masked bootstrap step it appends to every episode chunk,
  whose advantage runs into the next chunk's first value);
* Adam's ``eps`` is 1e-5 (torch's default 1e-8).
"""

from __future__ import annotations

import torch
from ray.rllib.algorithms.ppo.torch.ppo_torch_learner import PPOTorchLearner
from ray.rllib.core.columns import Columns
from ray.rllib.evaluation.postprocessing import Postprocessing

ADAM_EPS = 1e-5
"""Adam's epsilon (SB3's PPO default)."""


def normalized_advantages(advantages: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
    """``(A - mean) / (std + 1e-8)`` with mean and std over the rows where ``mask`` is True
    (all rows if ``mask`` is None), as SB3 normalizes each minibatch; shape unchanged. With fewer
    than 2 such rows the advantages are returned as they are (SB3's rule; the std is undefined)."""
    valid = advantages if mask is None else advantages[mask]
    if valid.numel() < 2:
        return advantages
    return (advantages - valid.mean()) / (valid.std() + 1e-8)


class SB3PPOLearner(PPOTorchLearner):
    """``PPOTorchLearner`` with per-minibatch advantage normalization and Adam eps 1e-5."""

    def configure_optimizers_for_module(self, module_id, config=None) -> None:
        params = self.get_parameters(self._module[module_id])
        optimizer = torch.optim.Adam(params, eps=ADAM_EPS)
        self.register_optimizer(module_id=module_id, optimizer=optimizer, params=params, lr_or_lr_schedule=config.lr)

    def _make_batch_if_necessary(self, training_data):
        batch = super()._make_batch_if_necessary(training_data=training_data)
        if batch is not None and self.config.shuffle_batch_per_epoch:  # also before the first epoch
            for module_batch in batch.policy_batches.values():
                module_batch.shuffle()
        return batch

    def compute_loss_for_module(self, *, module_id, config, batch, fwd_out):
        batch = dict(batch)
        key = Postprocessing.ADVANTAGES
        mask = batch.get(Columns.LOSS_MASK)
        batch[key] = normalized_advantages(batch[key], mask)
        with torch.no_grad():  # SB3's diagnostics of the update
            module = self.module[module_id].unwrapped()
            dist = module.get_train_action_dist_cls().from_logits(fwd_out[Columns.ACTION_DIST_INPUTS])
            log_ratio = dist.logp(batch[Columns.ACTIONS]) - batch[Columns.ACTION_LOGP]
            if mask is not None:
                log_ratio = log_ratio[mask]
            approx_kl = ((log_ratio.exp() - 1) - log_ratio).mean()
            clip_fraction = ((log_ratio.exp() - 1).abs() > config.clip_param).float().mean()
        self.metrics.log_dict({"approx_kl": approx_kl, "clip_fraction": clip_fraction}, key=module_id, window=1)
        return super().compute_loss_for_module(module_id=module_id, config=config, batch=batch, fwd_out=fwd_out)
