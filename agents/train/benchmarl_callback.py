"""The periodic work of ``vcs-env train --backend benchmarl`` as a BenchMARL ``Callback`` (imports BenchMARL;
BenchMARL pickles an experiment's callbacks, so the class lives at module level and its tasks are picklable,
e.g. ``functools.partial`` of module-level functions)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from benchmarl.experiment.callback import Callback


class Periodic(Callback):
    """After each update, run every task ``fn(policy, timesteps)`` whose period ``freq`` (timesteps: robot steps,
    BenchMARL's frames (world steps) times ``n_robots``) the update crossed; ``freq`` 0 never runs."""

    def __init__(self, n_robots: int, tasks: Sequence[tuple[int, Callable]]):
        super().__init__()
        self.n_robots, self.tasks = n_robots, list(tasks)
        self.next = [freq for freq, _ in self.tasks]

    def on_train_end(self, training_td, group: str) -> None:
        steps = self.experiment.total_frames * self.n_robots
        for k, (freq, fn) in enumerate(self.tasks):
            if freq > 0 and steps >= self.next[k]:
                self.next[k] = (steps // freq + 1) * freq
                fn(self.experiment.policy, steps)


class LinearLR(Callback):
    """``--lr-schedule linear``: before each update, every optimizer's learning rate is ``lr * (1 - frames /
    max_n_frames)`` (SB3's linear schedule: from ``lr`` at the start to 0 at the end of the budget)."""

    def __init__(self, lr: float):
        super().__init__()
        self.lr = lr

    def on_batch_collected(self, batch) -> None:
        exp = self.experiment
        lr = self.lr * max(0.0, 1.0 - exp.total_frames / exp.config.max_n_frames)
        for optimizers in exp.optimizers.values():
            for optimizer in optimizers.values():
                for group in optimizer.param_groups:
                    group["lr"] = lr
