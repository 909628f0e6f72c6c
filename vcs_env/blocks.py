"""Observation layouts: a robot's observation vector as a sequence of named blocks (:class:`Block`, :class:`Layout`).

:func:`vcs_env.observations.observation_layout` gives a scenario's layout; everything that reads an observation
(the policy's feature encoders, the shield, the ONNX export) takes its offsets from there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Block:
    """One block of a robot's observation: ``items`` slots of ``len(fields)`` floats each."""

    name: str
    """``ego``, ``neighbors``, ``lidar``, ``wall_points`` or ``clock``."""
    items: int
    """Slots (1 for ``ego``, one per beam for ``lidar``)."""
    fields: tuple[str, ...]
    """Names of the features of one slot."""
    low: tuple[float, ...]
    """Lower bound of each field (every upper bound is 1)."""
    scale: str
    """Physical scales of the fields (module docstring)."""
    encodes: str
    """What the block encodes."""

    @property
    def item_dim(self) -> int:
        """Floats per slot."""
        return len(self.fields)

    @property
    def size(self) -> int:
        """Floats in the block."""
        return self.items * self.item_dim

    def describe(self) -> dict:
        """What fixes the block's meaning: name, items and fields (JSON-ready)."""
        return {"name": self.name, "items": self.items, "fields": list(self.fields)}


@dataclass(frozen=True)
class Layout:
    """A robot's observation vector as a sequence of :class:`Block` (:func:`observation_layout`)."""

    version: int
    blocks: tuple[Block, ...]

    @property
    def dim(self) -> int:
        """Length D of one robot's observation."""
        return sum(b.size for b in self.blocks)

    def __contains__(self, name: str) -> bool:
        return any(b.name == name for b in self.blocks)

    def block(self, name: str) -> Block:
        """The block called ``name``; ``KeyError`` naming the blocks there are otherwise."""
        for b in self.blocks:
            if b.name == name:
                return b
        raise KeyError(f"observation v{self.version} has no block {name!r}; it has {[b.name for b in self.blocks]}")

    def span(self, name: str) -> slice:
        """Columns of block ``name`` in the observation vector."""
        at = 0
        for b in self.blocks:
            if b.name == name:
                return slice(at, at + b.size)
            at += b.size
        self.block(name)  # raises, naming the blocks
        raise AssertionError

    def read(self, obs, name: str):
        """Block ``name`` of observations ``(..., D)`` as ``(..., items, item_dim)`` (numpy or torch)."""
        b = self.block(name)
        return obs[..., self.span(name)].reshape(*obs.shape[:-1], b.items, b.item_dim)

    def columns_of(self, other: Layout) -> np.ndarray:
        """The columns ``(other.dim,)`` of this layout's observations that hold ``other``'s, field by field: an
        observation of this layout, indexed with them, reads as one of ``other`` (e.g. wall points with their
        segment fields read as wall points without). ``ValueError`` naming the first block or field of ``other``
        that is not here (or has another item count)."""
        cols = []
        for b in other.blocks:
            mine = self.block(b.name) if b.name in self else None
            if mine is None or mine.items != b.items or not set(b.fields) <= set(mine.fields):
                have = "none" if mine is None else f"{mine.items} items of {list(mine.fields)}"
                raise ValueError(
                    f"observation block {b.name!r} ({b.items} items of {list(b.fields)}) cannot be read from this "
                    f"layout's (it has {have})"
                )
            start = self.span(b.name).start
            for item in range(b.items):
                cols += [start + item * mine.item_dim + mine.fields.index(f) for f in b.fields]
        return np.asarray(cols, dtype=np.int64)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds ``(D,)`` float32."""
        low = np.concatenate([np.tile(np.asarray(b.low, dtype=np.float32), b.items) for b in self.blocks])
        return low, np.ones(self.dim, dtype=np.float32)
