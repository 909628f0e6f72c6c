#!/bin/bash
# Stage F of the generalist (not released; README.md): contact features from the start, collision
# weight 150, the stage C mixture shared by robots. 62 min on this 2-core machine shared with
# one or two other jobs. Usage: [ROOT=runs/stage-f] bash results/generalist/stage-f/run.sh
set -euo pipefail
ROOT=${ROOT:-runs/stage-f}
export OMP_NUM_THREADS=1
mkdir -p "$ROOT"
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
)
[ -f "$ROOT/expert.npz" ] || vcs-env collect --mixture "${MIX[@]}" --episodes 1200 --seed 0 --out "$ROOT/expert.npz"
[ -f "$ROOT/bc/model.zip" ] || vcs-env bc --data "$ROOT/expert.npz" --out "$ROOT/bc" --net-arch 256 256 --features contact \
  --epochs 20 --dagger-iters 3 --dagger-episodes 300 --eval-episodes 50
[ -f "$ROOT/ppo/model.zip" ] || vcs-env train --mixture "${MIX[@]}" --mixture-balance robots --on-collision terminate \
  --rewards collision=150 --net-arch 256 256 --features contact --init "$ROOT/bc/model.zip" --timesteps 12000000 \
  --n-worlds 300 --lr-schedule linear --eval-freq 2000000 --eval-episodes 96 --no-progress-bar --out "$ROOT/ppo"
echo "stage F policy: $ROOT/ppo/model.zip"
