"""Kernels over worlds in parallel (:mod:`vcs_env.threads`): the serial and parallel twins give the
same bits, and a rollout with walls, moving obstacles, lidar and terminate contacts is identical
with 1 and 2 threads. The twins' readable oracles are the serial kernels' (``test_kernels.py``,
``test_walls.py``, ``test_stop.py``, ``test_lidar.py``): equal to them bit for bit is enough."""

import numba
import numpy as np
import pytest

from baselines.vcs import VCSPlanner
from baselines.vcs import kernel as vcs_kernel
from vcs_env import kernels, lidar, threads
from vcs_env.engine import NavEngine
from vcs_env.lidar import LidarSpec
from vcs_env.rollout import planner_controller, run_episodes
from vcs_env.scenario import make_scenario
from vcs_env.suites import get_suite

TWO = pytest.mark.skipif(threads.max_threads() < 2, reason="NUMBA_NUM_THREADS < 2: numba has one thread")


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2", 10**6])
def test_set_threads_rejects_bad_values(bad):
    with pytest.raises(ValueError, match=r"set_threads\(n\): n must be an integer in"):
        threads.set_threads(bad)


def test_set_threads_default_is_the_usable_cores():
    old = threads.get_threads()
    try:
        assert threads.set_threads() == max(1, min(threads.available_cores(), threads.max_threads()))
        assert threads.set_threads(1) == threads.get_threads() == 1
        assert threads.set_threads(np.int64(1)) == 1 and type(threads.get_threads()) is int  # numpy integers too
    finally:
        threads.set_threads(old)


def test_twins_have_their_own_cache_files():
    """Numba keys its disk cache on the qualified name and line, not on ``parallel``: the parallel
    twin must carry another name or the two would load each other's machine code."""
    for kernel in (
        kernels.integrate,
        kernels.observe,
        kernels.wall_events_cached,
        kernels.stop_at_contact,
        lidar.cast_into,
        vcs_kernel.plan_batch,
    ):
        assert kernel.parallel.py_func.__qualname__ == kernel.serial.py_func.__qualname__ + "_parallel"
        assert kernel.parallel.targetoptions.get("parallel") and not kernel.serial.targetoptions.get("parallel")


def _scenario():
    return make_scenario(
        "walls",
        n_robots=4,
        n_walls=12,
        n_obstacles=3,
        obstacle_motion="arbitrary",
        on_collision="terminate",
        lidar=LidarSpec(n_beams=12),
        max_steps=30,
    )


def _rollout(n_threads, B=37, steps=60):
    """Every array the engine returns, and the world state, at every step (auto-reset on)."""
    old = threads.get_threads()
    threads.set_threads(n_threads)
    try:
        eng = NavEngine(_scenario(), batch_size=B)
        trace = [eng.reset(seeds=7)]
        rng = np.random.default_rng(3)
        for _ in range(steps):
            r = eng.step(rng.uniform(-1, 1, (B, 4, 2)), autoreset=True)
            ev = r.events
            trace += [r.obs, r.reward, r.terminated, r.truncated, ev.robot_hits, ev.obstacle_hits, ev.wall_hits]
            trace += [ev.min_separation, ev.reached, ev.collided, ev.goal_dist_after]
            w = eng.world
            trace += [w.pos.copy(), w.heading.copy(), w.speed.copy(), w.obs_pos.copy(), w.active.copy()]
        return trace
    finally:
        threads.set_threads(old)


@TWO
def test_rollout_is_identical_with_one_and_two_threads(monkeypatch):
    monkeypatch.setattr(threads, "MIN_PARALLEL_BATCH", 1)  # the parallel twins even at small B
    calls = []
    par = kernels.stop_at_contact.parallel
    monkeypatch.setattr(kernels.stop_at_contact, "parallel", lambda *a: calls.append(1) or par(*a))
    one, two = _rollout(1), _rollout(2)
    assert calls, "the rollout never ran the terminate kernel in parallel"
    assert len(one) == len(two)
    for a, b in zip(one, two):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)


@TWO
@pytest.mark.parametrize("suite", ["crowd-20-v0", "doorway-v0"])
def test_vcs_expert_plans_the_same_with_one_and_two_threads(monkeypatch, suite):
    """The VCS planner's world loop over blocks of worlds in parallel (37 worlds: five blocks of
    eight, the last one short): the same episodes, step for step, among moving obstacles and among walls."""
    monkeypatch.setattr(threads, "MIN_PARALLEL_BATCH", 1)
    calls = []
    par = vcs_kernel.plan_batch.parallel
    monkeypatch.setattr(vcs_kernel.plan_batch, "parallel", lambda *a: calls.append(1) or par(*a))
    scenario, seeds = get_suite(suite).scenario, range(5000, 5037)
    old = threads.get_threads()
    try:
        runs = []
        for n in (1, 2):
            threads.set_threads(n)
            runs.append(run_episodes(scenario, planner_controller(VCSPlanner()), seeds, max_steps=80))
    finally:
        threads.set_threads(old)
    assert calls, "the planner never ran its parallel twin"
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a.pos, b.pos)
        np.testing.assert_array_equal(a.actions, b.actions)


@TWO
@pytest.mark.parametrize("B", [1, 16, 17, 50])
def test_twins_agree_on_random_worlds(B):
    """Serial and parallel twins of the lidar and wall kernels on worlds across block edges."""
    numba.set_num_threads(2)
    s = _scenario()
    eng = NavEngine(s, batch_size=B)
    eng.reset(seeds=1)
    w = eng.world
    args = (w.pos, w.heading, w.present, w.radius, w.obs_pos, w.obs_radius, w.seg_a, w.seg_b, w.seg_present)
    args = (*args, s.lidar.offsets, 4.0)
    np.testing.assert_array_equal(lidar.cast(*args), _cast_parallel(*args))
    rng = np.random.default_rng(B)
    new_pos = w.pos + rng.normal(0, 0.3, w.pos.shape)
    sep, col = np.full(w.radius.shape, np.inf), np.zeros(w.radius.shape, bool)
    motion = (w.pos, new_pos, w.radius, w.present, w.active, w.seg_a, w.seg_b, w.seg_present, sep, col)
    got = []
    for kernel in (kernels.wall_events_cached.serial, kernels.wall_events_cached.parallel):
        cache = kernels.wall_cache(B, w.n_robots, w.n_segments)
        got.append(kernel(*motion, *cache, 0.5) + cache)
    for a, b in zip(*got):
        np.testing.assert_array_equal(a, b)


def _cast_parallel(*args):
    out = np.empty((*args[3].shape, args[9].shape[0]))
    lidar.cast_into.parallel(*args, out, 1.0)
    return out


FORK = """
import multiprocessing as mp
import numpy as np
from vcs_env import threads
from vcs_env.engine import NavEngine
from vcs_env.scenario import make_scenario

def work(_):
    eng = NavEngine(make_scenario("dynamic", n_robots=3, n_obstacles=4), batch_size=8)
    eng.reset(seeds=0)
    for _ in range(3):
        eng.step(np.zeros((8, 3, 2)))
    return float(eng.world.pos.sum())

if __name__ == "__main__":
    threads.MIN_PARALLEL_BATCH = 1
    threads.set_threads(2)
    parent = work(0)
    with mp.get_context("fork").Pool(2) as pool:
        assert pool.map_async(work, range(2)).get(timeout=120) == [parent, parent]
    import numba
    print(numba.threading_layer())
"""


@TWO
def test_forked_children_step_with_the_workqueue_layer(tmp_path):
    """The documented way around GNU OpenMP's fork hazard (:mod:`vcs_env.threads`): with
    ``NUMBA_THREADING_LAYER=workqueue`` the fork() children of a process that ran parallel kernels
    step (with ``omp`` they abort: "fork() called from a process already using GNU OpenMP")."""
    import os
    import subprocess
    import sys

    script = tmp_path / "fork.py"
    script.write_text(FORK)
    env = {**os.environ, "NUMBA_THREADING_LAYER": "workqueue"}
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "workqueue"
