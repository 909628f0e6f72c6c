"""Start-state pools (vcs_env.start_states, agents.train.collect_states): a restored world continues exactly
as the world it was taken from; reset worlds start from a pool with the given probability, drawn
from their own generators; files round-trip; bad pools and files give clear errors; collected
states precede the policy's contacts; training runs from them."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import vcs_env
from agents.outputs import check_out_file
from vcs_env.sim import Simulator
from vcs_env.start_states import StartStates, StatePool, scenario_key

ROOT = Path(__file__).resolve().parents[1]
GENERALIST = ROOT / "policies" / "generalist" / "model.zip"


def dynamic(**kw):
    return vcs_env.make_scenario("dynamic", **({"n_robots": 3, "n_obstacles": 6} | kw))


def advance(sim, steps, rng):
    """Step ``sim`` with random actions; returns them ``(steps, B, n, 2)``."""
    acts = rng.uniform(-1, 1, (steps, sim.batch_size, sim.scenario.n_robots, 2))
    for a in acts:
        sim.step(a)
    return acts


def pool_of(sc, seed=0, steps=(7, 15, 30), batch=4):
    """States of every world of ``sc`` after each number of ``steps`` of random driving."""
    sim = Simulator(sc, batch)
    sim.reset(seed)
    rng, parts, done = np.random.default_rng(seed), [], 0
    for t in steps:
        advance(sim, t - done, rng)
        done = t
        parts.append(StatePool.take(sim.world, sim.motion_params, range(batch)))
    return StatePool.concat(parts)


def test_a_restored_world_continues_exactly_like_the_original(rng):
    sc = dynamic()
    a = Simulator(sc, 3)
    a.reset(5)
    advance(a, 12, rng)
    pool = StatePool.take(a.world, a.motion_params, [2, 0])
    b = Simulator(sc, 2)
    b.reset(99)
    b.restore(pool, [0, 1])
    for f, v in a.world.arrays().items():
        np.testing.assert_array_equal(getattr(b.world, f), v[[2, 0]], err_msg=f)
    for t in range(40):  # long enough for obstacles to turn and bounce
        acts = rng.uniform(-1, 1, (3, sc.n_robots, 2))
        ea, eb = a.step(acts), b.step(acts[[2, 0]])
        for f, v in a.world.arrays().items():
            np.testing.assert_array_equal(getattr(b.world, f), v[[2, 0]], err_msg=f"{f} after {t + 1} steps")
        np.testing.assert_array_equal(eb.collided, ea.collided[[2, 0]])


def test_reset_starts_from_the_pool_with_the_given_probability():
    sc = dynamic()
    pool = pool_of(sc)
    starts = StartStates({scenario_key(sc): pool}, prob=0.3)
    sim = Simulator(sc, 400, start_states=starts)
    sim.reset(1000)
    saved = np.stack([pool.world["pos"][i] for i in range(len(pool))])
    from_pool = np.array([np.any(np.all(saved == p, axis=(1, 2))) for p in sim.world.pos])
    assert 0.2 < from_pool.mean() < 0.4
    assert sim.start_counts.tolist() == [400 - from_pool.sum(), from_pool.sum()]
    assert (sim.world.steps[from_pool] > 0).all() and (sim.world.steps[~from_pool] == 0).all()
    # The same seeds choose the same states; a world's next resets continue its own stream.
    again = Simulator(sc, 400, start_states=starts)
    again.reset(1000)
    np.testing.assert_array_equal(again.world.pos, sim.world.pos)
    sim.reset(None, [0, 1])
    again.reset(None, [0, 1])
    np.testing.assert_array_equal(again.world.pos, sim.world.pos)
    # The rewards do not enter the key: a pool serves the scenario under any reward weights.
    weighted = vcs_env.make_scenario("dynamic", n_robots=3, n_obstacles=6, rewards={"collision": 300.0})
    assert scenario_key(weighted) == scenario_key(sc) and starts.pool(weighted) is pool
    # ... nor the sensors, even with a term that needs one (stuck reads the stall clock).
    clocked = vcs_env.make_scenario(
        "dynamic", n_robots=3, n_obstacles=6, stall_clock=True, rewards={"collision": 300.0, "stuck": 10.0}
    )
    assert scenario_key(clocked) == scenario_key(sc) and starts.pool(clocked) is pool


@pytest.mark.parametrize("prob", [None, 0.0])
def test_without_a_pool_or_at_probability_zero_resets_are_those_of_a_plain_simulator(prob, rng):
    sc = dynamic()
    starts = None if prob is None else StartStates({scenario_key(sc): pool_of(sc)}, prob=prob)
    other = StartStates({scenario_key(dynamic(n_robots=2)): pool_of(dynamic(n_robots=2))}, prob=1.0)
    sims = [Simulator(sc, 3), Simulator(sc, 3, start_states=starts), Simulator(sc, 3, start_states=other)]
    for s in sims:
        s.reset(7)
    for _ in range(3):
        acts = rng.uniform(-1, 1, (3, sc.n_robots, 2))
        for s in sims:
            s.step(acts)
            s.reset(None, [1])
        for s in sims[1:]:
            np.testing.assert_array_equal(s.world.pos, sims[0].world.pos)
            np.testing.assert_array_equal(s.world.obs_vel, sims[0].world.obs_vel)


def test_files_round_trip_and_bad_pools_or_files_give_clear_errors(tmp_path):
    sc, small = dynamic(), dynamic(n_robots=2)
    starts = StartStates({scenario_key(sc): pool_of(sc), scenario_key(small): pool_of(small, steps=(3,))}, prob=0.25)
    back = StartStates.load(starts.save(tmp_path / "s.npz"), prob=0.25)
    assert list(back.pools) == list(starts.pools) and back.prob == 0.25 and back.command is None
    said = dataclasses.replace(starts, command="vcs-env collect-states --out s2.npz")
    assert StartStates.load(said.save(tmp_path / "s2.npz")).command == said.command
    for key, pool in starts.pools.items():
        for part in ("world", "motion"):
            assert set(getattr(back.pools[key], part)) == set(getattr(pool, part))
            for f, v in getattr(pool, part).items():
                np.testing.assert_array_equal(getattr(back.pools[key], part)[f], v)
    assert back.matching([sc, small, dynamic(n_robots=4)]) == [sc, small]
    # A name without .npz: the file written has it, as a dataset's (numpy adds it), is read by either name, and a
    # second run asked for the same name is refused naming the file there (it wrote "plain" and refused "plain")
    assert starts.save(tmp_path / "plain") == tmp_path / "plain.npz" and not (tmp_path / "plain").exists()
    assert list(StartStates.load(tmp_path / "plain").pools) == list(StartStates.load(tmp_path / "plain.npz").pools)
    with pytest.raises(ValueError, match=r"exists \(as '.*plain\.npz', the file it names\)"):
        check_out_file(str(tmp_path / "plain"), "--out", new=True)
    # Files keyed by the whole repr, reward weights included (before reward terms could be added), still fit.
    old_key = repr(dataclasses.replace(sc, rewards=type(sc.rewards)()))
    assert "rewards=RewardWeights(" in old_key and old_key != scenario_key(sc)
    old = StartStates.load(StartStates({old_key: pool_of(sc)}).save(tmp_path / "old.npz"))
    assert old.matching([sc]) == [sc]
    # ... and so do files written before a sensing field existed (wall_segments), whatever the sensing now.
    before = old_key.replace(", wall_segments=False", "")
    assert before != old_key
    old = StartStates.load(StartStates({before: pool_of(sc)}).save(tmp_path / "before.npz"))
    sensing = dataclasses.replace(sc, n_wall_points=4, wall_segments=True)
    assert old.matching([sc, sensing]) == [sc, sensing]
    # A pool saved under another scenario's key (here: other robot count) is refused by name.
    wrong = StartStates({scenario_key(sc): starts.pools[scenario_key(small)]})
    with pytest.raises(ValueError, match=r"pool of scenario dynamic \(n=3, m=6\) has pos of shape \(2, 2\)"):
        Simulator(sc, 2, start_states=wrong)
    with pytest.raises(ValueError, match="probability must be in"):
        StartStates({}, prob=1.5)
    with pytest.raises(ValueError, match="collect-states"):
        StartStates.load(tmp_path / "missing.npz")
    with pytest.raises(ValueError, match="collect-states"):  # a directory
        StartStates.load(tmp_path)
    (tmp_path / "empty.npz").write_bytes(b"")
    (tmp_path / "text.npz").write_text("not an archive")
    np.savez(tmp_path / "pickled.npz", scenarios=np.array([{}], dtype=object))
    for bad in ("empty.npz", "text.npz", "pickled.npz"):
        with pytest.raises(ValueError, match=rf"{bad}' is not a (readable )?\.npz start-state file"):
            StartStates.load(tmp_path / bad)
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a start-state file"):
        StartStates.load(tmp_path / "other.npz")
    with pytest.raises(ValueError, match="same number of states"):
        StatePool({"pos": np.zeros((3, 2, 2))}, {"speed": np.zeros(2)})


@pytest.mark.slow
def test_collected_states_precede_the_policys_contacts_and_feed_training(tmp_path, capsys):
    from agents.checkpoint import load_model
    from agents.policies import predictor_controller
    from agents.train.collect_states import obstacle_contact_time
    from vcs_cli import main
    from vcs_env.observations import observe

    out, only = tmp_path / "states.npz", tmp_path / "contacts.npz"
    entry = "dynamic-v0:n_obstacles=12,obstacle_speed=0.6-1.2"  # crowded and fast: the released policy touches
    # something in some episodes
    args = ["--policy", str(GENERALIST), "--on-collision", "terminate", "--mixture", entry, "--episodes", "60"]
    assert main(["collect-states", *args, "--before", "0.5", "1.0", "--danger-time", "0", "--out", str(only)]) == 0
    assert main(["collect-states", *args, "--before", "0.5", "1.0", "--out", str(out)]) == 0
    assert "pre-contact" in capsys.readouterr().out
    made = StartStates.load(out).command  # the file says how it was made, as its reproduce line
    assert made.startswith("vcs-env collect-states ") and f"--out {out}" in made
    kept = out.read_bytes()
    assert main(["collect-states", *args, "--episodes", "1", "--out", str(out)]) == 2  # not written over
    assert "exists: the new data would replace it" in capsys.readouterr().err and out.read_bytes() == kept
    for flag, value, said in (
        ("--before", "inf", "before must be finite times > 0"),
        ("--danger-time", "nan", "finite"),
    ):
        assert main(["collect-states", *args, flag, value, "--out", str(tmp_path / "bad.npz")]) == 2
        assert said in capsys.readouterr().err
    ((key, contacts),) = StartStates.load(only).pools.items()
    ((_, pool),) = StartStates.load(out).pools.items()
    k = len(contacts)
    assert k >= 10 and len(pool) > k
    np.testing.assert_array_equal(pool.world["pos"][:k], contacts.world["pos"])  # the same pre-contact states first
    # Replay every state with the same policy: a pre-contact state leads to a contact in the step that
    # ends 0.5 or 1 s later; at a danger state an obstacle is about to touch an active robot.
    from agents.config import ScenarioConfig
    from agents.mixture import mixture_scenarios

    (sc,) = mixture_scenarios(ScenarioConfig(on_collision="terminate"), (entry,))
    assert scenario_key(sc) == key
    sim = Simulator(sc, len(pool))
    sim.reset(0)
    w = sim.restore(pool, range(len(pool)))
    danger = ((obstacle_contact_time(w) < 1.5) & w.active).any(axis=1)
    seen = dataclasses.replace(sc, observation=1)  # as the released policy senses (collect-states ran it so)
    control = predictor_controller(load_model(GENERALIST, seen).policy)
    touched = np.zeros(len(pool), dtype=bool)
    for _ in range(11):
        touched |= sim.step(control(sim.world, observe(sim.world, seen))).collided.any(axis=1)
    assert touched[:k].all() and danger[k:].all()
    # The pool feeds a training run of the mixture (other scenarios start fresh).
    run = ["train", "--mixture", entry, "circle-8-v0", "--on-collision", "terminate", "--start-states", str(out)]
    run += ["--start-prob", "0.9", "--timesteps", "1000", "--n-worlds", "4", "--n-steps", "64", "--eval-freq", "0"]
    run += ["--eval-episodes", "2", "--no-progress-bar", "--no-tensorboard", "--out", str(tmp_path / "run")]
    assert main(run) == 0
    text = capsys.readouterr().out
    assert "start states: 1 of 2 scenarios start from" in text
    started = text.split("start states: ")[2].split(" of ")
    assert int(started[0]) >= 1
    # A pool collected under other scenario settings does not fit: a clear error, no silent fresh run.
    assert main([*run[:-2], "--max-steps", "50", "--out", str(tmp_path / "r2")]) == 2
    assert "no start-state pool" in capsys.readouterr().err


def test_the_rllib_backend_refuses_start_states(tmp_path, capsys):
    from vcs_cli import main

    args = ["train", "--backend", "rllib", "--start-states", str(tmp_path / "s.npz"), "--out", str(tmp_path / "r")]
    assert main(args) == 2
    assert "--start-states applies to the SB3 backend only" in capsys.readouterr().err


def test_training_refuses_a_start_state_file_without_states(tmp_path):
    from agents.config import build_scenario
    from agents.train import TrainConfig, start_states

    empty = StartStates({}).save(tmp_path / "empty.npz")
    cfg = TrainConfig(scenario="dynamic", start_states=str(empty))
    with pytest.raises(ValueError, match="holds no start states"):
        start_states(cfg, [build_scenario(cfg)])


def test_cli_names_the_subcommand_of_a_bad_episode_count(capsys):
    from vcs_cli import main

    assert main(["collect-states", "--episodes", "0", "--out", "unused.npz"]) == 2
    assert "vcs-env collect-states: error: --episodes must be >= 1, got 0" in capsys.readouterr().err


def test_robots_that_finished_in_a_saved_state_are_padding_in_the_vec_env():
    # A saved state may hold robots that already arrived (half of those collect-states takes on the
    # dynamic suite): their slots are padding from the start, never a live robot without reward.
    from agents.vec_env import NavVecEnv

    sc = dynamic(n_robots=3, max_steps=40)
    sim = Simulator(sc, 1)
    sim.reset(3)
    sim.world.active[0, 1] = False  # robot 1 arrived and parked
    sim.world.reached[0, 1] = True
    pool = StatePool.take(sim.world, sim.motion_params, [0])
    env = NavVecEnv(sc, n_worlds=2, start_states=StartStates({scenario_key(sc): pool}, prob=1.0))
    env.seed(0)
    obs = env.reset()
    np.testing.assert_array_equal(env.live_mask(), [True, False, True] * 2)
    assert not obs[[1, 4]].any() and obs[[0, 2, 3, 5], 4].all()  # index 4: v_max, > 0 for real robots
    ended = False
    for _ in range(60):
        obs, reward, dones, infos = env.step(np.zeros((6, 2)))
        assert reward[[1, 4]].sum() == 0 and all(infos[i].get("padding") for i in (1, 4) if not dones[i])
        if dones[1]:  # the world reset: the padding segment closes without bootstrapping
            assert infos[1]["TimeLimit.truncated"] is False and "episode" not in infos[1]
            ended = True
            break
    assert ended


def test_a_residual_policy_collects_its_states_as_evaluate_runs_it(tmp_path):
    """A residual checkpoint (``train --residual vcs``) drives with its planner plus its correction: an untrained one,
    its correction zero, is the VCS expert, which keeps clear of the movers; its network alone (zero actions: the
    robots stand) is run into. collect-states played the network alone (states of a policy nobody runs)."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from agents.checkpoint import save_model
    from agents.runs import TrainConfig
    from agents.train import zero_action_head
    from agents.train.collect_states import StatesConfig, collect_states
    from agents.vec_env import NavVecEnv

    scenario = dynamic(n_obstacles=10, on_collision="terminate")
    model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs={"net_arch": [8]}, seed=0)
    zero_action_head(model)
    counts = {}
    for residual in (None, "vcs"):
        cfg = TrainConfig(net_arch=(8,), residual=residual, scenario="dynamic")
        path = save_model(model, tmp_path / str(residual) / "model", "ppo", cfg, scenario)
        states = collect_states(
            StatesConfig(
                policy=str(path), scenario="dynamic", n_robots=3, n_obstacles=10, on_collision="terminate",
                episodes=8, out=str(tmp_path / f"{residual}.npz"),
            )
        )  # fmt: skip
        counts[residual] = sum(len(p) for p in states.pools.values())
    assert counts[None] > 2 * counts["vcs"]
