#!/bin/bash
# run.sh B STATES OUT SEED: the fifth round's variant v1 of ../round5.sh (same command, seed SEED) with the is-robot
# flag also telling how close a driving robot is to its goal, where it will stop dead (../parked-flag/parked_patch.py
# with INTENT_REF=1.5 m: 0.5 + 0.5 min(1, remaining / 1.5 m) for driving robots, 0 for parked ones, 1 as before
# beyond 1.5 m), applied to every vcs-env process through sitecustomize; then vcs-env select,
# ../../stage-m/evaluate.sh and ../contacts.py, all patched. B: run B's directory (its round4/model.zip),
# STATES: round5.sh's states5.npz. A diagnostic, not a recipe.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
B=$(cd "$1" && pwd); STATES=$(realpath "$2"); OUT=$3; seed=$4; mkdir -p "$OUT/site"; cd "$OUT"
cp "$HERE/../parked-flag/parked_patch.py" site/ && echo "import parked_patch  # noqa: F401" > site/sitecustomize.py
export OMP_NUM_THREADS=1 PYTHONPATH=$PWD/site INTENT_REF=1.5
source "$HERE/../mixture.sh"
name=i$((seed - 14))
vcs-env train --mixture "${MIX[@]}" --mixture-balance robots --on-collision terminate --rewards collision=300 \
  --net-arch 256 256 --features slots --init "$B/round4/model.zip" --timesteps 2000000 --seed "$seed" --n-worlds 300 \
  --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 --checkpoint-freq 500000 --no-progress-bar \
  --start-states "$STATES" --start-prob 0.5 --out "$name"
vcs-env select "$name" --from-step 1000000 --no-progress --out "sel-$name" \
  --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200
OUT="$PWD/eval" bash "$HERE/../../stage-m/evaluate.sh" "sel-$name/model.zip" "$name"
python "$HERE/../contacts.py" "sel-$name/model.zip" --seeds 9000:10000
