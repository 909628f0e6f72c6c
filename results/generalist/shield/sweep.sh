#!/bin/bash
# sweep.sh OUT: the released network under shields of several horizons [s] and margins [m] (and one that counts every
# robot, not only those at most 0.05 m/s fast), on the validation sets of policies/generalist.sh (seeds 7000 on, which
# no suite or probe uses): success / collision / time to goal per set, one line per shield. Chooses nothing by itself.
set -euo pipefail
OUT=$1; mkdir -p "$OUT"
export OMP_NUM_THREADS=1
ROOT=$(cd "$(dirname "$0")/../../.." && pwd)
row() {  # NAME [vcs-env shield flags | none]
  local name=$1; shift
  local d="$OUT/$name"; mkdir -p "$d"
  cp "$ROOT/policies/generalist/model.zip" "$ROOT/policies/generalist/model.json" "$d/"
  if [ "$*" = none ]; then vcs-env shield "$d/model.zip" --remove > /dev/null; else vcs-env shield "$d/model.zip" "$@" > /dev/null; fi
  for spec in dynamic-v0:7300 circle-24-v0:7200 crowd-20-v0:7200; do
    vcs-env evaluate --scenario "${spec%%:*}" --seeds "7000:${spec##*:}" --policy "$d/model.zip" --no-progress \
      --json "$d/val-${spec%%:*}.json" > /dev/null
  done
  python - "$d" "$name" <<'PY'
import json, sys
from pathlib import Path
d = Path(sys.argv[1])
def cell(s):
    m = json.loads((d / f"val-{s}.json").read_text())["summary"]
    return f"{m['success']['mean']:.3f} / {m['collision']['mean']:.3f} / {m['time_to_goal']['mean']:.2f}"
print(f"| {sys.argv[2]} | " + " | ".join(cell(s) for s in ("dynamic-v0", "circle-24-v0", "crowd-20-v0")) + " |", flush=True)
PY
}
echo "| shield | dynamic-v0 7000-7299 | circle-24-v0 7000-7199 | crowd-20-v0 7000-7199 |"
echo "|---|---|---|---|"
row none none
for h in 1.0 1.5 2.0; do
  for m in 0.05 0.1 0.2; do row "h$h-m$m" --horizon $h --margin $m; done
done
row "h1.5-m0.1-all-robots" --horizon 1.5 --margin 0.1 --robot-speed 1000
