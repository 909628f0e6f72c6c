#!/bin/bash
# control: three plain 3 M rounds (no start states), seeds 2, 3, 4, each from the previous final model
set -e
# Usage (from the repository root): ROOT=runs/control bash results/generalist/stage-l/control.sh
ROOT=${ROOT:-runs/control}; mkdir -p "$ROOT"
MIX=($(python -c "import sys; sys.path.insert(0, 'results/generalist/stage-l'); import start_states; print(' '.join(start_states.MIX[:-1]))"))
export OMP_NUM_THREADS=1
init=policies/generalist/model.zip
for r in 1 2 3; do
  vcs-env train --mixture "${MIX[@]}" "circle-24-v0:jitter=0.1-0.2/0.1" --mixture-balance robots --on-collision terminate \
    --rewards collision=300 --net-arch 256 256 --features slots --init $init --timesteps 3000000 --seed $((r + 1)) \
    --n-worlds 300 --learning-rate 1e-4 --lr-schedule linear --eval-freq 1000000 --eval-episodes 48 \
    --checkpoint-freq 500000 --no-progress-bar --out $ROOT/r$r > $ROOT/r$r.log 2>&1
  vcs-env evaluate --scenario dynamic-v0 --seeds 9000:10000 --policy $ROOT/r$r/model.zip --no-progress --json $ROOT/r$r-fresh.json > /dev/null 2>&1 &
  init=$ROOT/r$r/model.zip
done
wait
