"""The compiled placement loops (:mod:`vcs_env.placement`) place exactly what their readable oracles here
place, from the same draws, and leave the generator where the oracles leave it."""

import numpy as np
import pytest

from vcs_env.layouts import MAX_TRIES, Crowd, generate
from vcs_env.placement import Ahead
from vcs_env.scenario import make_scenario
from vcs_env.suites import SUITES


def _crowd_oracle(rng, s, start, goal, radius):
    """:meth:`Crowd._obstacles` as a plain loop, one draw call per try (the code before the compiled loop)."""
    m = len(radius)
    pos, target = np.zeros((m, 2)), np.zeros((m, 2))
    bodies = [(p, s.robot.radius) for p in np.concatenate((start, goal))]
    for k in range(m):
        for _ in range(MAX_TRIES):
            ang = rng.uniform(0.0, 2.0 * np.pi)
            noise = rng.uniform(-0.5, 0.5, size=2)
            p = s.circle_radius * np.array([np.cos(ang), np.sin(ang)]) + noise
            g = -p
            if all(np.linalg.norm(q - c) - rad - radius[k] >= s.min_separation for c, rad in bodies for q in (p, g)):
                break
        else:
            p = Crowd._search(rng, s, bodies, radius[k], k)
        pos[k], target[k] = p, -p
        bodies += [(p, radius[k]), (-p, radius[k])]
    return pos, target


def _layouts(s, seeds):
    """Each seed's layout arrays and the generator's next draw after it."""
    out = []
    for seed in seeds:
        rng = np.random.default_rng(seed)
        lay = generate(s, rng)
        out.append((lay.obs_pos, lay.obs_target, lay.obs_radius, rng.random()))
    return out


@pytest.mark.parametrize(
    "scenario, seeds",
    [
        (SUITES["crowd-20-v0"].scenario, range(40)),
        (make_scenario("crowd", n_obstacles=13), range(200)),  # near the packing bound: the search runs
        (make_scenario(SUITES["crowd-10-v0"].scenario, obstacle_radius=(0.6, 0.8), layout_radius=7.0), (20051, 20092)),
    ],
)
def test_crowd_obstacles_are_the_oracles(monkeypatch, scenario, seeds):
    searched = []
    search = Crowd._search

    def counting(*args):
        searched.append(args[-1])
        return search(*args)

    monkeypatch.setattr(Crowd, "_search", staticmethod(counting))
    fast = _layouts(scenario, seeds)
    n_search = len(searched)
    monkeypatch.setattr(Crowd, "_obstacles", staticmethod(_crowd_oracle))
    slow = _layouts(scenario, seeds)
    assert len(searched) == 2 * n_search  # both took the same paths
    if scenario.n_obstacles == 13:
        assert n_search > 0, "no seed reached the search over every place: the case tests nothing more"
    for a, b in zip(fast, slow):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("bits", [np.random.PCG64, np.random.MT19937, np.random.Philox])
def test_ahead_leaves_the_generator_where_its_own_draws_would(bits):
    for used in (0, 1, 7, 10):
        a, b = np.random.Generator(bits(3)), np.random.Generator(bits(3))
        for g in (a, b):  # a buffered 32-bit half-word is part of the state
            g.integers(0, 10, dtype=np.uint32)
        ahead = Ahead(a, 10)
        want = b.uniform(-2.0, 3.0, size=used)
        np.testing.assert_array_equal(-2.0 + 5.0 * ahead.u[:used], want)
        ahead.settle(used)
        assert a.integers(0, 2**32, dtype=np.uint32) == b.integers(0, 2**32, dtype=np.uint32)
        assert a.random() == b.random()
