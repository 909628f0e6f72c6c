"""``braking`` (agents.features.braking_time, ``vcs-env braking``): a still object's time to contact read as the time
left to brake, held to the simulator (drive on, then brake at a_max: the last step that still stops short), and the
copy command."""

import dataclasses
import json

import numpy as np
import pytest
import torch

from agents.features import T_REF, SlotEncoder
from vcs_env.custom_layout import CustomLayout, ObstacleTrajectory
from vcs_env.observations import NEIGHBOR_DIM, observe
from vcs_env.scenario import Scenario
from vcs_env.sim import Simulator
from vcs_env.spaces import observation_space


def world(heading: float, speed: float, obstacle=None, wall=None):
    """One robot at the origin driving ``speed`` [m/s] at ``heading`` [rad], its goal far beyond; ``obstacle`` an
    ObstacleTrajectory, ``wall`` one segment."""
    layout = CustomLayout(
        start=((0.0, 0.0),),
        goal=((8.0, 0.0),),
        heading=(heading,),
        speed=(speed,),
        obstacles=(obstacle,) if obstacle else (),
        walls=(wall,) if wall else (),
    )
    extra = {"n_wall_points": 1, "wall_segments": True} if wall else {}
    return Scenario(kind="custom", n_robots=1, n_obstacles=len(layout.obstacles), custom=layout, **extra)


def contact_time(s: Scenario, braking: bool) -> float:
    """The time to contact [s] the slots encoder reads for the one object the robot sees (a wall point or not)."""
    obs = torch.as_tensor(observe(Simulator(s).reset(0), s)[0])
    walls = 1 if s.n_wall_points else 0
    kwargs = {"wall_slots": 1, "wall_dim": 7} if walls else {}
    enc = SlotEncoder(observation_space(s), s.n_neighbors, neighbor_dim=NEIGHBOR_DIM, braking=braking, **kwargs)
    captured = []
    enc.encoder[0].register_forward_hook(lambda mod, inp, out: captured.append(inp[0]))
    enc(obs)
    slot = s.n_neighbors if walls else 0  # the wall slot follows the neighbour slots
    f = float(captured[0][0, slot, NEIGHBOR_DIM])
    return -T_REF * np.log(f) if f > 0 else np.inf


def last_safe_brake(s: Scenario) -> float:
    """The latest time [s] (a multiple of the step) at which the robot, driving on until then and braking at a_max
    from then on, stops without touching anything: the simulator's answer."""
    for k in range(200):
        sim = Simulator(s)
        sim.reset(0)
        touched = False
        for step in range(k + 60):
            action = np.zeros((1, 1, 2)) if step < k else np.array([[[-1.0, 0.0]]])
            out = sim.step(action)
            touched |= bool(out.obstacle_hits.any() or out.wall_hits.any())
        if touched:
            return (k - 1) * s.dt
    raise AssertionError("never touched")


@pytest.mark.parametrize(
    "heading, speed, obstacle, wall",
    [
        (0.0, 0.6, ObstacleTrajectory((0.0,), ((2.0, 0.0),), radius=0.25), None),  # head on
        (0.0, 0.9, ObstacleTrajectory((0.0,), ((3.0, 0.35),), radius=0.3), None),  # off centre
        (np.pi / 6, 0.8, None, ((-5.0, 1.0), (5.0, 1.0))),  # a long wall at a slant
    ],
)
def test_braking_time_is_the_last_moment_braking_stops_short(heading, speed, obstacle, wall):
    """Driving at a still obstacle (head on, off centre) or at a wall at a slant: the braking reading is the time to
    contact less v / (2 a_max), and the simulator agrees: braking at a_max from the last step before that reading
    stops short, braking a step after it touches (within a step: the simulator moves in steps of dt)."""
    s = world(heading, speed, obstacle, wall)
    t_c, t_b = contact_time(s, False), contact_time(s, True)
    a_max = s.robot.a_max
    assert np.isfinite(t_c) and t_b == pytest.approx(t_c - speed / (2 * a_max), abs=1e-4)
    assert abs(last_safe_brake(s) - t_b) <= s.dt + 1e-9


def test_moving_objects_keep_their_time_to_contact():
    """An obstacle coming at the robot: braking does not keep the robot clear of it, so its reading is unchanged; a
    robot standing still reads the same either way."""
    mover = ObstacleTrajectory((0.0, 10.0), ((3.0, 0.0), (-2.0, 0.0)), radius=0.25)
    s = world(0.0, 0.6, mover)
    assert contact_time(s, True) == contact_time(s, False) < np.inf
    still = world(0.0, 0.0, ObstacleTrajectory((0.0,), ((0.6, 0.0),), radius=0.25))
    assert contact_time(still, True) == contact_time(still, False)


def test_vcs_env_braking_copies_a_network_to_read_braking_times(tmp_path, capsys):
    """``vcs-env braking``: the copy has the original's weights and reads braking times (its record names the source,
    it loads so, and a network started from its weights reads so too); among moving robots only it acts as the
    original, before a still obstacle not. Existing output, a network without slots and a copy of a copy are refused
    by name."""
    from stable_baselines3 import PPO

    from agents.checkpoint import load_model, load_policy_weights, save_model
    from agents.features import extractor_kwargs
    from agents.runs import TrainConfig
    from agents.vec_env import NavVecEnv
    from vcs_cli import main
    from vcs_env.observations import observation_layout
    from vcs_env.suites import get_suite

    scenario = dataclasses.replace(get_suite("crowd-5-v0").scenario, obstacle_motion="static")
    kwargs = dict(net_arch=[16], **extractor_kwargs("slots", observation_layout(scenario)))
    model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=0)
    src = save_model(model, tmp_path / "src" / "model", "ppo", TrainConfig(net_arch=(16,), features="slots"), scenario)
    assert main(["braking", str(src), "--out", str(tmp_path / "brk")]) == 0
    copy = load_model(tmp_path / "brk" / "model.zip")
    assert copy.policy.pi_features_extractor.braking and copy.policy.vf_features_extractor.braking
    for a, b in zip(copy.policy.state_dict().values(), model.policy.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    assert json.loads((tmp_path / "brk" / "model.json").read_text())["braking_from"] == str(src)
    fresh = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=1)
    load_policy_weights(fresh, tmp_path / "brk" / "model.zip", scenario)  # train --init, bc --init: weights and reading
    assert fresh.policy.pi_features_extractor.braking and fresh.policy_kwargs["features_extractor_kwargs"]["braking"]
    moving = get_suite("circle-8-v0").scenario
    obs = observe(Simulator(moving, batch_size=2).reset(1), moving).reshape(-1, observation_layout(moving).dim)
    np.testing.assert_array_equal(copy.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0])
    s = world(0.0, 0.6, ObstacleTrajectory((0.0,), ((1.2, 0.0),), radius=0.25))
    ahead = observe(Simulator(s).reset(0), s).reshape(1, -1)
    assert not np.array_equal(copy.predict(ahead, deterministic=True)[0], model.predict(ahead, deterministic=True)[0])
    capsys.readouterr()
    assert main(["braking", str(src), "--out", str(tmp_path / "brk")]) == 2
    assert "exists: give a new directory" in capsys.readouterr().err
    assert main(["braking", "policies/circle8/model.zip", "--out", str(tmp_path / "c8")]) == 2
    assert "--features slots" in capsys.readouterr().err
    assert main(["braking", str(tmp_path / "brk" / "model.zip"), "--out", str(tmp_path / "again")]) == 2
    assert f"as braking times already (a copy of {str(src)!r})" in capsys.readouterr().err
