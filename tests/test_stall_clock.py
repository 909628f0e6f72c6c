"""The stall clock (vcs_env.stall): the memory the expert frees deadlocks with, kept by the simulator and
observed by policies (the ``clock`` block), changes no episode and tells a policy what the expert's
memory tells the expert."""

import dataclasses
import warnings

import numpy as np
import pytest

from baselines.vcs.planner import CoarseStepWarning, VCSPlanner
from vcs_env.engine import NavEngine
from vcs_env.observations import observation_config, observation_layout, observe, reference_observe, sensors_of
from vcs_env.scenario import Scenario
from vcs_env.sim import Simulator
from vcs_env.stall import CLOCK_DIM
from vcs_env.start_states import StartStates, StatePool
from vcs_env.suites import get_suite

MEMORY = ("stall", "detour", "ref", "wait", "tries")


def _clocked(name: str) -> Scenario:
    return dataclasses.replace(get_suite(name).scenario, stall_clock=True)


@pytest.mark.parametrize("name", ["door-headon-v0", "random-dense-v0"])
def test_the_clock_is_the_experts_memory_step_by_step(name):
    """With the expert driving, every robot's clock equals the expert's own memory after each plan and
    its detour flag the expert's detour, on a map (route distances, jittered detours) and in free
    space; the expert does detour in these episodes, so the flag is not trivially 0."""
    s = _clocked(name)
    seeds = list(get_suite(name).seeds)[:6]
    eng = NavEngine(s, len(seeds))
    eng.reset(seeds)
    planner, detours = VCSPlanner(), 0
    for _ in range(s.max_steps):
        action = planner.act(eng.world)
        clock = eng.world.clock
        for k, field in enumerate(MEMORY):
            np.testing.assert_array_equal(clock[..., k], getattr(planner._mem.out, field), err_msg=field)
        np.testing.assert_array_equal(clock[..., 5] > 0, planner.last["detour"])
        detours += int(planner.last["detour"][eng.world.active].sum())
        eng.step(action, autoreset=False)
        if not eng.world.active.any():
            break
    assert detours > 20


def test_the_clock_changes_no_episode_and_its_block_reads_the_clock():
    """The same actions give the same worlds with and without the clock (a sensing field); the block sits
    after the neighbours, reads the clock's fields in [0, 1], and the compiled observation equals the
    readable oracle."""
    plain = get_suite("door-headon-v0").scenario
    clocked = dataclasses.replace(plain, stall_clock=True, n_wall_points=3)
    a, b = Simulator(plain, 2), Simulator(clocked, 2)
    a.reset([3, 4])
    b.reset([3, 4])
    planner, seen = VCSPlanner(), np.zeros(2)
    for _ in range(120):
        act = planner.act(b.world)
        a.step(act)
        b.step(act)
        obs = observe(b.world, clocked)
        np.testing.assert_array_equal(obs, reference_observe(b.world, clocked))
        block = obs[..., observation_layout(clocked).span("clock")]
        assert block.min() >= 0.0 and block.max() <= 1.0
        np.testing.assert_array_equal(block[..., 0], b.world.clock[..., 5])
        np.testing.assert_allclose(block[..., 2], np.minimum(b.world.clock[..., 0] / 5.0, 1.0), rtol=1e-6)
        seen += block[..., 0].max(axis=1)
    for field, value in a.world.arrays().items():
        np.testing.assert_array_equal(value, getattr(b.world, field), err_msg=field)
    assert b.world.clock.shape == (2, plain.n_robots, CLOCK_DIM) and a.world.clock is None
    assert (seen > 0).all()  # both worlds had a detour
    names = [blk.name for blk in observation_layout(clocked).blocks]
    assert names == ["ego", "neighbors", "clock", "wall_points"]
    assert sensors_of(observation_config(clocked))["stall_clock"] is True
    assert sensors_of(observation_config(plain))["stall_clock"] is False


def test_a_restored_world_starts_a_new_clock_as_the_expert_clears_its_memory():
    """Start states leave the clock out (a pool serves any sensing); a world restored from one starts a
    fresh clock, as the expert's memory clears when a world jumps, so the two agree after it."""
    s = _clocked("room-v0")
    sim = Simulator(s, 2)
    sim.reset([0, 1])
    planner = VCSPlanner()
    for _ in range(40):
        sim.step(planner.act(sim.world))
    pool = StatePool.take(sim.world, sim.motion_params, [0, 1])
    assert "clock" not in pool.world
    eng = NavEngine(s, 2, start_states=StartStates({}, 0.0))
    eng.reset([5, 6])
    eng.sim.restore(pool, [1, 0])
    fresh = VCSPlanner()
    fresh.act(eng.world)
    for k, field in enumerate(MEMORY):
        np.testing.assert_array_equal(eng.world.clock[..., k], getattr(fresh._mem.out, field), err_msg=field)


def test_bad_clock_settings_are_refused_with_a_message():
    with pytest.raises(ValueError, match="stall_clock needs observation version 2"):
        Scenario(stall_clock=True, observation=1)
    with pytest.raises(ValueError, match="stall_clock must be True or False"):
        Scenario(stall_clock="yes")
    s = Scenario(stall_clock=True)
    world = Simulator(Scenario()).reset(0)  # made without the clock
    with pytest.raises(ValueError, match="keeps none"):
        observe(world, s)


def test_a_robot_at_rest_in_its_first_state_has_not_stalled_at_any_step():
    """At rest for ``stall_time`` means at rest in two states at least: with a step of dt >= stall_time (1 s) every
    robot at rest at its reset detoured at once (a review: two robots side by side in a corridor both turned off
    their walls, into each other). Held at rest into the next state, they do detour. A step over 0.25 s warns,
    once per planner: the expert is measured at shorter ones."""
    s = dataclasses.replace(get_suite("circle-8-v0").scenario, dt=1.0, stall_clock=True)
    eng = NavEngine(s, 2)
    eng.reset([0, 1])
    planner = VCSPlanner()
    with pytest.warns(CoarseStepWarning, match=r"dt = 1 s; it is measured at dt <= 0.25 s"):
        planner.plan(eng.world)
    assert not planner.last["detour"].any()
    assert not eng.world.clock[..., -1].any()  # the observed clock agrees
    eng.step(np.zeros((2, s.n_robots, 2)))  # no change of speed: still at rest
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # told once
        planner.plan(eng.world)
        fine = NavEngine(dataclasses.replace(s, dt=0.25), 1)
        fine.reset([0])
        VCSPlanner().plan(fine.world)  # CrowdNav's step: no warning
    assert planner.last["detour"].all()
    np.testing.assert_array_equal(eng.world.clock[..., -1], 1.0)
