"""Who touched whom, and who was at fault: the contacts of a recorded episode explained.

A *contact* is the first step of an unbroken run of steps in which robot ``i`` touched one
body (the simulator's swept test, :attr:`~vcs_env.rollout.Episode.robot_hits` and
``obstacle_hits``). The other body is an active ``"robot"``, a ``"parked"`` robot (one that no
longer drives: it arrived, or stopped after a crash), an ``"obstacle"`` or a ``"wall"`` segment
(``wall_hits``; its "centre" is the point of the segment nearest the robot). The robot is **at
fault** when its own velocity over that step had a component toward the other body's centre
of more than :data:`FAULT_SPEED`, the centre as it was when the bodies first touched within the
step (:func:`first_touch`): it drove into the contact. A robot hit while standing, or while
moving away or past, is not at fault. A contact between two robots is two contacts, one per
robot; both, one or neither may be at fault.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rollout import Episode

FAULT_SPEED = 0.05
"""[m/s] speed toward the other body above which a robot is at fault for a contact."""
KINDS = ("robot", "parked", "obstacle", "wall")
"""What the robot touched."""


@dataclass(frozen=True)
class Contact:
    """One contact of robot ``robot`` (see the module docstring)."""

    step: int
    """First step of the contact (0-based: the motion from state ``step`` to ``step + 1``)."""
    robot: int
    """The robot."""
    kind: str
    """``"robot"``, ``"parked"``, ``"obstacle"`` or ``"wall"``."""
    other: int
    """Index of the other robot, obstacle or wall segment."""
    toward: float
    """The robot's speed toward the other body's centre over the first step [m/s]."""
    depth: float
    """Deepest overlap at the end of a step of the run [m] (0 for a swept graze)."""

    @property
    def at_fault(self) -> bool:
        return self.toward > FAULT_SPEED


TOUCH_SAMPLES = 257
"""Points of a step at which :func:`first_touch` measures the gap (the step's 256 parts)."""


def first_touch(p0: np.ndarray, p1: np.ndarray, radius: float, other) -> tuple[np.ndarray, np.ndarray]:
    """The robot's centre and the other body's "centre" ``(2,)`` [m] when they first touch within a step, the robot
    moving from ``p0`` to ``p1`` in a straight line: the first of :data:`TOUCH_SAMPLES` points of the step where the
    gap is at most 0 (``radius`` [m]: both radii), else where it is least (a swept graze). ``other(s, pos)`` gives
    the other body's centre ``(k, 2)`` at fractions ``s (k,)`` of the step, the robot at ``pos = p0 + s (p1 - p0)``
    ``(k, 2)``. Measured at the end of the step instead, a robot that a step carries past a body's centre (speed x
    dt above its radius, or a thin wall) read as moving away from it."""
    s = np.linspace(0.0, 1.0, TOUCH_SAMPLES)
    pos = p0 + s[:, None] * (p1 - p0)
    centre = other(s, pos)
    gap = np.linalg.norm(centre - pos, axis=-1) - radius
    k = int(np.argmax(gap <= 1e-9)) if np.any(gap <= 1e-9) else int(np.argmin(gap))
    return pos[k], centre[k]


def contact_events(ep: Episode) -> list[Contact]:
    """Every contact of the episode, by step, then robot, then other body.

    Raises:
        ValueError: the episode was recorded without the hit matrices, or its arrays disagree (:meth:`Episode.check`).
    """
    if ep.robot_hits is None or ep.obstacle_hits is None:
        raise ValueError("this episode has no robot_hits/obstacle_hits record: contacts cannot be explained")
    ep.check()
    n, m = ep.n_robots, len(ep.obs_radius)
    parts = [ep.robot_hits, ep.obstacle_hits]
    if ep.wall_hits is not None and ep.wall_hits.shape[-1]:
        parts.append(ep.wall_hits)
    hits = np.concatenate(parts, axis=2)  # (T, n, n + m + s)
    radius = np.concatenate((ep.radius, ep.obs_radius, np.zeros(hits.shape[2] - n - m)))
    out: list[Contact] = []
    for t, i, j in zip(*np.nonzero(hits), strict=True):
        if t > 0 and hits[t - 1, i, j]:
            continue  # the same contact, still going on
        run = t
        while run + 1 < len(hits) and hits[run + 1, i, j]:
            run += 1
        if j < n + m:
            other = ep.pos[:, j] if j < n else ep.obs_pos[:, j - n]

            def along(s, _pos, o=other[t], o1=other[t + 1]):  # the body moves in a straight line too
                return o + s[:, None] * (o1 - o)
        else:  # the nearest point of the wall segment
            a, b = ep.segments[j - n - m]
            ab = b - a

            def along(_s, pos, a=a, ab=ab):
                return a + np.clip((pos - a) @ ab / (ab @ ab), 0.0, 1.0)[:, None] * ab

            other = along(None, ep.pos[:, i])
        here, there = first_touch(ep.pos[t, i], ep.pos[t + 1, i], ep.radius[i] + radius[j], along)
        centre = there - here
        dist = float(np.linalg.norm(centre))
        velocity = (ep.pos[t + 1, i] - ep.pos[t, i]) / ep.dt
        toward = float(velocity @ centre / dist) if dist > 0 else float(np.linalg.norm(velocity))
        gaps = np.linalg.norm(other[t + 1 : run + 2] - ep.pos[t + 1 : run + 2, i], axis=-1) - ep.radius[i] - radius[j]
        if j >= n + m:
            kind, index = "wall", int(j - n - m)
        elif j >= n:
            kind, index = "obstacle", int(j - n)
        else:
            kind, index = ("robot" if ep.acted[t, j] else "parked"), int(j)
        out.append(Contact(int(t), int(i), kind, index, toward, max(0.0, float(-gaps.min()))))
    return out
