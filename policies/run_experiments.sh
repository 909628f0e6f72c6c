#!/bin/bash
# Reproduces the RL study of policies/README.md (sequential; about 75 min on 2 shared cores for
# 3 seeds of every method on both scenarios, plus 20 min per seed of the long crowd-5 runs).
# Usage: [ROOT=runs] [SEEDS="0 1 2"] [ONLY=circle|crowd] [METHODS="ppo dagger-ppo ..."] policies/run_experiments.sh
# Methods: ppo, ppo-imitation, ppo-potential, dagger-ppo, dagger-ppo-8m (crowd only). Runs that
# already have a model.zip are skipped, so an interrupted study continues where it stopped.
set -euo pipefail
ROOT=${ROOT:-runs}
SEEDS=${SEEDS:-"0 1 2"}
ONLY=${ONLY:-}
METHODS=${METHODS:-"ppo ppo-imitation ppo-potential dagger-ppo dagger-ppo-8m"}
export OMP_NUM_THREADS=1
mkdir -p "$ROOT/data" "$ROOT/bc" "$ROOT/logs"

want() { [[ " $METHODS " == *" $1 "* ]]; }

run() {  # run OUT ARGS...: skip if OUT/model.zip exists, else run ARGS logging to $ROOT/logs/<name of OUT>.log
  local out=$1; shift
  if [ -f "$out/model.zip" ]; then echo "done: $out"; return; fi
  echo "$(date +%T) start: $out"
  "$@" > "$ROOT/logs/$(basename "$(dirname "$out")")_$(basename "$out").log" 2>&1 || echo "FAILED: $out"
}

# --- circle-8: 8 robots swap through the centre of a 5 m circle (0.1 m start jitter, like circle-8-v0)
CIRCLE="--scenario circle --n-robots 8 --jitter 0.1"
CIRCLE_PPO="$CIRCLE --timesteps 1000000 --n-worlds 16 --lr-schedule linear --eval-freq 250000 --eval-episodes 50 --no-progress-bar"
if [ "$ONLY" != crowd ]; then
  [ -f "$ROOT/data/circle8_expert.npz" ] || vcs-env collect $CIRCLE --episodes 100 --seed 0 --out "$ROOT/data/circle8_expert.npz"
  for s in $SEEDS; do
    ! want ppo || run "$ROOT/circle8_ppo_s$s" vcs-env train $CIRCLE_PPO --seed $s --out "$ROOT/circle8_ppo_s$s"
    ! want ppo-imitation || run "$ROOT/circle8_ppo-imitation_s$s" vcs-env train $CIRCLE_PPO --seed $s --shaping vcs_imitation --out "$ROOT/circle8_ppo-imitation_s$s"
    ! want ppo-potential || run "$ROOT/circle8_ppo-potential_s$s" vcs-env train $CIRCLE_PPO --seed $s --shaping vcs_potential --out "$ROOT/circle8_ppo-potential_s$s"
    if want dagger-ppo; then
      run "$ROOT/bc/circle8_s$s" vcs-env bc --data "$ROOT/data/circle8_expert.npz" --seed $s --epochs 30 --dagger-iters 4 \
        --dagger-episodes 50 --dagger-epochs 10 --eval-episodes 50 --out "$ROOT/bc/circle8_s$s"
      run "$ROOT/circle8_dagger-ppo_s$s" vcs-env train $CIRCLE_PPO --seed $s --init "$ROOT/bc/circle8_s$s/model.zip" \
        --out "$ROOT/circle8_dagger-ppo_s$s"
    fi
  done
fi

# --- crowd-5: one robot crosses a 4 m circle among 5 non-reactive obstacles (like crowd-5-v0).
# Collision weight 30 instead of 10 (chosen on the training-time evaluation seeds, not on the suite).
CROWD="--scenario crowd"
CROWD_PPO="$CROWD --rewards collision=30 --timesteps 2000000 --n-worlds 128 --lr-schedule linear --eval-freq 250000 --eval-episodes 50 --no-progress-bar"
CROWD_LONG="$CROWD --rewards collision=30 --timesteps 8000000 --n-worlds 256 --lr-schedule linear --eval-freq 1000000 --eval-episodes 100 --no-progress-bar"
if [ "$ONLY" != circle ]; then
  [ -f "$ROOT/data/crowd5_expert.npz" ] || vcs-env collect $CROWD --episodes 500 --seed 0 --out "$ROOT/data/crowd5_expert.npz"
  for s in $SEEDS; do
    if want dagger-ppo || want dagger-ppo-8m; then
      run "$ROOT/bc/crowd5_s$s" vcs-env bc --data "$ROOT/data/crowd5_expert.npz" --seed $s --epochs 30 --dagger-iters 4 \
        --dagger-episodes 200 --dagger-epochs 10 --eval-episodes 50 --out "$ROOT/bc/crowd5_s$s"
    fi
    ! want dagger-ppo || run "$ROOT/crowd5_dagger-ppo_s$s" vcs-env train $CROWD_PPO --seed $s --init "$ROOT/bc/crowd5_s$s/model.zip" \
      --out "$ROOT/crowd5_dagger-ppo_s$s"
    ! want ppo || run "$ROOT/crowd5_ppo_s$s" vcs-env train $CROWD_PPO --seed $s --out "$ROOT/crowd5_ppo_s$s"
    ! want ppo-potential || run "$ROOT/crowd5_ppo-potential_s$s" vcs-env train $CROWD_PPO --seed $s --shaping vcs_potential --out "$ROOT/crowd5_ppo-potential_s$s"
    ! want ppo-imitation || run "$ROOT/crowd5_ppo-imitation_s$s" vcs-env train $CROWD_PPO --seed $s --shaping vcs_imitation --out "$ROOT/crowd5_ppo-imitation_s$s"
    ! want dagger-ppo-8m || run "$ROOT/crowd5_dagger-ppo-8m_s$s" vcs-env train $CROWD_LONG --seed $s --init "$ROOT/bc/crowd5_s$s/model.zip" \
      --out "$ROOT/crowd5_dagger-ppo-8m_s$s"
  done
fi

# --- scores on the fixed suites (100 episodes each, deterministic actions), next to the expert,
# with the learning curves (policies/study_*.json and docs/*_learning_curves.png come from these)
[ "$ONLY" = crowd ] || python -m agents.experiments --suite circle-8-v0 --runs "$ROOT"/circle8_*_s* \
  --json "$ROOT/circle8_results.json" --markdown "$ROOT/circle8_results.md" --figure "$ROOT/circle8_learning_curves.png"
[ "$ONLY" = circle ] || python -m agents.experiments --suite crowd-5-v0 --runs "$ROOT"/crowd5_*_s* \
  --json "$ROOT/crowd5_results.json" --markdown "$ROOT/crowd5_results.md" --figure "$ROOT/crowd5_learning_curves.png"
