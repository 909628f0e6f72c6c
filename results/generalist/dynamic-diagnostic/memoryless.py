"""Run a vcs-env command with the VCS expert's memory cleared every period (a diagnostic).

The VCS planner keeps per-robot memory across periods (the residual of its last target for
the hysteresis cost, stall, detour and progress-mark timers; baselines/vcs/planner.py). A
policy that sees one observation cannot know it. This wrapper clears it before every plan, so
the expert becomes a function of the current state only, then runs the vcs-env CLI:

    python results/generalist/dynamic-diagnostic/memoryless.py evaluate --policy vcs --suite dynamic-v0
    python results/generalist/dynamic-diagnostic/memoryless.py collect --scenario dynamic-v0 ...
"""

import sys

from baselines.vcs import planner
from vcs_cli import main

_sync = planner._Memory.sync


def _forget(self, world):
    _sync(self, world)
    for inp in (self.prev_in, self.has_prev_in, self.stall_in, self.detour_in, self.ref_in, self.wait_in):
        inp[...] = 0


planner._Memory.sync = _forget
sys.exit(main(sys.argv[1:]))
