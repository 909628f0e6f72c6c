"""Issue 13 infrastructure: ad-hoc evaluation from scenario flags, training settings against the
suites, training on mixtures (groups of worlds), reproducible toy runs."""

import dataclasses
import json
import math
import re

import numpy as np
import pytest

import vcs_cli as cli
from agents.config import (
    ScenarioConfig,
    build_scenario,
    parse_seeds,
    probe_scenario,
    suite_differences,
)
from vcs_env.scenario import MAPS, SCENARIOS, TIME_MARGIN, fit_time_limit
from vcs_env.suites import get_suite


def test_parse_seeds_ranges_and_errors():
    assert parse_seeds("5000:5003") == (5000, 5001, 5002)
    assert parse_seeds("7") == (7,)
    for bad, msg in (("5:3", "0 <= START < STOP"), ("-1:3", "0 <= START"), ("a:b", "START:STOP"), ("1:", "START")):
        with pytest.raises(ValueError, match=msg):
            parse_seeds(bad)


def test_probe_scenario_starts_from_the_family_suite():
    suite = get_suite("circle-8-v0").scenario
    assert probe_scenario(ScenarioConfig(scenario="circle")) == suite
    s = probe_scenario(ScenarioConfig(scenario="circle", n_robots=12, jitter=0.3))
    assert (s.n_robots, s.jitter, s.on_collision, s.min_separation) == (12, 0.3, "continue", 0.3)
    assert s.circle_radius == 5.0 and probe_scenario(ScenarioConfig(n_robots=24)).circle_radius == pytest.approx(7.2)
    crowd = probe_scenario(ScenarioConfig(scenario="crowd", n_obstacles=3, obstacle_speed=(1.0, 1.5)))
    assert (crowd.n_obstacles, crowd.obstacle_speed, crowd.min_separation) == (3, (1.0, 1.5), 0.2)
    for build in (probe_scenario, build_scenario):  # the custom preset's example layout is no user's choice
        with pytest.raises(ValueError, match="--scenario custom has no layout here"):
            build(ScenarioConfig(scenario="custom"))
    straight = probe_scenario(ScenarioConfig(scenario="dynamic", obstacle_motion="constant"))
    assert straight == dataclasses.replace(get_suite("dynamic-v0").scenario, obstacle_motion="constant")


def test_training_differences_from_the_suite_are_listed():
    suite, diffs = suite_differences(build_scenario(ScenarioConfig(scenario="crowd")))
    assert suite == "crowd-5-v0"
    assert diffs == ["on_collision: terminate (suite: continue)", "min_separation: 0.3 (suite: 0.2)"]
    assert suite_differences(get_suite("swap-v0").scenario) == ("swap-v0", [])
    assert suite_differences(SCENARIOS["custom"]) == (None, [])  # no custom suite


def test_the_time_limit_grows_with_the_layout_or_refuses_a_hopeless_one(capsys):
    big = build_scenario(ScenarioConfig(scenario="circle", n_robots=256))
    assert big.circle_radius == pytest.approx(76.8) and big.max_time >= TIME_MARGIN * big.least_time_to_goal
    assert big.max_steps == 9304  # the preset's 600 steps for its 10 m trip, for 153.5 m
    assert "note: max_steps 600 -> 9304" in capsys.readouterr().out
    # An explicit limit is kept, with a note when nobody can arrive in it.
    assert build_scenario(ScenarioConfig(scenario="circle", n_robots=256, max_steps=100)).max_steps == 100
    assert "note: max_steps=100 (10 s at dt=0.1 s) leaves no robot the time to arrive" in capsys.readouterr().out
    # Layouts the preset's limit fits keep it, with no note: the suites' and the generalist mixture's sizes.
    for n in (8, 24, 28, 40):
        assert build_scenario(ScenarioConfig(scenario="circle", n_robots=n)).max_steps == 600
    assert build_scenario(ScenarioConfig(scenario="circle-40-v0")) == get_suite("circle-40-v0").scenario
    assert capsys.readouterr().out == ""
    # A kind with no bound on the trip (random starts and goals) is left alone.
    assert fit_time_limit(SCENARIOS["random"], SCENARIOS["random"]) == (SCENARIOS["random"], None)
    # Ad-hoc evaluation (probe_scenario: from the family's suite) grows it too, and says so.
    wide = probe_scenario(ScenarioConfig(scenario="circle", layout_radius=40.0))
    assert (
        wide.max_time >= TIME_MARGIN * wide.least_time_to_goal and "note: max_steps 600 ->" in capsys.readouterr().out
    )
    assert probe_scenario(ScenarioConfig(scenario="circle", layout_radius=40.0, max_steps=100)).max_steps == 100
    assert "leaves no robot the time to arrive" in capsys.readouterr().out
    assert probe_scenario(ScenarioConfig(scenario="circle")) == get_suite("circle-8-v0").scenario
    assert capsys.readouterr().out == ""
    # A layout that spans the arena grows with an arena larger than the scenario it is made from: walls in 8 m against
    # the preset's 6 m, 4/3 of the preset's limit; a smaller arena keeps the preset's.
    preset = MAPS["walls"].max_steps
    walls = build_scenario(ScenarioConfig(scenario="walls", arena_half_size=8.0))
    assert walls.max_steps == math.ceil(preset * 8.0 / 6.0) > preset
    assert "walls layout the arena's half size is 8 m (the scenario it grew from: 6 m)" in capsys.readouterr().out
    assert build_scenario(ScenarioConfig(scenario="walls", arena_half_size=5.0)).max_steps == preset


def test_arena_half_size_is_a_flag_where_the_arena_sets_the_worlds():
    """``--arena-half-size`` (and the mixture field) sizes the layouts that span the arena, and the arena obstacles
    bounce off; a scenario it cannot change refuses it by name, as a layout field it does not read."""
    from agents.mixture import mixture_scenarios

    assert build_scenario(ScenarioConfig(scenario="random", arena_half_size=7.5)).arena_half_size == 7.5
    doors = mixture_scenarios(ScenarioConfig(), ("doorway:arena_half_size=4-5/1",))
    assert [s.arena_half_size for s in doors] == [4, 5]
    for name in ("circle", "crowd", "corridor"):
        with pytest.raises(ValueError, match=f"arena_half_size does not apply to {name} scenarios"):
            build_scenario(ScenarioConfig(scenario=name, arena_half_size=8.0))
    # With obstacles a kind places in the arena (not the crowd's ring), the arena sizes where they are placed.
    assert build_scenario(ScenarioConfig(scenario="circle", n_obstacles=3, arena_half_size=8.0)).arena_half_size == 8
    with pytest.raises(ValueError, match="arena_half_size does not apply to crowd scenarios"):
        build_scenario(ScenarioConfig(scenario="crowd", n_obstacles=3, arena_half_size=8.0))
    bouncing = build_scenario(ScenarioConfig(scenario="dynamic-fast-v0", arena_half_size=8.0))
    assert bouncing.bounce and bouncing.arena_half_size == 8.0
    square = build_scenario(ScenarioConfig(scenario="crowdnav-square-v0", arena_half_size=6.0))
    assert square.arena_half_size == 6.0  # pedestrians crossing the square walk in the arena
    for suite in ("crowdnav-circle-v0", "crowdnav-circle-unicycle-v0"):  # those crossing the circle never read it
        with pytest.raises(ValueError, match="arena_half_size does not apply to crowd scenarios"):
            build_scenario(ScenarioConfig(scenario=suite, arena_half_size=8.0))


def test_cli_evaluate_and_compare_on_ad_hoc_episodes(tmp_path, capsys):
    out = tmp_path / "out.json"
    args = ["evaluate", "--policy", "vcs", "--scenario", "circle", "--n-robots", "5", "--jitter", "0.3"]
    assert cli.main([*args, "--seeds", "5000:5002", "--json", str(out), "--no-progress"]) == 0
    data = json.loads(out.read_text())
    assert [e["seed"] for e in data["episodes"]] == [5000, 5001]
    assert data["suite"] == "circle[n_robots=5,jitter=0.3]@5000:5002"
    assert data["summary"]["success"]["mean"] == 1.0
    report = tmp_path / "report"
    args = ["compare", "--policies", "vcs,straight", "--scenario", "crowd", "--n-obstacles", "3"]
    assert cli.main([*args, "--seeds", "10:12", "--out", str(report), "--no-plots", "--no-progress"]) == 0
    data = json.loads((report / "results.json").read_text())
    assert data["seeds"] == [10, 11]
    # The report records the command that made it, with the date and machine.
    assert data["provenance"].startswith("`vcs-env compare --policies vcs,straight --scenario crowd --n-obstacles 3")
    assert data["provenance"] in (report / "results.md").read_text()
    assert f"numpy {np.__version__}, numba" in data["provenance"]  # and the library versions a rerun matches
    args = ["evaluate", "--policy", "vcs", "--scenario", "dynamic", "--obstacle-motion", "constant", "--seeds", "3:4"]
    assert cli.main([*args, "--json", str(out), "--no-progress"]) == 0
    assert json.loads(out.read_text())["suite"] == "dynamic[obstacle_motion=constant]@3:4"
    capsys.readouterr()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--scenario", "circle"], "give --suite NAME, or scenario flags"),
        (["--seeds", "9:3"], "0 <= START < STOP"),
        (["--suite", "swap-v0-smoke", "--n-robots", "4"], "either --suite or scenario flags"),
        (["--suite", "swap-v0-smoke", "--lidar-beams", "16"], "(got --suite and --lidar-beams)"),
        (["--scenario", "nope", "--seeds", "1:2"], "unknown scenario 'nope'"),
        (["--scenario", "crowd", "--obstacle-speed", "1", "--seeds", "1:2"], "obstacle_speed must be two numbers"),
        (["--scenario", "dynamic", "--obstacle-motion", "wobbly", "--seeds", "1:2"], "obstacle_motion must be one of"),
    ],
)
def test_cli_ad_hoc_errors_are_messages(args, message, capsys):
    assert cli.main(["evaluate", "--policy", "vcs", "--no-progress", *args]) == 2
    assert message in capsys.readouterr().err


# --------------------------------------------------------------------------- mixtures
def test_obstacle_motion_flag_applies_to_every_mixture_entry():
    from agents.mixture import mixture_scenarios

    entries = ("dynamic-v0", "crowd-5-v0:n_obstacles=3-4")
    assert [s.obstacle_motion for s in mixture_scenarios(ScenarioConfig(), entries)] == ["arbitrary", *["constant"] * 2]
    moved = mixture_scenarios(ScenarioConfig(obstacle_motion="stop_and_go"), entries)
    assert [s.obstacle_motion for s in moved] == ["stop_and_go"] * 3


def test_mixture_entries_expand_to_grids_and_bad_entries_are_named():
    from agents.mixture import mixture_scenarios, parse_mixture_entry

    assert parse_mixture_entry("circle:n_robots=4-16/4,jitter=0-0.4") == (
        "circle",
        {"n_robots": (4, 8, 12, 16), "jitter": (0.0, 0.2, 0.4)},
    )
    assert parse_mixture_entry("crowd:n_obstacles=3,obstacle_speed=1-1.5") == (
        "crowd",
        {"n_obstacles": (3,), "obstacle_speed": ((1.0, 1.5),)},
    )
    # Numbers in exponent notation: the exponent's dash is not the range's.
    assert parse_mixture_entry("circle:jitter=1e-2") == ("circle", {"jitter": (0.01,)})
    assert parse_mixture_entry("circle:jitter=1e-2-3e-2/1e-2") == ("circle", {"jitter": (0.01, 0.02, 0.03)})
    scenarios = mixture_scenarios(
        ScenarioConfig(on_collision="continue"), ("circle:n_robots=4-8/4,jitter=0-0.2/0.2", "crowd")
    )
    assert [(s.kind, s.n_robots, s.jitter) for s in scenarios] == [
        ("circle", 4, 0.0),
        ("circle", 4, 0.2),
        ("circle", 8, 0.0),
        ("circle", 8, 0.2),
        ("crowd", 1, 0.0),
    ]
    assert {s.on_collision for s in scenarios} == {"continue"}  # common flags apply to every entry
    for entry, msg in (
        ("circel", "unknown scenario 'circel'"),
        ("circle:speed=1", "FIELD in"),
        ("circle:n_robots=8-4", "LO <= HI"),
        ("circle:n_robots=a", "needs int values"),
        ("circle:jitter=inf", "jitter needs finite values, got 'inf'"),
        ("circle:jitter=0-nan", "needs finite values"),
    ):
        with pytest.raises(ValueError, match=msg):
            parse_mixture_entry(entry)
    with pytest.raises(ValueError, match="set --n-robots inside the mixture entries"):
        mixture_scenarios(ScenarioConfig(n_robots=8), ("circle",))
    with pytest.raises(ValueError, match="set --scenario inside the mixture entries"):
        mixture_scenarios(ScenarioConfig(scenario="dynamic"), ("circle",))


def test_map_fields_and_sensing_flags_reach_every_mixture_entry():
    """Map entries set corridor and door widths and wall counts; the sensing flags apply to every entry
    (one observation config for the mixture); a map field on a kind that does not read it is refused."""
    from agents.mixture import mixture_scenarios

    entries = ("doorway-v0:door_width=1.2-1.6/0.2", "walls:n_walls=4-8/4", "corridor:corridor_width=2.5", "circle")
    scenarios = mixture_scenarios(ScenarioConfig(n_wall_points=6, lidar_beams=8), entries)
    assert [(s.kind, s.door_width, s.n_walls, s.corridor_width) for s in scenarios][:5] == [
        ("doorway", 1.2, 8, 2.0),
        ("doorway", 1.4, 8, 2.0),
        ("doorway", 1.6, 8, 2.0),
        ("walls", 1.2, 4, 2.0),
        ("walls", 1.2, 8, 2.0),
    ]
    assert scenarios[5].corridor_width == 2.5
    assert {(s.n_wall_points, s.lidar.n_beams) for s in scenarios} == {(6, 8)}
    for entry, msg in (("circle:door_width=1.2", "door_width does not apply to circle"),
                       ("walls:corridor_width=2", "corridor_width does not apply to walls")):  # fmt: skip
        with pytest.raises(ValueError, match=msg):
            mixture_scenarios(ScenarioConfig(), (entry,))
    with pytest.raises(ValueError, match="set --n-walls inside the mixture entries"):
        mixture_scenarios(ScenarioConfig(n_walls=4), ("walls",))


def test_mixture_grids_end_at_hi_and_fields_that_change_nothing_are_refused():
    """A grid whose step does not reach HI, a step on the speed interval, a field given twice,
    and a field the entry's scenario does not read are errors naming the entry, never a silently
    shorter grid or a scenario repeated under another label."""
    from agents.mixture import mixture_scenarios, parse_mixture_entry

    assert parse_mixture_entry("circle:n_robots=4-12/4,jitter=0.1-0.5/0.2")[1] == {
        "n_robots": (4, 8, 12),
        "jitter": (0.1, 0.3, 0.5),
    }
    for entry, msg in (
        ("circle:n_robots=4-12/3", "does not end at 12: the step must divide HI - LO"),
        ("circle:jitter=0.1-0.5/0.3", "does not end at 0.5"),
        ("crowd:obstacle_speed=1.0-1.5/0.1", "it takes no /STEP"),
        ("circle:n_robots=4,n_robots=8", "n_robots is set twice"),
    ):
        with pytest.raises(ValueError, match=f"mixture entry '{re.escape(entry)}': .*{msg}"):
            parse_mixture_entry(entry)
    for entry, msg in (
        ("crowd:jitter=0.1-0.3/0.2", "jitter does not apply to crowd scenarios"),
        ("dynamic-v0:layout_radius=4", "layout_radius does not apply to dynamic scenarios"),
        ("circle:obstacle_speed=0.5-1", "obstacle_speed needs obstacles"),
        ("swap-v0:n_robots=5-9/2", "n_robots must be even"),
    ):
        with pytest.raises(ValueError, match=f"mixture entry '{re.escape(entry)}': {msg}"):
            mixture_scenarios(ScenarioConfig(), (entry,))
    from agents.imitation import CollectConfig, collect

    with pytest.raises(ValueError, match="--episodes 2 is fewer than the mixture's 3 scenarios"):
        collect(CollectConfig(mixture=("circle:n_robots=4-8/4", "crowd"), episodes=2, out="unused.npz"))
    # A common flag applies where it can: --obstacle-motion beside an entry without obstacles.
    both = mixture_scenarios(ScenarioConfig(obstacle_motion="stop_and_go"), ("circle", "crowd"))
    assert [s.n_obstacles for s in both] == [0, 5] and both[1].obstacle_motion == "stop_and_go"


@pytest.mark.parametrize("name", sorted({**SCENARIOS, **MAPS}))
def test_each_kind_reads_exactly_the_layout_fields_it_declares(name):
    """The oracle of ``ScenarioKind.reads``: changing a declared field (of jitter, layout_radius and arena_half_size)
    changes some of five worlds' starts, goals or obstacles; changing any other leaves all of them unchanged."""
    from vcs_env.layouts import KINDS, generate

    base = {**SCENARIOS, **MAPS}[name]

    def worlds(s):
        out = []
        for seed in range(5):
            layout = generate(s, np.random.default_rng(seed))
            out += [np.asarray(v) for v in vars(layout).values() if isinstance(v, np.ndarray)]
        return out

    for field, value in (
        ("jitter", base.jitter + 0.05),
        ("layout_radius", base.circle_radius + 0.5),
        ("arena_half_size", base.arena_half_size + 1.0),
    ):
        moved = dataclasses.replace(base, **{field: value})
        changed = any(a.shape != b.shape or not np.allclose(a, b) for a, b in zip(worlds(base), worlds(moved)))
        assert changed == (field in KINDS[base.kind].reads), (name, field)
    if base.kind != "custom":  # with obstacles, the arena also sizes where a kind places them (obstacles_in_arena)
        some = dataclasses.replace(base, n_obstacles=2)
        moved = dataclasses.replace(some, arena_half_size=some.arena_half_size + 1.0)
        changed = any(a.shape != b.shape or not np.allclose(a, b) for a, b in zip(worlds(some), worlds(moved)))
        kind = KINDS[base.kind]
        assert changed == ("arena_half_size" in kind.reads or kind.obstacles_in_arena), name


def test_suite_names_are_scenario_bases_with_their_conventions():
    """``--scenario crowd-20-v0`` and mixture entries named by a suite start from that suite's
    scenario; flags and entry fields change only what they name; the note names the nearest suite."""
    from agents.mixture import mixture_scenarios, parse_mixture_entry

    crowd20 = get_suite("crowd-20-v0").scenario
    assert build_scenario(ScenarioConfig(scenario="crowd-20-v0")) == crowd20
    assert parse_mixture_entry("crowd-20-v0:n_obstacles=14-18/4")[0] == "crowd-20-v0"
    got = mixture_scenarios(ScenarioConfig(on_collision="terminate"), ("crowd-20-v0:n_obstacles=14-18/4",))
    assert [s.n_obstacles for s in got] == [14, 18]
    for s in got:
        assert (s.circle_radius, s.max_steps, s.min_separation, s.on_collision) == (6.0, 400, 0.2, "terminate")
    assert probe_scenario(ScenarioConfig(scenario="circle-24-v0", jitter=0.3)).circle_radius == 7.0
    assert suite_differences(crowd20) == ("crowd-20-v0", [])  # nearest suite, not the family's first
    suite, diffs = suite_differences(got[0])
    assert suite == "crowd-20-v0" and diffs == ["on_collision: terminate (suite: continue)"]
    with pytest.raises(ValueError, match="unknown scenario 'crowd-99-v0'.*or a suite name"):
        build_scenario(ScenarioConfig(scenario="crowd-99-v0"))


def test_mixture_vec_env_is_its_groups_side_by_side():
    """Slots of a MixtureVecEnv are exactly those of one NavVecEnv per scenario (world b of the
    mixture seeded with seed + b), stepped with the same actions; robot counts differ per group."""
    np = pytest.importorskip("numpy")
    pytest.importorskip("stable_baselines3")
    from agents.vec_env import MixtureVecEnv, NavVecEnv
    from vcs_env import make_scenario

    scenarios = [make_scenario("circle", n_robots=3, max_steps=30), make_scenario("crowd", n_obstacles=2)]
    mix = MixtureVecEnv(scenarios, n_worlds=5)  # worlds 0, 2, 4 circle; 1, 3 crowd
    assert mix.num_envs == 3 * 3 + 2 * 1
    alone = [NavVecEnv(scenarios[0], 3), NavVecEnv(scenarios[1], 2)]
    mix.seed(10)
    alone[0].seed(10)
    alone[1].seed(13)  # the crowd group's first world is world 3 of the mixture
    np.testing.assert_array_equal(mix.reset(), np.concatenate([v.reset() for v in alone]))
    rng = np.random.default_rng(0)
    for _ in range(40):
        actions = rng.uniform(-1, 1, (mix.num_envs, 2)).astype(np.float32)
        got = mix.step(actions)
        want = [v.step(a) for v, a in zip(alone, np.split(actions, [9]))]
        for k in range(3):
            np.testing.assert_array_equal(got[k], np.concatenate([w[k] for w in want]))
        assert [sorted(i) for i in got[3]] == [sorted(i) for w in want for i in w[3]]
    with pytest.raises(ValueError, match="n_worlds must be an integer >= the number of mixture scenarios"):
        MixtureVecEnv(scenarios, n_worlds=1)
    with pytest.raises(ValueError, match="one observation config"):
        MixtureVecEnv([scenarios[0], make_scenario("crowd", n_neighbors=2)], n_worlds=2)


def test_mixture_balance_by_robots_steps_about_as_many_robots_per_scenario():
    pytest.importorskip("stable_baselines3")
    from agents.vec_env import MixtureVecEnv, mixture_world_counts
    from vcs_env import make_scenario

    assert mixture_world_counts([1, 24], 26) == [13, 13]
    for n_robots, n_worlds in [([1, 1, 4, 24], 100), ([3, 8, 16], 7), ([5], 9), ([2, 12, 1], 200), ([6, 4], 50)]:
        counts = mixture_world_counts(n_robots, n_worlds, "robots")
        assert sum(counts) == n_worlds and min(counts) >= 1
        robots = [c * n for c, n in zip(counts, n_robots)]
        # Scenarios above their one-world floor step as many robots as the fewest, up to one world.
        low = min(robots)
        assert all(r - low <= n for r, n, c in zip(robots, n_robots, counts) if c > 1)
    assert mixture_world_counts([1, 1, 4, 24], 100, "robots") == [44, 43, 11, 2]
    assert mixture_world_counts([1, 24], 3, "robots") == [2, 1]  # at least one world each
    scenarios = [make_scenario("circle", n_robots=4, max_steps=30), make_scenario("crowd", n_obstacles=2)]
    mix = MixtureVecEnv(scenarios, n_worlds=10, balance="robots")
    assert [g.n_worlds for g in mix.groups] == [2, 8] and mix.num_envs == 2 * 4 + 8
    with pytest.raises(ValueError, match="balance must be 'worlds' or 'robots', got 'agents'"):
        mixture_world_counts([1, 2], 4, "agents")


def test_reproduction_command_of_a_toy_mixture_run_gives_the_same_metrics(tmp_path, capsys):
    """Honest reproducibility (``docs/training.md``, "Reproducibility"): re-running the command saved beside a
    checkpoint gives the same evaluation metrics on the same machine and library versions. The
    test compares metrics, not weight bytes (those may differ across CPUs)."""
    import shlex

    pytest.importorskip("stable_baselines3")
    from agents.checkpoint import open_checkpoint
    from agents.train import TrainConfig, train

    cfg = TrainConfig(
        mixture=("circle:n_robots=2-3", "crowd:n_obstacles=2"),
        max_steps=40,
        timesteps=768,
        n_worlds=3,
        n_steps=64,
        batch_size=128,
        n_epochs=2,
        net_arch=(16,),
        eval_freq=0,
        eval_episodes=3,
        checkpoint_freq=0,
        out=str(tmp_path / "a"),
        progress_bar=False,
        tensorboard=False,
    )
    first = train(cfg)
    printed = capsys.readouterr().out
    assert "settings unlike its suite circle-8-v0: jitter: 0.0 (suite: 0.1)" in printed
    meta = open_checkpoint(first["model"]).record
    assert meta["scenario_family"] == ["circle", "crowd"]
    command = shlex.split(meta["command"])
    assert command[:2] == ["vcs-env", "train"] and "--mixture" in command
    out_at = command.index("--out")
    command[out_at + 1] = str(tmp_path / "b")
    assert cli.main([*command[1:], "--no-progress-bar", "--no-tensorboard"]) == 0
    second = open_checkpoint(tmp_path / "b" / "model.zip").record["evaluation"]
    timing = ("wall_time", "eval_seconds")
    metrics = {k: v for k, v in meta["evaluation"].items() if k not in timing}
    assert metrics["return"] != 0.0 and metrics["episodes"] == 3  # the return depends on every weight
    assert {k: v for k, v in second.items() if k not in timing} == metrics


def test_collect_and_dagger_on_a_mixture_play_every_scenario(tmp_path, capsys):
    """``vcs-env collect --mixture`` labels episodes of every grid point (episode j plays point
    j % S), and ``vcs-env bc`` clones on them, plays its DAgger rounds on the same mixture and
    saves the mixture's family."""
    pytest.importorskip("stable_baselines3")
    from agents.checkpoint import open_checkpoint
    from agents.imitation.data import load_dataset

    data_path = tmp_path / "mix.npz"
    args = ["collect", "--mixture", "circle:n_robots=2-3", "crowd:n_obstacles=2", "--max-steps", "30"]
    assert cli.main([*args, "--episodes", "6", "--seed", "3", "--out", str(data_path)]) == 0
    data, meta = load_dataset(data_path)
    # The dataset is not written over, and a dataset keeps the scenario's own reward (no shaping).
    assert cli.main([*args, "--episodes", "6", "--out", str(data_path)]) == 2
    assert f"--out {str(data_path)!r} exists: the new data would replace it" in capsys.readouterr().err
    assert cli.main([*args, "--episodes", "6", "--shaping", "vcs_potential", "--out", str(tmp_path / "s.npz")]) == 2
    assert "--shaping vcs_potential shapes PPO's reward; a dataset keeps the scenario's own" in capsys.readouterr().err
    assert not (tmp_path / "s.npz").exists()
    robots_per_seed = {}
    for seed, robot in zip(data["traj_seed"], data["traj_robot"]):
        robots_per_seed.setdefault(int(seed), set()).add(int(robot))
    # seeds 3..8 -> points circle n=2, circle n=3, crowd (1 robot), circle n=2, circle n=3, crowd
    assert {s: len(r) for s, r in robots_per_seed.items()} == {3: 2, 4: 3, 5: 1, 6: 2, 7: 3, 8: 1}
    assert meta["config"]["mixture"] == ["circle:n_robots=2-3", "crowd:n_obstacles=2"]
    out = tmp_path / "bc"
    args = ["bc", "--data", str(data_path), "--epochs", "1", "--net-arch", "16", "--dagger-iters", "1"]
    assert cli.main([*args, "--dagger-episodes", "3", "--eval-episodes", "3", "--out", str(out)]) == 0
    meta = open_checkpoint(out / "model.zip").record
    assert meta["scenario_family"] == ["circle", "crowd"]
    assert meta["report"]["dagger_env_steps"] > 0
    assert meta["report"]["rows"] + meta["report"]["held_out_rows"] == len(data["actions"])
    capsys.readouterr()
    # A dataset whose arrays were cut by hand (meta edited to match) is refused by name, not inside torch.
    cut = {k: v for k, v in data.items()}
    cut["observations"] = data["observations"][:, :60]
    narrow = dict(load_dataset(data_path)[1], observation_dim=60)
    np.savez_compressed(tmp_path / "cut.npz", **cut, meta=np.array(json.dumps(narrow)))
    assert cli.main(["bc", "--data", str(tmp_path / "cut.npz"), "--epochs", "1", "--out", str(tmp_path / "bc2")]) == 2
    assert "holds observations of size 60, but the scenario its record names observes" in capsys.readouterr().err
