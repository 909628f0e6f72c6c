"""The compiled placement loops (:mod:`vcs_env.placement`) place exactly what their readable oracles here
place, from the same draws, and leave the generator where the oracles leave it."""

import numpy as np
import pytest

from vcs_env.layouts import MAX_TRIES, Crowd, generate
from vcs_env.placement import Ahead, _free, place_discs
from vcs_env.scenario import make_scenario
from vcs_env.suites import SUITES
from vcs_env.walls import clearance


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


def _discs_oracle(rng, half, radius, sep, fixed=(), fixed_radius=0.0, segments=None, anchor=None, min_anchor=0.0):
    """:func:`place_discs` as a plain loop, one draw call per try, numpy's gaps (the former ``Sampler``)."""
    discs = [(np.asarray(q, dtype=float), fixed_radius) for q in fixed]
    out = []
    for i, r in enumerate(radius):
        lim = half - r
        for _ in range(MAX_TRIES):
            p = rng.uniform(-lim, lim, size=2)
            if not all(np.linalg.norm(q - p, axis=-1) - rq - r >= sep for q, rq in discs):
                continue
            if segments is not None and len(segments) and not clearance(p, segments) - r >= sep:
                continue
            if min_anchor > 0 and not np.linalg.norm(p - anchor[i], axis=-1) >= min_anchor:
                continue
            break
        else:
            raise ValueError(f"disc {i}")
        discs.append((p, r))
        out.append(p)
    return np.array(out).reshape(-1, 2)


def test_place_discs_is_the_oracle():
    cases = 0
    failed = 0
    for seed in range(300):
        g = np.random.default_rng(seed)
        half = float(g.uniform(1.5, 5.0))
        radius = g.uniform(0.1, 0.5, int(g.integers(1, 12)))
        fixed = g.uniform(-half, half, (int(g.integers(0, 6)), 2))
        segments = g.uniform(-half, half, (int(g.integers(0, 4)), 2, 2)) if seed % 2 else None
        anchor = g.uniform(-half, half, (len(radius), 2)) if seed % 3 == 0 else None
        kw = dict(
            fixed=fixed, fixed_radius=0.3, segments=segments, anchor=anchor, min_anchor=1.0 if seed % 3 == 0 else 0.0
        )
        sep = float(g.choice([0.0, 0.2]))
        a, b = np.random.default_rng(seed + 1000), np.random.default_rng(seed + 1000)
        try:
            got = place_discs(a, half, radius, sep, "disc {}", **kw)
        except ValueError as e:
            with pytest.raises(ValueError, match=str(e).split(" without")[0].replace("could not place ", "")):
                _discs_oracle(b, half, radius, sep, **kw)
            failed += 1
        else:
            np.testing.assert_array_equal(got, _discs_oracle(b, half, radius, sep, **kw))
            cases += 1
        assert a.random() == b.random()  # the generator left where the oracle leaves it
    assert cases > 100 and failed > 0  # both ends were reached


def test_the_gap_test_decides_as_numpy_at_the_limit():
    """The compiled gap test (:func:`vcs_env.placement._free`) against its readable numpy form,
    ``all(|q - p| - r_q - r >= sep)``, on discs placed right at the limit, and with a NaN."""
    rng = np.random.default_rng(0)
    for _ in range(300):
        sep = float(rng.choice([0.0, 0.2]))
        placed = rng.uniform(-4, 4, (int(rng.integers(1, 6)), 2))
        radii = rng.uniform(0.1, 0.5, len(placed))
        r = float(rng.uniform(0.1, 0.5))
        k = int(rng.integers(len(placed)))
        u = rng.normal(size=2)
        p = placed[k] + u / np.linalg.norm(u) * (radii[k] + r + sep + rng.choice([-1e-12, 0.0, 1e-12]))
        expected = bool(np.all(np.linalg.norm(placed - p, axis=-1) - radii - r >= sep))
        assert _free(p[0], p[1], r, placed, radii, len(placed), sep) == expected
    assert not _free(np.nan, 0.0, 0.3, np.zeros((1, 2)), np.array([0.3]), 1, 0.0)


def test_place_discs_refuses_radii_that_leave_no_room_and_a_missing_anchor():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"cannot place disc 1: its radius 2.5 m leaves no room .* half size 2 m"):
        place_discs(rng, 2.0, np.array([0.5, 2.5]), 0.1, "disc {}")
    with pytest.raises(ValueError, match="cannot place disc 0: its radius nan"):
        place_discs(rng, 2.0, np.array([np.nan]), 0.1, "disc {}")
    with pytest.raises(ValueError, match=r"min_anchor > 0 needs an anchor of shape \(2, 2\)"):
        place_discs(rng, 2.0, np.array([0.5, 0.5]), 0.1, "disc {}", min_anchor=1.0)


def test_float32_radii_give_numpys_float32_limits():
    # numpy computes half - r in float32 for a float32 radius, and draws in that range: so does place_discs.
    radius = np.array([0.3, 0.45, 0.2], dtype=np.float32)
    a, b = np.random.default_rng(4), np.random.default_rng(4)
    got = place_discs(a, 3.0, radius, 0.1, "disc {}")
    want = _discs_oracle(b, 3.0, radius, 0.1)
    np.testing.assert_array_equal(got, want)
