"""A safety shield: a minimal-intervention filter on a learned policy's actions, from its observation alone.

The shield predicts, for the action the policy chose and for a fixed grid of alternatives, how close the
robot would come to its sensed neighbours within ``horizon`` seconds, and replaces the policy's action
only when that action would come closer than ``margin``. It reads nothing but the robot's own
observation (its ``ego`` and ``neighbors`` blocks, :mod:`vcs_env.observations`), so a shielded policy stays a
decentralised policy: observation in, action out.

Prediction (per robot, in its own frame, :meth:`Shield.min_gaps`):

* the robot holds the candidate action, step after step of the observation's ``dt``, over the fewest
  steps that reach the horizon, as the simulator moves it (:mod:`vcs_env.dynamics`, ``delta`` action
  units, unicycle robots): each step its speed changes by ``a_0 a_max dt`` within ``[0, v_max]`` and its
  heading by ``a_1 omega_max dt``, then it drives straight for ``dt``; positions are taken at every
  step's end and, for steps longer than 0.1 s, every ``dt / ceil(dt / 0.1 s)`` along it;
* the nearest points on walls, when the observation has them (its ``wall_points`` block), count as still
  points: a wall is where its nearest points were (a robot driving towards another part of the wall
  than its nearest point is not protected from it);
* every sensed obstacle moves on at its observed velocity; a sensed robot counts only while its speed
  is at most ``robot_speed`` [m/s] or it is parked (observation v2's flag), since a moving
  robot reacts itself and a constant-velocity guess of it makes the shield fight reciprocal avoidance
  (on circle-24, counting every robot cost 15 points of success, ``docs/experiments.md``);
* with ``robots_stand`` (on by default) a counted robot stands where it is over the horizon: at most
  ``robot_speed`` it moves on less than ``robot_speed * horizon`` (0.075 m), and it reacts itself, so the shield
  keeps the robot from driving into it and leaves its creep to it. Predicted creeping on, a robot at 0.04 m/s
  drifting towards ours made every candidate fall short, and the least-overlap choice fled it: the shield replaced
  the network's braking with creeping on, then speeding up, into a robot parked on the other side
  (``intersection-v0`` seed 1089, a contact the network alone does not make). Run records written before the field
  predict them at their observed velocity;
* the gap is the distance between centres minus both radii [m]; to a *still* body (a point on a wall, a
  parked robot, a body at most ``robot_speed`` fast), whose prediction is exact, the shield keeps
  ``still_margin`` (0.01 m; 0.02 m in records before ``brake_backup``) instead of ``margin``, which is for the
  constant-velocity guess of moving obstacles: it counts that gap as ``gap + margin - still_margin``, so one
  threshold, ``margin``, applies below. With ``margin`` to still bodies too, a passage narrower than the robot's
  diameter plus twice the margin (a 0.7 m door for a robot of 0.5 m, the 0.7 m between two robots parked side by
  side in a corridor) could not be driven through: the v2 generalist deadlocked on every corridor and door suite
  with it (``docs/experiments.md``). Run records written before ``still_margin`` keep that rule.
* with ``brake_backup`` (on by default), a still body is judged along the better of two ways on: the
  candidate held over the horizon, or the candidate for one step and then full braking without a turn until
  the robot stands (at least the horizon): a candidate is safe from still bodies if either way keeps the still
  margin. Held alone, every move of a robot wedged 0.02 m between a parked robot and a wall came closer than
  that at some point of the horizon, and it stood for good where the network alone drove through; braking
  alone, a fast robot could not turn away from a still body it cannot stop before. Run records written before
  the field judge by the held candidate alone (and keep the driving guard below without its exception).

Choice (:meth:`Shield.filter`): the policy's action stands if its smallest predicted gap is at least
``margin``; otherwise the candidate (the policy's action, one of :data:`GRID`, acceleration and turn
in ``{-1, -0.5, 0, 0.5, 1}``, or with ``keep_turn`` the policy's turn at one of those accelerations) with the
largest score ``1e6 * min(gap, margin) - |candidate - action|`` (gap in metres, the first candidate on ties): the
largest smallest gap capped at ``margin``, and of those equal in it to within a few micrometres (all that reach
the margin, say) the one nearest the policy's action.

No harm to the robots it leaves to the policy (``driving_guard``, on by default): a candidate may replace the
policy's action only if it comes no closer to the sensed *driving* robots (those not counted above, each moving on
at its observed velocity) than the policy's action does, below ``margin``: its smallest predicted gap to them is at
least ``min(that of the policy's action, margin)`` (to a micrometre). Driving robots never make the shield step in
(but for ``driving_stop``'s cap, below); they only rule out replacements that would steer into them. Without the
guard the shield, keeping its margin to a wall or a parked robot, replaced a robot's braking with speeding up into
a robot creeping past at 0.07 m/s (``doorway-v0`` seed 1005, a contact the network alone does not make;
``docs/experiments.md``). With ``brake_backup`` full braking (acceleration -1, any turn) passes the guard whatever
its gap: braking is never steering into a driving robot, and without the exception a robot beside a wall with a
driving robot coming at it had only faster candidates left and was sent into the wall (the probe of a 1.0 m door:
0.68 without the exception, 0.88 with it, ``docs/experiments.md``). Run records written before the field run
without the guard.

The policy's own steering first (``keep_turn``, on by default): the candidates include the policy's turn with each
acceleration level of :data:`LEVELS`, so a robot that must not go on as the policy asks can brake (or speed up)
while turning as the policy turns, before any other steering is imposed. Without them the nearest candidate that
kept the margin was often "no turn": a robot held at an intersection or a door stood with its heading frozen; with
them it turns as the policy turns (on the distilled v2: ``intersection-v0`` 1.00 against 0.97, 3 suite episodes with a
new at-fault contact against 5). Run records written before the field run without them.

Room to stop short of driving robots (``driving_stop``, off by default), before the rest: the simulator parks a
robot dead on arrival, at whatever speed it has, and a robot cannot tell from its observation which neighbour is
about to arrive; a follower at full speed close behind one that parks has neither the room to brake nor the time to
swerve (every contact of the v2 network of the morning of 2026-12-05 on ``circle-24-v0``, ``docs/experiments.md``).
So every driving robot may also stop where it is now: the policy's acceleration is lowered, its turn kept, to the
highest level of :data:`LEVELS` (never above the policy's) from which one step and then full braking without a turn
keeps ``still_margin`` (``margin`` without one) from where each driving robot is now; full braking if none does.
The capped action is then the policy's action for the rest of the rule. A cap is not a prediction of the driving
robot's motion: the robots it meets head-on or crossing still avoid each other as their policies do.

A checkpoint carries its shield in its run record (``"shield"`` in ``model.json``, written by
``vcs-env shield``); :func:`agents.policies.load_checkpoint` returns it as a :class:`ShieldedPredictor`,
so it applies wherever a checkpoint is run (``vcs-env evaluate``, ``compare``, ``probe``, ``select``,
:func:`agents.policies.resolve_policy`), unless ``shield=False`` (``--no-shield`` on ``evaluate``,
``compare`` and ``probe``); their results say which policy ran with which shield.
:func:`agents.checkpoint.load_model` and stable-baselines3's ``PPO.load`` give the network alone.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from vcs_env.observations import DT_REF, SENSE_REF, Layout, observation_layout
from vcs_env.scenario import A_REF, OMEGA_REF, R_REF, V_REF, Scenario

from .shield_paths import path_gaps

LEVELS = (-1.0, -0.5, 0.0, 0.5, 1.0)
GRID = np.array([(a, w) for a in LEVELS for w in LEVELS])
"""The alternative actions ``(25, 2)`` (acceleration, turn) in delta action units."""
SAMPLE = 0.1
"""Longest interval between predicted positions [s]."""
HORIZON_MAX = 10.0
"""Longest horizon [s] (the neighbours' positions read at most 10 m away)."""
STILL_MARGIN = 0.01
"""Default smallest predicted gap to still bodies [m] (:attr:`Shield.still_margin`)."""
NEAR_SLACK = 1e-6
"""Slack of :meth:`Shield.near`'s bound [m], for rounding."""


def step_of(obs: np.ndarray) -> np.ndarray:
    """The step ``dt`` [s] ``(N,)`` of every row of ``obs``, from its feature 10 (``dt / DT_REF`` in float32,
    rounded back to the microsecond)."""
    return np.maximum(np.round(np.asarray(obs, dtype=np.float64)[:, 10] * DT_REF, 6), 1e-6)


def limits(o: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The robot's ``v_max`` [m/s], ``a_max`` [m/s^2] and ``omega_max`` [rad/s], each ``(N,)``, from the ``ego``
    features 4-6 of the observations ``o`` ``(N, D)`` (float64)."""
    return o[:, 4] * V_REF, o[:, 5] * A_REF, o[:, 6] * OMEGA_REF


def own_turn(actions: np.ndarray) -> np.ndarray:
    """The turn of each action ``(N, 2)`` at every acceleration level of :data:`LEVELS`: ``(N, len(LEVELS), 2)``."""
    levels = np.broadcast_to(np.array(LEVELS), (len(actions), len(LEVELS)))
    return np.stack((levels, np.broadcast_to(actions[:, 1:], levels.shape)), axis=-1)


@dataclass(frozen=True)
class Shield:
    """Parameters of the shield (module docstring)."""

    horizon: float = 1.5
    """How far ahead the shield predicts [s]."""
    margin: float = 0.1
    """Smallest predicted gap the policy's action may leave to any counted neighbour [m]."""
    robot_speed: float = 0.05
    """Sensed robots at most this fast are counted, faster ones left to the policy [m/s]."""
    still_margin: float | None = STILL_MARGIN
    """Smallest predicted gap to still bodies [m]: the nearest points on walls, parked robots and bodies at
    most ``robot_speed`` fast, whose prediction is exact (None: ``margin``, the rule of run records written
    before this field, 2026-12-04)."""
    driving_guard: bool = True
    """A replacement comes no closer to the driving robots than the policy's action, below ``margin`` (module
    docstring; False: the rule of run records written before this field, 2026-12-04)."""
    keep_turn: bool = True
    """The candidates include the policy's turn with every acceleration level (module docstring; False: the rule
    of run records written before this field, 2026-12-05)."""
    driving_stop: bool = False
    """Room to stop short of where every driving robot is now: a speed cap before the rest of the rule (module
    docstring)."""
    brake_backup: bool = True
    """Still bodies are judged along the better of two ways on: the candidate held over the horizon, or held for
    one step and then full braking without a turn; and full braking passes the driving guard (module docstring;
    False: held only, the rule of run records written before this field, 2026-12-05)."""
    robots_stand: bool = True
    """The robots the shield counts (parked, or at most ``robot_speed`` fast) stand where they are over the horizon
    (module docstring; False: they move on at their observed velocity, the rule of run records written before this
    field, 2026-12-06)."""

    def __post_init__(self):
        checks = [("horizon", 0.0, HORIZON_MAX), ("margin", None, None), ("robot_speed", None, None)]
        if self.still_margin is not None:
            checks.append(("still_margin", None, None))
        for name, low, high in checks:
            value = getattr(self, name)
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ValueError(f"shield {name} must be a finite number, got {value!r}")
            if (low is not None and value <= low) or value < 0:
                raise ValueError(f"shield {name} must be {'> 0' if low is not None else '>= 0'}, got {value!r}")
            if high is not None and value > high:
                raise ValueError(f"shield {name} must be at most {high:g}, got {value!r}")
            object.__setattr__(self, name, float(value))
        for name in ("driving_guard", "keep_turn", "brake_backup", "driving_stop", "robots_stand"):
            value = getattr(self, name)
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"shield {name} must be true or false, got {value!r}")
            object.__setattr__(self, name, bool(value))

    def min_gaps(self, obs: np.ndarray, candidates: np.ndarray, layout: Layout) -> np.ndarray:
        """Smallest predicted gap [m] ``(N, K)`` of every robot under every candidate action.

        Args:
            obs: observations ``(N, D)`` of ``layout``.
            candidates: actions ``(N, K, 2)`` in delta units, each held over the horizon.
            layout: the observation's blocks (:func:`vcs_env.observations.observation_layout`).

        Returns:
            ``+inf`` where no neighbour counts; a gap to a still body as ``gap + margin - still_margin``
            (module docstring).
        """
        return self._gaps(obs, candidates, layout)[..., 0]

    def _gaps(self, obs: np.ndarray, candidates: np.ndarray, layout: Layout) -> np.ndarray:
        """Smallest predicted gaps [m] ``(N, K, 2)``: to the counted neighbours (:meth:`min_gaps`), and to the
        driving robots, the ones the shield leaves to the policy (``+inf`` where there are none)."""
        o = np.asarray(obs, dtype=np.float64)
        dt = step_of(o)
        gap = np.full((*candidates.shape[:2], 2), np.inf)
        for value in np.unique(dt):  # one step length at a time (one, unless rows of several scenarios)
            rows = dt == value
            gap[rows] = self._min_gaps(o[rows], candidates[rows], layout, float(value))
        return gap

    def _min_gaps(self, o: np.ndarray, candidates: np.ndarray, layout: Layout, dt: float) -> np.ndarray:
        counted, pos, vel, _, _, reach, *_, driving, still = self._neighbours(o, layout)
        if not self.brake_backup:
            return self._path_gaps(o, candidates, pos, vel, reach, (counted, driving), dt, backup=False)
        still = counted & still  # the better of holding on and braking after one step
        held = self._path_gaps(o, candidates, pos, vel, reach, (counted & ~still, still, driving), dt, backup=False)
        backup = self._path_gaps(o, candidates, pos, vel, reach, (still,), dt, backup=True)
        return np.stack((np.minimum(held[..., 0], np.maximum(held[..., 1], backup[..., 0])), held[..., 2]), axis=-1)

    def _path_gaps(self, o, candidates, pos, vel, reach, masks, dt: float, backup: bool) -> np.ndarray:
        """Smallest predicted gaps [m] ``(N, K, len(masks))`` to the slots of each mask ``(N, S)``, along every
        candidate held over the horizon, or (``backup``) held for one step, then full braking without a turn
        until the robot stands (:meth:`backup_steps`)."""
        v_max, a_max, w_max = limits(o)
        sub = max(1, math.ceil(dt / SAMPLE - 1e-9))  # samples along each step's straight segment
        n_steps = int(self.backup_steps(o, dt).max()) if backup else int(self.steps(dt))
        heading, cos, sin = np.zeros(candidates.shape[:2]), [], []
        for t in range(1, n_steps + 1):  # the headings' trigonometry in numpy, the rest compiled
            heading = heading + (candidates[..., 1] if t == 1 or not backup else 0.0) * (w_max * dt)[:, None]
            cos.append(np.cos(heading))
            sin.append(np.sin(heading))
        return path_gaps(
            o[:, 0] * v_max,
            a_max * dt,
            v_max,
            np.ascontiguousarray(candidates[..., 0], dtype=np.float64),
            backup,
            np.stack(cos),
            np.stack(sin),
            np.ascontiguousarray(pos, dtype=np.float64),
            np.ascontiguousarray(vel, dtype=np.float64),
            np.ascontiguousarray(reach, dtype=np.float64),
            np.stack(masks),
            float(dt),
            sub,
        )

    def steps(self, dt: float | np.ndarray) -> np.ndarray:
        """Steps of ``dt`` [s] the prediction covers: the fewest that reach the horizon (at least one)."""
        return np.maximum(1, np.ceil(self.horizon / np.asarray(dt, dtype=np.float64) - 1e-9)).astype(int)

    def backup_steps(self, o: np.ndarray, dt: float | np.ndarray) -> np.ndarray:
        """Steps of ``dt`` [s] ``(N,)`` of the still bodies' prediction with ``brake_backup``: the horizon's, and
        at least the candidate's step and enough full braking to stand from ``v_max``."""
        v_max, a_max, _ = limits(o)
        brake = np.ceil(v_max / np.maximum(a_max * dt, 1e-9) - 1e-9).astype(int)
        return np.maximum(self.steps(dt), 1 + brake)

    def _neighbours(self, o: np.ndarray, layout: Layout) -> tuple[np.ndarray, ...]:
        """Per slot ``(N, S)``: counted mask, position and velocity ``(N, S, 2)`` in the robot frame [m, m/s],
        gap now and radius sum [m]; with the robot's speed, limits and radius ``(N,)``; and the driving robots'
        and the still bodies' masks ``(N, S)``. The slots are the neighbour slots, then the wall points if the
        observation has them (still, of radius 0)."""
        v_max, a_max, w_max = limits(o)
        v0, radius = o[:, 0] * v_max, o[:, 7] * R_REF
        slots = layout.read(o, "neighbors")
        pos = slots[..., 1:3] * SENSE_REF
        vel = slots[..., 3:5] * (2 * V_REF)
        vel[..., 0] += v0[:, None]  # relative -> the neighbour's own velocity, robot frame [m/s]
        speed = np.sqrt(vel[..., 0] ** 2 + vel[..., 1] ** 2)
        still = speed <= self.robot_speed
        fields = layout.block("neighbors").fields
        if "parked" in fields:  # observation v2: parked robots stay where they are, whatever they read
            still |= slots[..., fields.index("parked")] > 0.5
        counted = (slots[..., 0] > 0.5) & ((slots[..., 7] < 0.5) | still)
        driving = (slots[..., 0] > 0.5) & ~counted
        if self.robots_stand:  # the counted robots stand where they are
            standing = counted & (slots[..., 7] > 0.5)
            vel[standing], speed[standing] = 0.0, 0.0
        reach = radius[:, None] + slots[..., 5] * R_REF
        gap = slots[..., 6] * SENSE_REF
        if "wall_points" in layout:  # the nearest points on walls: still points (radius 0)
            walls = layout.read(o, "wall_points")
            points = walls[..., 1:3] * SENSE_REF
            counted = np.concatenate((counted, walls[..., 0] > 0.5), axis=1)
            driving = np.concatenate((driving, np.zeros(walls.shape[:2], dtype=bool)), axis=1)
            still = np.concatenate((still, np.ones(walls.shape[:2], dtype=bool)), axis=1)
            pos, vel = np.concatenate((pos, points), axis=1), np.concatenate((vel, np.zeros_like(points)), axis=1)
            speed = np.concatenate((speed, np.zeros(walls.shape[:2])), axis=1)
            gap = np.concatenate((gap, np.hypot(points[..., 0], points[..., 1]) - radius[:, None]), axis=1)
            reach = np.concatenate((reach, np.repeat(radius[:, None], walls.shape[1], axis=1)), axis=1)
        if self.still_margin is not None:  # a still body's gap counts from its own margin: shifted by the difference
            shift = np.where(still, self.margin - self.still_margin, 0.0)
            reach, gap = reach - shift, gap + shift
        return counted, pos, vel, speed, gap, reach, v0, v_max, a_max, w_max, driving, still

    def near(self, obs: np.ndarray, layout: Layout) -> np.ndarray:
        """``(N,)`` bool: some counted neighbour is within ``margin + T * (v_max + its speed)`` now, ``T`` the
        time the prediction covers (the gap feature reads at most 10 m, never more than the true gap; 1e-6 m
        of slack for rounding); elsewhere no action can come within the margin over the horizon."""
        o = np.asarray(obs, dtype=np.float64)
        counted, _, _, speed, gap, _, _, v_max, *_ = self._neighbours(o, layout)
        dt = step_of(o)
        cover = ((self.backup_steps(o, dt) if self.brake_backup else self.steps(dt)) * dt)[:, None]
        return (counted & (gap < self.margin + NEAR_SLACK + cover * (v_max[:, None] + speed))).any(1)

    def filter(self, obs: np.ndarray, actions: np.ndarray, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
        """The shielded actions and where the policy's action fell short of the margin.

        Args:
            obs: observations ``(..., D)``.
            actions: the policy's actions ``(..., 2)`` in delta units (clipped to ``[-1, 1]`` first, as the
                env does).
            layout: the observation's blocks (:func:`vcs_env.observations.observation_layout`).

        Returns:
            actions ``(..., 2)`` float64, and the mask ``(...)`` bool of the rows whose action fell short
            (replaced by the best candidate, which may be the action itself when no candidate does better) or
            was capped (``driving_stop``).
        """
        lead = np.shape(actions)[:-1]
        if np.shape(actions)[-1:] != (2,) or np.shape(obs)[:-1] != lead:
            raise ValueError(
                f"the shield needs observations (..., D) and actions (..., 2) of the same leading shape, got "
                f"{np.shape(obs)} and {np.shape(actions)}"
            )
        act = np.clip(np.asarray(actions, dtype=np.float64).reshape(-1, 2), -1.0, 1.0)
        if not len(act):  # no row (no active robot): nothing to filter (a reshape of zero rows cannot infer D)
            return act.reshape(*lead, 2), np.zeros(lead, dtype=bool)
        o = np.asarray(obs).reshape(act.shape[0], -1)
        if o.shape[1] != layout.dim:
            raise ValueError(f"the shield reads observations of length {layout.dim} (its layout), got {o.shape[1]}")
        # Rows where a counted neighbour could come within the margin at all (near); there the policy's
        # action; the alternatives only where it falls short (row by row the same numbers as all at once).
        capped = np.zeros(len(act), dtype=bool)
        if self.driving_stop:
            act, capped = self._cap(o, act, layout)
        unsafe = self.near(o, layout)
        unsafe[unsafe] = self.min_gaps(o[unsafe], act[unsafe, None], layout)[:, 0] < self.margin
        out = act.copy()
        if unsafe.any():
            a = act[unsafe]
            candidates = np.concatenate((a[:, None], np.broadcast_to(GRID, (len(a), *GRID.shape))), axis=1)
            if self.keep_turn:  # the policy's turn with every acceleration level
                candidates = np.concatenate((candidates, own_turn(a)), axis=1)
            gaps = self._gaps(o[unsafe], candidates, layout)
            score = np.minimum(gaps[..., 0], self.margin) * 1e6 - np.linalg.norm(candidates - a[:, None], axis=-1)
            if self.driving_guard:  # no closer to the driving robots than the policy's action, below the margin
                floor = np.minimum(gaps[:, :1, 1], self.margin) - NEAR_SLACK
                keep = gaps[..., 1] >= floor
                if self.brake_backup:  # full braking is never steering into a driving robot
                    keep |= candidates[..., 0] <= -1.0
                score = np.where(keep, score, -np.inf)
            out[unsafe] = np.take_along_axis(candidates, score.argmax(1)[:, None, None], 1)[:, 0]
        return out.reshape(*lead, 2), (unsafe | capped).reshape(lead)

    def _cap(self, o: np.ndarray, act: np.ndarray, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
        """The actions ``(N, 2)`` with the speed cap of ``driving_stop``, and the mask ``(N,)`` of the capped rows."""
        o = np.asarray(o, dtype=np.float64)
        out, capped = act.copy(), np.zeros(len(act), dtype=bool)
        dt = step_of(o)
        for value in np.unique(dt):
            rows = np.flatnonzero(dt == value)
            sub = o[rows]
            _, pos, _, _, gap, reach, *_, driving, _ = self._neighbours(sub, layout)
            v_max = limits(sub)[0]
            cover = (self.backup_steps(sub, float(value)) * float(value))[:, None]
            near = (driving & (gap < self.margin + NEAR_SLACK + cover * v_max[:, None])).any(1)
            if not near.any():
                continue
            rows, sub, a = rows[near], sub[near], act[rows[near]]
            cand = np.concatenate((a[:, None], own_turn(a)), axis=1)
            shift = 0.0 if self.still_margin is None else self.margin - self.still_margin
            g = self._path_gaps(
                sub,
                cand,
                pos[near],
                np.zeros_like(pos[near]),
                reach[near] - shift,
                (driving[near],),
                float(value),
                backup=True,
            )[..., 0]
            ok = g >= self.margin
            ok[:, 1:] &= cand[:, 1:, 0] <= a[:, :1]  # never faster than the policy asks
            best = np.where(ok[:, 1:], np.arange(len(LEVELS)), -1).max(1)
            best = np.where(best < 0, 0, best)  # none clear: full braking
            replace = ~ok[:, 0]
            out[rows[replace]] = cand[replace, 1 + best[replace]]
            capped[rows[replace]] = True
        return out, capped


def check_scenario(scenario: Scenario) -> None:
    """Refuse scenarios the shield's prediction does not model (holonomic robots)."""
    if scenario.robot.holonomic:
        raise ValueError(
            "the shield predicts unicycle robots; this scenario's robots are holonomic "
            "(run the network alone: --no-shield, or shield=False)"
        )


class ShieldedPredictor:
    """An SB3-style ``PolicyPredictor`` whose actions pass through a shield.

    Args:
        model: the network's predictor (``predict(observation, state, episode_start, deterministic)``).
        shield: the shield.
        scenario: the scenario it runs in (its neighbour slots; holonomic robots are refused).

    The shield reads actions in delta units (``action_mode="delta"``, what ``vcs-env train`` policies emit).
    ``replaced`` and ``decisions`` count the rows whose action fell short of the margin and the rows the
    shield judged: the active robots' when :meth:`predict` is told which they are (``active``, as the
    evaluation harness does), else every row given.
    """

    def __init__(self, model: Any, shield: Shield, scenario: Scenario):
        check_scenario(scenario)
        self.model, self.shield, self.layout = model, shield, observation_layout(scenario)
        self.observation_space = getattr(model, "observation_space", None)
        self.action_space = getattr(model, "action_space", None)
        self.replaced = self.decisions = 0

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False, active=None):
        """The network's actions ``(..., 2)`` float32 for ``observation`` ``(..., D)``, shielded; and its state.

        ``active`` ``(...)`` bool, if given, names the rows of robots still driving: only those are shielded
        and counted (the others' actions are the network's, and ignored by the env)."""
        actions, state = self.model.predict(
            observation, state=state, episode_start=episode_start, deterministic=deterministic
        )
        safe = np.asarray(actions, dtype=np.float64).copy()
        rows = np.ones(safe.shape[:-1], dtype=bool) if active is None else np.asarray(active, dtype=bool)
        if rows.shape != safe.shape[:-1]:
            raise ValueError(f"active must have the actions' leading shape {safe.shape[:-1]}, got {rows.shape}")
        obs = np.asarray(observation)
        safe[rows], replaced = self.shield.filter(obs[rows], safe[rows], self.layout)
        self.replaced += int(replaced.sum())
        self.decisions += replaced.size
        return safe.astype(np.float32), state


def shield_from_record(record: dict[str, Any], where: str = "the run record") -> Shield | None:
    """The shield a run record names (``record["shield"]``), or None; ``where`` names the record in errors."""
    spec = record.get("shield") if isinstance(record, dict) else None
    if spec is None:
        return None
    if not isinstance(spec, dict) or set(spec) - set(Shield.__dataclass_fields__):
        keys = list(Shield.__dataclass_fields__)
        raise ValueError(f"the shield in {where} must be an object with keys of {keys}, got {spec!r}")
    try:
        # records without a key keep the rule they were run with
        rules = ("driving_guard", "keep_turn", "brake_backup", "robots_stand")
        return Shield(**{"still_margin": None, **dict.fromkeys(rules, False), **spec})
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None
