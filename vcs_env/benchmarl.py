"""BenchMARL tasks over :class:`vcs_env.torchrl.VcsNavEnv`: MAPPO, IPPO, MASAC ... on the batched engine.

The only module of ``vcs_env`` that imports ``benchmarl`` (the ``benchmarl`` extra and one more command, see
``docs/torchrl.md``); ``import vcs_env`` does not load it. A task is one scenario: a preset or suite name
(``circle-8-v0``) or a :class:`~vcs_env.scenario.Scenario`, plus Scenario fields as overrides::

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models import MlpConfig
    from vcs_env.benchmarl import VcsNavTask

    task = VcsNavTask.CIRCLE.get_task()  # circle-8-v0's scenario, or with a config:
    task = VcsNavTask.CIRCLE.get_task({"scenario": "circle-16-v0", "on_collision": "terminate"})
    config = ExperimentConfig.get_from_yaml()
    config.loggers = ["csv"]  # BenchMARL's default also logs to wandb, which the extra does not install
    Experiment(task, MappoConfig.get_from_yaml(), MlpConfig.get_from_yaml(), seed=0, config=config,
               critic_model_config=MlpConfig.get_from_yaml()).run()

Every robot is one agent of the group ``"agents"``; the policy reads ``("agents", "observation")`` only (the
env's ``mask``, ``info`` and ``expert_action`` are left out of the model's inputs). A world resets when all its
robots are done; a robot that finished earlier keeps a zero observation and zero reward until then.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

from .checks import missing_extra

try:
    from benchmarl.environments.common import Task, TaskClass
    from torchrl.data import Composite
    from torchrl.envs import EnvBase
except ImportError as e:  # a bare "No module named 'benchmarl'" named no extra
    raise ImportError(missing_extra(e, "benchmarl")) from e

from .scenario import Scenario
from .torchrl import GROUP, VcsNavEnv

DEFAULTS: dict[str, str] = {
    "circle": "circle-8-v0",
    "crowd": "crowd-5-v0",
    "dynamic": "dynamic-v0",
    "doorway": "doorway-v0",
}
"""The scenario of each task of :class:`VcsNavTask` when its config names none (a suite's scenario)."""
KEYS = ("scenario", "max_steps", "action_mode", "expert", "gamma")
"""Task config entries that are not Scenario fields (those of :class:`~vcs_env.torchrl.VcsNavEnv`; ``gamma`` is the
discount of the ``vcs_potential`` shaping, which should be the algorithm's: ``vcs-env train`` passes ``--gamma``)."""


def task_scenario(config: dict[str, Any], name: str) -> Scenario:
    """The scenario of a task config: ``config["scenario"]`` (a suite or preset name, or a Scenario; default: the
    task's suite, :data:`DEFAULTS`) with every other entry but :data:`KEYS` as a Scenario field."""
    from .scenario import make_scenario

    base = config.get("scenario", DEFAULTS.get(name.lower()))
    if base is None:
        raise ValueError(f"task {name!r} needs a 'scenario' in its config (a suite or preset name, or a Scenario)")
    over = {k: v for k, v in config.items() if k not in KEYS}
    return make_scenario(base, **over)


def _only(env: EnvBase, key: str) -> Composite:
    """The env's unbatched observation spec with only ``("agents", key)`` in its group."""
    spec = env.full_observation_spec_unbatched.clone()
    for other in [k for k in spec[GROUP].keys() if k != key]:
        del spec[(GROUP, other)]
    return spec


class VcsNavClass(TaskClass):
    """A vcs-env scenario as a BenchMARL task (continuous actions, ``delta`` mode by default)."""

    def get_env_fun(self, num_envs: int, continuous_actions: bool, seed: int | None, device) -> Callable[[], EnvBase]:
        if not continuous_actions:
            raise ValueError("vcs-env tasks have continuous actions only; use an algorithm with continuous actions")
        config = copy.deepcopy(self.config)
        scenario = task_scenario(config, self.name)

        def make() -> VcsNavEnv:
            env = VcsNavEnv(
                scenario,
                num_envs,
                action_mode=config.get("action_mode", "delta"),
                expert=config.get("expert"),
                max_steps=config.get("max_steps"),
                gamma=config.get("gamma", 0.99),
                device=device,
            )
            if seed is not None:
                env.set_seed(seed)
            return env

        return make

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        return int(env.engine.max_steps)

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return dict(env.group_map)

    def observation_spec(self, env: EnvBase) -> Composite:
        return _only(env, "observation")

    def info_spec(self, env: EnvBase) -> Composite | None:
        return _only(env, "info")

    def state_spec(self, env: EnvBase) -> Composite | None:
        return None

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec_unbatched

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "vcs_env"


class VcsNavTask(Task):
    """vcs-env's tasks: one per scenario family, each defaulting to a suite's scenario (:data:`DEFAULTS`)."""

    CIRCLE = None
    CROWD = None
    DYNAMIC = None
    DOORWAY = None

    @staticmethod
    def associated_class():
        return VcsNavClass

    def get_task(self, config: dict[str, Any] | None = None) -> TaskClass:
        """The task with ``config`` (default ``{}``: the suite of :data:`DEFAULTS`); BenchMARL's default would
        read a yaml file of its own package, which holds no vcs-env tasks."""
        return VcsNavClass(name=self.name, config=dict(config or {}))

    def get_from_yaml(self, path: str | None = None) -> TaskClass:
        if path is None:
            return self.get_task()
        return super().get_from_yaml(path)
