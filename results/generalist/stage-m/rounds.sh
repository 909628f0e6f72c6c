#!/bin/bash
# Start-state rounds: each round collects the previous policy's pre-contact and danger states on the
# mixture's crowd and dynamic entries (vcs-env collect-states, 400 episodes per scenario), then trains
# STEPS more PPO steps from it with half of those scenarios' worlds starting from the pools.
# Usage: bash results/generalist/stage-m/rounds.sh DIR INIT STEPS ROUNDS SEED0 [FIRST_ROUND]
# (round r: collection seeds 80000 + 100000 r on, PPO seed SEED0 + r; rounds with a model.zip are skipped)
set -euo pipefail
DIR=$1; prev=$2; STEPS=$3; R=$4; S0=$5; FIRST=${6:-1}
export OMP_NUM_THREADS=1
MIX=(  # policies/generalist.sh's mixture and its jittered circle-24 entry
  "circle-8-v0:n_robots=4-12/4,jitter=0.1-0.5/0.2" "circle-16-v0:jitter=0.1-0.3/0.2" "circle-24-v0"
  "swap-v0:n_robots=6-10/4" "crossing-v0:n_robots=8-12/2,jitter=0.1-0.2/0.1"
  "crowd-5-v0:n_obstacles=3-8" "crowd-5-v0:obstacle_speed=1.0-1.5" "crowd-10-v0:n_obstacles=9-12"
  "crowd-20-v0:n_obstacles=14-22/2" "dynamic-v0:n_robots=2-6/2" "dynamic-v0:n_obstacles=4-8/2"
  "dynamic-v0:obstacle_speed=0.6-1.2" "circle-24-v0:jitter=0.1-0.2/0.1"
)
OBST=("${MIX[@]:5:7}")
mkdir -p "$DIR"
for r in $(seq "$FIRST" "$R"); do
  if [ ! -f "$DIR/r$r/model.zip" ]; then
    vcs-env collect-states --policy "$prev" --on-collision terminate --mixture "${OBST[@]}" --episodes 400 \
      --seed $((80000 + 100000 * r)) --out "$DIR/states$r.npz"
    vcs-env train --mixture "${MIX[@]}" --mixture-balance robots --on-collision terminate --rewards collision=300 \
      --net-arch 256 256 --features slots --init "$prev" --timesteps "$STEPS" --seed $((S0 + r)) --n-worlds 300 \
      --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 --checkpoint-freq 500000 --no-progress-bar \
      --start-states "$DIR/states$r.npz" --start-prob 0.5 --out "$DIR/r$r"
  fi
  prev="$DIR/r$r/model.zip"
done
