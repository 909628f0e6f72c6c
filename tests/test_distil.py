"""vcs-env distil: network teachers label their own mixture entries, and the student learns each teacher's actions
where that teacher teaches (agents/imitation/distil.py)."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
import torch  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

from agents.checkpoint import attach_shield, load_model, save_model  # noqa: E402
from agents.imitation.data import play  # noqa: E402
from agents.imitation.distil import EXPERT, DistilConfig, distil, teachers_of  # noqa: E402
from agents.policies import load_checkpoint  # noqa: E402
from agents.runs import TrainConfig  # noqa: E402
from agents.shield import Shield  # noqa: E402
from agents.vec_env import NavVecEnv  # noqa: E402
from vcs_env.scenario import make_scenario  # noqa: E402

torch.set_num_threads(1)


def checkpoint(tmp_path: Path, name: str, seed: int, scale: float) -> Path:
    """An untrained PPO checkpoint; ``scale`` multiplies its action head (teachers differ clearly)."""
    scenario = make_scenario("circle", n_robots=3)
    model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=dict(net_arch=[32]), seed=seed)
    with torch.no_grad():
        model.policy.action_net.weight.mul_(scale)
    return save_model(model, tmp_path / name / "model", "ppo", TrainConfig(net_arch=(32,)), scenario)


def short_run(tmp_path: Path, start: Path, **teachers) -> DistilConfig:
    """A distillation of 2 short rounds from the student ``start`` into ``tmp_path/distil``, fitted hard (30 epochs
    at lr 3e-3) so that a student visibly follows its teachers; ``teachers``: the mixture and who teaches it."""
    return DistilConfig(
        max_steps=30,
        init=str(start),
        rounds=2,
        robots=24,
        epochs=30,
        learning_rate=3e-3,
        out=str(tmp_path / "distil"),
        **teachers,
    )


def test_play_labels_every_acting_step_with_the_teacher_and_executes_it():
    scenario = make_scenario("circle", n_robots=3, max_steps=25)

    def teacher(obs):  # a readable oracle: any function of the observation
        return np.tanh(obs[:, :2] - 0.5 * obs[:, 2:4])

    data = play(scenario, [0, 1], teacher=teacher)
    np.testing.assert_allclose(data["actions"], teacher(data["observations"]).astype(np.float32), atol=1e-6)
    # actor=None executes the labels: the same episodes as a controller that plays the teacher itself
    again = play(scenario, [0, 1], actor=lambda o: np.zeros((len(o), 2)), beta=1.0, teacher=teacher)
    np.testing.assert_array_equal(again["observations"], data["observations"])


def test_student_learns_each_teacher_on_its_own_entries(tmp_path):
    a, b, start = (
        checkpoint(tmp_path, "a", 1, 60.0),
        checkpoint(tmp_path, "b", 2, -60.0),
        checkpoint(tmp_path, "s", 3, 1.0),
    )
    out = distil(
        short_run(
            tmp_path,
            start,
            mixture=("circle:n_robots=3", "circle:n_robots=6"),  # observations that differ clearly
            teacher=str(a),
            teacher_for=(f"circle:n_robots=6={b}",),
        )
    )
    assert out["teachers"] == {"circle:n_robots=3": str(a), "circle:n_robots=6": str(b)}
    assert len(list((tmp_path / "distil" / "checkpoints").glob("model_*.zip"))) == 2

    def error(student, teacher, scenario):
        obs = play(scenario, range(500, 504), teacher=lambda o: np.zeros((len(o), 2)))["observations"]
        s, t = (load_model(p, scenario).predict(obs, deterministic=True)[0] for p in (student, teacher))
        return float(np.linalg.norm(s - t, axis=1).mean())

    circle, six = make_scenario("circle", n_robots=3, max_steps=30), make_scenario("circle", n_robots=6, max_steps=30)
    final = out["model"]
    # each entry follows its own teacher, far closer than at the start and than the other teacher
    assert error(final, a, circle) < 0.3 * error(start, a, circle)
    assert error(final, b, six) < 0.3 * error(start, b, six)
    assert error(final, a, circle) < 0.3 * error(final, b, circle)
    assert error(final, b, six) < 0.3 * error(final, a, six)


def test_the_expert_teaches_the_entries_it_is_named_for(tmp_path):
    start = checkpoint(tmp_path, "s", 3, 1.0)
    out = distil(short_run(tmp_path, start, mixture=("circle:n_robots=3",), teacher=EXPERT))
    assert out["teachers"] == {"circle:n_robots=3": EXPERT}
    scenario = make_scenario("circle", n_robots=3, max_steps=30)
    expert = play(scenario, range(500, 504))  # the expert plays and labels episodes no round played

    def error(student):
        act = load_model(student, scenario).predict(expert["observations"], deterministic=True)[0]
        return float(np.linalg.norm(act - expert["actions"], axis=1).mean())

    assert error(out["model"]) < 0.5 * error(start)
    with pytest.raises(ValueError, match="--teacher-shield puts network teachers behind their shield"):
        cfg = short_run(tmp_path, start, mixture=("circle:n_robots=3",), teacher=EXPERT, teacher_shield=True)
        distil(replace(cfg, out=str(tmp_path / "shielded")))


def test_settings_a_distillation_cannot_use_are_refused():
    """Each would leave the run bit for bit the one without it: the mixing of a round that plays the student alone,
    and rewards, which no round reads."""
    with pytest.raises(ValueError, match="with --rounds 1 the one round plays the student alone"):
        DistilConfig(rounds=1, beta=0.5)
    DistilConfig(rounds=2, beta=0.5)
    with pytest.raises(ValueError, match="--shaping sets a reward, and distillation reads none"):
        DistilConfig(shaping="vcs_potential")
    with pytest.raises(ValueError, match="--rewards sets a reward"):
        DistilConfig(rewards="collision=20")


def test_bad_teacher_pairs_are_named():
    with pytest.raises(ValueError, match="needs --teacher"):
        teachers_of(DistilConfig(mixture=("circle",)))
    with pytest.raises(ValueError, match="needs --mixture"):
        teachers_of(DistilConfig(teacher="t.zip"))
    with pytest.raises(ValueError, match=r"'swap=u.zip': no entry of --mixture \(\['circle'\]\) followed by '='"):
        teachers_of(DistilConfig(mixture=("circle",), teacher="t.zip", teacher_for=("swap=u.zip",)))
    # Entries and paths with "=" in them; an entry named twice.
    mix = ("circle-8-v0:n_robots=6-8/2", "swap")
    got = teachers_of(DistilConfig(mixture=mix, teacher="t.zip", teacher_for=("circle-8-v0:n_robots=6-8/2=a=b/m.zip",)))
    assert got == {"circle-8-v0:n_robots=6-8/2": "a=b/m.zip", "swap": "t.zip"}
    with pytest.raises(ValueError, match="names 'swap' twice"):
        teachers_of(DistilConfig(mixture=mix, teacher="t.zip", teacher_for=("swap=u.zip", "swap=v.zip")))
    with pytest.raises(ValueError, match="ENTRY=CHECKPOINT"):
        teachers_of(DistilConfig(mixture=("circle",), teacher="t.zip", teacher_for=("u.zip",)))
    with pytest.raises(ValueError, match="needs --init"):
        teachers_of(DistilConfig(mixture=("circle",), teacher=EXPERT))
    with pytest.raises(ValueError, match=r"DistilConfig\.rounds must be"):
        DistilConfig(rounds=0)


def test_a_teacher_for_other_observations_is_refused(tmp_path):
    a = checkpoint(tmp_path, "a", 1, 1.0)  # observes without wall points
    cfg = DistilConfig(mixture=("corridor",), n_wall_points=6, teacher=str(a), rounds=1, out=str(tmp_path / "d"))
    with pytest.raises(ValueError, match="observation"):
        distil(cfg)


def test_a_shielded_teacher_teaches_its_shielded_actions(tmp_path):
    """With --teacher-shield the labels are the teacher's actions through the shield its record names: where the
    shield replaces them (among obstacles), the student comes closer to the replacements than a student taught by the
    network alone (the ablation)."""
    entry, scenario = "crowd:n_obstacles=12", make_scenario("crowd", n_obstacles=12, max_steps=100)
    teacher, start = checkpoint(tmp_path, "t", 1, 60.0), checkpoint(tmp_path, "s", 3, 1.0)
    cfg = short_run(tmp_path, start, mixture=(entry,), teacher=str(teacher), teacher_shield=True)
    cfg = replace(cfg, max_steps=100, robots=96)
    with pytest.raises(ValueError, match="names no shield"):
        distil(cfg)
    attach_shield(teacher, Shield())
    plain = distil(replace(cfg, teacher_shield=False, out=str(tmp_path / "plain")))["model"]  # the ablation
    out = distil(cfg)["model"]
    shielded = load_checkpoint(str(teacher), scenario)
    actor = lambda o: shielded.predict(o, deterministic=True)[0]  # noqa: E731
    obs = play(scenario, range(500, 508), actor=actor, beta=0.0, teacher=actor)["observations"]
    want, bare = actor(obs), load_model(teacher, scenario).predict(obs, deterministic=True)[0]
    rows = np.abs(want - bare).max(1) > 0.2  # where the shield steps in
    assert rows.sum() >= 10

    def error(student):
        return np.linalg.norm(
            load_model(student, scenario).predict(obs[rows], deterministic=True)[0] - want[rows], axis=1
        ).mean()

    assert error(out) < 0.8 * error(plain), (error(out), error(plain))


def test_widen_fine_gives_the_student_the_fine_inputs_and_it_learns_its_teacher(tmp_path):
    """--widen-fine on a slots student: the rounds train a slots-fine network (saved as one) that follows its
    teacher; a student without slots encoders is refused before any round is played."""
    from agents.config import config_command
    from agents.features import extractor_kwargs
    from vcs_env.observations import observation_layout

    scenario = make_scenario("circle", n_robots=3)
    kwargs = dict(net_arch=[32], **extractor_kwargs("slots", observation_layout(scenario)))
    model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=3)
    start = save_model(model, tmp_path / "s" / "model", "ppo", TrainConfig(net_arch=(32,), features="slots"), scenario)
    teacher = checkpoint(tmp_path, "t", 1, 60.0)
    cfg = replace(short_run(tmp_path, start, mixture=("circle:n_robots=3",), teacher=str(teacher)), widen_fine=True)
    assert "--widen-fine" in config_command("distil", cfg)
    out = distil(cfg)["model"]
    student = load_model(out, scenario).policy
    assert student.pi_features_extractor.fine and student.vf_features_extractor.fine
    # The record says what the student is (its --init's record says slots), and so does a refused --init.
    record = json.loads(Path(out).with_suffix(".json").read_text())
    assert record["report"]["student"] == {"features": "slots-fine", "net_arch": [32]}
    from agents.checkpoint import CheckpointError, load_policy_weights

    plain = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=3)
    with pytest.raises(CheckpointError, match="the checkpoint's: --features slots-fine --net-arch 32"):
        load_policy_weights(plain, out, scenario)
    obs = play(scenario, range(500, 504), teacher=lambda o: np.zeros((len(o), 2)))["observations"]

    def error(path):
        got = load_model(path, scenario).predict(obs, deterministic=True)[0]
        want = load_model(teacher, scenario).predict(obs, deterministic=True)[0]
        return float(np.linalg.norm(got - want, axis=1).mean())

    assert error(out) < 0.3 * error(start)
    flat = checkpoint(tmp_path, "f", 2, 1.0)
    with pytest.raises(ValueError, match="--features slots"):
        distil(replace(cfg, init=str(flat), out=str(tmp_path / "flat")))


def test_a_student_made_to_read_wall_segments_learns_and_teachers_without_them_read_their_own_fields(tmp_path):
    """--wall-segments --read-wall-segments: a slots student and a teacher trained on wall points without their segment
    fields; the teacher labels from its own fields of the run's observations (the same actions as on its own
    observation), and the student, made to read the segments with its weights kept, learns it and saves as a
    network reading the wider observation. Without --wall-segments, --read-wall-segments is refused."""
    import dataclasses

    from agents.features import extractor_kwargs
    from agents.imitation.distil import load_teacher
    from vcs_env.observations import observation_layout, observe
    from vcs_env.sim import Simulator

    scenario = make_scenario("doorway", n_robots=2, n_wall_points=3)
    wide = dataclasses.replace(scenario, wall_segments=True)
    kwargs = dict(net_arch=[32], **extractor_kwargs("slots", observation_layout(scenario)))

    def slots_checkpoint(name, seed, scale):
        model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=seed)
        with torch.no_grad():
            model.policy.action_net.weight.mul_(scale)
        cfg = TrainConfig(net_arch=(32,), features="slots", n_wall_points=3)
        return save_model(model, tmp_path / name / "model", "ppo", cfg, scenario)

    start, teacher = slots_checkpoint("s", 3, 1.0), slots_checkpoint("t", 1, 60.0)
    world = Simulator(wide, batch_size=2).reset(5)
    obs = observe(world, wide).reshape(-1, observation_layout(wide).dim)
    narrow = observe(world, scenario).reshape(len(obs), -1)
    got = load_teacher(str(teacher), wide, shield=False).predict(obs, deterministic=True)[0]
    np.testing.assert_array_equal(got, load_model(teacher, scenario).predict(narrow, deterministic=True)[0])
    entry = "doorway:n_robots=2"
    cfg = replace(short_run(tmp_path, start, mixture=(entry,), teacher=str(teacher)), n_wall_points=3)
    with pytest.raises(ValueError, match="--wall-segments"):
        distil(replace(cfg, read_wall_segments=True))
    out = distil(replace(cfg, wall_segments=True, read_wall_segments=True, out=str(tmp_path / "seg")))["model"]
    student = load_model(out, wide)
    assert student.policy.pi_features_extractor.wall_dim == 7 and student.observation_space.shape == obs.shape[1:]
    obs = play(wide, range(500, 504), teacher=lambda o: np.zeros((len(o), 2)))["observations"]
    want = load_teacher(str(teacher), wide, shield=False).predict(obs, deterministic=True)[0]

    def error(model):
        return float(np.linalg.norm(model.predict(obs, deterministic=True)[0] - want, axis=1).mean())

    assert error(student) < 0.3 * error(load_teacher(str(start), wide, shield=False))


def test_each_teacher_is_checked_against_the_entry_it_labels(tmp_path):
    """Every teacher was loaded against the mixture's first entry: a crowd teacher labelling the crowd entry was told
    it ran outside its family (and a misfit named the first entry's kind)."""
    import warnings

    from agents.fits import FamilyWarning

    crowd = make_scenario("crowd", n_obstacles=3)
    model = PPO("MlpPolicy", NavVecEnv(crowd, 1), device="cpu", policy_kwargs=dict(net_arch=[32]), seed=4)
    teacher = save_model(model, tmp_path / "crowd" / "model", "ppo", TrainConfig(net_arch=(32,)), crowd)
    start = checkpoint(tmp_path, "s", 3, 1.0)  # trained on circles: it teaches the circle entry
    mixture = ("circle:n_robots=3", "crowd:n_obstacles=3")
    cfg = replace(short_run(tmp_path, start, mixture=mixture, teacher=str(start)), rounds=1, robots=4, epochs=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FamilyWarning)
        distil(replace(cfg, teacher_for=(f"crowd:n_obstacles=3={teacher}",)))
    # A teacher of several entries is checked against each, whatever their order (it was the first one's only).
    for order in (mixture, mixture[::-1]):
        with pytest.warns(FamilyWarning, match="kind='crowd'"):
            distil(replace(cfg, mixture=order, out=str(tmp_path / f"d-{order[0][:5]}")))


def test_rounds_start_from_saved_states_where_the_file_has_a_pool(tmp_path, capsys):
    """--start-states: episodes of an entry with a pool begin from its saved states (taken here 15 steps into
    30-step episodes, so those trajectories are at most 15 steps long); a file with no pool for the run is refused."""
    from agents.mixture import mixture_scenarios
    from vcs_env.sim import Simulator
    from vcs_env.start_states import StartStates, StatePool, scenario_key

    start = checkpoint(tmp_path, "s", 3, 1.0)
    cfg = replace(short_run(tmp_path, start, mixture=("circle:n_robots=3",), teacher=str(start)), epochs=1)
    (sc,) = mixture_scenarios(cfg, cfg.mixture)
    sim = Simulator(sc, 4)
    sim.reset(0)
    rng = np.random.default_rng(0)
    for _ in range(15):
        sim.step(rng.uniform(-1, 1, (4, sc.n_robots, 2)))
    pool = StatePool.take(sim.world, sim.motion_params, range(4))
    starts = StartStates({scenario_key(sc): pool}, prob=1.0)

    def teacher(obs):
        return np.zeros((len(obs), 2))

    longest = [
        int(np.diff(play(sc, range(8), teacher=teacher, start_states=s)["traj_start"]).max()) for s in (None, starts)
    ]
    assert longest[0] > 15 >= longest[1]
    path = starts.save(tmp_path / "states.npz")
    runs = [replace(cfg, out=str(tmp_path / f"d{p}"), start_states=str(path), start_prob=p) for p in (0.0, 1.0)]
    rows = [distil(run)["rounds"][-1]["rows"] for run in runs]
    assert rows[1] < rows[0]
    assert "start states: 1 of 1 scenarios" in capsys.readouterr().out
    other = StartStates({scenario_key(replace(sc, max_steps=50)): pool}, prob=1.0).save(tmp_path / "other.npz")
    with pytest.raises(ValueError, match="no start-state pool .* fits a distillation scenario"):
        distil(replace(cfg, out=str(tmp_path / "d-other"), start_states=str(other)))


def test_a_teacher_of_another_observation_version_is_refused_not_adapted():
    """A v1 teacher's fields are names a v2 run also has, but their meaning differs (v2's goal features follow the
    route): only the same version and scales with fewer fields is read from the run's observations."""
    import dataclasses

    from agents.checkpoint import CheckpointError
    from agents.imitation.distil import load_teacher, narrower
    from vcs_env.observations import observation_config

    v2 = make_scenario("doorway", n_robots=2, n_wall_points=3, wall_segments=True)
    fewer = dataclasses.replace(v2, wall_segments=False)

    def record(scenario):
        return {"observation": observation_config(scenario)}

    assert narrower(record(fewer), v2) == fewer
    assert narrower(record(v2), v2) is None and narrower(record(v2), fewer) is None
    v1 = dataclasses.replace(fewer, observation=1)
    assert narrower(record(v1), v2) is None and narrower({}, v2) is None
    with pytest.raises(CheckpointError, match="observation"):
        load_teacher("policies/generalist/model.zip", v2, shield=False)
