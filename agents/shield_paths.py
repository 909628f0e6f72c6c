"""The shield's prediction loop, compiled (numba): smallest gaps along every candidate's path.

:meth:`agents.shield.Shield._path_gaps` computes the headings' cosines and sines with numpy and hands the
rest to :func:`path_gaps`: the robot's speed step by step, its sampled positions along each step's straight
segment, and the smallest gap to each mask's slots, each moving on at its constant velocity. Every operation
is the one the former numpy code made, in its order, so the gaps are the same bits
(``tests/test_shield.py`` holds the whole filter to a readable per-robot oracle).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def path_gaps(speed0, a_dt, v_max, accel, backup, cos, sin, pos, vel, reach, masks, dt, sub):
    """Smallest predicted gaps [m] ``(N, K, M)``.

    Args:
        speed0: the robots' speed now ``(N,)`` [m/s].
        a_dt: ``a_max * dt`` ``(N,)`` [m/s]; ``v_max``: ``(N,)`` [m/s].
        accel: each candidate's acceleration in delta units ``(N, K)``.
        backup: after the first step, full braking (acceleration -1) instead of the candidate's.
        cos, sin: the heading's cosine and sine at every step ``(T, N, K)`` (robot frame, heading 0 now).
        pos, vel: the slots' positions [m] and velocities [m/s] ``(N, S, 2)``, robot frame.
        reach: the sum of radii per slot ``(N, S)`` [m]; ``masks``: the slots of each gap ``(M, N, S)``.
        dt: the step [s]; ``sub``: samples along each step's straight segment.
    """
    n, k = accel.shape
    n_steps, n_slots, n_masks = cos.shape[0], pos.shape[1], masks.shape[0]
    gap = np.full((n, k, n_masks), np.inf)
    for i in range(n):
        for c in range(k):
            speed, x, y = speed0[i], 0.0, 0.0
            for t in range(1, n_steps + 1):
                acc = accel[i, c] if t == 1 or not backup else -1.0
                speed = min(max(speed + acc * a_dt[i], 0.0), v_max[i])
                cs, sn = cos[t - 1, i, c], sin[t - 1, i, c]
                px, py = x, y
                for j in range(1, sub + 1):
                    tau = dt * j / sub
                    px, py = x + speed * tau * cs, y + speed * tau * sn
                    when = (t - 1 + j / sub) * dt
                    for s in range(n_slots):
                        dx = px - (pos[i, s, 0] + vel[i, s, 0] * when)
                        dy = py - (pos[i, s, 1] + vel[i, s, 1] * when)
                        d = math.sqrt(dx * dx + dy * dy) - reach[i, s]
                        for m in range(n_masks):
                            if masks[m, i, s] and d < gap[i, c, m]:
                                gap[i, c, m] = d
                x, y = px, py
    return gap
