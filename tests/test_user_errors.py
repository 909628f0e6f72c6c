"""Mistakes a new user makes, each met with a one-line error that names the problem (or with what they meant), found
by running the documented commands and the public API from outside: a gradient clip of 0, suite names where a
scenario is asked for, TorchRL's standard Gym wrapper, a step without an action, bad collection sizes, files that
are not datasets, labels without a policy, reset options no env reads, and the install hints of missing extras."""

import re
import warnings

import gymnasium as gym
import numpy as np
import pytest

import vcs_cli
import vcs_env
from agents.imitation.data import load_dataset
from agents.policies import load_checkpoint
from agents.vec_env import NavVecEnv
from vcs_env.checks import install_hint
from vcs_env.scenario import make_scenario
from vcs_env.suites import SUITES


def test_a_gradient_clip_of_zero_is_refused_before_the_run_starts(tmp_path, capsys):
    # SB3 (and RLlib, BenchMARL) clip the gradients' norm to it: at 0 no weight ever changes, yet the run "succeeds".
    out = tmp_path / "run"
    assert vcs_cli.main(["train", "--max-grad-norm", "0", "--timesteps", "100", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "max_grad_norm must be a finite number in (0.0, inf), got 0.0" in err
    assert not out.exists()


def test_unknown_features_are_refused_before_the_run_directory_is_made(tmp_path, capsys):
    out = tmp_path / "run"
    assert vcs_cli.main(["train", "--features", "bogus", "--timesteps", "100", "--out", str(out)]) == 2
    assert "features must be one of ['flat', 'contact', 'slots', 'slots-fine'], got 'bogus'" in capsys.readouterr().err
    assert not out.exists()  # it used to be left behind, empty


@pytest.mark.parametrize("n_worlds", ["0", "-1"])
def test_collect_refuses_a_batch_of_no_worlds(tmp_path, capsys, n_worlds):
    args = ["collect", "--scenario", "circle", "--episodes", "2", "--n-worlds", n_worlds, "--out", str(tmp_path / "d")]
    assert vcs_cli.main(args) == 2
    assert f"n_worlds must be an integer in [1, 1000000], got {n_worlds}" in capsys.readouterr().err


def test_a_label_without_a_policy_is_named(tmp_path, capsys):
    args = ["compare", "--suite", "circle-8-v0", "--policies", "ppo=", "--out", str(tmp_path / "c"), "--no-plots"]
    assert vcs_cli.main(args) == 2
    assert "policy 'ppo=' has a label and nothing after '='" in capsys.readouterr().err
    args[4] = "x|y=vcs"  # the table's column separator: every column after it was shifted
    assert vcs_cli.main(args) == 2
    assert "policy label 'x|y' holds '|'" in capsys.readouterr().err
    adhoc = ["evaluate", "--policy", "vcs", "--scenario", "circle", "--seeds", "0:2", "--no-progress"]
    for flag in (["--lidar-beams", "8"], ["--stall-clock"], ["--n-wall-points", "4"]):  # the same episodes renamed
        assert vcs_cli.main([*adhoc, *flag]) == 2
        assert f"{flag[0]} set what robots sense, which never changes an episode" in capsys.readouterr().err
    args[4] = "vcs"  # which episode to plot, with no plots: it changed nothing
    assert vcs_cli.main([*args, "--episode", "2"]) == 2
    assert "--episode chooses the episode whose trajectories are plotted" in capsys.readouterr().err


def test_suite_names_give_the_suites_scenario_everywhere_a_scenario_is_named():
    assert make_scenario("crowd-20-v0") is SUITES["crowd-20-v0"].scenario
    assert make_scenario("door-headon-v0", n_robots=4).n_robots == 4
    env = vcs_env.parallel_env(scenario="crowd-5-v0")
    assert env.scenario == SUITES["crowd-5-v0"].scenario
    obs, _ = env.reset(seed=3)
    assert len(obs) == SUITES["crowd-5-v0"].scenario.n_robots
    with pytest.raises(ValueError, match="unknown scenario 'crowd-99-v0'; give a preset .* or a suite name"):
        make_scenario("crowd-99-v0")


def test_unknown_scenario_fields_are_both_value_and_python_keyword_errors():
    # Wrappers that drop an optional keyword on Python's TypeError (TorchRL's GymEnv and `frameskip`) get one.
    for kind in (TypeError, ValueError):
        with pytest.raises(kind, match=r"unknown Scenario fields \['frameskip'\] \(unexpected keyword argument"):
            make_scenario("circle", frameskip=1)


def test_torchrl_standard_gym_wrapper_opens_the_registered_envs():
    pytest.importorskip("torchrl")
    from torchrl.envs import GymEnv

    env = GymEnv("vcs_env/Navigation-v2")
    td = env.rollout(3)
    assert td["next", "observation"].shape[0] == 3


def test_torchrl_env_step_without_an_action_names_it():
    pytest.importorskip("torchrl")
    from vcs_env.torchrl import VcsNavEnv

    env = VcsNavEnv("circle", num_envs=2, n_robots=2)
    with pytest.raises(ValueError, match=r"has no \('agents', 'action'\): set one of shape \(2, 2, 2\)"):
        env.step(env.reset())


def test_load_checkpoint_takes_a_scenario_or_its_name_and_names_anything_else():
    pytest.importorskip("stable_baselines3")
    from agents.checkpoint import CheckpointError

    ckpt = "policies/circle8/model.zip"  # observation v1
    scenario = make_scenario("circle", n_robots=8, observation=1)
    model = load_checkpoint(ckpt, scenario)
    assert model.predict(np.zeros((1, model.observation_space.shape[0]), np.float32))[0].shape == (1, 2)
    with pytest.raises(CheckpointError, match="reads observation v1, but scenario kind='circle' gives v2"):
        load_checkpoint(ckpt, "circle-8-v0")  # the suite's scenario, which observes v2
    env = vcs_env.parallel_env(scenario=scenario)
    with pytest.raises(TypeError, match="scenario must be a Scenario or a preset or suite name, got \\w+ \\(an env"):
        load_checkpoint(ckpt, env)
    with pytest.raises(ValueError, match="unknown scenario 'circel'"):
        load_checkpoint(ckpt, "circel")


def test_a_file_that_is_not_a_dataset_is_named_without_numpys_pickle_advice(tmp_path):
    bad = tmp_path / "notes.npz"
    bad.write_text("not an archive")
    with pytest.raises(ValueError, match="is not a .npz file") as e:
        load_dataset(bad)
    assert "pickle" not in str(e.value)
    with pytest.raises(ValueError, match="is a directory; give the .npz file"):  # it said "dataset not found"
        load_dataset(tmp_path)
    # Hand-edited metadata: named with the dataset (a bare JSON error, and a KeyError in bc, before).
    rows = {"observations": np.zeros((2, 3)), "actions": np.zeros((2, 2)), "rewards": np.zeros(2)}
    rows |= {"traj_start": np.array([0, 2]), "traj_seed": np.array([0])}
    for meta, said in (
        ("{not json", "its meta entry is not JSON"),
        ('{"format": "vcs-env-expert-v1"}', "holds no config"),
    ):
        np.savez(tmp_path / "edited.npz", meta=np.array(meta), **rows)
        with pytest.raises(ValueError, match=f"edited.npz'.*{said}"):
            load_dataset(tmp_path / "edited.npz")


def test_install_hints_name_the_checkout_install_the_readme_uses():
    from agents.checkpoint import RAY_HINT
    from agents.export import EXPORT_HINT

    assert install_hint("orca") == "pip install -e '.[orca]' in the vcs-env checkout"
    assert EXPORT_HINT == install_hint("export") and RAY_HINT.startswith(install_hint("rllib"))


def test_reset_options_that_no_env_reads_are_refused():
    # A user who sets the scenario through reset(options=...) had it ignored: the episode ran the env's own scenario.
    env = gym.make("vcs_env/Navigation-v2", scenario="circle", n_robots=3)
    env.reset(seed=0, options={})  # what Gymnasium's checker and SB3's DummyVecEnv pass
    with pytest.raises(ValueError, match=r"reset reads no options, got \['n_robots'\]: .* made \(gym.make\(id"):
        env.reset(seed=0, options={"n_robots": 4})
    vec = gym.make_vec("vcs_env/Navigation-v2", num_envs=2, scenario="circle", n_robots=3)
    vec.reset(seed=0, options={"reset_mask": np.array([True, False])})
    with pytest.raises(ValueError, match=r"reset reads only \['reset_mask'\], got \['mask'\]"):
        vec.reset(seed=0, options={"mask": np.array([True, False])})
    par = vcs_env.parallel_env(scenario="circle", n_robots=3)
    par.reset(seed=0, options=None)
    with pytest.warns(UserWarning, match=r"reset reads no options, got \['scenario'\]: .*; ignored"):
        par.reset(seed=0, options={"scenario": "crowd"})  # PettingZoo's API test resets with an arbitrary option
    venv = NavVecEnv(make_scenario("circle", n_robots=3), n_worlds=2)
    venv.seed(3)
    with pytest.raises(ValueError, match=r"got \['n_robots'\]: .*made \(NavVecEnv\(make_scenario"):
        venv.set_options({"n_robots": 4})  # SB3's VecEnv API: the options of the next reset, refused at once
    with pytest.raises(ValueError, match=r"got \['n_robots'\]"):
        venv.set_options([{}, {"n_robots": 4}])
    venv.set_options([{}] * venv.num_envs)
    first = venv.reset()  # the seed set before the refusals still holds
    venv.seed(3)
    assert np.array_equal(venv.reset(), first) and first.shape[0] == 6


def test_a_step_before_the_first_reset_says_so():
    env = vcs_env.parallel_env(scenario="circle", n_robots=2, max_steps=5, render_mode="ansi")
    with pytest.raises(RuntimeError, match=r"step\(\) called before the first reset\(\)"):
        env.step({})
    for call in ("state", "render"):  # they gave zeros and robots at (0, 0), "crashed"
        with pytest.raises(RuntimeError, match=rf"{call}\(\) called before the first reset\(\)"):
            getattr(env, call)()
    env.reset(seed=0)
    while env.agents:
        env.step({a: np.array([0.0, 0.0], dtype=np.float32) for a in env.agents})
    with pytest.raises(RuntimeError, match=r"step\(\) called on a finished episode"):
        env.step({})


def test_the_gymnasium_env_refuses_a_step_before_reset_and_after_the_end():
    """As the PettingZoo env: it rendered a zeroed world before reset, and after the end stepped on with terminated
    False again, no truncation ever, and the time cost paid to a robot past its episode."""
    from vcs_env.gym_env import VcsNavEnv

    env = VcsNavEnv(scenario="circle", n_robots=2, max_steps=5, render_mode="ansi")
    for call, args in (("step", (np.zeros(2, np.float32),)), ("render", ())):
        with pytest.raises(RuntimeError, match=rf"{call}\(\) called before the first reset\(\)"):
            getattr(env, call)(*args)
    for _ in range(2):  # the second episode ends as the first
        env.reset(seed=0)
        ended, steps = False, 0
        while not ended:
            _, _, terminated, truncated, _ = env.step(np.zeros(2, np.float32))
            ended, steps = terminated or truncated, steps + 1
        assert truncated and steps == 5
        with pytest.raises(RuntimeError, match=r"step\(\) called on a finished episode; call reset\(\) first"):
            env.step(np.zeros(2, np.float32))
        assert "robot_0" in env.render()  # the ended episode still renders


def test_a_refused_train_run_leaves_no_directory_and_conflicting_weights_are_named(tmp_path, capsys):
    base = ["train", "--n-robots", "2", "--timesteps", "64", "--n-worlds", "1", "--n-steps", "64", "--batch-size", "64"]
    base += ["--eval-freq", "0", "--eval-episodes", "1", "--no-progress-bar", "--out", str(tmp_path / "run")]
    assert vcs_cli.main([*base, "--lr-schedule", "bogus"]) == 2  # refused while PPO is set up
    assert "bogus" in capsys.readouterr().err and not (tmp_path / "run").exists()
    assert vcs_cli.main([*base, "--eval-seed", "-1"]) == 2  # refused before training, not at its first evaluation
    assert "--eval-seed must be >= 0, got -1" in capsys.readouterr().err and not (tmp_path / "run").exists()
    bc = ["bc", "--data", str(tmp_path / "none.npz"), "--out", str(tmp_path / "bc")]
    for flag in ("--seed", "--dagger-seed", "--eval-seed"):  # every seed flag by its name, before anything is read
        assert vcs_cli.main([*bc, flag, "-5"]) == 2
        assert f"vcs-env bc: error: {flag} must be >= 0, got -5" in capsys.readouterr().err
    assert vcs_cli.main([*base, "--shaping", "vcs_potential", "--rewards", "vcs_potential=0.7"]) == 2
    assert "--rewards sets vcs_potential=0.7 and --shaping vcs_potential sets its weight too" in capsys.readouterr().err
    assert vcs_cli.main([*base, "--rewards", "collision=1,time=2,collision=5"]) == 2  # the last one won, silently
    assert "rewards: 'collision' is given twice" in capsys.readouterr().err
    assert vcs_cli.main([*base, "--shaping-weight", "0.4"]) == 2
    assert "--shaping-weight weighs the --shaping term: give --shaping too" in capsys.readouterr().err
    for flag, value, needs in (  # a setting of another flag's feature alone changed nothing, and was recorded
        ("--residual-scale", "0.9", "--residual"),
        ("--guide-weight", "5", "--guide"),
        ("--mixture-balance", "robots", "--mixture"),
        ("--start-prob", "0.9", "--start-states"),
        ("--residual-scale", "0.5", "--residual"),  # the default value, given: the same
        ("--guide-weight", "1.0", "--guide"),
    ):
        assert vcs_cli.main([*base, flag, value]) == 2
        assert f"give {needs} too, or leave {flag} out" in capsys.readouterr().err and not (tmp_path / "run").exists()


def test_outputs_never_overwrite_a_checkpoint_its_record_or_a_file_given_as_a_run_directory(tmp_path, capsys):
    """``--json`` over a checkpoint's run record or weights is refused before the episodes (it made the checkpoint
    unloadable); a results file is replaced; a run directory that is a file is refused before any work."""
    import shutil

    run = tmp_path / "c8"
    run.mkdir()
    for f in ("model.zip", "model.json"):
        shutil.copy(f"policies/circle8/{f}", run / f)
    base = ["evaluate", "--suite", "circle-8-v0-smoke", "--policy", str(run), "--json"]
    record = (run / "model.json").read_text()
    assert vcs_cli.main([*base, str(run / "model.json")]) == 2
    assert "is a checkpoint's run record that this would overwrite" in capsys.readouterr().err
    assert vcs_cli.main([*base, str(run / "model.zip")]) == 2
    assert "is a .zip file (a checkpoint or data) that this would overwrite" in capsys.readouterr().err
    assert (run / "model.json").read_text() == record
    for _ in range(2):  # a results file is written, then replaced
        assert vcs_cli.main([*base, str(tmp_path / "results.json")]) == 0
    (tmp_path / "afile").write_text("")
    select = ["select", str(run), "--validation", "circle:0:2", "--out", str(tmp_path / "afile")]
    assert vcs_cli.main(select) == 2
    assert f"--out {str(tmp_path / 'afile')!r} is a file: give a directory for the run" in capsys.readouterr().err
    under = ["select", str(run), "--validation", "circle:0:2", "--out", str(tmp_path / "afile" / "x")]
    assert vcs_cli.main(under) == 2  # bc failed so only after its training, when the model was saved
    assert f"lies under {str(tmp_path / 'afile')!r}, a file: give a directory" in capsys.readouterr().err


def test_wrong_types_are_named_before_they_are_used():
    with pytest.raises(ValueError, match="observation must be an integer in \\[1, 2\\], got None"):
        vcs_env.make_scenario("walls", observation=None, n_wall_points=2, wall_segments=True)  # was a TypeError
    with pytest.raises(ValueError, match="reward_terms must be a dict \\{name: \\(weight, fn\\)\\}, got a list"):
        vcs_env.parallel_env(reward_terms=[("a", (1.0, lambda *a: 0.0))])  # was an AttributeError deep inside


def test_a_dataset_given_as_a_policy_is_named_as_one(tmp_path):
    """A collect dataset passed as --policy was read as an SB3 file and the error advised copying a run record."""
    from agents.checkpoint import CheckpointError, open_checkpoint

    np.savez(tmp_path / "data.npz", observations=np.zeros((1, 3)))
    with pytest.raises(CheckpointError, match=r"is a dataset \(vcs-env collect's \.npz\), not a checkpoint"):
        open_checkpoint(tmp_path / "data.npz")


def test_a_custom_goal_no_robot_can_arrive_at_is_refused():
    """A goal inside a still obstacle, or two goals too close for both robots to park: every episode was truncated
    (the goal on a wall was refused already). With finished robots leaving the world, shared goals are fine."""
    from vcs_env.custom_layout import ObstacleTrajectory

    twins = vcs_env.CustomLayout(start=[(0, 0), (0, 2)], goal=[(3, 1), (3, 1.25)])
    with pytest.raises(ValueError, match="goals of robots 0 and 1 are too close for both to park there"):
        vcs_env.make_scenario("custom", custom=twins)
    assert vcs_env.make_scenario("custom", custom=twins, park_finished=False).n_robots == 2
    apart = vcs_env.CustomLayout(start=[(0, 0), (0, 2)], goal=[(3, 1), (3, 1.35)])  # 0.35 + 2 r_goal >= 2 radii
    # ... possible, but only if neither parks toward the other (it parks where it first comes within r_goal): said
    with pytest.warns(UserWarning, match=r"goals of robots 0 and 1 are 0.35 m apart, less than two radii and twice"):
        assert vcs_env.make_scenario("custom", custom=apart).n_robots == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # two radii and twice r_goal apart: nothing to say
        vcs_env.make_scenario("custom", custom=vcs_env.CustomLayout(start=[(0, 0), (0, 2)], goal=[(3, 1), (3, 1.7)]))
    rock = ObstacleTrajectory(times=(0,), positions=((3, 0),), radius=0.5)
    inside = vcs_env.CustomLayout(start=[(0, 0)], goal=[(3.5, 0)], obstacles=(rock,))
    with pytest.raises(ValueError, match="the goal of robot 0 lies inside still obstacle 0"):
        vcs_env.make_scenario("custom", custom=inside)
    beside = vcs_env.CustomLayout(start=[(0, 0)], goal=[(3.7, 0)], obstacles=(rock,))  # 0.7 + r_goal > 0.75
    assert vcs_env.make_scenario("custom", custom=beside).n_robots == 1
    # An obstacle that comes to rest on a goal blocks it as well (it holds its last waypoint for good).
    park = ObstacleTrajectory(times=(0.0, 1.0), positions=((3.0, 3.0), (3.0, 0.0)), radius=0.4)
    parked = vcs_env.CustomLayout(start=[(-3.0, 0.0)], goal=[(3.0, 0.0)], obstacles=(park,))
    with pytest.raises(ValueError, match=r"inside obstacle 0 where it comes to rest \(its last waypoint, from 1 s\)"):
        vcs_env.make_scenario("custom", custom=parked)
    # Coordinates beyond COORD_LIMIT (a start at 1e155 m made the progress reward NaN), headings and speeds that are
    # no numbers (numpy's messages named no field; True was a speed of 1), a heading of many turns (wrapped).
    for kw, said in (
        ({"start": [(1e155, 0.0)]}, r"CustomLayout.start\[0\] = .* is beyond \+-1e\+06 m"),
        ({"walls": [((-1e155, -1.5), (1e155, -1.5))]}, r"CustomLayout.walls\[0\] = .* reaches beyond \+-1e\+06 m"),
        ({"heading": ["a"]}, "CustomLayout.heading must be numbers, one per robot, got \\['a'\\]"),
        ({"heading": [1j]}, "CustomLayout.heading must be numbers"),
        ({"speed": [True]}, "CustomLayout.speed must be numbers"),
    ):
        with pytest.raises(ValueError, match=said):
            vcs_env.CustomLayout(**{"start": [(0.0, 0.0)], "goal": [(3.0, 0.0)], **kw})
    turns = vcs_env.CustomLayout(start=[(0.0, 0.0)], goal=[(3.0, 0.0)], heading=[3.14159e12])
    assert -np.pi <= turns.heading[0] < np.pi
    kept = vcs_env.CustomLayout(start=[(0.0, 0.0)], goal=[(3.0, 0.0)], heading=[0.1])
    assert kept.heading == (0.1,)  # a heading within a half turn is kept as given, bit for bit


def test_a_crowd_whose_obstacles_cannot_fit_between_the_robots_is_refused_when_made():
    """16 robots of radius 0.5 m on the crowd circle leave no room for an obstacle: every reset failed, the scenario
    was accepted (the ring's length was checked, not the room between the robots)."""
    with pytest.raises(ValueError, match="no crowd obstacle of radius 0.3 m fits"):
        vcs_env.parallel_env(scenario="crowd", n_robots=16, n_obstacles=1, robot={"radius": 0.5})
    env = vcs_env.parallel_env(scenario="crowd", n_robots=8, n_obstacles=1, robot={"radius": 0.5})
    env.reset(seed=0)  # room for it: made and reset


def test_an_env_whose_time_limit_nobody_can_arrive_in_warns():
    """The command line grows a grown layout's time limit; the envs keep the scenario's, and now say when no robot can
    arrive in it (a 76.8 m circle of 256 robots in the preset's 60 s: every episode truncated, silently)."""
    import warnings

    with pytest.warns(UserWarning, match="leaves no robot the time to arrive.*every episode will be truncated"):
        vcs_env.parallel_env(scenario="circle", n_robots=256)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vcs_env.parallel_env(scenario="circle", n_robots=256, max_steps=2000)
        vcs_env.parallel_env(scenario="circle", n_robots=256, max_cycles=2000)  # the env's own limit counts
    # The limit named as given, with the least one that leaves the time (it said max_steps=20 for max_cycles=20).
    with pytest.warns(
        UserWarning, match=r"max_cycles=20 .*leaves no robot the time to arrive.*max_cycles >= (\d+)\)"
    ) as w:
        vcs_env.parallel_env(scenario="circle", max_cycles=20)
    least = int(re.search(r"max_cycles >= (\d+)\)", str(w[0].message)).group(1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vcs_env.parallel_env(scenario="circle", max_cycles=least)
    with pytest.warns(UserWarning, match=rf"max_cycles={least - 1} "):
        vcs_env.parallel_env(scenario="circle", max_cycles=least - 1)
    with pytest.warns(UserWarning, match=r"max_steps=20 .*max_steps >= "):
        vcs_env.parallel_env(scenario="circle", max_steps=20)


SCRIPTED = vcs_env.CustomLayout(
    start=[(0, 0)], goal=[(4, 0)], obstacles=(vcs_env.ObstacleTrajectory(times=(0, 5), positions=((2, 2), (2, -2))),)
)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"scenario": "random", "jitter": 2.0}, "jitter does not apply to random scenarios"),
        ({"scenario": "circle", "n_walls": 3}, "n_walls does not apply to circle scenarios"),
        ({"scenario": "dynamic", "layout_radius": 3.0}, "layout_radius does not apply to dynamic scenarios"),
        ({"scenario": "circle", "obstacle_motion": "constant"}, "obstacle_motion needs obstacles"),
        ({"scenario": "custom", "custom": SCRIPTED, "bounce": True}, "bounce does not apply to custom scenarios"),
        (
            {"scenario": "crowd", "obstacle_motion": "pedestrians", "obstacle_speed": (2.0, 2.5)},
            "obstacle_speed does not apply to obstacle_motion='pedestrians'.*PedestrianSpec.v_pref",
        ),
        ({"scenario": "dynamic", "obstacle_motion": "constant", "turn_rate": 1.0}, "turn_rate does not apply to"),
        ({"scenario": "crowdnav-circle-v0", "go_time": (1.0, 2.0)}, "go_time does not apply to"),
    ],
)
def test_an_env_keyword_that_cannot_change_the_episodes_is_refused_as_on_the_command_line(kwargs, message):
    """The envs dropped these silently (the same worlds as without them); the command line refused them by name."""
    import gymnasium as gym

    with pytest.raises(ValueError, match=message):
        vcs_env.parallel_env(**kwargs)
    with pytest.raises(ValueError, match=message):
        gym.make("vcs_env/Navigation-v2", **kwargs)


@pytest.mark.parametrize("field, value", [("bounce", True), ("turn_rate", 1.0), ("go_time", [1.0, 2.0])])
def test_a_custom_scenario_built_directly_refuses_what_its_scripts_ignore(field, value):
    """``Scenario(kind="custom", bounce=True)`` was accepted and the scripts drove the obstacles as without it; the
    defaults, also as lists from JSON, stay accepted."""
    from vcs_env.scenario import Scenario

    with pytest.raises(ValueError, match=f"{field} does not apply to custom scenarios"):
        Scenario(kind="custom", custom=SCRIPTED, n_robots=1, n_obstacles=1, **{field: value})
    Scenario(kind="custom", custom=SCRIPTED, n_robots=1, n_obstacles=1, bounce=False, go_time=[2.0, 5.0])


def test_the_time_limit_warning_names_the_users_line():
    """A fixed stacklevel named a line inside the library for the class constructors and inside Gymnasium for
    ``gym.make``; the warning now points at the caller's line, however it made the env."""
    import warnings

    import gymnasium as gym

    from vcs_env.parallel import VcsNavParallelEnv

    makers = [
        lambda: vcs_env.parallel_env(scenario="circle", n_robots=256),
        lambda: VcsNavParallelEnv(scenario="circle", n_robots=256),
        lambda: gym.make("vcs_env/Navigation-v2", scenario="circle", n_robots=256),
    ]
    for make in makers:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            make()
        assert [w.filename for w in caught if "time to arrive" in str(w.message)] == [__file__]


def test_motion_settings_stay_with_the_motions_that_read_them():
    """What the refusals above leave alone: a preset's own unread settings (the crowd's speeds under pedestrians),
    a field the named motion reads, and any field beside an obstacle motion object of one's own (it may read it)."""
    from vcs_env.obstacles import ObstacleMotion

    vcs_env.parallel_env(scenario="crowd", obstacle_motion="pedestrians")
    vcs_env.parallel_env(scenario="dynamic", obstacle_motion="arbitrary", turn_rate=1.0, obstacle_speed=(0.3, 0.4))
    vcs_env.parallel_env(scenario="dynamic", obstacle_motion=ObstacleMotion(), turn_rate=1.0)


def test_another_motion_on_a_suite_with_pedestrians():
    """No flag sets or clears a suite's PedestrianSpec, and --obstacle-motion constant on a CrowdNav suite failed
    naming it; the command line now drops the spec with the motion, and the envs' error says how to."""
    from agents.config import ScenarioConfig, build_scenario

    s = build_scenario(ScenarioConfig(scenario="crowdnav-circle-v0", obstacle_motion="constant"))
    assert s.obstacle_motion == "constant" and s.pedestrians is None
    with pytest.raises(ValueError, match="give pedestrians=None too"):
        vcs_env.parallel_env(scenario="crowdnav-circle-v0", obstacle_motion="constant")
    vcs_env.parallel_env(scenario="crowdnav-circle-v0", obstacle_motion="constant", pedestrians=None)


def test_imitation_flags_without_their_partner_are_refused():
    """They were accepted and the run was bit for bit the one without them (a helper's sweep compared weights)."""
    from agents.imitation import BCConfig
    from agents.imitation.distil import DistilConfig

    for kw in ({"dagger_beta": 0.3}, {"dagger_seed": 7}, {"dagger_episodes": 3}, {"dagger_epochs": 2}):
        with pytest.raises(ValueError, match="set DAgger's rounds: give --dagger-iters too"):
            BCConfig(**kw)
        BCConfig(**kw, dagger_iters=1)
    with pytest.raises(ValueError, match="--init keeps the checkpoint's"):
        BCConfig(init="policies/circle8/model.zip", log_std_init=-1.0)
    for arch in ((0,), (64, -3), ()):  # as train checks it: (0,) saved a policy of one constant action
        with pytest.raises(ValueError, match="net_arch must be one or more layer sizes >= 1"):
            BCConfig(net_arch=arch)
    with pytest.raises(ValueError, match="--start-prob is the share of episodes begun from --start-states"):
        DistilConfig(start_prob=0.3)


def test_a_run_record_that_is_not_a_json_object_is_named(tmp_path, capsys):
    """model.json holding a list or a string crashed every loading door (AttributeError: 'list' object has no
    attribute 'get'); an empty object was called missing."""
    import shutil

    from agents.checkpoint import CheckpointError

    run = tmp_path / "run"
    run.mkdir()
    shutil.copy("policies/generalist-v2/model.zip", run / "model.zip")
    for text, kind in (("[1, 2]", "list"), ('"just a string"', "str")):
        (run / "model.json").write_text(text)
        with pytest.raises(CheckpointError, match=f"is a JSON {kind}, not a run record"):
            load_checkpoint(run, "doorway-v0")
        assert vcs_cli.main(["evaluate", "--suite", "doorway-v0-smoke", "--policy", str(run), "--no-progress"]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and f"is a JSON {kind}" in err
    (run / "model.json").write_text("{}")
    with pytest.raises(CheckpointError, match=r"model.json' holds no fields"):
        load_checkpoint(run, "doorway-v0")  # the scenario's sensing does not fit, and nothing says the trained one


@pytest.mark.parametrize(
    "args",
    [
        ["collect", "--scenario", "circle", "--n-robots", "2", "--episodes", "2", "--out", "/proc/vcs-env-x.npz"],
        ["compare", "--suite", "circle-8-v0-smoke", "--policies", "vcs", "--out", "/proc/vcs-env-x"],
        ["evaluate", "--suite", "circle-8-v0-smoke", "--policy", "vcs", "--json", "/proc/vcs-env-x.json"],
        ["train", "--n-robots", "2", "--timesteps", "10", "--out", "/proc/vcs-env-x"],
    ],
)
def test_outputs_that_cannot_be_written_are_refused_before_the_work(args, capsys, monkeypatch):
    """collect, compare and evaluate --json ran every episode and then failed with a PermissionError traceback; train
    failed with one before training. (/proc takes no new file, even from root, who may write in a chmod 555
    directory.)"""
    from vcs_env import rollout

    monkeypatch.setattr(rollout, "play", lambda *a, **k: pytest.fail("episodes were run"))
    assert vcs_cli.main(args) == 2
    err = capsys.readouterr().err
    assert f"{args[-2]} {args[-1]!r} cannot be written" in err and "Traceback" not in err
