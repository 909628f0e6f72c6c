"""Evaluation: metrics on hand-made episodes, suites, the harness (planners, predictors,
checkpoints), fair comparison and the ``evaluate`` / ``compare`` commands."""

import dataclasses
import json
import math
import shutil
import subprocess
import sys

import numpy as np
import pytest

import vcs_cli as cli
from agents.evaluate import compare, evaluate
from agents.policies import MIN_ROWS
from baselines import PLANNERS
from vcs_env import metrics
from vcs_env.rollout import Episode
from vcs_env.spaces import observation_space
from vcs_env.suites import SMOKE_SEEDS, SUITES, Suite, get_suite, suite_names


# --------------------------------------------------------------------------- hand-made episodes
def make_episode(pos, speed=None, heading=None, reached_step=None, dt=1.0, goal=None):
    """One robot's recorded episode from positions ``(T+1, 2)`` [m] (``n = 1``, no obstacles)."""
    pos = np.asarray(pos, dtype=np.float64)[:, None, :]
    T = len(pos) - 1
    step = np.diff(pos, axis=0)
    if heading is None:
        h = np.arctan2(step[..., 1], step[..., 0])
        heading = np.concatenate((h[:1], h))
    if speed is None:
        v = np.linalg.norm(step, axis=-1) / dt
        speed = np.concatenate((np.zeros((1, 1)), v))
    heading = np.asarray(heading, dtype=np.float64).reshape(T + 1, 1)
    speed = np.asarray(speed, dtype=np.float64).reshape(T + 1, 1)
    goal = pos[-1] if goal is None else np.asarray(goal, dtype=np.float64).reshape(1, 2)
    reached = T if reached_step is None else reached_step
    acted = (np.arange(T) < (reached if reached >= 0 else T))[:, None]
    return Episode(
        seed=0,
        dt=dt,
        radius=np.array([0.25]),
        goal=goal,
        obs_radius=np.zeros(0),
        pos=pos,
        heading=heading,
        speed=speed,
        obs_pos=np.zeros((T + 1, 0, 2)),
        actions=np.zeros((T, 1, 2)),
        acted=acted,
        collided=np.zeros((T, 1), dtype=bool),
        robot_contact=np.zeros((T, 1), dtype=bool),
        obstacle_contact=np.zeros((T, 1), dtype=bool),
        min_separation=np.where(acted, 1.0, np.inf),
        reached_step=np.array([reached]),
        straight_time=np.linalg.norm(goal - pos[0], axis=-1) / 1.0,
    )


def test_straight_path_has_ratio_one():
    ep = make_episode([(x, 0.0) for x in range(11)])  # 10 m in 10 s
    m = metrics.episode_metrics(ep)
    assert m["path_ratio"] == pytest.approx(1.0)
    assert m["path_length"] == pytest.approx(10.0)
    assert m["time_to_goal"] == pytest.approx(10.0)
    assert m["extra_time"] == pytest.approx(0.0)
    assert m["heading_change"] == pytest.approx(0.0)
    assert m["success"] == 1.0 and m["collision"] == m["timeout"] == m["deadlock"] == 0.0


def test_right_angle_detour_has_known_ratio_and_heading_change():
    # 3 m east then 4 m north: 7 m driven for a 5 m straight line; one quarter turn.
    ep = make_episode([(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (3, 3), (3, 4)])
    m = metrics.episode_metrics(ep)
    assert m["path_length"] == pytest.approx(7.0)
    assert m["path_ratio"] == pytest.approx(7.0 / 5.0)
    assert metrics.heading_change(ep)[0] == pytest.approx(math.pi / 2)


def test_heading_change_across_the_pi_boundary():
    # 3.0 rad -> -3.0 rad is a 0.283 rad left turn through pi, not a 6 rad turn.
    ep = make_episode([(0, 0), (1, 0), (2, 0)], heading=[3.0, -3.0, -3.0], speed=[0, 1, 1])
    assert metrics.heading_change(ep)[0] == pytest.approx(2 * math.pi - 6.0)


def test_speed_reversals_of_a_known_profile():
    # dv = +, +, 0, -, +, -  ->  3 switches between speeding up and slowing down.
    speed = [0.0, 0.5, 1.0, 1.0, 0.5, 1.0, 0.5]
    ep = make_episode([(x, 0.0) for x in range(7)], speed=speed, reached_step=-1)
    assert metrics.speed_reversals(ep)[0] == 3


def test_parking_jump_on_arrival_is_not_driving():
    # Constant acceleration, then the simulator zeroes the speed of the arrived robot: no
    # commanded jerk, no reversal.
    speed = [0.0, 0.1, 0.2, 0.3, 0.4, 0.0]
    ep = make_episode([(0.1 * x * x / 2, 0.0) for x in range(6)], speed=speed, dt=0.1)
    assert not metrics.driving_steps(ep)[-1, 0]
    assert metrics.mean_jerk(ep)[0] == pytest.approx(0.0, abs=1e-9)
    assert metrics.speed_reversals(ep)[0] == 0


def test_robot_that_never_moves_is_a_deadlock():
    still = np.zeros(201)  # 20 s without moving, 5 m from the goal
    ep = make_episode(np.zeros((201, 2)), speed=still, heading=still, reached_step=-1, dt=0.1, goal=(5.0, 0.0))
    m = metrics.episode_metrics(ep)
    assert m["deadlock"] == 1.0 and m["success"] == m["timeout"] == 0.0
    assert math.isnan(m["time_to_goal"]) and m["arrived_fraction"] == 0.0
    # An episode shorter than the deadlock window cannot show a robot stuck: a time out.
    short = make_episode(
        np.zeros((51, 2)), speed=still[:51], heading=still[:51], reached_step=-1, dt=0.1, goal=(5.0, 0.0)
    )
    m = metrics.episode_metrics(short)
    assert m["timeout"] == 1.0 and m["deadlock"] == 0.0
    # Also where the window is no whole number of steps: 33 steps of 0.3 s (9.9 s) are not 10 s.
    for steps, outcome in ((33, "timeout"), (34, "deadlock")):
        ep = make_episode(np.zeros((steps + 1, 2)), speed=still[: steps + 1], heading=still[: steps + 1],
                          reached_step=-1, dt=0.3, goal=(5.0, 0.0))  # fmt: skip
        assert metrics.episode_metrics(ep)[outcome] == 1.0


def test_wilson_interval():
    lo, hi = metrics.wilson_interval(5, 10)
    assert (lo, hi) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert metrics.wilson_interval(0, 10)[0] == 0.0 and metrics.wilson_interval(10, 10)[1] == 1.0
    assert 0.0 < metrics.wilson_interval(0, 10)[1] < 0.3
    for k, n in ((0, 5), (3, 7), (99, 100)):
        lo, hi = metrics.wilson_interval(k, n)
        assert 0.0 <= lo <= k / n <= hi <= 1.0
    assert np.diff(metrics.wilson_interval(50, 100)) < np.diff(metrics.wilson_interval(5, 10))
    assert all(math.isnan(x) for x in metrics.wilson_interval(0, 0))


def test_aggregate_takes_time_over_the_solved_mask_only():
    rows = [
        {"success": 1.0, "time_to_goal": 10.0, "jerk": 1.0},
        {"success": 1.0, "time_to_goal": 12.0, "jerk": 1.0},
        {"success": 0.0, "time_to_goal": 50.0, "jerk": 4.0},
    ]
    agg = metrics.aggregate(rows, solved_mask=[True, True, False])
    assert agg["time_to_goal"]["mean"] == pytest.approx(11.0) and agg["time_to_goal"]["n"] == 2
    assert agg["success"]["mean"] == pytest.approx(2 / 3) and agg["success"]["n"] == 3
    assert agg["jerk"]["mean"] == pytest.approx(2.0)
    # A rate undefined in an episode (NaN: at fault without the hit matrices) is left out, as for the other metrics.
    rated = metrics.aggregate([{"at_fault_collision": 1.0}, {"at_fault_collision": float("nan")}])
    assert rated["at_fault_collision"]["mean"] == 1.0 and rated["at_fault_collision"]["n"] == 1
    with pytest.raises(ValueError, match="solved_mask must have one entry per row \\(3\\)"):
        metrics.aggregate(rows, solved_mask=[True, False])


def test_the_interval_of_a_bounded_metric_stays_in_its_range():
    """With few episodes the interval left the range: a share of time in personal space from -0.2, an SPL above 1;
    a metric without bounds (min separation may be negative) keeps the plain interval. Its half-width is Student's
    t's (1.96 made three episodes' intervals 2.2x too narrow), and one episode gives none (it read "± 0.00")."""
    from agents.evaluate.report import format_stat

    rows = [{"personal_intrusion": x, "spl": 1.0 - x, "jerk": x, "min_separation": x} for x in (0.0, 0.0, 0.6)]
    agg = metrics.aggregate(rows)
    assert agg["personal_intrusion"]["low"] == 0.0 and agg["spl"]["high"] == 1.0 and agg["jerk"]["low"] == 0.0
    half = 4.303 * np.std([0.0, 0.0, 0.6], ddof=1) / np.sqrt(3)  # t at 0.975 with 2 degrees of freedom
    assert agg["min_separation"]["high"] == pytest.approx(0.2 + half) and agg["min_separation"]["low"] < 0.0
    assert format_stat(agg["min_separation"], rate=False) == f"0.20 ± {half:.2f}"
    assert format_stat(agg["personal_intrusion"], rate=False) == "0.20 [0.00, 1.00]"  # cut by the range: both ends
    ttc = metrics.aggregate([{"min_ttc": x} for x in (0.0, 10.0, 10.0)])["min_ttc"]  # capped at TTC_CAP = 10 s
    assert ttc["high"] == 10.0 and ttc["low"] == 0.0
    one = metrics.aggregate([{"jerk": 0.7}])["jerk"]
    assert one["n"] == 1 and np.isnan(one["low"]) and format_stat(one, rate=False) == "0.70"
    assert metrics.t95(1) == 12.706 and abs(metrics.t95(60) - 2.000) < 0.004 and abs(metrics.t95(10**6) - 1.96) < 0.001


@pytest.mark.slow
def test_a_new_metric_is_one_object(monkeypatch, capsys, tmp_path):
    """Adding a Metric to METRICS puts it in the rows, the aggregate, the comparison table, the
    plots and the evaluate summary; its flags decide how each treats it."""
    from agents.evaluate.report import table_lines, write_plots

    final_speed = metrics.Metric("final_speed", "final speed [m/s]", lambda f: float(f.ep.speed[-1].mean()))
    quick = metrics.Metric("quick", "quick", lambda f: float(f.ep.steps < 100), rate=True, plot=False)
    monkeypatch.setattr(metrics, "METRICS", (*metrics.METRICS, final_speed, quick))
    comp = compare(["straight"], "swap-v0-smoke", progress=False)
    rows = comp.results["straight"].rows
    summary = comp.results["straight"].summary
    assert all(list(r)[-2:] == ["final_speed", "quick"] and r["quick"] in (0.0, 1.0) for r in rows)
    assert summary["final_speed"]["n"] == len(rows)
    k = sum(r["quick"] for r in rows)
    assert (summary["quick"]["low"], summary["quick"]["high"]) == metrics.wilson_interval(k, len(rows))
    assert table_lines(comp)[0].endswith("| final speed [m/s] | quick | ms/decision |")
    names = {p.name for p in write_plots(comp, tmp_path)}
    assert "bar_final_speed.png" in names and "bar_quick.png" not in names
    assert cli.main(["evaluate", "--suite", "swap-v0-smoke", "--policy", "straight", "--no-progress"]) == 0
    assert "final speed [m/s]" in capsys.readouterr().out


def test_a_metric_that_gives_other_than_one_number_or_a_taken_name_is_named(monkeypatch):
    """A per-robot array was averaged as robots x episodes ('n': 18 for 3 episodes), and a second 'success' replaced the
    first."""
    ep = make_episode([(x, 0.0) for x in range(11)])
    per_robot = metrics.Metric("speeds", "speeds", lambda f: f.ep.speed[-1])
    monkeypatch.setattr(metrics, "METRICS", (*metrics.METRICS, per_robot))
    with pytest.raises(ValueError, match="metric 'speeds' gave array.*one number per episode"):
        metrics.episode_metrics(ep)
    for name, said in (  # the seed column was overwritten, a plot replaced, or a file path failed after the run
        ("seed", "a key the harness writes beside the metrics"),
        ("ms_per_decision", "a key the harness writes"),
        ("speed/final", "must be an identifier"),
    ):
        with pytest.raises(ValueError, match=f"metric name '{name}' .*{said}"):
            metrics.Metric(name, name, lambda f: 0.0)
    monkeypatch.setattr(metrics, "METRICS", (*metrics.METRICS[:-1], metrics.Metric("success", "s", lambda f: 1.0)))
    with pytest.raises(ValueError, match="two metrics in METRICS are named 'success'"):
        metrics.episode_metrics(ep)
    base = metrics.METRICS[:-1]
    for bad, said in [
        (metrics.Metric("half", "half", lambda f: "0.5"), "metric 'half' gave '0.5'.*one number per episode"),
        (metrics.Metric("hits", "hits", lambda f: 2.0, rate=True), "metric 'hits' is a rate.*gave 2.0"),
    ]:  # a string was taken as its number; a rate of 2 failed in the Wilson interval as 'math domain error'
        monkeypatch.setattr(metrics, "METRICS", (*base, bad))
        with pytest.raises(ValueError, match=said):
            metrics.episode_metrics(ep)


def test_metric_flags_match_the_documented_groups():
    by = {m.name: m for m in metrics.METRICS}
    assert len(by) == len(metrics.METRICS)  # names are unique
    assert {n for n, m in by.items() if m.rate} == {
        "success",
        "collision",
        "robot_collision",
        "obstacle_collision",
        "at_fault_collision",
        "not_at_fault_collision",
        "parked_collision",
        "timeout",
        "deadlock",
    }
    assert {n for n, m in by.items() if m.solved_only} == {
        "time_to_goal",
        "makespan",
        "extra_time",
        "path_length",
        "path_ratio",
    }
    assert set(metrics.OUTCOMES) <= {n for n, m in by.items() if m.rate}


# --------------------------------------------------------------------------- suites
FINGERPRINTS = {
    "circle-8-v0": "ed883d121ce71df4",
    "circle-16-v0": "e0bfebba614a3bb7",
    "circle-24-v0": "b4f7ee2c4666361e",
    "swap-v0": "3f027a8b607bd4b8",
    "crossing-v0": "c57ebfcb7c3ca536",
    "crowd-5-v0": "da508bb1ccbe803c",
    "crowd-20-v0": "d058c166c0502a14",
    "dynamic-v0": "7807d1e035719215",
    "circle-40-v0": "6692b5af4ed37c75",
    "circle-40-symmetric-v0": "db4964fed54eec57",
    "random-dense-v0": "20c20a70ed1fbe31",
    "crowd-10-v0": "e5911e00eedb3f45",
    "corridor-v0": "91672d7d89bd25bd",
    "doorway-v0": "941b9ed8918f51ac",
    "door-headon-v0": "76f62c204494ad8e",
    "room-v0": "9f5ae9c5afce0901",
    "intersection-v0": "46883bb5cd2a1772",
    "walls-v0": "3f7a5c20f7158643",
    "corridor-narrow-v0": "dd00fae24219b275",
    "dynamic-fast-v0": "139d93f7a08503f1",
    "random-dense-holonomic-v0": "f24882e3b7712cd2",
    "crowdnav-circle-v0": "b11c1b9f3866818b",
    "crowdnav-square-v0": "9d9b21bc19cb3553",
    "crowdnav-circle-unicycle-v0": "577ceb207b3654ae",
    "crowdnav-circle-10-v0": "bd3aec6a094ec143",
    "crowdnav-circle-20-v0": "8108e8f48190c860",
}


def test_suites_are_fixed_and_versioned():
    assert set(suite_names(smoke=False)) == set(FINGERPRINTS)
    changed = {k: SUITES[k].fingerprint for k, v in FINGERPRINTS.items() if SUITES[k].fingerprint != v}
    assert not changed, (
        f"suite content changed: {changed}. If episodes can differ, add a new version (e.g. -v1) and keep "
        "the old one; if not (e.g. a new Scenario field with a neutral default), update FINGERPRINTS."
    )
    for name in FINGERPRINTS:
        full, smoke = SUITES[name], SUITES[name + "-smoke"]
        assert full.scenario.on_collision == "continue" and smoke.scenario.on_collision == "continue"
        assert smoke.is_smoke and not full.is_smoke
        assert smoke.seeds == full.seeds[:SMOKE_SEEDS]
        assert smoke.scenario.n_robots <= 16
    assert SUITES["crowd-20-v0"].scenario.n_obstacles == 20
    assert SUITES["circle-24-v0"].scenario.n_robots == 24 and SUITES["circle-24-v0"].n_episodes == 50
    with pytest.raises(ValueError, match="unknown suite"):
        get_suite("circle-9-v0")
    with pytest.raises(ValueError, match="seeds"):
        Suite("x", SUITES["swap-v0"].scenario, (1, 1))
    for seeds in ((1.5, 2.7), "123", (True, 2), 5):  # each was turned into other seeds (or a TypeError)
        with pytest.raises(ValueError, match="seeds must be a sequence of integers"):
            Suite("x", SUITES["swap-v0"].scenario, seeds)
    assert Suite("x", SUITES["swap-v0"].scenario, np.arange(3)).seeds == (0, 1, 2)
    with pytest.raises(ValueError, match="batch_size must be an integer >= 1, got None"):
        evaluate("straight", "swap-v0-smoke", batch_size=None)


@pytest.mark.slow
def test_every_seed_of_every_suite_can_be_placed():
    from vcs_env.engine import NavEngine

    for name in suite_names(smoke=False):
        suite = SUITES[name]
        NavEngine(suite.scenario, suite.n_episodes).reset(list(suite.seeds))  # raises if a layout fails


# --------------------------------------------------------------------------- planners x smoke suites
@pytest.mark.slow
@pytest.mark.parametrize("planner", sorted(PLANNERS))
def test_every_planner_runs_every_smoke_suite(planner):
    if planner == "orca":
        pytest.importorskip("pyrvo", reason="the 'orca' planner needs the orca extra (pyrvo)")
    for name in suite_names(smoke=True):
        res = evaluate(planner, name, progress=False)
        assert len(res.rows) == SMOKE_SEEDS, name
        assert res.decisions > 0 and res.seconds_per_decision >= 0.0
        for key in ("success", "collision", "timeout", "deadlock"):
            assert 0.0 <= res.summary[key]["mean"] <= 1.0
        outcomes = [r["success"] + r["collision"] + r["timeout"] + r["deadlock"] for r in res.rows]
        assert outcomes == [1.0] * SMOKE_SEEDS, (planner, name)


# --------------------------------------------------------------------------- predictors
class DriveForward:
    """A PolicyPredictor that only speeds up; records the observation shapes it was given."""

    def __init__(self):
        self.shapes = []

    def predict(self, observation, state=None, episode_start=None, deterministic=False):
        obs = np.asarray(observation)
        self.shapes.append(obs.shape)
        actions = np.zeros((*obs.shape[:-1], 2), dtype=np.float32)
        actions[..., 0] = 1.0
        return actions, state


def test_evaluate_accepts_any_predict_object():
    suite = get_suite("swap-v0-smoke")
    policy = DriveForward()
    res = evaluate(policy, suite, progress=False)
    assert res.policy == "DriveForward"
    n, dim = suite.scenario.n_robots, observation_space(suite.scenario).shape[0]
    # All robots of all worlds in one call, at least MIN_ROWS rows (plus a short one-world warm-up before timing).
    rows, one = max(SMOKE_SEEDS * n, MIN_ROWS), max(n, MIN_ROWS)
    assert (rows, dim) in policy.shapes and set(policy.shapes) <= {(one, dim), (rows, dim)}
    # Starts face the goals: driving straight ahead arrives, through the oncoming robot.
    assert res.summary["arrived_fraction"]["mean"] == 1.0
    assert res.summary["robot_collision"]["mean"] == 1.0


def test_predictor_with_wrong_spaces_or_actions_is_rejected():
    import gymnasium

    wrong = DriveForward()
    wrong.observation_space = gymnasium.spaces.Box(-1, 1, (5,))
    with pytest.raises(ValueError, match=r"observation space Box\(5,\)"):
        evaluate(wrong, "swap-v0-smoke", progress=False)

    class ThreeActions(DriveForward):
        def predict(self, observation, state=None, episode_start=None, deterministic=False):
            return np.zeros((len(observation), 3)), state

    with pytest.raises(ValueError, match="actions of shape"):
        evaluate(ThreeActions(), "swap-v0-smoke", progress=False)
    with pytest.raises(ValueError, match="a policy must be"):
        evaluate(42, "swap-v0-smoke", progress=False)


def test_module_does_not_import_torch():
    code = "import sys, agents.evaluate; sys.exit(int('torch' in sys.modules or 'stable_baselines3' in sys.modules))"
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


# --------------------------------------------------------------------------- compare
def test_compare_uses_episodes_every_policy_solved():
    comp = compare({"a": "vcs", "b": "straight"}, "crossing-v0-smoke", progress=False)
    solved = comp.results["a"].solved & comp.results["b"].solved
    assert np.array_equal(comp.solved_by_all, solved)
    for name, res in comp.results.items():
        expected = metrics.aggregate(res.rows, solved_mask=solved)
        assert comp.summaries[name]["time_to_goal"]["n"] == expected["time_to_goal"]["n"] == int(solved.sum())
        assert comp.summaries[name]["success"] == res.summary["success"]
    # One policy alone: evaluate's summary is compare's (time and path over the episodes it solved).
    alone = comp.results["b"]  # straight solves none, yet some of its robots arrive in every episode
    assert np.isfinite([r["time_to_goal"] for r in alone.rows]).all()
    assert alone.summary["time_to_goal"]["n"] == alone.solved.sum() == 0
    again = compare({"b": "straight"}, "crossing-v0-smoke", progress=False).summaries["b"]
    timing = "compute_per_decision"  # a measured time: differs from run to run
    assert {k: v for k, v in alone.summary.items() if k != timing} == {k: v for k, v in again.items() if k != timing}
    with pytest.raises(ValueError, match="distinct names"):
        compare(["straight", "straight"], "crossing-v0-smoke", progress=False)
    with pytest.raises(ValueError, match="two policies"):
        compare([DriveForward(), DriveForward()], "crossing-v0-smoke", progress=False)


def test_progress_counter_without_tqdm(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # as if the train extra were not installed
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    evaluate("straight", "swap-v0-smoke", batch_size=2, progress=True)
    assert "straight on swap-v0-smoke: 3/3 episodes" in capsys.readouterr().err


# --------------------------------------------------------------------------- command line
def test_cli_evaluate_writes_json(tmp_path, capsys):
    out = tmp_path / "out.json"
    args = ["evaluate", "--suite", "circle-8-v0-smoke", "--policy", "vcs", "--json", str(out), "--no-progress"]
    assert cli.main(args) == 0
    assert "success" in capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["suite"] == "circle-8-v0-smoke" and data["policy"] == "vcs"
    assert len(data["episodes"]) == SMOKE_SEEDS and data["summary"]["success"]["mean"] == 1.0


@pytest.mark.slow
def test_cli_compare_writes_report(tmp_path):
    out = tmp_path / "report"
    args = ["compare", "--suite", "dynamic-v0-smoke", "--policies", "vcs,straight", "--out", str(out)]
    assert cli.main([*args, "--episode", "1", "--no-progress"]) == 0
    md = (out / "results.md").read_text()
    assert md.count("| vcs |") == 2 and md.count("| straight |") == 2  # main table and percentiles
    assert "robot-obstacle" in md and "ms/decision" in md
    data = json.loads((out / "results.json").read_text())
    assert set(data["policies"]) == {"vcs", "straight"}
    for name in ("bar_success.png", "bar_extra_time.png", "trajectory_vcs_ep1.png", "trajectory_straight_ep1.png"):
        assert (out / name).stat().st_size > 0, name
    # Again into the same directory, one policy, no plots: no plot of the earlier report stays beside it.
    (out / "notes.txt").write_text("mine")
    again = ["compare", "--suite", "dynamic-v0-smoke", "--policies", "vcs", "--out", str(out), "--no-plots"]
    assert cli.main(again) == 0
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "results.json", "results.md"]


def test_a_run_directory_named_without_a_slash_is_a_checkpoint(tmp_path, monkeypatch):
    from agents.policies import is_checkpoint_spec

    (tmp_path / "run").mkdir()
    monkeypatch.chdir(tmp_path)
    assert not is_checkpoint_spec("run")  # no model.zip yet: a (mistyped) planner name
    (tmp_path / "run" / "model.zip").write_bytes(b"")
    assert is_checkpoint_spec("run") and not is_checkpoint_spec("vcs")


def test_a_trained_checkpoint_refuses_absolute_actions(tmp_path):
    from agents.policies import resolve_policy

    scenario = get_suite("circle-8-v0-smoke").scenario
    with pytest.raises(ValueError, match="act in delta mode; --action-mode absolute"):
        resolve_policy("policies/circle8/model.zip", scenario, action_mode="absolute")
    # Without a run record (an SB3 zip trained elsewhere) the mode is the caller's to choose, and so is the
    # sensing (no record says it: this one reads observation v1).
    shutil.copy("policies/circle8/model.zip", tmp_path / "model.zip")
    v1 = dataclasses.replace(scenario, observation=1)
    assert resolve_policy(str(tmp_path / "model.zip"), v1, action_mode="absolute").kind == "checkpoint"


def test_cli_errors_are_messages(tmp_path, capsys, monkeypatch):
    base = ["evaluate", "--suite", "swap-v0-smoke", "--no-progress", "--policy"]
    assert cli.main([*base, "no-such-planner"]) == 2
    assert "unknown planner 'no-such-planner'" in capsys.readouterr().err
    assert cli.main([*base, str(tmp_path / "missing.zip")]) == 2
    assert "not found" in capsys.readouterr().err
    assert cli.main(["evaluate", "--suite", "nope-v0", "--policy", "vcs"]) == 2
    assert "unknown suite" in capsys.readouterr().err
    if "orca" in PLANNERS:
        monkeypatch.setitem(sys.modules, "pyrvo", None)  # as if the orca extra were not installed
        assert cli.main([*base, "orca"]) == 2
        assert "pip install -e '.[orca]'" in capsys.readouterr().err


def test_a_mixture_scored_with_fewer_episodes_than_scenarios_says_the_rest_are_left_out():
    """Episode j plays scenario j % S (the periodic evaluation of train, bc's): fewer episodes than scenarios leave the
    last ones unplayed, and a warning says so; one episode per scenario is silent."""
    import warnings

    from agents.evaluate import score_scenarios
    from vcs_env.rollout import planner_controller
    from vcs_env.scenario import make_scenario

    scenarios = [make_scenario("circle", n_robots=n, max_steps=20) for n in (2, 3, 4)]
    controller = planner_controller(PLANNERS["straight"]())
    with pytest.warns(UserWarning, match="2 evaluation episodes over a mixture of 3 scenarios.* last 1 are not scored"):
        assert score_scenarios(controller, scenarios, [0, 1])["episodes"] == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert score_scenarios(controller, scenarios, [0, 1, 2])["episodes"] == 3
