"""SB3 ``VecEnv`` over a Gymnasium ``VectorEnv`` (Gymnasium 1.x API, ``NEXT_STEP`` autoreset).

SB3 expects a finished env to be reset within the same ``step`` (its observation is then the
new episode's first, the last one in ``info["terminal_observation"]``); Gymnasium's default
``NEXT_STEP`` autoreset returns the last observation and resets on the following step. The
adapter closes the gap with ``reset(options={"reset_mask": done})`` right after a step that
ended some envs, which our :class:`~vcs_env.gym_env.VcsNavVectorEnv` and Gymnasium's
``SyncVectorEnv`` / ``AsyncVectorEnv`` support. The result equals SB3's ``DummyVecEnv`` over the
single envs (same seeds, same actions, same numbers)::

    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor
    from agents.gym_vec import GymVectorToSB3

    venv = VecMonitor(GymVectorToSB3(gym.make_vec("vcs_env/Navigation-v2", num_envs=64,
                                                   vectorization_mode="vector_entry_point")))
    PPO("MlpPolicy", venv).learn(100_000)

``info`` per env: ``terminal_observation`` and ``TimeLimit.truncated`` on the step an episode
ends (wrap in ``VecMonitor`` for episode returns and lengths); the vector env's own batched
info is not unpacked. Keep episode statistics outside the adapter (``VecMonitor``), not inside
it: Gymnasium's ``SyncVectorEnv`` and ``AsyncVectorEnv`` take ``reset_mask`` out of the reset's
options, so its vector ``RecordEpisodeStatistics`` between them and the adapter never sees the
mask and restarts every env's totals at each reset.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from vcs_env.checks import missing_extra

try:
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn
except ImportError as e:  # a bare "No module named 'stable_baselines3'" named no extra
    raise ImportError(missing_extra(e)) from e


class GymVectorToSB3(VecEnv):
    """Adapt a Gymnasium ``VectorEnv`` with ``NEXT_STEP`` autoreset and ``reset_mask`` support
    to SB3 (module docstring).

    Args:
        env: the vector env, e.g. ``gym.make_vec(id, num_envs, vectorization_mode="vector_entry_point")``.
    """

    def __init__(self, env: VectorEnv):
        mode = env.metadata.get("autoreset_mode")
        if mode != AutoresetMode.NEXT_STEP:
            raise ValueError(f"GymVectorToSB3 needs a vector env with AutoresetMode.NEXT_STEP, got {mode!r}")
        self.env = env
        self.render_mode = None
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        """Reset every env; a pending ``seed(s)`` seeds env ``i`` with ``s + i``, and pending
        ``set_options(options)`` go to the vector env's ``reset`` (one dict for all envs)."""
        seeds = None if self._seeds[0] is None else [int(s) for s in self._seeds]
        options = self._options[0] if self._options else {}
        if any(o != options for o in self._options):
            raise ValueError("GymVectorToSB3 passes one options dict to the vector env's reset; got one per env")
        obs, _ = self.env.reset(seed=seeds, options=options or None)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        obs, reward, terminated, truncated, _ = self.env.step(self._actions)
        self._actions = None
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if done.any():
            for i in np.flatnonzero(done):
                infos[i] = {
                    "terminal_observation": obs[i].copy(),
                    "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                }
            new_obs, _ = self.env.reset(options={"reset_mask": done})
            obs = np.where(done.reshape(-1, *([1] * (obs.ndim - 1))), new_obs, obs)
        return obs, reward.astype(np.float32), done, infos

    def close(self) -> None:
        self.env.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs

    # Attribute access goes to the one vector env.
    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        return [getattr(self.env, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.env, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices: VecEnvIndices = None, **method_kwargs) -> list[Any]:
        method = getattr(self.env, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]
