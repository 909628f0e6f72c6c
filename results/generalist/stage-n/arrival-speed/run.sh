#!/bin/bash
# run.sh B STATES OUT [WEIGHT...]: the fifth round's variant v1 of ../round5.sh (same command, seed 15) with the
# arrival_speed reward term weighted WEIGHT (default 5), then vcs-env select, ../../stage-m/evaluate.sh, ../contacts.py
# and the mean arrival speed on 300 fresh dynamic-v0 episodes. B: run B's directory (its round4/model.zip), STATES:
# round5.sh's states5.npz. A diagnostic, not a recipe.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
B=$(cd "$1" && pwd); STATES=$(realpath "$2"); OUT=$3; shift 3; mkdir -p "$OUT"; cd "$OUT"
export OMP_NUM_THREADS=1
MIX=(
  "circle-8-v0:n_robots=4-12/4,jitter=0.1-0.5/0.2"
  "circle-16-v0:jitter=0.1-0.3/0.2"
  "circle-24-v0"
  "swap-v0:n_robots=6-10/4"
  "crossing-v0:n_robots=8-12/2,jitter=0.1-0.2/0.1"
  "crowd-5-v0:n_obstacles=3-8"
  "crowd-5-v0:obstacle_speed=1.0-1.5"
  "crowd-10-v0:n_obstacles=9-12"
  "crowd-20-v0:n_obstacles=14-22/2"
  "dynamic-v0:n_robots=2-6/2"
  "dynamic-v0:n_obstacles=4-8/2"
  "dynamic-v0:obstacle_speed=0.6-1.2"
  "circle-24-v0:jitter=0.1-0.2/0.1"
)
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
