#!/bin/bash
# run.sh B STATES OUT BUMPER [SEED]: the fifth round's variant v1 of ../round5.sh (same command, seed SEED, default
# 15) trained with obstacle contacts counted from a gap of BUMPER metres (bumper_patch.py, through sitecustomize, in
# the training process only), then vcs-env select, ../../stage-m/evaluate.sh, ../contacts.py and
# ../obstacle_contacts.py, all without the patch (true contacts). B: run B's directory (its round4/model.zip),
# STATES: round5.sh's states5.npz. A diagnostic, not a recipe.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
B=$(cd "$1" && pwd); STATES=$(realpath "$2"); OUT=$3; bumper=$4; seed=${5:-15}; name=b${bumper}-s$seed
mkdir -p "$OUT/site-$name"; cd "$OUT"
cp "$HERE/bumper_patch.py" "site-$name/" && echo "import bumper_patch  # noqa: F401" > "site-$name/sitecustomize.py"
export OMP_NUM_THREADS=1
source "$HERE/../mixture.sh"
PYTHONPATH=$PWD/site-$name BUMPER=$bumper vcs-env train --mixture "${MIX[@]}" --mixture-balance robots \
  --on-collision terminate --rewards collision=300 --net-arch 256 256 --features slots --init "$B/round4/model.zip" \
  --timesteps 2000000 --seed "$seed" --n-worlds 300 --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 \
  --checkpoint-freq 500000 --no-progress-bar --start-states "$STATES" --start-prob 0.5 --out "$name"
vcs-env select "$name" --from-step 1000000 --no-progress --out "sel-$name" \
  --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200
OUT="$PWD/eval" bash "$HERE/../../stage-m/evaluate.sh" "sel-$name/model.zip" "$name"
python "$HERE/../contacts.py" "sel-$name/model.zip" --seeds 9000:10000
python "$HERE/../obstacle_contacts.py" "sel-$name/model.zip" --seeds 9000:10000
