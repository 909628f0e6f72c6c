"""The registered ids' entry points: one per observation version, so that the version in the id holds.

Gymnasium and PettingZoo merge the keywords a user gives into the registered ones, so an id that
registered ``observation=1`` as a keyword would build version 2 when asked ``observation=2``, under
its ``-v1`` name. Each id's entry point here fixes its version instead, and refuses another one by
name (:func:`pin_observation`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium
import numpy as np
import pettingzoo

from .gym_env import VcsNavEnv, VcsNavVectorEnv
from .parallel import VcsNavParallelEnv, raw_env

VERSIONS = (2, 1)
"""Observation versions with registered ids (``-v2``, ``-v1``)."""


def pin_observation(kwargs: dict, version: int) -> dict:
    """``kwargs`` of an env made from a ``-v{version}`` id, with ``observation = version``; a value that is no
    observation version is left for the env's own check to name.

    Raises:
        ValueError: ``kwargs`` ask for the other observation version.
    """
    given = kwargs.get("observation", version)
    if isinstance(given, bool) or not isinstance(given, (int, np.integer)) or given not in VERSIONS:
        return kwargs  # not a version at all: the scenario's check says what it must be
    if given != version:
        raise ValueError(
            f"observation={given} was given to a -v{version} id, which fixes observation version {version}: use the "
            f"-v{given} id of the same name (vcs_env/<Name>-v{given}, vcs_env/VcsNav-v{given}) and leave "
            "observation= out"
        )
    return {**kwargs, "observation": version}


def _pinned(factory: Callable[..., Any], version: int, metadata: dict) -> Callable[..., Any]:
    def make(**kwargs):
        return factory(**pin_observation(kwargs, version))

    make.metadata = metadata  # gym.make reads an entry point's render modes
    make.__doc__ = f"{getattr(factory, '__name__', 'the env')} with observation version {version}."
    return make


gym_v2 = _pinned(VcsNavEnv, 2, VcsNavEnv.metadata)
gym_v1 = _pinned(VcsNavEnv, 1, VcsNavEnv.metadata)
vector_v2 = _pinned(VcsNavVectorEnv, 2, VcsNavVectorEnv.metadata)
vector_v1 = _pinned(VcsNavVectorEnv, 1, VcsNavVectorEnv.metadata)
parallel_v2 = _pinned(VcsNavParallelEnv, 2, VcsNavParallelEnv.metadata)
parallel_v1 = _pinned(VcsNavParallelEnv, 1, VcsNavParallelEnv.metadata)
aec_v2 = _pinned(raw_env, 2, VcsNavParallelEnv.metadata)
aec_v1 = _pinned(raw_env, 1, VcsNavParallelEnv.metadata)


def register(gym_ids: dict[str, str], pz_id: str) -> None:
    """Register ``gym_ids`` (a ``-v2`` id -> its preset; the ``-v1`` twins too) with Gymnasium, and ``pz_id``
    (``-v2``) and its ``-v1`` twin with PettingZoo, each id's observation version fixed (module docstring). Ids
    already registered are left as they are."""
    for gid, preset in gym_ids.items():
        for v in VERSIONS:
            vid = gid.replace("-v2", f"-v{v}")
            if vid not in gymnasium.registry:
                gymnasium.register(
                    id=vid,
                    entry_point=f"vcs_env.registry:gym_v{v}",
                    vector_entry_point=f"vcs_env.registry:vector_v{v}",
                    kwargs={"scenario": preset},
                )
    for kind in ("parallel", "aec"):
        for v in VERSIONS:
            vid = pz_id.replace("-v2", f"-v{v}")
            if vid not in getattr(pettingzoo, f"{kind}_registry"):
                pettingzoo.register(kind, vid, entry_point=f"vcs_env.registry:{kind}_v{v}")
