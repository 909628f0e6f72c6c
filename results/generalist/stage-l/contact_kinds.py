"""Kinds of contact in `vcs-env evaluate --json` files of the same episodes, and the overlap of the
episodes with a contact between the first file and every other one.
    python results/generalist/stage-l/contact_kinds.py vcs.json released.json p50r2.json
"""

import json
import sys

KINDS = ("at_fault_collision", "not_at_fault_collision", "robot_collision", "obstacle_collision", "parked_collision")
runs = {f: {e["seed"]: e for e in json.load(open(f))["episodes"]} for f in sys.argv[1:]}
ref = sys.argv[1]
hit_ref = {s for s, e in runs[ref].items() if e["collision"]}
for f, eps in runs.items():
    hit = {s for s, e in eps.items() if e["collision"]}
    kinds = ", ".join(f"{k.replace('_collision', '')} {int(sum(eps[s][k] for s in hit))}" for k in KINDS)
    print(f"{f}: {len(hit)} of {len(eps)} episodes with a contact ({kinds}); also in {ref}: {len(hit & hit_ref)}")
