"""``--features contact`` (agents.features): the per-neighbour block against an oracle computed
from the world state in metres and seconds (not from the observation), by brute-force time
sampling; ``--features slots`` against a slot-by-slot loop; and the choice travelling through
bc, train --init and evaluation."""

import dataclasses
import json

import numpy as np
import pytest
import torch

from agents.features import (
    CONTACT_DIM,
    FINE_DIM,
    FINE_G_REF,
    FINE_T_REF,
    G_REF,
    SLOT_WIDTH,
    T_REF,
    SlotEncoder,
    check_features,
    contact_features,
    slot_contacts,
    wall_block,
    wall_slots,
    widen_fine,
)
from vcs_env.observations import EGO_DIM, NEIGHBOR_DIM, observation_layout, observe
from vcs_env.sim import Simulator
from vcs_env.spaces import observation_space
from vcs_env.suites import get_suite


def oracle(world, b: int, i: int, k: int) -> np.ndarray:
    """Contact block ``(k, 3)`` of robot ``i`` in world ``b``: the k sensed objects nearest by
    gap, contact time by sampling t every 1 ms over 40 s."""
    pos = np.concatenate((world.pos[b], world.obs_pos[b]))
    vel = np.concatenate((world.vel[b], world.obs_vel[b]))
    rad = np.concatenate((world.radius[b], world.obs_radius[b]))
    present = np.concatenate((world.present[b], np.ones(world.n_obstacles, dtype=bool)))
    t = np.arange(0.0, 40.0, 1e-3)
    rows = []
    for j in range(len(rad)):
        rel = pos[j] - pos[i]
        if j == i or not present[j] or np.hypot(*rel) > world.r_ca:
            continue
        u = vel[j] - vel[i]
        gap = np.hypot(*rel) - rad[i] - rad[j]
        dist = np.hypot(rel[0] + u[0] * t, rel[1] + u[1] * t)
        touching = np.flatnonzero(dist <= rad[i] + rad[j])
        contact = np.exp(-t[touching[0]] / T_REF) if len(touching) else 0.0
        reach = np.exp(-max(gap, 0.0) / (world.v_max[b, i] + np.hypot(*vel[j])) / T_REF)
        rows.append((gap, j, (contact, np.exp(-max(gap, 0.0) / G_REF), reach)))
    rows.sort(key=lambda r: (r[0], r[1]))
    block = np.zeros((k, CONTACT_DIM))
    for s, (_, _, feats) in enumerate(rows[:k]):
        block[s] = feats
    return block


@pytest.mark.parametrize("k", [3, 8])
def test_contact_block_matches_a_brute_force_oracle(k):
    scenario = dataclasses.replace(get_suite("dynamic-v0").scenario, n_neighbors=k, n_robots=6)
    sim = Simulator(scenario, 2)
    sim.reset([7, 8])
    rng = np.random.default_rng(0)
    checked = 0
    for step in range(40):
        sim.step(rng.uniform(-1, 1, (2, scenario.n_robots, 2)))
        if step % 10:
            continue
        world = sim.world
        obs = observe(world, scenario)
        got = contact_features(torch.as_tensor(obs.reshape(-1, obs.shape[-1])), k, NEIGHBOR_DIM).numpy()
        got = got.reshape(2, scenario.n_robots, k, CONTACT_DIM)
        for b in range(2):
            for i in np.flatnonzero(world.present[b]):
                np.testing.assert_allclose(got[b, i], oracle(world, b, i, k), atol=2e-3)
                checked += int((got[b, i, :, 0] > 0).sum())
    assert checked >= 5  # some objects were on a collision course


def slots_oracle(enc: SlotEncoder, obs: np.ndarray) -> np.ndarray:
    """The slots encoding of one observation ``(D,)``, one real slot at a time; with ``wall_slots``, each
    valid nearest wall point (the last block) as a still slot of radius 0, written out by hand."""
    k, d, walls = enc.n_neighbors, enc.neighbor_dim, enc.wall_slots
    ego, end = obs[:EGO_DIM], EGO_DIM + k * d
    slots = [obs[EGO_DIM + s * d : EGO_DIM + (s + 1) * d] for s in range(k)]
    for valid, x, y in obs[len(obs) - 3 * walls :].reshape(walls, 3):
        slot = np.zeros(d, dtype=np.float32)
        own_speed = obs[0] * obs[4] * 3.0  # [m/s]
        slot[:4] = [valid, x, y, -own_speed / 6.0 * valid]
        slot[6] = (np.hypot(x, y) * 10.0 - obs[7] * 2.0) / 10.0 * valid  # gap [m] / 10 m
        slots.append(slot)
    codes = []
    for slot in slots:
        if slot[0] == 1.0:
            contact = slot_contacts(torch.as_tensor(obs[None]), torch.as_tensor(slot[None, None]))[0, 0].numpy()
            inputs = [slot, contact, ego]
            if enc.fine:  # the gap [m] and the time to contact [s] (from exp(-t_c / T_REF)), at fine scales
                t_c = -T_REF * np.log(contact[0]) if contact[0] > 0 else np.inf
                inputs.append([np.exp(-max(slot[6] * 10.0, 0.0) / FINE_G_REF), np.exp(-t_c / FINE_T_REF)])
            x = torch.as_tensor(np.concatenate(inputs).astype(np.float32))
            codes.append(enc.encoder(x).detach().numpy())
    width = enc.width // 2
    pooled = (np.max(codes, axis=0), np.mean(codes, axis=0)) if codes else (np.zeros(width), np.zeros(width))
    return np.concatenate((ego, obs[end : len(obs) - 3 * walls], *pooled))


def test_slot_encoder_matches_a_slot_by_slot_loop_and_ignores_the_order():
    """On real observations (some robots with padded slots, some with walls after the slots):
    the batched encoder equals the loop, and shuffling the real slots changes nothing."""
    torch.manual_seed(0)
    for suite, extra, walls, fine in (
        ("dynamic-v0", {}, 0, False),
        ("walls-v0", {"n_wall_points": 4}, 0, False),  # wall points read flat (runs before wall slots)
        ("walls-v0", {"n_wall_points": 4}, 4, False),  # wall points as slots
        ("dynamic-v0", {}, 0, True),  # slots-fine
        ("walls-v0", {"n_wall_points": 4}, 4, True),
    ):
        scenario = dataclasses.replace(get_suite(suite).scenario, n_robots=6, r_ca=3.0, **extra)
        sim = Simulator(scenario, 2)
        sim.reset([3, 4])
        obs = observe(sim.world, scenario).reshape(-1, observation_space(scenario).shape[0])
        space = observation_space(scenario)
        enc = SlotEncoder(space, scenario.n_neighbors, neighbor_dim=NEIGHBOR_DIM, wall_slots=walls, fine=fine)
        if walls:
            assert (obs[:, -12::3] == 1).any()  # some robots see walls: their slots are exercised
        got = enc(torch.as_tensor(obs)).detach().numpy()
        n_real = obs[:, EGO_DIM : EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM : NEIGHBOR_DIM].sum(1)
        assert (n_real < scenario.n_neighbors).any()  # padding is exercised
        assert obs.shape[1] - EGO_DIM - scenario.n_neighbors * NEIGHBOR_DIM == 3 * extra.get("n_wall_points", 0)
        assert enc.features_dim == got.shape[1]
        for r in range(len(obs)):
            np.testing.assert_allclose(got[r], slots_oracle(enc, obs[r]), rtol=1e-5, atol=1e-6)
        shuffled = obs.copy()
        slots = shuffled[:, EGO_DIM : EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM].reshape(len(obs), -1, NEIGHBOR_DIM)
        shuffled[:, EGO_DIM : EGO_DIM + scenario.n_neighbors * NEIGHBOR_DIM] = slots[:, ::-1].reshape(len(obs), -1)
        np.testing.assert_allclose(enc(torch.as_tensor(shuffled)).detach().numpy(), got, rtol=1e-5, atol=1e-6)


def test_slot_encoder_default_width_is_the_one_older_checkpoints_were_trained_at():
    """Checkpoints saved before SLOT_WIDTH carry no ``width`` in their extractor kwargs, so SB3 rebuilds
    them with the constructor's default: it must stay 128 (their tensors' size), while new runs pass
    SLOT_WIDTH explicitly."""
    from agents.features import extractor_kwargs

    scenario = get_suite("dynamic-v0").scenario
    space = observation_space(dataclasses.replace(scenario, observation=1))
    assert SlotEncoder(space, 8).encoder[0].out_features == 128
    assert SlotEncoder(space, 8).encoder[0].in_features == 8 + CONTACT_DIM + EGO_DIM  # v1 slots, as they were
    kwargs = extractor_kwargs("slots", observation_layout(scenario))["features_extractor_kwargs"]
    assert kwargs["width"] == SLOT_WIDTH and kwargs["neighbor_dim"] == NEIGHBOR_DIM and "wall_slots" not in kwargs
    walled = observation_layout(dataclasses.replace(scenario, n_wall_points=6))
    assert extractor_kwargs("slots", walled)["features_extractor_kwargs"]["wall_slots"] == 6  # new runs: walls as slots
    space = observation_space(scenario)
    assert SlotEncoder(space, **kwargs).encoder[0].out_features == SLOT_WIDTH


def test_fine_inputs_resolve_millimetres_where_the_contact_block_does_not():
    """One robot 5 mm and one 20 mm from a still robot ahead, each alone in its slot: the contact block's nearness
    reads 0.99 and 0.96, the fine one exp(-0.25) and exp(-1); the time to contact at 0.1 m/s (0.05 s and 0.2 s)
    reads 0.98 and 0.90 in the contact block, exp(-0.2) and exp(-0.8) in the fine one."""
    scenario = dataclasses.replace(get_suite("circle-8-v0").scenario, n_robots=1, n_neighbors=1)
    space = observation_space(scenario)
    enc = SlotEncoder(space, 1, neighbor_dim=NEIGHBOR_DIM, fine=True)
    obs = torch.zeros(2, space.shape[0])
    obs[:, 0], obs[:, 4], obs[:, 7] = 0.1, 1.0 / 3.0, 0.25 / 2.0  # 0.1 of 1 m/s, v_max 1 m/s, radius 0.25 m
    for row, gap in enumerate((0.005, 0.02)):
        slot = obs[row, EGO_DIM : EGO_DIM + NEIGHBOR_DIM]
        slot[0], slot[1], slot[3], slot[5] = 1.0, (0.5 + gap) / 10.0, -0.1 / 6.0, 0.25 / 2.0  # still, ahead
        slot[6] = gap / 10.0
    captured = []
    enc.encoder[0].register_forward_hook(lambda mod, inp, out: captured.append(inp[0]))
    enc(obs)
    x = captured[0][:, 0]  # (2, inputs) of the one slot
    contact, fine = x[:, NEIGHBOR_DIM : NEIGHBOR_DIM + CONTACT_DIM], x[:, -FINE_DIM:]
    np.testing.assert_allclose(contact[:, 1], np.exp(-np.array([0.005, 0.02]) / G_REF), rtol=1e-5)
    np.testing.assert_allclose(fine[:, 0], np.exp([-0.25, -1.0]), rtol=1e-4)
    np.testing.assert_allclose(contact[:, 0], np.exp(-np.array([0.05, 0.2]) / T_REF), rtol=1e-4)
    np.testing.assert_allclose(fine[:, 1], np.exp([-0.2, -0.8]), rtol=1e-3)


def test_check_features_names_the_choices():
    assert check_features("contact") == "contact"
    with pytest.raises(ValueError, match="flat.*contact.*'lidar'"):
        check_features("lidar")


@pytest.mark.parametrize("features", ["contact", "slots", "slots-fine"])
def test_features_travel_through_bc_init_and_evaluation(tmp_path, features):
    """A contact or slots checkpoint loads with its extractor, scores in the harness, and seeds
    only a run that reads the same features."""
    from agents.checkpoint import CheckpointError, load_model
    from agents.evaluate import evaluate
    from agents.features import ContactFeatures
    from agents.imitation import BCConfig, CollectConfig, behaviour_clone, collect
    from vcs_env import make_scenario

    data = str(collect(CollectConfig(scenario="crowd", episodes=3, out=str(tmp_path / "d.npz"))))
    small = dict(data=data, net_arch=(16, 16), epochs=1, eval_episodes=0)
    path = behaviour_clone(BCConfig(**small, out=str(tmp_path / "bc"), features=features))["model"]
    policy = load_model(path, make_scenario("crowd")).policy
    if features == "contact":
        assert isinstance(policy.features_extractor, ContactFeatures)
        assert policy.mlp_extractor.policy_net[0].in_features == policy.observation_space.shape[0] + 8 * CONTACT_DIM
    else:  # actor and critic each have their own encoder
        assert isinstance(policy.pi_features_extractor, SlotEncoder)
        assert policy.pi_features_extractor is not policy.vf_features_extractor
        assert policy.pi_features_extractor.width == SLOT_WIDTH  # stored in the checkpoint
        assert policy.pi_features_extractor.fine == (features == "slots-fine")
        rest = policy.observation_space.shape[0] - 8 * NEIGHBOR_DIM
        assert policy.mlp_extractor.policy_net[0].in_features == rest + 2 * (SLOT_WIDTH // 2)
    assert evaluate(path, "crowd-5-v0-smoke").summary["success"]["n"] > 0
    with pytest.raises(CheckpointError, match="--features"):
        behaviour_clone(BCConfig(**small, out=str(tmp_path / "flat"), init=path))


def test_rllib_backend_refuses_contact_features():
    from agents.runs import RLlibConfig
    from agents.train.rllib import train

    with pytest.raises(ValueError, match="SB3 only"):
        train(RLlibConfig(features="contact", out="unused"))


def test_widen_fine_keeps_the_actions_and_the_values_and_saves_a_slots_fine_checkpoint(tmp_path):
    """A trained slots network widened by the fine inputs acts and values as before, bit for bit, on observations
    near walls and robots; saved, it loads as slots-fine and still does; a contact or already fine network is
    refused by name."""
    from agents.checkpoint import load_model, save_model
    from agents.imitation import BCConfig, CollectConfig, behaviour_clone, collect
    from agents.imitation.data import play
    from agents.runs import TrainConfig

    scenario = get_suite("doorway-v0-smoke").scenario
    walled = dict(scenario="doorway", n_wall_points=4, max_steps=60)
    data = str(collect(CollectConfig(**walled, episodes=3, out=str(tmp_path / "d.npz"))))
    small = dict(data=data, net_arch=(16, 16), epochs=2, eval_episodes=0)
    path = behaviour_clone(BCConfig(**small, out=str(tmp_path / "bc"), features="slots"))["model"]
    sc = dataclasses.replace(scenario, n_wall_points=4)
    model = load_model(path, sc)
    obs = play(sc, [5, 6])["observations"]
    near = obs[:, EGO_DIM + 6 : EGO_DIM + 8 * NEIGHBOR_DIM : NEIGHBOR_DIM] * 10.0  # gaps [m] of the slots
    assert ((near > 0) & (near < 0.3)).any()  # some slots close enough for the fine inputs to be far from 0
    before = model.predict(obs, deterministic=True)[0]
    values = model.policy.predict_values(torch.as_tensor(obs)).detach().numpy()
    widen_fine(model)
    enc = model.policy.pi_features_extractor
    assert enc.fine and model.policy.vf_features_extractor.fine and model.policy.features_extractor is enc
    assert enc.encoder[0].in_features == NEIGHBOR_DIM + CONTACT_DIM + EGO_DIM + FINE_DIM
    np.testing.assert_array_equal(model.predict(obs, deterministic=True)[0], before)
    np.testing.assert_array_equal(model.policy.predict_values(torch.as_tensor(obs)).detach().numpy(), values)
    saved = save_model(model, tmp_path / "fine" / "model", "bc", TrainConfig(features="slots-fine"), sc)
    again = load_model(saved, sc)
    assert again.policy.pi_features_extractor.fine and again.policy.vf_features_extractor.fine
    np.testing.assert_array_equal(again.predict(obs, deterministic=True)[0], before)
    with pytest.raises(ValueError, match="already"):
        widen_fine(again)
    shared = load_model(path, sc)  # actor and critic sharing one encoder keep sharing one
    shared.policy.vf_features_extractor = shared.policy.features_extractor = shared.policy.pi_features_extractor
    widen_fine(shared)
    pol = shared.policy
    assert pol.vf_features_extractor is pol.pi_features_extractor is pol.features_extractor
    np.testing.assert_array_equal(shared.predict(obs, deterministic=True)[0], before)
    contact = behaviour_clone(BCConfig(**small, out=str(tmp_path / "contact"), features="contact"))["model"]
    with pytest.raises(ValueError, match="--features slots"):
        widen_fine(load_model(contact, sc))


def wall_oracle(world, b: int, i: int, k: int) -> np.ndarray:
    """exp(-t_c / T_REF) ``(k,)`` of robot ``i``'s k nearest wall segments (nearest point first): t_c the first time
    its disc, driving on at its velocity, meets the segment, by sampling t every 1 ms over 20 s (0: never)."""
    pos, r = world.pos[b, i], world.radius[b, i]
    vel = world.speed[b, i] * np.array([np.cos(world.heading[b, i]), np.sin(world.heading[b, i])])
    t = np.arange(0.0, 20.0, 1e-3)
    centre = pos + t[:, None] * vel
    rows = []
    for a, e, ok in zip(world.seg_a[b], world.seg_b[b], world.seg_present[b]):
        u = e - a
        near = np.clip((pos - a) @ u / (u @ u), 0.0, 1.0)
        if not ok or np.hypot(*(a + near * u - pos)) > world.r_ca:
            continue
        s = np.clip((centre - a) @ u / (u @ u), 0.0, 1.0)
        dist = np.hypot(*(a + s[:, None] * u - centre).T)
        touching = np.flatnonzero(dist <= r)
        rows.append((np.hypot(*(a + near * u - pos)), np.exp(-t[touching[0]] / T_REF) if len(touching) else 0.0))
    rows.sort()
    out = np.zeros(k)
    out[: min(k, len(rows))] = [v for _, v in rows[:k]]
    return out


def test_segment_contact_is_the_time_the_robot_meets_the_wall_segment():
    """With the wall points' segment fields, each wall point's contact time is the first time the robot's disc driving
    on meets that wall segment, against an oracle sampling the motion in the world (room walls, doors and random
    walls; random headings and speeds)."""
    k = 6
    for name, seed in (("room-v0", 3), ("walls-v0", 5), ("doorway-v0", 7)):
        s = dataclasses.replace(get_suite(name).scenario, n_wall_points=k, wall_segments=True)
        world = Simulator(s, batch_size=3).reset(seed)
        rng = np.random.default_rng(seed)
        world.heading[:] = rng.uniform(-np.pi, np.pi, world.heading.shape)
        world.speed[:] = rng.uniform(0.0, world.v_max)
        obs = torch.as_tensor(observe(world, s)).reshape(-1, observation_layout(s).dim)
        enc = SlotEncoder(observation_space(s), s.n_neighbors, neighbor_dim=NEIGHBOR_DIM, wall_slots=k, wall_dim=7)
        captured = []
        enc.encoder[0].register_forward_hook(lambda mod, inp, out, into=captured: into.append(inp[0]))
        enc(obs)
        got = captured[0][:, -k:, NEIGHBOR_DIM].reshape(3, s.n_robots, k).numpy()
        for b in range(3):
            for i in range(s.n_robots):
                np.testing.assert_allclose(got[b, i], wall_oracle(world, b, i, k), atol=2e-3)


def slant_at_wall(wall=((-5.0, 1.0), (5.0, 1.0))):
    """One robot at the origin driving 0.8 m/s at 30 degrees toward a long wall 1 m away along y = 1."""
    from vcs_env.custom_layout import CustomLayout
    from vcs_env.scenario import Scenario

    layout = CustomLayout(start=((0.0, 0.0),), goal=((4.0, 3.0),), heading=(np.pi / 6,), speed=(0.8,), walls=(wall,))
    s = Scenario(kind="custom", n_robots=1, custom=layout, n_wall_points=1, wall_segments=True)
    return s, Simulator(s)


def wall_contact_inputs(s, world) -> dict:
    """exp(-t_c / T_REF) of the one wall slot: the point as a still disc (False) and the segment (True)."""
    obs = torch.as_tensor(observe(world, s)[0])
    enc = SlotEncoder(observation_space(s), s.n_neighbors, neighbor_dim=NEIGHBOR_DIM, wall_slots=1, wall_dim=7)
    captured = []
    enc.encoder[0].register_forward_hook(lambda mod, inp, o: captured.append(inp[0]))
    enc(obs)
    slots = torch.cat((obs[:, EGO_DIM : EGO_DIM + s.n_neighbors * NEIGHBOR_DIM].reshape(1, -1, NEIGHBOR_DIM),
                       wall_slots(obs, wall_block(obs, 1, 7), NEIGHBOR_DIM)), dim=1)  # fmt: skip
    return {False: float(slot_contacts(obs, slots)[0, -1, 0]), True: float(captured[0][0, -1, NEIGHBOR_DIM])}


def test_segment_contact_reads_the_wall_where_the_point_reads_never_and_a_door_post_as_a_post():
    """Driving at a slant at a long wall, the robot passes its nearest point 0.87 m off, so the point as a still disc
    (the contact block's model) reads never; the segment reads 0.75 m / 0.4 m/s = 1.875 s, and the simulator
    driving the robot on (no action) makes the first contact in the step that ends at 1.9 s. A wall that starts at
    that point and runs away from the robot's path (a door post) reads never with both."""
    s, sim = slant_at_wall()
    got = wall_contact_inputs(s, sim.reset(0))
    assert got[False] == 0.0 and got[True] == pytest.approx(np.exp(-1.875 / T_REF), rel=1e-5)
    step = 0
    while not sim.step(np.zeros((1, 1, 2))).wall_hits.any():
        step += 1
        assert step < 40
    assert step * s.dt < 1.875 <= (step + 1) * s.dt
    s, sim = slant_at_wall(wall=((0.0, 1.0), (-4.0, 1.0)))  # ends at the robot's nearest point, runs back
    assert wall_contact_inputs(s, sim.reset(0)) == {False: 0.0, True: 0.0}


def test_vcs_env_wall_segments_copies_a_network_to_read_wall_segments(tmp_path, capsys):
    """``vcs-env wall-segments``: the copy has the original's weights, reads the wall points with their segment fields
    (its run record says so, and names the source), and is evaluated with that sensing; where no wall is in range it
    acts as the original. Existing output and checkpoints without wall points are refused by name."""
    from stable_baselines3 import PPO

    from agents.checkpoint import load_model, save_model
    from agents.evaluate import evaluate
    from agents.features import extractor_kwargs
    from agents.runs import TrainConfig
    from agents.vec_env import NavVecEnv
    from vcs_cli import main
    from vcs_env.scenario import make_scenario

    scenario = make_scenario("doorway", n_robots=2, n_wall_points=3)
    kwargs = dict(net_arch=[16], **extractor_kwargs("slots", observation_layout(scenario)))
    model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=0)
    cfg = TrainConfig(net_arch=(16,), features="slots", n_wall_points=3)
    src = save_model(model, tmp_path / "src" / "model", "ppo", cfg, scenario)
    assert main(["wall-segments", str(src), "--out", str(tmp_path / "seg")]) == 0
    copy = load_model(tmp_path / "seg" / "model.zip")
    assert copy.policy.pi_features_extractor.wall_dim == copy.policy.vf_features_extractor.wall_dim == 7
    for a, b in zip(copy.policy.state_dict().values(), model.policy.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    record = json.loads((tmp_path / "seg" / "model.json").read_text())
    assert record["wall_segments_from"] == str(src) and record["config"]["wall_segments"]
    wide = dataclasses.replace(scenario, wall_segments=True)
    assert copy.observation_space.shape[0] == observation_layout(wide).dim == observation_layout(scenario).dim + 12
    open_floor = dataclasses.replace(get_suite("circle-8-v0").scenario, n_robots=2, n_wall_points=3)
    world = Simulator(dataclasses.replace(open_floor, wall_segments=True), batch_size=2).reset(1)
    obs7 = observe(world, dataclasses.replace(open_floor, wall_segments=True)).reshape(4, -1)
    obs3 = observe(world, open_floor).reshape(4, -1)
    np.testing.assert_array_equal(copy.predict(obs7, deterministic=True)[0], model.predict(obs3, deterministic=True)[0])
    res = evaluate(str(tmp_path / "seg" / "model.zip"), "doorway-v0-smoke", progress=False)
    assert res.summary["success"]["n"] > 0
    capsys.readouterr()
    assert main(["wall-segments", str(src), "--out", str(tmp_path / "seg")]) == 2
    assert "exists: give a new directory" in capsys.readouterr().err
    assert main(["wall-segments", "policies/circle8/model.zip", "--out", str(tmp_path / "c8")]) == 2
    assert "without wall points" in capsys.readouterr().err
    assert main(["wall-segments", str(tmp_path / "seg" / "model.zip"), "--out", str(tmp_path / "again")]) == 2
    assert f"reads its wall points' segments already (a copy of {str(src)!r})" in capsys.readouterr().err
