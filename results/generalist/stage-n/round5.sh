#!/bin/bash
# round5.sh B OUT: a fifth start-state round on top of run B's round 4 (B = the 1:10 run's directory of
# policies/generalist.sh, $ROOT/run-1-10), four variants, each scored with ../stage-m/evaluate.sh on the checkpoint
# `vcs-env select` keeps (from 1 M steps on). v1: the recipe's round repeated (seed 15); v2: two more
# plain dynamic-v0 entries; v3: collisions weighted 1000; v4: collisions weighted 600.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
B=$(cd "$1" && pwd); OUT=$2; mkdir -p "$OUT"; cd "$OUT"
export OMP_NUM_THREADS=1
source "$HERE/mixture.sh"
OBST=("${MIX[@]:5:7}")
[ -f states5.npz ] || vcs-env collect-states --policy "$B/round4/model.zip" --on-collision terminate --mixture "${OBST[@]}" \
  --episodes 400 --seed 580000 --out states5.npz
variant() {  # NAME COLLISION_WEIGHT [EXTRA ENTRIES...]
  local name=$1 cw=$2; shift 2
  vcs-env train --mixture "${MIX[@]}" "$@" --mixture-balance robots --on-collision terminate --rewards collision="$cw" \
    --net-arch 256 256 --features slots --init "$B/round4/model.zip" --timesteps 2000000 --seed 15 --n-worlds 300 \
    --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 --checkpoint-freq 500000 --no-progress-bar \
    --start-states states5.npz --start-prob 0.5 --out "$name"
  vcs-env select "$name" --from-step 1000000 --no-progress --out "sel-$name" \
    --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200
  OUT="$PWD/eval" bash "$HERE/../stage-m/evaluate.sh" "sel-$name/model.zip" "$name"
}
variant v1 300
variant v2 300 dynamic-v0 dynamic-v0
variant v3 1000
variant v4 600
