"""Expert datasets: episodes played with every active robot-step labelled by the expert's action
(:func:`play`), and their ``.npz`` files (``vcs-env collect`` writes them, ``vcs-env bc`` reads them).

**Dataset** (``.npz``, written by :func:`agents.imitation.collect`, numpy only). Rows are robot-steps, grouped by
robot trajectory (one robot's part of one episode), in time order:

================== =============== ==========================================================
key                shape / dtype   meaning
================== =============== ==========================================================
observations       (N, D) float32  the robot's observation (:mod:`vcs_env.observations`)
actions            (N, 2) float32  the expert's action for that observation (delta units; a
                                   teacher network's in vcs-env distil's rounds)
rewards            (N,) float32    reward of the step taken (scenario weights, no shaping)
episode_starts     (N,) bool       first row of a trajectory
traj_start         (K + 1,) int64  trajectory k = rows traj_start[k] : traj_start[k + 1]
traj_seed          (K,) int64      reset seed of the episode the trajectory belongs to
traj_robot         (K,) int64      robot index i
traj_reached       (K,) bool       the robot arrived
traj_collided      (K,) bool       the robot touched something
traj_truncated     (K,) bool       the episode hit max_steps before the robot ended
meta               () str          JSON: format, scenario config and fields, seeds, planner,
                                   executed policy, observation_dim
================== =============== ==========================================================

In expert datasets the executed actions are the expert's; in DAgger data the executed actions
came from the learner (mixed with the expert with probability beta) and ``actions`` are still
the expert's labels for the visited states.
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vcs_env.files import replacing
from vcs_env.rollout import Hook
from vcs_env.rollout import play as play_episodes
from vcs_env.start_states import StartStates, npz_path, saved_npz

from ..mixture import mixture_split
from ..outputs import check_out_file

DATASET_FORMAT = "vcs-env-expert-v1"

Actor = Callable[[np.ndarray], np.ndarray]
"""``actor(obs (N, D) float32) -> actions (N, 2)`` (e.g. a deterministic policy)."""


def play(
    scenario,
    seeds: Sequence[int],
    actor: Actor | None = None,
    beta: float = 1.0,
    rng: np.random.Generator | None = None,
    n_worlds: int = 32,
    expert: str = "vcs",
    teacher: Actor | None = None,
    start_states: StartStates | None = None,
) -> dict[str, np.ndarray]:
    """Play one episode per seed, labelling every active robot-step with the expert's (or ``teacher``'s) action.

    Args:
        scenario: the episode family.
        seeds: one reset seed per episode.
        actor: the executed policy; None executes the expert.
        beta: per robot-step probability of executing the expert's action instead of ``actor``'s.
        rng: draws the beta mixing (needed when ``actor`` is given and ``0 < beta < 1``).
        n_worlds: worlds stepped together.
        expert: the labelling planner.
        teacher: a policy that labels instead of ``expert`` (its actions for the observations, e.g. a
            network's deterministic actions: :mod:`agents.imitation.distil`); it is also what beta executes.
        start_states: pools of saved states an episode may start from instead of its fresh layout
            (:mod:`vcs_env.start_states`; ``vcs-env distil --start-states``).

    Returns:
        The dataset arrays of the module docstring (without ``meta``).
    """
    seeds = [int(s) for s in seeds]
    rng = rng if rng is not None else np.random.default_rng(0)
    labels = ExpertLabels()

    def control(world, obs: np.ndarray) -> np.ndarray:
        B, n = world.batch_size, world.n_robots
        if teacher is not None:
            labels.current = np.asarray(teacher(obs.reshape(B * n, -1)), dtype=np.float64).reshape(B, n, 2)
        if actor is None:
            return labels.current
        own = np.asarray(actor(obs.reshape(B * n, -1)), dtype=np.float64).reshape(B, n, 2)
        return np.where((rng.random((B, n)) < beta)[..., None], labels.current, own)

    for c0 in range(0, len(seeds), n_worlds):
        play_episodes(
            scenario,
            control,
            seeds[c0 : c0 + n_worlds],
            [labels],
            expert=None if teacher is not None else expert,
            first=c0,
            start_states=start_states,
        )
    return labels.dataset()


def play_mixture(scenarios: Sequence, seeds: Sequence[int], **kwargs) -> dict[str, np.ndarray]:
    """:func:`play` over a mixture: episode ``j`` plays ``scenarios[j % len(scenarios)]`` with
    ``seeds[j]`` (as :func:`agents.evaluate.score_scenarios` scores them); the datasets of the
    scenarios follow each other. ``kwargs`` as :func:`play`."""
    return concat_datasets(*(play(sc, part, **kwargs) for sc, part in mixture_split(scenarios, seeds)))


class ExpertLabels(Hook):
    """A :class:`vcs_env.rollout.Hook` that records every acting robot-step of :func:`play`: the
    observation, the expert's action for it (``current`` before the step), the reward, and per
    robot trajectory how it ended. :meth:`dataset` orders the rows by trajectory."""

    def __init__(self) -> None:
        self.parts: dict[str, list[np.ndarray]] = {k: [] for k in ("obs", "act", "rew", "key", "step")}
        self.traj: dict[int, dict[str, Any]] = {}

    def begin(self, engine, seeds: Sequence[int], first: int) -> None:
        self.engine, self.seeds, self.first = engine, list(seeds), first
        self.current = engine.expert_action
        """``(B, n, 2)`` the expert's actions for the current state."""

    def step(self, s) -> None:
        world, res, n = self.engine.world, s.result, self.engine.world.n_robots
        b_idx, i_idx = np.nonzero(s.acting)
        self.parts["obs"].append(s.obs[b_idx, i_idx])
        self.parts["act"].append(self.current[b_idx, i_idx].astype(np.float32))
        self.parts["rew"].append(res.reward[b_idx, i_idx].astype(np.float32))
        self.parts["key"].append((self.first + b_idx) * n + i_idx)
        self.parts["step"].append(s.steps[b_idx])
        for b, i in zip(*np.nonzero(s.acting & (res.terminated | res.truncated))):
            self.traj[(self.first + b) * n + i] = {
                "seed": self.seeds[b],
                "robot": i,
                "reached": bool(world.reached[b, i]),
                "collided": bool(world.collided[b, i]),
                "truncated": bool(res.truncated[b, i]),
            }
        self.current = res.expert_action

    def dataset(self) -> dict[str, np.ndarray]:
        """The dataset arrays (module docstring), rows grouped by trajectory in time order."""
        parts = self.parts
        key = np.concatenate(parts["key"])
        order = np.lexsort((np.concatenate(parts["step"]), key))
        key = key[order]
        starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        info = [self.traj[int(k)] for k in key[starts]]
        episode_starts = np.zeros(len(key), dtype=bool)
        episode_starts[starts] = True
        return {
            "observations": np.concatenate(parts["obs"])[order].astype(np.float32),
            "actions": np.concatenate(parts["act"])[order],
            "rewards": np.concatenate(parts["rew"])[order],
            "episode_starts": episode_starts,
            "traj_start": np.r_[starts, len(key)].astype(np.int64),
            "traj_seed": np.array([t["seed"] for t in info], dtype=np.int64),
            "traj_robot": np.array([t["robot"] for t in info], dtype=np.int64),
            "traj_reached": np.array([t["reached"] for t in info], dtype=bool),
            "traj_collided": np.array([t["collided"] for t in info], dtype=bool),
            "traj_truncated": np.array([t["truncated"] for t in info], dtype=bool),
        }


def save_dataset(path: str | Path, data: dict[str, np.ndarray], meta: dict[str, Any]) -> Path:
    """Write ``data`` and ``meta`` to ``path`` and return the file written: numpy adds ``.npz`` to a
    name without it, so the returned path has it; an existing directory is refused."""
    check_out_file(str(path), "--out")  # not a directory; its parent is made
    path = npz_path(path)
    with replacing(path) as part, open(part, "wb") as f:  # a file object: numpy adds no .npz to the part's name
        np.savez_compressed(f, **data, meta=np.array(json.dumps(meta)))
    return path


def load_dataset(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``(arrays, meta)`` of a dataset (``path``, or ``path`` with ``.npz`` added, as :func:`save_dataset` and numpy
    write a name without it); ``ValueError`` naming the problem if it is not one."""
    path = saved_npz(path)
    if path.is_dir():
        raise ValueError(f"dataset {str(path)!r} is a directory; give the .npz file vcs-env collect wrote")
    if not path.is_file():
        raise ValueError(f"dataset not found: {str(path)!r} (make one with vcs-env collect)")
    if not zipfile.is_zipfile(path):  # numpy would try it as a pickle and say so
        raise ValueError(f"dataset {str(path)!r} is not a .npz file (no zip archive; make one with vcs-env collect)")
    try:
        with np.load(path, allow_pickle=False) as f:
            data = {k: f[k] for k in f.files}
    except Exception as e:
        raise ValueError(f"dataset {str(path)!r} is not a readable .npz file: {type(e).__name__}: {e}") from None
    missing = {"observations", "actions", "rewards", "traj_start", "traj_seed", "meta"} - set(data)
    if missing:
        raise ValueError(f"dataset {str(path)!r} lacks {sorted(missing)} (not a vcs-env collect dataset)")
    try:
        meta = json.loads(str(data.pop("meta")))
    except ValueError as e:
        raise ValueError(f"dataset {str(path)!r}: its meta entry is not JSON ({e})") from None
    if not isinstance(meta, dict) or meta.get("format") != DATASET_FORMAT:
        found = meta.get("format") if isinstance(meta, dict) else meta
        raise ValueError(f"dataset {str(path)!r} has format {found!r}, expected {DATASET_FORMAT!r}")
    if not isinstance(meta.get("config"), dict):  # the scenario the rows were collected on (a KeyError in bc before)
        raise ValueError(f"dataset {str(path)!r}: its meta entry holds no config (not a vcs-env collect dataset)")
    check_rows(data, f"dataset {str(path)!r}")
    return data, meta


def check_rows(data: dict[str, np.ndarray], what: str = "dataset") -> int:
    """The row count N of a dataset (module docstring) whose arrays agree; ``ValueError`` naming the
    first that does not (or N = 0)."""
    obs, start = data["observations"], np.asarray(data["traj_start"])
    n = len(obs)
    if obs.ndim != 2 or n == 0:
        raise ValueError(f"{what} holds no robot-steps (observations of shape {obs.shape}, expected (N > 0, D))")
    for key, shape in {"actions": (n, 2), "rewards": (n,), "episode_starts": (n,)}.items():
        if key in data and np.shape(data[key]) != shape:
            raise ValueError(f"{what}: {key} has shape {np.shape(data[key])}, expected {shape} (N = {n} observations)")
    if start.ndim != 1 or len(start) < 2 or start[0] != 0 or start[-1] != n or np.any(np.diff(start) < 0):
        raise ValueError(f"{what}: traj_start must rise from 0 to N = {n}, got {start[:3]}...{start[-2:]}")
    k = len(start) - 1
    for key in ("traj_seed", "traj_robot", "traj_reached", "traj_collided", "traj_truncated"):
        if key in data and np.shape(data[key]) != (k,):
            raise ValueError(f"{what}: {key} has shape {np.shape(data[key])}, expected ({k},) (one per trajectory)")
    return n


def concat_datasets(*parts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The datasets ``parts`` one after the other, in one copy (trajectory offsets shifted)."""
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k != "traj_start"}
    offsets = np.cumsum([0] + [p["traj_start"][-1] for p in parts])
    starts = [p["traj_start"][:-1] + o for p, o in zip(parts, offsets)]
    out["traj_start"] = np.concatenate(starts + [offsets[-1:]])
    return out


def discounted_returns(rewards: np.ndarray, traj_start: np.ndarray, gamma: float) -> np.ndarray:
    """Return-to-go ``(N,)`` of every row within its trajectory (0 after the last row)."""
    out = np.zeros(len(rewards), dtype=np.float64)
    for s, e in zip(traj_start[:-1], traj_start[1:]):
        g = 0.0
        for t in range(e - 1, s - 1, -1):
            g = rewards[t] + gamma * g
            out[t] = g
    return out
