#!/bin/bash
# run.sh B STATES OUT [WEIGHT...]: the fifth round's variant v1 of ../round5.sh (same command, seed 15) with the
# arrival_speed reward term weighted WEIGHT (default 5), then vcs-env select, ../../stage-m/evaluate.sh, ../contacts.py
# and the mean arrival speed on 300 fresh dynamic-v0 episodes. B: run B's directory (its round4/model.zip), STATES:
# round5.sh's states5.npz. A diagnostic, not a recipe.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
B=$(cd "$1" && pwd); STATES=$(realpath "$2"); OUT=$3; shift 3; mkdir -p "$OUT"; cd "$OUT"
export OMP_NUM_THREADS=1
source "$HERE/../mixture.sh"
for w in "${@:-5}"; do
  name=a$w
  vcs-env train --mixture "${MIX[@]}" --mixture-balance robots --on-collision terminate \
    --rewards collision=300,arrival_speed="$w" --net-arch 256 256 --features slots --init "$B/round4/model.zip" \
    --timesteps 2000000 --seed 15 --n-worlds 300 --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 \
    --checkpoint-freq 500000 --no-progress-bar --start-states "$STATES" --start-prob 0.5 --out "$name"
  vcs-env select "$name" --from-step 1000000 --no-progress --out "sel-$name" \
    --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200
  OUT="$PWD/eval" bash "$HERE/../../stage-m/evaluate.sh" "sel-$name/model.zip" "$name"
  python "$HERE/../contacts.py" "sel-$name/model.zip" vcs --seeds 9000:10000
  python "$HERE/arrival.py" "sel-$name/model.zip" vcs
done
