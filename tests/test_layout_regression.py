"""Generated layouts are bit-for-bit those of the fixture ``data/layout_hashes.json``.

The fixture was written by ``python tests/test_layout_regression.py`` from the string-switch
layout code that preceded the scenario-kind objects of :mod:`vcs_env.layouts`; a change to a
kind's generator, its sizing (``world_extent``, ``view_extent``) or its random draws shows here.
Regenerate it only for a deliberate change of layouts (and bump the env versions).
"""

import hashlib
import pathlib

import bitwise
import numpy as np
import pytest

from vcs_env.layouts import generate
from vcs_env.scenario import make_scenario

REGENERATE = "python tests/test_layout_regression.py"
"""Writes this platform's entry of the fixture (:mod:`bitwise`)."""
FIXTURE = pathlib.Path(__file__).parent / "data" / "layout_hashes.json"
SEEDS = (0, 1, 7)
CASES = {
    "circle": {},
    "circle-13-jitter-obstacles": {"n_robots": 13, "jitter": 0.1, "n_obstacles": 3, "arena_half_size": 8.0},
    "swap": {},
    "swap-6-jitter-obstacles": {"n_robots": 6, "jitter": 0.05, "n_obstacles": 2},
    "crossing": {},
    "crossing-9-obstacles": {"n_robots": 9, "n_obstacles": 2, "layout_radius": 6.0},
    "random": {},
    "random-10-obstacles": {"n_robots": 10, "n_obstacles": 4, "arena_half_size": 7.0},
    "crowd": {},
    "crowd-3-8": {"n_robots": 3, "n_obstacles": 8, "layout_radius": 6.0},
    "dynamic": {},
    "dynamic-8-3": {"n_robots": 8, "n_obstacles": 3},
    "custom": {},
    "custom-initial-state": {"initial_speed": 0.5, "jitter": 0.3},
    "corridor": {},
    "corridor-7-obstacles": {"n_robots": 7, "n_obstacles": 2, "corridor_width": 3.0},
    "doorway": {},
    "room": {},
    "intersection": {},
    "walls": {},
    "walls-3-obstacles": {"n_robots": 3, "n_obstacles": 3, "n_walls": 12},
}
FIELDS = ("start", "goal", "heading", "speed", "obs_pos", "obs_target", "obs_radius", "segments")


def _scenario(case: str):
    return make_scenario(case.split("-")[0], **CASES[case])


def fingerprint(case: str) -> dict:
    """Sizes and per-seed array hashes of one case (sha256 of the float64 bytes)."""
    s = _scenario(case)
    out = {"world_extent": repr(s.world_extent), "view_extent": repr(s.view_extent)}
    for seed in SEEDS:
        lay = generate(s, np.random.default_rng(seed))
        digest = hashlib.sha256()
        for name in FIELDS:
            arr = np.ascontiguousarray(getattr(lay, name), dtype=np.float64)
            if name == "segments" and arr.size == 0:
                continue  # layouts without walls keep the hashes they had before walls existed
            digest.update(name.encode() + repr(arr.shape).encode() + arr.tobytes())
        out[f"seed{seed}"] = digest.hexdigest()
    return out


@pytest.mark.parametrize("case", sorted(CASES))
def test_layout_matches_fixture(case):
    assert fingerprint(case) == bitwise.expected(FIXTURE, REGENERATE)[case]


def test_fixture_covers_every_case_and_kind():
    from vcs_env.layouts import KINDS

    assert set(bitwise.expected(FIXTURE, REGENERATE)) == set(CASES)
    assert {_scenario(c).kind for c in CASES} == set(KINDS)


if __name__ == "__main__":
    bitwise.write(FIXTURE, {c: fingerprint(c) for c in CASES})
