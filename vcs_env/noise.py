"""Counter-based random numbers for planners: a pure function of (world key, step, index).

Planners must not keep random state of their own: their output must depend only on the world
state, so that stepping B worlds together equals stepping them one by one, and replaying a
snapshot gives the same plan. Each world draws a 64-bit ``key`` from its generator at reset
(``WorldState.key``); a planner derives its numbers from that key, the world's step count and
the robot index with the splitmix64 mixer.
"""

from __future__ import annotations

import numpy as np

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)


def _mix(z: np.ndarray) -> np.ndarray:
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


def uniform(key: np.ndarray, steps: np.ndarray, n: int, stream: int = 0) -> np.ndarray:
    """Uniform numbers in [0, 1) of shape ``(B, n)``.

    Args:
        key: per-world keys ``(B,)`` uint64.
        steps: per-world step counts ``(B,)``.
        n: numbers per world (usually one per robot).
        stream: separates independent uses within one planner.
    """
    with np.errstate(over="ignore"):
        counter = (
            steps.astype(np.uint64)[:, None] * np.uint64(1 << 20)
            + np.arange(n, dtype=np.uint64)[None, :] * np.uint64(64)
            + np.uint64(stream)
        )
        z = _mix(key.astype(np.uint64)[:, None] + (counter + np.uint64(1)) * _GOLDEN)
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)
