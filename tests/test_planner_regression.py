"""Planner outputs are bit for bit those of the fixture ``data/planner_hashes.json``.

The fixture was written by ``python tests/test_planner_regression.py`` from the single-file VCS
kernel that preceded the split by stage (:mod:`baselines.vcs.kernel`). Each case drives a VCS
rollout of a scenario and hashes, at every step, every planner's ``plan()`` output (VCS with its
``last`` diagnostics, a few VCS variants, VO, RVO and HRVO) and VCS ``evaluate()`` at a few
states, so a refactor of the kernels that changes a single bit of a plan shows here.
Regenerate it only for a deliberate change of planner behaviour. It holds one entry per float
platform (:mod:`bitwise`) and a machine writes only its own, so a rule added after the fixture runs
here with its flag off (:data:`PINNED`) until both entries can be written; such a rule is tested by
the behaviour tests that measure it against its ablation.
"""

import hashlib
import pathlib

import bitwise
import numpy as np
import pytest

from baselines import make_planner
from baselines.vcs import VCSPlanner
from vcs_env.engine import NavEngine
from vcs_env.scenario import make_scenario

REGENERATE = "python tests/test_planner_regression.py"
"""Writes this platform's entry of the fixture (:mod:`bitwise`)."""
FIXTURE = pathlib.Path(__file__).parent / "data" / "planner_hashes.json"
STEPS = 100
CASES = {
    "circle-16": ("circle", {"n_robots": 16, "jitter": 0.1, "on_collision": "continue"}, 2),
    "random-12-dense": ("random", {"n_robots": 12, "arena_half_size": 4.0, "on_collision": "continue"}, 2),
    "crowd": ("crowd", {"n_obstacles": 12, "on_collision": "continue"}, 2),
    "dynamic": ("dynamic", {"on_collision": "continue"}, 2),
    "circle-10-holonomic": (
        "circle",
        {"n_robots": 10, "jitter": 0.1, "on_collision": "continue", "robot": {"holonomic": True}},
        2,
    ),
    "swap-parked": ("swap", {"n_robots": 4, "n_obstacles": 2, "on_collision": "continue"}, 1),
}
VARIANTS = {
    "vcs-rvo-infinite": {"reciprocity": "rvo", "horizon": "infinite", "fallback": "penalty"},
    "vcs-vo-one-step": {"reciprocity": "vo", "window": "one_step", "goal_metric": "vcs"},
    "vcs-rules-off": {
        "arriving_non_reactive": False,
        "joint_escape": False,
        "ramp_check": False,
        "crowd_margin": False,
        "stop_margin": False,
    },
}
PINNED = {
    "arriving_goal_twin": False,
    "mirror_bounces": False,
    "no_follow": False,
    "detour_escalate": False,
    "stall_turn": False,
    "free_turn": False,
    "mover_turn_lead": None,
    "fallback_contact": None,
    "holonomic_window_fit": False,
    "fit_discs": False,
}
"""Planner rules newer than the fixture, off in every VCS planner here (module docstring): the goal
twin, the mirror images of bouncing obstacles, no following inside a mover's buffer, escalating
detours, turning in place from rest, movers that turn and the fallback's play-out against
movers (2026-11-28), the holonomic window fitted to its disc (2026-11-29), buffers fitted between two
parked robots (2026-12-01), turning in place toward a free heading (2026-12-08); ``tests/test_vcs_safety.py``
and ``tests/test_vcs_walls.py`` measure them."""
EVAL_EVERY = 25
"""Steps between the states at which ``evaluate()`` of robot 0 is hashed."""


def _update(digest, arrays: dict) -> None:
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(name.encode() + a.dtype.str.encode() + repr(a.shape).encode() + a.tobytes())


def fingerprint(case: str) -> dict:
    """sha256 per planner over the whole rollout of one case."""
    kind, overrides, worlds = CASES[case]
    scenario = make_scenario(kind, **overrides)
    eng = NavEngine(scenario, worlds)
    eng.reset(list(range(worlds)))
    driver = VCSPlanner(**PINNED)
    others = {"vo": make_planner("vo"), "rvo": make_planner("rvo"), "hrvo": make_planner("hrvo")}
    others.update({name: VCSPlanner(**PINNED, **kw) for name, kw in VARIANTS.items()})
    digests = {name: hashlib.sha256() for name in ("vcs", "vcs-evaluate", *others)}
    grid_dv, grid_dth = np.meshgrid(np.linspace(-1.0, 1.0, 9), np.linspace(-np.pi, np.pi, 13))
    for step in range(STEPS):
        world = eng.world
        target = driver.plan(world)
        _update(digests["vcs"], {"target": target, **driver.last})
        for name, planner in others.items():
            out = {"target": planner.plan(world)}
            if isinstance(planner, VCSPlanner):
                out.update(planner.last)
            _update(digests[name], out)
        if step % EVAL_EVERY == 0:
            ok, cost, horizon = driver.evaluate(world, 0, 0, grid_dv, grid_dth)
            _update(digests["vcs-evaluate"], {"ok": ok, "cost": cost, "horizon": horizon})
        eng.step(driver.act(world))
    return {name: d.hexdigest() for name, d in digests.items()}


@pytest.mark.parametrize("case", sorted(CASES))
def test_planner_matches_fixture(case):
    assert fingerprint(case) == bitwise.expected(FIXTURE, REGENERATE)[case]


if __name__ == "__main__":
    bitwise.write(FIXTURE, {c: fingerprint(c) for c in sorted(CASES)})
