#!/bin/bash
# evaluate.sh CKPT NAME: 1000 fresh dynamic-v0 episodes (seeds 9000-9999), the validation triple of
# policies/generalist.sh (seeds 7000 on) and the dynamic, circle-24 and crowd-20 suites; one line of
# success / collision. Files under $OUT (default runs/stage-m-eval)/NAME.
set -e
export OMP_NUM_THREADS=1
c=$1; n=$2; o=${OUT:-runs/stage-m-eval}/$n; mkdir -p $o
vcs-env evaluate --scenario dynamic-v0 --seeds 9000:10000 --policy $c --no-progress --json $o/fresh.json > /dev/null
for spec in circle-24-v0:7200 dynamic-v0:7300 crowd-20-v0:7200; do
  vcs-env evaluate --scenario "${spec%%:*}" --seeds "7000:${spec##*:}" --policy $c --no-progress --json $o/val-${spec%%:*}.json > /dev/null
done
for s in dynamic-v0 circle-24-v0 crowd-20-v0; do
  vcs-env evaluate --suite $s --policy $c --no-progress --json $o/suite-$s.json > /dev/null
done
python - "$o" "$n" <<'PY'
import json,sys
from pathlib import Path
o=Path(sys.argv[1])
def sc(f):
    s=json.loads((o/f).read_text())["summary"]; return f"{s['success']['mean']:.3f}/{s['collision']['mean']:.3f}"
print(f"{sys.argv[2]:<22} fresh {sc('fresh.json')} | val " + " ".join(sc(f"val-{f}.json") for f in ("circle-24-v0","dynamic-v0","crowd-20-v0")) + " | suite " + " ".join(sc(f"suite-{f}.json") for f in ("dynamic-v0","circle-24-v0","crowd-20-v0")))
PY
