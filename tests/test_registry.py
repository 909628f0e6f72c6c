"""The planner registry of ``vcs_env``: entry points of installed packages plus planners
registered in the process; one registry, re-exported by ``baselines``."""

import re

import numpy as np
import pytest

import baselines
import vcs_env
from vcs_env import planning
from vcs_env.planning import PLANNERS, Planner, make_planner, register_planner

BUILT_IN = ["hrvo", "orca", "rvo", "straight", "vcs", "vo"]


class StandStill(Planner):
    """Every robot stops, facing where it faces."""

    name = "stand-still"

    def plan(self, world):
        return np.stack((np.zeros_like(world.speed), world.heading), axis=-1)


@pytest.fixture
def registry(monkeypatch):
    """A copy of the process registry, restored after the test."""
    monkeypatch.setattr(planning, "_REGISTERED", dict(planning._REGISTERED))


def test_installed_planners_come_from_entry_points_and_baselines_shares_the_registry():
    assert list(PLANNERS) == BUILT_IN  # sorted names of the vcs_env.planners entry points
    assert baselines.PLANNERS is PLANNERS and baselines.make_planner is make_planner
    assert PLANNERS["straight"] is baselines.StraightPlanner
    assert make_planner("hrvo").name == "hrvo" and make_planner("vcs").name == "vcs"


def test_unknown_planner_lists_the_registered_names():
    with pytest.raises(ValueError, match=r"unknown planner 'nope'; registered planners are \['hrvo', 'orca'"):
        make_planner("nope")
    with pytest.raises(ValueError, match="a planner must be a name"):
        make_planner(3)
    with pytest.raises(ValueError, match="keyword arguments"):
        make_planner(StandStill(), speed=1.0)


def test_an_env_copies_a_planner_it_is_given_or_says_why_it_cannot():
    import threading

    import vcs_env.planning as planning

    class Locked(StandStill):
        def __init__(self):
            self.lock = threading.Lock()  # no copy of a lock

    free = StandStill()
    assert planning.own_planner(free) is not free and isinstance(planning.own_planner(free), StandStill)
    locked = Locked()
    with pytest.warns(UserWarning, match="cannot be copied .* give every env its own"):
        assert planning.own_planner(locked) is locked
    assert planning.own_planner("straight").name == "straight"


def test_planner_options_and_masks_are_checked_by_name():
    """Options a planner does not take are bad input (a ValueError naming them), not a TypeError; a bool is no
    number of the VO planners; every planner's plan_for checks its mask."""
    for name, opts, said in (
        ("vcs", {"horizn": 1.0}, "'horizn'"),
        ("straight", {"bogus": 1}, "['bogus']"),
        ("vo", {"method": "rvo"}, "'method'"),
    ):
        with pytest.raises(ValueError, match=f"planner '{name}' does not take the options .*{re.escape(said)}"):
            make_planner(name, **opts)
    for opts in ({"r_ca": True}, {"weight": True}):
        with pytest.raises(ValueError, match="must be finite and > 0"):
            make_planner("vo", **opts)
    s = vcs_env.make_scenario("circle", n_robots=3)
    eng = vcs_env.engine.NavEngine(s)
    eng.reset([0])
    for name in ("vcs", "vo", "straight"):
        with pytest.raises(ValueError, match=r"robots must be a bool mask of shape \(3,\), got shape \(2,\)"):
            make_planner(name).plan_for(eng.world, np.ones(2, dtype=bool))


def test_register_a_planner_and_use_it_as_the_expert(registry):
    assert register_planner("stand-still", StandStill) is StandStill
    assert "stand-still" in PLANNERS and list(PLANNERS) == sorted([*BUILT_IN, "stand-still"])
    env = vcs_env.parallel_env(scenario="swap", expert="stand-still")
    env.reset(seed=0)
    _, _, _, _, infos = env.step({a: np.zeros(2, np.float32) for a in env.agents})
    # delta actions: braking from rest is a zero speed change, no turn.
    np.testing.assert_array_equal(infos["robot_0"]["expert_action"], [0.0, 0.0])


def test_register_rejects_taken_names_and_bad_factories(registry):
    with pytest.raises(ValueError, match="'vcs' is already registered"):
        register_planner("vcs", StandStill)
    with pytest.raises(ValueError, match="must be callable"):
        register_planner("x", "not a factory")
    with pytest.raises(ValueError, match="non-empty string"):
        register_planner("", StandStill)
    register_planner("still", StandStill)
    with pytest.raises(ValueError, match="'still' is already registered"):
        register_planner("still", StandStill)


class Returns(Planner):
    """A planner whose plan returns ``out(world)``: for the checks of what planners give."""

    name = "returns"

    def __init__(self, out):
        self.out = out

    def plan(self, world):
        return self.out(world)


def test_what_a_planner_gives_is_checked_by_name(registry):
    """Targets of another shape were broadcast into the actions (a (B, n) plan drove a rollout) or failed deep in
    numpy; a factory that made no Planner failed at its first use; a missing plan said nothing."""
    eng = vcs_env.NavEngine(vcs_env.make_scenario("circle", n_robots=3))
    eng.reset([0])
    world = eng.world
    bad = {
        "must have shape \\(1, 3, 2\\), got \\(1, 3\\)": lambda w: np.zeros(w.speed.shape),
        "must have shape \\(1, 3, 2\\), got \\(2, 1, 3\\)": lambda w: np.zeros((2, 1, 3)),
        "must be real numbers .* got None": lambda w: None,
        "must be finite": lambda w: np.full(w.pos.shape, np.nan),
    }
    for said, out in bad.items():
        with pytest.raises(ValueError, match="the targets of planner 'returns' \\(Returns\\) " + said):
            Returns(out).act(world)
    assert Returns(lambda w: [[[0.0, 0.0]] * 3]).act(world).shape == (1, 3, 2)  # a nested list of numbers is fine
    with pytest.raises(NotImplementedError, match="planner Planner must define plan"):
        Planner().act(world)
    register_planner("dict", lambda: {})
    with pytest.raises(ValueError, match="the factory of planner 'dict' returned a dict, not a Planner"):
        make_planner("dict")


def test_rows_nobody_reads_may_hold_anything():
    """plan_for may leave the rows of robots not asked for unspecified (NaN), and a planner may give NaN for robots that
    have finished: only the rows read are checked."""
    from vcs_env.gym_env import VcsNavEnv

    class Subset(StandStill):
        def plan_for(self, world, robots):
            out = np.full(world.pos.shape, np.nan)
            out[:, robots] = self.plan(world)[:, robots]
            return out

    env = VcsNavEnv(scenario="circle", others=Subset(), n_robots=4)
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    eng = vcs_env.NavEngine(vcs_env.make_scenario("circle", n_robots=3))
    eng.reset([0])
    eng.world.active[0, 1] = False  # robot 1 has finished
    row_1_nan = Returns(lambda w: np.where(np.arange(3)[None, :, None] == 1, np.nan, np.zeros(w.pos.shape)))
    assert np.isfinite(row_1_nan.act(eng.world)).all()
    eng.world.active[0, 1] = True  # driving: its row is read
    with pytest.raises(ValueError, match="the targets of planner 'returns' .* must be finite"):
        row_1_nan.act(eng.world)
    assert np.isfinite(row_1_nan.act(eng.world, robots=np.array([True, False, True]))[0, [0, 2]]).all()
