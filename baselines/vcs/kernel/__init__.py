"""The VCS planner's inner loops, compiled with numba (one call plans every robot of every world).

Scalar math mirrors :mod:`baselines.vcs.geometry` (which is the readable reference; tests check
that both agree). Per robot (vcs-method §2.14), by stage:

0. :mod:`.period`: the memory across periods, the stall and detour rules and the obstacles as the
   search sees them before it, the residual and polar targets after it (vcs-method §2.4,
   vcs-method §2.13, vcs-method §2.15);
1. :mod:`.neighbours`: what the robot senses within r_ca, one record each: regulated radius r_eff
   (vcs-method §2.6), cone and apex (vcs-method §2.1, vcs-method §2.4), current time to
   collision t_c0;
2. :mod:`.horizon`: time needed to leave each cone T_need and the horizon T_h (vcs-method §2.7);
3. :mod:`.cost`: admissibility and the multi-objective cost J of a candidate (vcs-method §2.12);
4. :mod:`.window` and :mod:`.search`: the window W_k* sized by the first threat (vcs-method §2.10)
   and the point search over a grid of W_k* plus {G, 0, clip1(G)} (vcs-method §2.11): the
   cheapest admissible point wins;
5. :mod:`.fallback`: the least-bad point when none is admissible (vcs-method §2.13).

Named records (:mod:`.records`) carry the parameters, the robot's context and the neighbour state.

Numba's on-disk cache (``cache=True``) is invalidated per source file only: a caller compiled from
:mod:`.search` keeps the code of a stage module it inlined. Importing :mod:`vcs_env` clears the
cached kernels when a source of ``vcs_env`` or ``baselines`` changed (:mod:`vcs_env.kernel_cache`); measure or test an
edit in a new process. ``tests/test_planner_regression.py`` holds every plan to the fixture bit for bit.
"""

from .period import (
    finish,
    mover_images,
    push,
    remember_movers,
    robot_planning_steps,
    stall_rules,
    sync_memory,
    turn_leads,
)
from .records import PARAMS, Inputs, Memory, Outputs, Setting, StallRules, World, params_record
from .scalar import PLAN_STEPS, tau, tau_within
from .search import evaluate_points, plan_batch

__all__ = [
    "PARAMS",
    "PLAN_STEPS",
    "Inputs",
    "Memory",
    "Outputs",
    "Setting",
    "StallRules",
    "World",
    "evaluate_points",
    "finish",
    "mover_images",
    "params_record",
    "plan_batch",
    "push",
    "remember_movers",
    "robot_planning_steps",
    "stall_rules",
    "sync_memory",
    "turn_leads",
    "tau",
    "tau_within",
]
