#!/bin/bash
# Stage F of the generalist (not released; README.md): contact features from the start, collision
# weight 150, the stage C mixture shared by robots. 62 min on this 2-core machine shared with
# one or two other jobs. Usage: [ROOT=runs/stage-f] bash results/generalist/stage-f/run.sh
set -euo pipefail
ROOT=${ROOT:-runs/stage-f}
export OMP_NUM_THREADS=1
mkdir -p "$ROOT"
source "$(dirname "${BASH_SOURCE[0]}")/../../../policies/generalist-mixture.sh"
[ -f "$ROOT/expert.npz" ] || vcs-env collect --mixture "${MIX_WIDE[@]}" --episodes 1200 --seed 0 --out "$ROOT/expert.npz"
[ -f "$ROOT/bc/model.zip" ] || vcs-env bc --data "$ROOT/expert.npz" --out "$ROOT/bc" --net-arch 256 256 --features contact \
  --epochs 20 --dagger-iters 3 --dagger-episodes 300 --eval-episodes 50
[ -f "$ROOT/ppo/model.zip" ] || vcs-env train --mixture "${MIX_WIDE[@]}" --mixture-balance robots --on-collision terminate \
  --rewards collision=150 --net-arch 256 256 --features contact --init "$ROOT/bc/model.zip" --timesteps 12000000 \
  --n-worlds 300 --lr-schedule linear --eval-freq 2000000 --eval-episodes 96 --no-progress-bar --out "$ROOT/ppo"
echo "stage F policy: $ROOT/ppo/model.zip"
