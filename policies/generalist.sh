#!/bin/bash
# Reproduces policies/generalist (83 min on this 2-core machine, shared with 2-3 other jobs):
# expert data on a mixture of the suites' families (1 min), BC + 3 DAgger rounds (15 min),
# PPO from those weights, 12 M steps (38 min), then 8 M more PPO steps on a wider mixture shared
# by robots, with collisions weighted 150 (29 min; results/generalist/stage-e).
# Usage: [ROOT=runs/generalist] bash policies/generalist.sh   (steps with a model.zip are skipped)
set -euo pipefail
ROOT=${ROOT:-runs/generalist}
export OMP_NUM_THREADS=1
mkdir -p "$ROOT"
# The mixture: every grid point is one scenario with a fixed share of the worlds.
MIX=(
  "circle-8-v0:n_robots=4-12/4,jitter=0.1-0.5/0.2"
  "circle-16-v0:jitter=0.1-0.3/0.2"
  "circle-24-v0"
  "swap-v0:n_robots=6-10/4"
  "crossing-v0:n_robots=8-12/4"
  "crowd-5-v0:n_obstacles=3-8"
  "crowd-5-v0:obstacle_speed=1.0-1.5"
  "crowd-10-v0:n_obstacles=9-12"
  "crowd-20-v0:n_obstacles=14-22/2"
  "dynamic-v0:n_robots=2-6/2"
  "dynamic-v0:obstacle_speed=0.6-1.2"
)
[ -f "$ROOT/expert.npz" ] || vcs-env collect --mixture "${MIX[@]}" --episodes 1200 --seed 0 --out "$ROOT/expert.npz"
[ -f "$ROOT/bc/model.zip" ] || vcs-env bc --data "$ROOT/expert.npz" --out "$ROOT/bc" --net-arch 256 256 --epochs 20 \
  --dagger-iters 3 --dagger-episodes 300 --eval-episodes 50
[ -f "$ROOT/ppo/model.zip" ] || vcs-env train --mixture "${MIX[@]}" --on-collision terminate --rewards collision=30 \
  --net-arch 256 256 --init "$ROOT/bc/model.zip" --timesteps 12000000 --n-worlds 96 --lr-schedule linear \
  --eval-freq 2000000 --eval-episodes 48 --no-progress-bar --out "$ROOT/ppo"
# Stage E: a wider mixture (crossing jitter, dynamic obstacle counts), every scenario stepping
# about as many robots, and a collision weight that makes one robot's contact cost more than
# the time it saves.
source "$(dirname "${BASH_SOURCE[0]}")/generalist-mixture.sh"
[ -f "$ROOT/ppo2/model.zip" ] || vcs-env train --mixture "${MIX_WIDE[@]}" --mixture-balance robots --on-collision terminate \
  --rewards collision=150 --net-arch 256 256 --init "$ROOT/ppo/model.zip" --timesteps 8000000 --n-worlds 300 \
  --lr-schedule linear --eval-freq 2000000 --eval-episodes 96 --no-progress-bar --out "$ROOT/ppo2"
echo "released policy: $ROOT/ppo2/model.zip"
