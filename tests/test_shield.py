"""The safety shield (agents.shield): its prediction is what the simulator then does, its choice follows the
documented rule (a readable per-robot oracle), it reads the observation alone, and its record and CLI refuse bad
input by name (its ablation on the released generalist: tests/test_shield_ablation.py)."""

import dataclasses
import json
import math
import shutil

import numpy as np
import pytest

from agents.checkpoint import attach_shield
from agents.evaluate import evaluate
from agents.evaluate.report import describe_shield
from agents.policies import load_checkpoint, resolve_policy
from agents.shield import GRID, LEVELS, SAMPLE, Shield, ShieldedPredictor, shield_from_record
from vcs_cli import main
from vcs_env.observations import EGO_DIM, observation_dim, observation_layout, observe
from vcs_env.scenario import SCENARIOS, CustomLayout, make_scenario
from vcs_env.sim import Simulator
from vcs_env.suites import Suite

GENERALIST = "policies/generalist/model.zip"
LAYOUT = observation_layout(SCENARIOS["dynamic"])  # observation v2, 8 neighbour slots of 9 floats
V1 = observation_layout(dataclasses.replace(SCENARIOS["dynamic"], observation=1))  # what the generalist reads


def _oracle(shield: Shield, row: np.ndarray, action: np.ndarray, k: int) -> tuple[np.ndarray, bool]:
    """One robot, one candidate at a time, in plain Python: the module docstring's rule (observation v2)."""
    v_max, a_max, w_max = row[4] * 3.0, row[5] * 10.0, row[6] * 2 * math.pi
    v0, radius = row[0] * v_max, row[7] * 2.0
    others = []
    for j in range(k):
        s = row[EGO_DIM + j * 9 : EGO_DIM + (j + 1) * 9]
        vx, vy = s[3] * 6.0 + v0, s[4] * 6.0
        still = math.hypot(vx, vy) <= shield.robot_speed or s[8] > 0.5
        counted = s[7] < 0.5 or still
        if shield.robots_stand and s[7] > 0.5 and still:  # a counted robot stands where it is
            vx, vy = 0.0, 0.0
        if s[0] > 0.5:
            # the gap to a still body is kept at still_margin: it counts as that much farther than margin
            shift = shield.margin - shield.still_margin if still and shield.still_margin is not None else 0.0
            others.append((s[1] * 10.0, s[2] * 10.0, vx, vy, s[5] * 2.0 - shift, counted, counted and still))
    steps = math.ceil(shield.horizon / SAMPLE - 1e-9)
    h = shield.horizon / steps  # the observations' dt (0.1 s = SAMPLE)
    brake = 1 + math.ceil(v_max / (a_max * h) - 1e-9)  # the candidate's step, then braking to a stand

    def path_gap(acc: float, turn: float, bodies: list, backup: bool) -> float:
        """Along the candidate held over the horizon, or held for one step and then braking without a turn."""
        speed, heading, x, y, best = v0, 0.0, 0.0, 0.0, math.inf
        for t in range(1, (max(steps, brake) if backup else steps) + 1):
            a, w = (acc, turn) if t == 1 or not backup else (-1.0, 0.0)
            speed = min(max(speed + a * a_max * h, 0.0), v_max)
            heading += w * w_max * h
            x, y = x + speed * h * math.cos(heading), y + speed * h * math.sin(heading)
            for ox, oy, vx, vy, r, *_ in bodies:
                best = min(best, math.hypot(x - ox - vx * t * h, y - oy - vy * t * h) - radius - r)
        return best

    def smallest_gap(acc: float, turn: float, counted: bool = True) -> float:
        """To the counted bodies, or (counted False) to the driving robots the shield leaves to the policy."""
        if not counted:
            return path_gap(acc, turn, [b for b in others if not b[5]], backup=False)
        if not shield.brake_backup:
            return path_gap(acc, turn, [b for b in others if b[5]], backup=False)
        moving = path_gap(acc, turn, [b for b in others if b[5] and not b[6]], backup=False)
        still = [b for b in others if b[6]]  # the better of holding on and braking after one step
        return min(moving, max(path_gap(acc, turn, still, backup=False), path_gap(acc, turn, still, backup=True)))

    action, capped = np.clip(action, -1, 1), False
    if shield.driving_stop:  # the speed cap: stop short of where every driving robot is now, the turn kept
        shift = shield.margin - shield.still_margin if shield.still_margin is not None else 0.0
        twins = [(ox, oy, 0.0, 0.0, r - shift) for ox, oy, _, _, r, counted, _ in others if not counted]
        if path_gap(*action, twins, backup=True) < shield.margin:
            clear = [a for a in LEVELS if a <= action[0] and path_gap(a, action[1], twins, True) >= shield.margin]
            action, capped = np.array([max(clear, default=-1.0), action[1]]), True
    if smallest_gap(*action) >= shield.margin:
        return action, capped
    candidates = [action, *GRID]
    if shield.keep_turn:  # the policy's own turn at every acceleration level
        candidates += [np.array([level, action[1]]) for level in LEVELS]
    if shield.driving_guard:  # a replacement comes no closer to the driving robots, below the margin
        floor = min(smallest_gap(*action, counted=False), shield.margin) - 1e-6
        # with the braking backup, full braking passes the guard whatever its gap
        brake = shield.brake_backup
        candidates = [c for c in candidates if smallest_gap(*c, counted=False) >= floor or (brake and c[0] <= -1)]
    score = [1e6 * min(smallest_gap(*c), shield.margin) - float(np.linalg.norm(c - action)) for c in candidates]
    return candidates[score.index(max(score))], True


def _world_observations(scenario, seeds, steps=30):
    """Observations of real worlds of ``scenario`` after ``steps`` steps of random actions."""
    sim = Simulator(scenario, batch_size=len(seeds))
    sim.reset(list(seeds))
    rng = np.random.default_rng(0)
    for _ in range(steps):
        sim.step(rng.uniform(-1, 1, (len(seeds), scenario.n_robots, 2)))
    return observe(sim.world, scenario).reshape(-1, observation_dim(scenario)), rng.uniform(
        -1.2, 1.2, (len(seeds) * scenario.n_robots, 2)
    )


# moving obstacles; and still ones among robots (the still margin matters there)
STILL = make_scenario("random", n_robots=6, n_obstacles=8, obstacle_motion="static", arena_half_size=4.0)


@pytest.mark.parametrize(
    "name, still_margin, guard, keep_turn, backup, stop, stand",
    [
        ("dynamic", None, False, False, False, False, False),
        ("dynamic", 0.02, True, True, False, False, False),
        ("dynamic", 0.01, True, True, True, False, False),
        ("dynamic", 0.01, True, True, True, False, True),
        ("dynamic", 0.01, True, True, True, True, True),
        ("still", 0.02, False, True, False, False, False),
        ("still", 0.15, True, False, False, False, False),
        ("still", 0.01, True, True, True, False, True),
        ("still", 0.01, True, True, True, True, True),
        ("crowded", 0.01, True, True, True, False, True),
        ("crowded", 0.01, True, True, True, True, True),
        ("crowded", None, False, False, False, True, False),
        ("crowded", 0.02, False, False, False, False, True),
    ],
)
def test_filter_matches_the_readable_oracle_on_real_observations(
    name, still_margin, guard, keep_turn, backup, stop, stand
):
    shield = Shield(
        horizon=1.5,
        margin=0.1,
        still_margin=still_margin,
        driving_guard=guard,
        keep_turn=keep_turn,
        brake_backup=backup,
        driving_stop=stop,
        robots_stand=stand,
    )
    obs, actions = _world_observations(STILL if name == "still" else SCENARIOS["dynamic"], range(40))
    if name == "still":
        assert observation_layout(STILL) == LAYOUT
        old_rule = Shield(still_margin=None, driving_guard=guard, brake_backup=False).filter(obs, actions, LAYOUT)[1]
        assert (shield.filter(obs, actions, LAYOUT)[1] != old_rule).any()
        if backup:  # the still bodies judged along the braking backup: the shield steps in less often
            held = dataclasses.replace(shield, brake_backup=False).filter(obs, actions, LAYOUT)[1]
            assert shield.filter(obs, actions, LAYOUT)[1].sum() < held.sum()
    if name == "crowded":
        obs, actions = _crowded_rows(np.random.default_rng(1), 300)
        # slow robots among them: standing or creeping on, the shield's choices differ
        other = dataclasses.replace(shield, robots_stand=not stand).filter(obs, actions, LAYOUT)
        assert (other[0] != shield.filter(obs, actions, LAYOUT)[0]).any()
        if stop:  # the speed cap steps in for driving robots, which the shield without it never does
            plain = dataclasses.replace(shield, driving_stop=False).filter(obs, actions, LAYOUT)[1]
            assert (shield.filter(obs, actions, LAYOUT)[1] & ~plain).sum() >= 5
        # the guard changes choices here, never whether the shield steps in (judged along held actions: with
        # the braking backup few of these rows are replaced at all)
        held = dataclasses.replace(shield, brake_backup=False, driving_stop=False)
        ref = held.filter(obs, actions, LAYOUT)
        other = dataclasses.replace(held, driving_guard=not guard).filter(obs, actions, LAYOUT)
        assert np.array_equal(other[1], ref[1])
        assert (other[0] != ref[0]).any(1).sum() >= 5
        # so does keeping the policy's turn: some replacements now turn as the policy does
        kept = dataclasses.replace(held, keep_turn=not keep_turn).filter(obs, actions, LAYOUT)
        assert np.array_equal(kept[1], ref[1])
        assert (kept[0] != ref[0]).any(1).sum() >= 5
    out, replaced = shield.filter(obs, actions, LAYOUT)
    assert 0 < replaced.sum() < len(obs)  # both branches are exercised
    for row, act, got, rep in zip(obs, actions, out, replaced):
        want, want_rep = _oracle(shield, row.astype(np.float64), act, 8)
        assert rep == want_rep
        np.testing.assert_allclose(got, want, atol=1e-12)
    assert np.array_equal(out[~replaced], np.clip(actions[~replaced], -1, 1))  # untouched where safe


@pytest.mark.parametrize("dt, speed", [(0.1, 0.0), (0.05, 0.6), (0.2, 0.3), (0.5, 0.8)])
def test_prediction_is_what_the_simulator_does(dt, speed):
    """Obstacles on straight lines, the robot holding one action: the predicted smallest gap to the sensed
    obstacles is the one the simulator then produces, at every step's end and, for steps over 0.1 s, along
    its straight segment, for every candidate, whatever the step and the robot's starting speed."""
    scenario = dataclasses.replace(
        SCENARIOS["crowd"], n_obstacles=6, on_collision="continue", dt=dt, initial_speed=speed
    )
    shield = Shield(horizon=1.5, margin=0.1)
    steps, sub = math.ceil(1.5 / dt - 1e-9), max(1, math.ceil(dt / SAMPLE - 1e-9))
    for seed in range(3):
        sim = Simulator(scenario)
        world = sim.reset([seed])
        obs = observe(world, scenario)[0]
        sensed = np.hypot(*(world.obs_pos[0] - world.pos[0, 0]).T) <= scenario.r_ca
        for cand in GRID[::4]:
            predicted = shield.min_gaps(obs, np.broadcast_to(cand, (1, 1, 2)).copy(), LAYOUT)[0, 0]
            sim.reset([seed])
            gaps = []
            for _ in range(steps):
                before, obs_before = sim.world.pos[0, 0].copy(), sim.world.obs_pos[0].copy()
                sim.step(np.broadcast_to(cand, (1, 1, 2)))
                w = sim.world
                for f in np.arange(1, sub + 1) / sub:  # straight motion of both within the step
                    p, q = before + f * (w.pos[0, 0] - before), obs_before + f * (w.obs_pos[0] - obs_before)
                    d = np.hypot(*(q - p).T) - w.obs_radius[0] - w.radius[0, 0]
                    gaps.append(d[sensed].min())
            assert predicted == pytest.approx(min(gaps), abs=1e-5)


def _crowded_rows(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` observations (of :func:`_obs`) of a robot close to still bodies, to robots creeping at most
    ``robot_speed`` and to driving robots, with random actions: where the shield steps in for the still ones, its
    choices may steer into the driving ones."""
    rows = []
    for _ in range(n):
        bodies = []
        for kind in ("still", "parked", "slow", "driving", "driving"):
            x, y = rng.uniform(-0.8, 1.6), rng.uniform(-1.2, 1.2)
            if math.hypot(x, y) < 0.55:  # keep the bodies off the robot
                continue
            if kind == "driving":
                bodies.append((x, y, *rng.uniform(-0.8, 0.8, 2), 0.25, 1.0, 0.0))
            elif kind == "slow":
                turn = rng.uniform(0, 2 * math.pi)
                bodies.append(
                    (x, y, *(rng.uniform(0.01, 0.05) * np.array([math.cos(turn), math.sin(turn)])), 0.25, 1.0)
                )
            else:
                bodies.append((x, y, 0.0, 0.0, 0.25, float(kind == "parked"), float(kind == "parked")))
        rows.append(_obs(rng.uniform(0.0, 1.0), bodies))
    return np.stack(rows), rng.uniform(-1.2, 1.2, (n, 2))


def _obs(speed=1.0, neighbours=(), layout=LAYOUT):
    """One unicycle robot of the default spec (v_max 1, a_max 0.5, omega_max pi/2, radius 0.25, dt 0.1)
    with neighbours ``(x, y, vx, vy, radius, is_robot[, parked])`` in its frame [m, m/s] (absolute
    velocities), as observations of ``layout``."""
    o = np.zeros(layout.dim)
    o[:11] = [speed, 0.5, 1, 0, 1 / 3, 0.05, 0.25, 0.125, 0.6, 0.1, 0.1]
    slots = layout.read(o, "neighbors")  # a view into o
    for j, (x, y, vx, vy, r, robot, *parked) in enumerate(neighbours):
        slots[j, :8] = [1, x / 10, y / 10, (vx - speed) / 6, vy / 6, r / 2, 0, robot]
        if parked:
            slots[j, 8] = parked[0]
    return o


def test_who_counts_and_what_replaces_an_unsafe_action():
    shield = Shield()
    ahead = [(1.2, 0.0, 0.0, 0.0, 0.25, 0.0)]  # a still obstacle 0.7 m ahead of a robot at 1 m/s
    act, rep = shield.filter(_obs(1.0, ahead), np.array([1.0, 0.0]), LAYOUT)
    assert rep and not np.array_equal(act, [1.0, 0.0])  # full speed ahead is replaced ...
    gaps = shield.min_gaps(_obs(1.0, ahead)[None], np.stack(([1.0, 0.0], act, [-1.0, 0.0]))[None], LAYOUT)[0]
    assert gaps[0] < gaps[2] < 0 < shield.margin <= gaps[1]  # ... by a turn that keeps the margin (braking would not)
    # Nothing sensed, or the obstacle behind: the action stands, bit for bit.
    assert not shield.filter(_obs(1.0), np.array([0.3, -0.7]), LAYOUT)[1]
    assert not shield.filter(_obs(1.0, [(-1.5, 0.0, 0.0, 0.0, 0.25, 0.0)]), np.array([1.0, 0.0]), LAYOUT)[1]
    # A still robot counts like a still obstacle; a driving robot on the same spot is left to the policy,
    # unless it reads parked (v2), which a robot that has finished is whatever its velocity reads.
    assert shield.filter(_obs(1.0, [(*ahead[0][:5], 1.0)]), np.array([1.0, 0.0]), LAYOUT)[1]
    assert not shield.filter(_obs(1.0, [(1.2, 0.0, -0.5, 0.0, 0.25, 1.0)]), np.array([1.0, 0.0]), LAYOUT)[1]
    assert Shield(robot_speed=1.0).filter(_obs(1.0, [(1.2, 0.0, -0.5, 0.0, 0.25, 1.0)]), np.array([1.0, 0.0]), LAYOUT)[
        1
    ]
    assert shield.filter(_obs(1.0, [(1.2, 0.0, -0.5, 0.0, 0.25, 1.0, 1.0)]), np.array([1.0, 0.0]), LAYOUT)[1]
    # Shapes follow the actions: (B, n, 2) in, (B, n, 2) and (B, n) out.
    out, rep = shield.filter(np.stack([_obs(1.0, ahead)] * 6).reshape(2, 3, -1), np.tile([1.0, 0.0], (2, 3, 1)), LAYOUT)
    assert out.shape == (2, 3, 2) and rep.shape == (2, 3) and rep.all()


def test_still_bodies_keep_the_still_margin_and_passages_stay_open():
    """Between two parked robots 0.7 m apart (surface to surface) a robot of 0.5 m driving through the middle
    passes 0.08 m from each: further than ``still_margin`` (0.02 m), so full speed ahead stands, where the rule
    of records without it (``margin`` to every body) stops the robot; obstacles moving on the same spots still
    get ``margin``. The same between two walls (their nearest points)."""
    gate = [(1.0, y, 0.0, 0.0, 0.25, 1.0, 1.0) for y in (0.58, -0.58)]  # parked robots beside the way
    ahead = np.array([1.0, 0.0])
    assert not Shield().filter(_obs(1.0, gate), ahead, LAYOUT)[1]
    assert Shield(still_margin=None).filter(_obs(1.0, gate), ahead, LAYOUT)[1]
    assert Shield(still_margin=0.1).filter(_obs(1.0, gate), ahead, LAYOUT)[1]
    movers = [(1.0, y, 0.0, 0.3, 0.25, 0.0) for y in (0.58, -0.58)]  # obstacles drifting at 0.3 m/s
    assert Shield().filter(_obs(1.0, movers), ahead, LAYOUT)[1]
    walled = observation_layout(dataclasses.replace(SCENARIOS["dynamic"], n_wall_points=2))
    row = np.zeros(walled.dim)
    row[: LAYOUT.dim] = _obs(1.0)
    walled.read(row, "wall_points")[:] = [[1.0, 0.0, 0.033], [1.0, 0.0, -0.033]]  # walls 0.08 m from the body
    assert not Shield().filter(row, ahead, walled)[1]
    assert Shield(still_margin=None).filter(row, ahead, walled)[1]
    # Into a still body the shield still steps in, and its choice keeps the still margin (the true gap,
    # which the rule without a still margin reports).
    row = _obs(1.0, [(1.2, 0.0, 0.0, 0.0, 0.25, 1.0, 1.0)])
    act, replaced = Shield().filter(row, ahead, LAYOUT)
    gaps = Shield(still_margin=None).min_gaps(row[None], np.stack((ahead, act))[None], LAYOUT)[0]
    assert replaced and gaps[0] < 0 < Shield().still_margin <= gaps[1]


def test_a_wedged_robot_may_creep_on_where_it_can_still_brake():
    """A robot standing 0.025 m from a parked robot ahead-left and from a still obstacle behind-right (the wedge of
    ``corridor-narrow-v0``, docs/experiments.md): held over the horizon, every move that is not a turn in place comes
    closer than the still margin to one of them, so the rule of records before ``brake_backup`` makes it stand for
    good; judged also along one step and braking, the policy's slow start stands (it could brake clear of both),
    while speeding up towards a parked robot too close to brake for after that step is still replaced, by a
    candidate that keeps the still margin."""
    d = 0.5 + 0.025  # between centres [m]: the radii and 0.025 m
    wedge = [(d * 0.7071, d * 0.7071, 0.0, 0.0, 0.25, 1.0, 1.0), (-d * 0.7071, -d * 0.7071, 0.0, 0.0, 0.25, 0.0)]
    row, creep = _obs(0.0, wedge), np.array([0.5, 0.0])
    held = Shield(still_margin=0.02, brake_backup=False)
    act, replaced = held.filter(row, creep, LAYOUT)
    assert replaced and act[0] <= 0.0  # it stands (at rest: no positive acceleration)
    assert not Shield().filter(row, creep, LAYOUT)[1]
    fast = _obs(0.6, [(0.95, 0.0, 0.0, 0.0, 0.25, 1.0, 1.0)])  # 0.45 m from a parked robot ahead at 0.6 m/s
    act, replaced = Shield().filter(fast, np.array([1.0, 0.0]), LAYOUT)
    assert replaced and Shield().min_gaps(fast[None], act[None, None], LAYOUT)[0, 0] >= Shield().margin


def test_a_robot_creeping_up_from_behind_does_not_push_the_robot_into_a_parked_one():
    """``intersection-v0`` seed 1089, reduced: a robot at 0.024 m/s brakes 0.06 m short of a parked robot, while
    another creeps up from behind at 0.04 m/s, 0.02 m away. Predicted creeping on (records before ``robots_stand``),
    it falls within the still margin whatever the robot does, and the least-overlap choice replaces the braking
    with driving on towards the parked robot; standing where it is, the braking stands."""
    bodies = [(0.56, 0.0, 0.0, 0.0, 0.25, 1.0, 1.0), (-0.52, 0.0, 0.04, 0.0, 0.25, 1.0, 0.0)]
    row, brake = _obs(0.024, bodies), np.array([-0.15, -0.7])
    assert not Shield().filter(row, brake, LAYOUT)[1]
    act, replaced = Shield(robots_stand=False).filter(row, brake, LAYOUT)
    assert replaced and act[0] > brake[0]
    parked = _obs(0.024, bodies[:1])[None]  # along the replacement, closer to the parked robot than braking
    gaps = Shield().min_gaps(parked, np.stack((brake, act))[None], LAYOUT)[0]
    assert gaps[1] < gaps[0]


def test_a_replacement_does_not_steer_into_a_driving_robot():
    """An obstacle ahead makes the shield step in; its old choice, a hard right turn, would meet a robot driving
    slowly on that side (which the shield leaves to the policy: it never steps in for it). With the driving guard
    it turns left instead, keeping the margin to both; without the guard (records before it) the turn meets it."""
    ahead = (1.2, 0.0, 0.0, 0.0, 0.25, 0.0)
    robot = (0.9, -0.8, 0.0, 0.1, 0.25, 1.0)  # a robot creeping left at 0.1 m/s, ahead on the right
    row, full = _obs(1.0, [ahead, robot]), np.array([1.0, 0.0])
    assert not Shield().filter(_obs(1.0, [robot]), full, LAYOUT)[1]  # the driving robot alone: left to the policy
    old, replaced_old = Shield(driving_guard=False).filter(row, full, LAYOUT)
    new, replaced = Shield().filter(row, full, LAYOUT)
    assert replaced and replaced_old and old[1] < 0 < new[1]
    gaps = Shield()._gaps(row[None], np.stack((full, old, new))[None], LAYOUT)[0]  # (candidate, counted/driving)
    assert gaps[1, 1] < 0 < Shield().margin <= min(gaps[2, 0], gaps[2, 1])
    assert gaps[1, 0] == pytest.approx(gaps[2, 0])  # both keep the margin to the obstacle


class _FullAhead:
    """Full throttle, no turn, for every robot: a policy that leaves all care to the shield."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.tile(np.float32([1.0, 0.0]), (*np.shape(observation)[:-1], 1)), state


@pytest.mark.parametrize("gap", [0.15, 0.3])
def test_a_follower_can_stop_behind_a_leader_that_parks_dead(gap):
    """The simulator parks a robot dead on arrival, at whatever speed it has. A follower at full speed ``gap`` m
    behind a leader on the same line runs into it where the leader stops: without the speed cap the shield leaves
    the driving leader to the policy and, once it is parked, the follower can neither brake nor swerve in time.
    With ``driving_stop`` the follower keeps the room to stop short of where the leader is, and no contact."""
    start = ((0.0, 0.0), (-0.5 - gap, 0.0))
    layout = CustomLayout(start=start, goal=((2.5, 0.0), (8.0, 0.0)), heading=(0.0, 0.0), speed=(1.0, 1.0))
    scenario = make_scenario("custom", custom=layout, n_robots=2, n_obstacles=0, max_steps=80)
    suite = Suite("follow", scenario, (0,))
    rows = {}
    for stop in (False, True):
        rows[stop] = evaluate(ShieldedPredictor(_FullAhead(), Shield(driving_stop=stop), scenario), suite).rows[0]
    assert rows[False]["at_fault_collision"] == 1.0 and rows[False]["parked_collision"] == 1.0
    assert rows[True]["collision"] == 0.0 and rows[True]["min_separation"] >= Shield().still_margin - 1e-6


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"still_margin": -0.01}, "still_margin must be >= 0"),
        ({"horizon": 0.0}, "horizon must be > 0"),
        ({"horizon": 1e9}, "horizon must be at most 10"),
        ({"margin": -0.1}, "margin must be >= 0"),
        ({"margin": float("nan")}, "margin must be a finite number"),
        ({"robot_speed": True}, "robot_speed must be a finite number"),
        ({"horizon": "1"}, "horizon must be a finite number"),
        ({"driving_guard": "yes"}, "driving_guard must be true or false"),
    ],
)
def test_bad_parameters_are_named(kw, match):
    with pytest.raises(ValueError, match=match):
        Shield(**kw)


def test_any_real_number_and_any_step_work():
    assert Shield(horizon=np.float32(1.5), margin=np.int64(0)) == Shield(horizon=1.5, margin=0.0)
    row = _obs(1.0, [(1.2, 0.0, 0.0, 0.0, 0.25, 0.0)])
    assert Shield(horizon=1e-10).filter(row, np.array([1.0, 0.0]), LAYOUT)[0].shape == (2,)  # one step at least
    with pytest.raises(ValueError, match="same leading shape"):
        Shield().filter(np.stack([row] * 5), np.zeros((3, 2)), LAYOUT)


def test_a_wall_point_ahead_counts_like_a_still_point():
    """With a wall-points block the shield keeps the margin to the nearest points on walls (radius 0); the
    same observation without the block (or with the point marked invalid) leaves full speed ahead alone."""
    walled = observation_layout(dataclasses.replace(SCENARIOS["dynamic"], n_wall_points=2))
    row = np.zeros(walled.dim)
    row[: LAYOUT.dim] = _obs(1.0)
    walled.read(row, "wall_points")[0] = [1.0, 0.8 / 10, 0.0]  # a wall 0.8 m ahead (0.55 m from the body)
    act, replaced = Shield().filter(row, np.array([1.0, 0.0]), walled)
    assert replaced and Shield().min_gaps(row[None], act[None, None], walled)[0, 0] >= Shield().margin
    assert not Shield().filter(row[: LAYOUT.dim], np.array([1.0, 0.0]), LAYOUT)[1]
    walled.read(row, "wall_points")[0, 0] = 0.0  # not valid: nothing to keep away from
    assert not Shield().filter(row, np.array([1.0, 0.0]), walled)[1]


def test_counters_count_the_active_robots_only():
    """Told which rows drive (as the harness does), the shield judges and counts only those; others keep the action."""

    class Ahead:  # full speed ahead, whatever it sees
        def predict(self, observation, state=None, episode_start=None, deterministic=False):
            return np.tile([1.0, 0.0], (len(observation), 1)), state

    guard = ShieldedPredictor(Ahead(), Shield(), SCENARIOS["dynamic"])
    obs = np.stack([_obs(1.0, [(1.2, 0.0, 0.0, 0.0, 0.25, 0.0)])] * 4)  # each unsafe at full speed
    actions, _ = guard.predict(obs, active=np.array([True, False, True, False]))
    assert (guard.replaced, guard.decisions) == (2, 2) and np.array_equal(actions[[1, 3]], [[1.0, 0.0]] * 2)
    assert not np.array_equal(actions[0], [1.0, 0.0])
    guard.predict(obs)  # not told: every row counts; none drives: the network's actions (a zero-row reshape raised)
    assert (guard.replaced, guard.decisions) == (6, 6)
    assert np.array_equal(guard.predict(obs, active=np.zeros(4, dtype=bool))[0], [[1.0, 0.0]] * 4)
    with pytest.raises(ValueError, match="leading shape"):
        guard.predict(obs, active=np.ones(3, dtype=bool))
    with pytest.raises(ValueError, match="shielded policy, whose shield reads its actions in delta mode"):
        resolve_policy(guard, SCENARIOS["dynamic"], action_mode="absolute")  # refused as its checkpoint by path is
    assert (guard.replaced, guard.decisions) == (6, 6)


def test_record_round_trip_and_cli(tmp_path, capsys):
    model = tmp_path / "g" / "model.zip"
    model.parent.mkdir()
    shutil.copy(GENERALIST, model)
    record = json.loads(open(GENERALIST.replace(".zip", ".json")).read())
    record.pop("shield", None)
    model.with_suffix(".json").write_text(json.dumps(record))
    scenario = dataclasses.replace(SCENARIOS["dynamic"], observation=1)  # the generalist reads observation v1
    assert not isinstance(load_checkpoint(model, scenario), ShieldedPredictor)  # no shield in the record
    assert main(["shield", str(model), "--horizon", "1.0", "--margin", "0.2"]) == 0
    assert "wrote" in capsys.readouterr().out
    saved = json.loads(model.with_suffix(".json").read_text())
    assert shield_from_record(saved) == Shield(horizon=1.0, margin=0.2)
    assert {k: saved[k] for k in record} == record  # nothing else in the record changed
    shielded = load_checkpoint(model, scenario)
    assert isinstance(shielded, ShieldedPredictor) and shielded.shield == Shield(horizon=1.0, margin=0.2)
    assert not isinstance(load_checkpoint(model, scenario, shield=False), ShieldedPredictor)
    # One observation in, one action out, as SB3's predict; the shield's choice where it steps in.
    obs = _obs(1.0, [(1.2, 0.0, 0.0, 0.0, 0.25, 0.0)], V1).astype(np.float32)
    action, _ = shielded.predict(obs, deterministic=True)
    network, _ = shielded.model.predict(obs, deterministic=True)
    assert action.shape == (2,) and action.dtype == np.float32 and shielded.replaced == shielded.decisions == 1
    np.testing.assert_array_equal(action, Shield(horizon=1.0, margin=0.2).filter(obs, network, V1)[0])
    # Given as the loaded object, the evaluation records its shield as it does for the path.
    for given in (shielded, model):
        guard = resolve_policy(given, scenario, "delta", True, "g", True).shield
        assert guard == dataclasses.asdict(Shield(horizon=1.0, margin=0.2))
    capsys.readouterr()
    assert main(["shield", str(model), "--no-driving-guard"]) == 0  # the rule of records before the guard
    assert "(it replaces {'horizon': 1.0, 'margin': 0.2" in capsys.readouterr().out  # the earlier shield is named
    assert shield_from_record(json.loads(model.with_suffix(".json").read_text())) == Shield(driving_guard=False)
    assert main(["shield", str(model), "--no-keep-turn"]) == 0  # the rule of records before keep_turn
    assert shield_from_record(json.loads(model.with_suffix(".json").read_text())) == Shield(keep_turn=False)
    assert main(["shield", str(model), "--no-brake-backup", "--still-margin", "0.02"]) == 0  # before brake_backup
    want = Shield(still_margin=0.02, brake_backup=False)
    assert shield_from_record(json.loads(model.with_suffix(".json").read_text())) == want
    assert main(["shield", str(model), "--no-robots-stand"]) == 0  # the rule of records before robots_stand
    assert shield_from_record(json.loads(model.with_suffix(".json").read_text())) == Shield(robots_stand=False)
    capsys.readouterr()
    assert main(["shield", str(model), "--remove", "--margin", "0.3"]) == 2  # settings with --remove: refused
    assert "--remove takes the shield out; it takes no shield settings (--margin)" in capsys.readouterr().err
    assert main(["shield", str(model), "--remove"]) == 0
    assert "removed the shield from" in capsys.readouterr().out
    assert "shield" not in json.loads(model.with_suffix(".json").read_text())
    assert main(["shield", str(model), "--remove"]) == 0
    assert "no shield to remove in" in capsys.readouterr().out
    assert main(["shield", str(model), "--horizon", "0"]) == 2
    assert "error: shield horizon must be > 0, got 0.0" in capsys.readouterr().err
    assert "shield" not in json.loads(model.with_suffix(".json").read_text())
    with pytest.raises(ValueError, match="keys of"):
        shield_from_record({"shield": {"horizon": 1.0, "reach": 2}})
    # Results name the still margin where the shield has one (records before it: margin for every body).
    assert describe_shield(dataclasses.asdict(Shield())).endswith(
        "robots at most 0.05 m/s, still bodies 0.01 m, no closer to driving robots, the policy's turn kept first, "
        "still bodies also along braking, counted robots standing"
    )
    assert describe_shield(record_before := {"horizon": 1.5, "margin": 0.1, "robot_speed": 0.05}).endswith("m/s")
    assert shield_from_record({"shield": record_before}).still_margin is None
    assert not shield_from_record({"shield": {**record_before, "still_margin": 0.02}}).driving_guard
    assert not shield_from_record({"shield": {**record_before, "driving_guard": True}}).keep_turn
    assert not shield_from_record({"shield": {**record_before, "keep_turn": True}}).brake_backup
    assert not shield_from_record({"shield": {**record_before, "brake_backup": True}}).robots_stand
    plain = Shield(still_margin=0.02, driving_guard=False, keep_turn=False, brake_backup=False, robots_stand=False)
    assert describe_shield(dataclasses.asdict(plain)).endswith("still bodies 0.02 m")
    for bad, said in (("[1, 2]", "is a JSON list, not a run record"), ("{}", "no run record"), (None, "no run record")):
        model.with_suffix(".json").write_text(bad) if bad else model.with_suffix(".json").unlink()
        with pytest.raises(ValueError, match=said):
            attach_shield(model, Shield())
    holonomic = dataclasses.replace(scenario, robot=dataclasses.replace(scenario.robot, holonomic=True))
    with pytest.raises(ValueError, match="holonomic"):
        ShieldedPredictor(None, Shield(), holonomic)
