"""Robot kinematics, action decoding and the planner-target -> action mapping.

Action units (``action_mode="delta"``, the default): a point of the one-step velocity change
window, as fractions of the one-step limits.

* unicycle: ``a = (dv / (a_max dt), dtheta / (omega_max dt))``; the new speed is clipped to
  ``[0, v_max]`` (no reversing) and the heading turns by ``dtheta``.
* holonomic: ``a`` is the velocity change in the robot's frame (forward, left) as a fraction of
  ``a_max dt``; it is clipped to the unit disc and the new speed to ``v_max``.

``action_mode="absolute"``: ``a`` is a velocity command that the robot tracks within its limits:

* unicycle: target speed ``(a_0 + 1) / 2 v_max`` and target heading ``a_1 pi`` (world frame).
* holonomic: target velocity ``a v_max`` (world frame), clipped to the unit disc.

Out-of-range components are clipped to ``[-1, 1]`` (a documented clip, like every Box action
space); NaN, inf, wrong shapes and anything but real numbers (complex, strings) are errors
(:func:`check_actions`, used by every adapter).
"""

from __future__ import annotations

import numpy as np

from .geometry import rotate, unit, wrap_angle
from .state import WorldState

ACTION_MODES = ("delta", "absolute")


def check_actions(
    actions, shape: tuple[int, ...], what: str = "actions", ignored: np.ndarray | None = None
) -> np.ndarray:
    """Return ``actions`` as float64 of ``shape``; raise ``ValueError`` naming ``what`` on anything
    but real numbers (complex, strings), on a wrong shape, NaN or inf. ``ignored`` ``(shape[0],)``
    bool: rows no one steps with (a vector env's worlds that auto-reset), set to 0 instead of checked."""
    try:
        raw = np.asarray(actions)
        if actions is None or raw.dtype.kind not in "biufO":
            raise TypeError(f"dtype {raw.dtype}")
        arr = raw.astype(np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what} must be real numbers of shape {shape}, got {actions!r} ({e})") from None
    if arr.shape != shape:
        raise ValueError(f"{what} must have shape {shape}, got {arr.shape}")
    if ignored is not None:
        arr[ignored] = 0.0
    if not np.isfinite(arr).all():
        raise ValueError(f"{what} must be finite, got {arr[~np.isfinite(arr)][:4]} (NaN or inf)")
    return arr


def _clip_disc(vec: np.ndarray, radius: np.ndarray | float = 1.0) -> np.ndarray:
    """Scale vectors ``(..., 2)`` longer than ``radius`` back onto the disc."""
    norm = np.sqrt(np.einsum("...i,...i->...", vec, vec))
    scale = np.where(norm > radius, radius / np.maximum(norm, 1e-300), 1.0)
    return vec * scale[..., None]


def integrate(
    world: WorldState, actions: np.ndarray, action_mode: str = "delta"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """New (speed, heading, position) of every robot after one step of ``actions``.

    The readable reference: the simulator steps with the compiled twin
    :func:`vcs_env.kernels.integrate`, which ``tests/test_kernels.py`` holds to this function.

    Speed and heading change first, then the robot moves on a straight line for ``dt`` with the
    new velocity (explicit Euler; straight motion keeps swept collision checks exact).

    Args:
        world: current state.
        actions: ``(B, n, 2)``, already checked finite.
        action_mode: ``"delta"`` or ``"absolute"``.

    Returns:
        speed ``(B, n)`` [m/s], heading ``(B, n)`` [rad], position ``(B, n, 2)`` [m].
    """
    a = np.clip(actions, -1.0, 1.0)
    dt = world.dt
    dv_max = world.a_max * dt
    if world.holonomic:
        vel = world.vel
        if action_mode == "delta":
            delta = rotate(_clip_disc(a), world.heading) * dv_max[..., None]
        else:
            target = _clip_disc(a) * world.v_max[..., None]
            delta = _clip_disc(target - vel, dv_max)
        new_vel = _clip_disc(vel + delta, world.v_max)
        speed = np.sqrt(np.einsum("...i,...i->...", new_vel, new_vel))
        heading = np.where(speed > 1e-12, np.arctan2(new_vel[..., 1], new_vel[..., 0]), world.heading)
    else:
        dth_max = world.omega_max * dt
        if action_mode == "delta":
            dv = a[..., 0] * dv_max
            dth = a[..., 1] * dth_max
        else:
            dv = np.clip((a[..., 0] + 1.0) * 0.5 * world.v_max - world.speed, -dv_max, dv_max)
            dth = np.clip(wrap_angle(a[..., 1] * np.pi - world.heading), -dth_max, dth_max)
        speed = np.clip(world.speed + dv, 0.0, world.v_max)
        heading = wrap_angle(world.heading + dth)
    pos = world.pos + (speed * dt)[..., None] * unit(heading)
    return speed, heading, pos


def stop_at_goal(
    pos: np.ndarray, new_pos: np.ndarray, goal: np.ndarray, acted: np.ndarray, r_goal: float
) -> tuple[np.ndarray, np.ndarray]:
    """Where the steps end once arrivals stop robots: the readable reference of
    :func:`vcs_env.kernels.stop_at_goal`.

    A robot arrives when its straight step passes within ``r_goal`` of its goal, and an arriving robot
    stops driving. A step that enters the goal disc and leaves it again (a fast robot, a long ``dt``)
    therefore ends at its point nearest the goal, not at its end beyond the disc.

    Args:
        pos: ``(B, n, 2)`` positions at the start of the step [m].
        new_pos: ``(B, n, 2)`` positions where the steps would end [m].
        goal: ``(B, n, 2)`` goals [m].
        acted: ``(B, n)`` robots that moved this step.
        r_goal: arrival radius [m].

    Returns:
        The step ends ``(B, n, 2)`` [m] and the robots stopped short ``(B, n)`` (bool).
    """
    start, end = pos - goal, new_pos - goal
    d = end - start
    dd = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]
    along = -(start[..., 0] * d[..., 0] + start[..., 1] * d[..., 1])  # the nearest point's fraction, times dd
    s = np.where(along > 0.0, along / np.where(dd > 0.0, dd, 1.0), 0.0)
    near = start + s[..., None] * d
    r2 = r_goal * r_goal
    outside = end[..., 0] * end[..., 0] + end[..., 1] * end[..., 1] > r2
    stopped = acted & outside & (along < dd) & (near[..., 0] * near[..., 0] + near[..., 1] * near[..., 1] <= r2)
    return np.where(stopped[..., None], pos + s[..., None] * d, new_pos), stopped


def target_to_action(world: WorldState, target: np.ndarray, action_mode: str = "delta") -> np.ndarray:
    """Map planner targets to actions: the one mapping every planner goes through.

    A target is a desired velocity in polar form, ``(speed [m/s], heading [rad])``, possibly
    outside the one-step window; the action moves toward it as far as the limits allow. The
    polar form keeps the desired heading of a unicycle that wants to stop and turn.

    Args:
        world: current state.
        target: ``(B, n, 2)`` = (speed, heading).
        action_mode: ``"delta"`` or ``"absolute"``.

    Returns:
        Actions ``(B, n, 2)`` in ``[-1, 1]`` (float32).
    """
    if action_mode not in ACTION_MODES:  # every other string was taken for "absolute"
        raise ValueError(f"action_mode must be one of {ACTION_MODES}, got {action_mode!r}")
    t_speed = np.clip(target[..., 0], 0.0, world.v_max)
    t_head = target[..., 1]
    if world.holonomic:
        t_vel = t_speed[..., None] * unit(t_head)
        if action_mode == "delta":
            rel = rotate(t_vel - world.vel, -world.heading) / (world.a_max * world.dt)[..., None]
            act = _clip_disc(rel)
        else:
            act = _clip_disc(t_vel / world.v_max[..., None])
    elif action_mode == "delta":
        act = np.stack(
            (
                (t_speed - world.speed) / (world.a_max * world.dt),
                wrap_angle(t_head - world.heading) / (world.omega_max * world.dt),
            ),
            axis=-1,
        )
    else:
        act = np.stack((2.0 * t_speed / world.v_max - 1.0, wrap_angle(t_head) / np.pi), axis=-1)
    return np.clip(act, -1.0, 1.0).astype(np.float32)
