"""The world state: a struct of flat arrays with a leading batch axis ``B`` (worlds).

``n`` robots, ``m`` obstacles and ``s`` wall segments per world. Robots that finish are masked (``active``), never
deleted. Planners read this (privileged) state; learned policies see observations.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
from dataclasses import dataclass

import numpy as np
from numba import njit

from .checks import A_REF, LEAST_LIMIT, OMEGA_REF, R_REF, V_REF, check_range
from .geometry import unit


@dataclass
class WorldState:
    """State of ``B`` worlds at one instant. Shapes in the comments; units in brackets.

    Robots may be moved by hand between steps; walls are static between resets (the simulator
    keeps each robot's nearby wall segments from step to step): change them through
    :meth:`vcs_env.sim.Simulator.reset`, or by replacing the segment arrays, not in place."""

    time: np.ndarray  # (B,) elapsed time [s]
    steps: np.ndarray  # (B,) int, steps taken
    key: np.ndarray  # (B,) uint64, per-episode random key for planners (vcs_env.noise)
    pos: np.ndarray  # (B, n, 2) robot centres [m]
    heading: np.ndarray  # (B, n) heading = direction of motion [rad]
    speed: np.ndarray  # (B, n) speed >= 0 [m/s]
    radius: np.ndarray  # (B, n) [m]
    goal: np.ndarray  # (B, n, 2) [m]
    v_max: np.ndarray  # (B, n) [m/s]
    a_max: np.ndarray  # (B, n) [m/s^2]
    omega_max: np.ndarray  # (B, n) [rad/s]
    active: np.ndarray  # (B, n) bool: still driving (not arrived, not stopped by a crash)
    present: np.ndarray  # (B, n) bool: physically in the world (parked robots are present)
    reached: np.ndarray  # (B, n) bool: has arrived
    collided: np.ndarray  # (B, n) bool: has touched something at least once
    obs_pos: np.ndarray  # (B, m, 2) obstacle centres [m]
    obs_vel: np.ndarray  # (B, m, 2) obstacle velocity over the last step [m/s]
    obs_radius: np.ndarray  # (B, m) [m]
    dt: float  # step [s]
    r_goal: float  # arrival radius [m]
    r_ca: float  # sensing radius [m]
    holonomic: bool  # robots are holonomic (else unicycle)
    seg_a: np.ndarray | None = None  # (B, s, 2) wall segment start points [m] (vcs_env.walls); None: no walls
    seg_b: np.ndarray | None = None  # (B, s, 2) wall segment end points [m]
    seg_present: np.ndarray | None = None  # (B, s) bool: segment k exists in world b
    bounce_half: float | None = None  # obstacles reflect off the arena's edges at +-bounce_half [m]; None: no edges
    clock: np.ndarray | None = None  # (B, n, 6) stall clock (vcs_env.stall, Scenario.stall_clock); None: not kept

    def __post_init__(self) -> None:
        if self.seg_a is None:
            B = self.pos.shape[0]
            self.seg_a, self.seg_b = np.zeros((B, 0, 2)), np.zeros((B, 0, 2))
            self.seg_present = np.zeros((B, 0), dtype=bool)

    def check_shapes(self) -> None:
        """A ``ValueError`` naming the first array field whose shape does not fit the others: ``pos`` ``(B, n, 2)``
        sets ``B`` and ``n``, ``obs_pos`` ``(B, m, 2)`` sets ``m`` and ``seg_present`` ``(B, s)`` sets ``s`` (the
        other shapes in the field comments). The compiled kernels index every array by these sizes, so a field
        replaced by hand with another shape would be read past its end. About a microsecond: the simulator's
        step and the VCS planner's plan check it every time (robots may be moved by hand between steps)."""
        try:
            clock = None if self.clock is None else self.clock.shape
            sizes = (*self.pos.shape[:2], self.obs_pos.shape[1], self.seg_present.shape[1], clock is not None)
            if [a.shape for a in _ARRAYS(self)] + [clock] == _wanted(sizes):
                return
        except (AttributeError, IndexError):
            pass
        for name in ("pos", "obs_pos", "seg_present"):  # the sizes
            value = getattr(self, name)
            if not isinstance(value, np.ndarray) or value.ndim != len(_SHAPES[name]):
                raise ValueError(f"WorldState.{name} must be an array of shape {_SIZED[name]}, got {_described(value)}")
        sizes = (*self.pos.shape[:2], self.obs_pos.shape[1], self.seg_present.shape[1])
        dims = dict(zip("Bnms", sizes), **{"2": 2, "6": 6})
        for name in _FIELDS + (("clock",) if self.clock is not None else ()):
            value, want = getattr(self, name), tuple(dims[c] for c in _SHAPES[name])
            if not isinstance(value, np.ndarray) or value.shape != want:
                raise ValueError(
                    f"WorldState.{name} must be an array of shape {want}, got {_described(value)} (B={sizes[0]} worlds "
                    f"and n={sizes[1]} robots from pos {self.pos.shape}, m={sizes[2]} obstacles from obs_pos, "
                    f"s={sizes[3]} wall segments from seg_present)"
                )

    def check_limits(self) -> None:
        """A ``ValueError`` naming the step or the first robot limit outside the ranges a
        :class:`~vcs_env.scenario.Scenario` allows: ``dt`` in [0.001, 1] s, each robot's ``v_max`` in (0, 3] m/s,
        ``a_max`` in [0.001, 10] m/s^2, ``omega_max`` in [0.001, 2 pi] rad/s and ``radius`` in (0, 2] m, every one
        finite. The planners divide by them and count steps of them (a zero ended in a ZeroDivisionError inside a
        kernel, a NaN in NaN actions), so they check it on every plan, as :meth:`check_shapes` (fields may be replaced
        by hand). About a microsecond."""
        check_range("WorldState.dt [s]", self.dt, LEAST_LIMIT, 1.0)
        b, i, f = _first_out_of_range(self.v_max, self.a_max, self.omega_max, self.radius, LEAST_LIMIT, *_TOPS)
        if f >= 0:
            name, lo = _LIMITS[f]
            got = float(getattr(self, name)[b, i])
            raise ValueError(f"WorldState.{name}[{b}, {i}] must be a finite number in {lo}, {_TOPS[f]}], got {got!r}")

    def saved_arrays(self) -> dict[str, np.ndarray]:
        """The per-world arrays a saved state holds (:mod:`vcs_env.start_states`): :meth:`arrays` without
        the stall clock (a restored world starts a new clock, as the expert's memory starts afresh when a world
        jumps, so the two stay in step)."""
        return {f: v for f, v in self.arrays().items() if f != "clock"}

    @property
    def batch_size(self) -> int:
        return self.pos.shape[0]

    @property
    def n_robots(self) -> int:
        return self.pos.shape[1]

    @property
    def n_obstacles(self) -> int:
        return self.obs_pos.shape[1]

    @property
    def n_segments(self) -> int:
        """Wall segments per world (some may be absent, ``seg_present``)."""
        return self.seg_present.shape[1]

    @property
    def vel(self) -> np.ndarray:
        """Robot velocities ``(B, n, 2)`` [m/s]."""
        return self.speed[..., None] * unit(self.heading)

    def arrays(self) -> dict[str, np.ndarray]:
        """The per-world arrays, ``{field: (B, ...)}`` (the other fields are constants of the scenario)."""
        return {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if isinstance(getattr(self, f.name), np.ndarray)
        }

    def copy(self) -> WorldState:
        """A deep copy (arrays copied)."""
        return dataclasses.replace(self, **{f: v.copy() for f, v in self.arrays().items()})

    def world(self, b: int) -> WorldState:
        """World ``b`` alone, as a batch of one (arrays copied)."""
        return dataclasses.replace(self, **{f: v[b : b + 1].copy() for f, v in self.arrays().items()})


_LIMITS = (("v_max", "(0"), ("a_max", f"[{LEAST_LIMIT}"), ("omega_max", f"[{LEAST_LIMIT}"), ("radius", "(0"))
_TOPS = (V_REF, A_REF, OMEGA_REF, R_REF)
"""The robot limits :meth:`WorldState.check_limits` checks, each with the bound it gives below and above."""


@njit(cache=True)
def _first_out_of_range(v_max, a_max, omega_max, radius, least, v_top, a_top, omega_top, r_top):
    """``(b, i, f)`` of the first robot ``i`` of world ``b`` whose limit ``f`` (an index of ``_LIMITS``) is out of its
    range (NaN is), or ``f = -1`` when none is."""
    B, n = v_max.shape
    for b in range(B):
        for i in range(n):
            if not 0.0 < v_max[b, i] <= v_top:
                return b, i, 0
            if not least <= a_max[b, i] <= a_top:
                return b, i, 1
            if not least <= omega_max[b, i] <= omega_top:
                return b, i, 2
            if not 0.0 < radius[b, i] <= r_top:
                return b, i, 3
    return 0, 0, -1


_SHAPES = {
    "pos": "Bn2", "obs_pos": "Bm2", "seg_present": "Bs", "time": "B", "steps": "B", "key": "B", "heading": "Bn",
    "speed": "Bn", "radius": "Bn", "goal": "Bn2", "v_max": "Bn", "a_max": "Bn", "omega_max": "Bn", "active": "Bn",
    "present": "Bn", "reached": "Bn", "collided": "Bn", "obs_vel": "Bm2", "obs_radius": "Bm", "seg_a": "Bs2",
    "seg_b": "Bs2", "clock": "Bn6",
}  # fmt: skip
"""The shape of each array field (:meth:`WorldState.check_shapes`): ``B`` worlds, ``n`` robots, ``m`` obstacles, ``s``
wall segments; ``2`` a point's coordinates, ``6`` the stall clock's entries."""
_FIELDS = tuple(_SHAPES)[:-1]
"""The fields :meth:`WorldState.check_shapes` compares (the clock, which may be None, apart)."""
_ARRAYS = operator.attrgetter(*_FIELDS)
_SIZED = {"pos": "(B, n, 2)", "obs_pos": "(B, m, 2)", "seg_present": "(B, s)"}


@functools.cache
def _wanted(sizes: tuple[int, int, int, int, bool]) -> tuple:
    """The shapes of :data:`_FIELDS` for sizes ``(B, n, m, s, a clock is kept)``, then the clock's (None: not kept)."""
    dims = dict(zip("Bnms", sizes[:4]), **{"2": 2, "6": 6})
    return [*(tuple(dims[c] for c in _SHAPES[f]) for f in _FIELDS), (*sizes[:2], 6) if sizes[4] else None]


def _described(value) -> str:
    """``value`` in an error message: an array's shape, else its type."""
    return f"shape {value.shape}" if isinstance(value, np.ndarray) else f"a {type(value).__name__}"
