"""The periodic evaluation of ``vcs-env train --backend benchmarl`` as a BenchMARL ``Callback`` (imports
BenchMARL; BenchMARL pickles an experiment's callbacks, so the class lives at module level)."""

from __future__ import annotations

from collections.abc import Callable

from benchmarl.experiment.callback import Callback

from vcs_env.scenario import Scenario

from ..checkpoint import BenchMARLPolicy
from .periodic import PeriodicEval


class Evaluate(Callback):
    """Run ``evaluator`` after each update that crosses a multiple of its ``eval_freq`` timesteps (robot steps:
    BenchMARL's frames, world steps, times ``n_robots``) on the policy network ``extract(policy, scenario)`` gives
    (:func:`agents.train.benchmarl.actor_network`)."""

    def __init__(self, evaluator: PeriodicEval, scenario: Scenario, name: str, extract: Callable):
        super().__init__()
        self.evaluator, self.scenario, self.name, self.extract = evaluator, scenario, name, extract
        self.n_robots = scenario.n_robots
        self.next_eval = evaluator.cfg.eval_freq

    def on_train_end(self, training_td, group: str) -> None:
        steps, freq = self.experiment.total_frames * self.n_robots, self.evaluator.cfg.eval_freq
        if freq > 0 and steps >= self.next_eval:
            self.next_eval = (steps // freq + 1) * freq
            net, layout = self.extract(self.experiment.policy, self.scenario)
            self.evaluator(BenchMARLPolicy(net, layout, name=self.name), steps)
