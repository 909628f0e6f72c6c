#!/bin/bash
# Reproduces policies/generalist (about 100 min on this 2-core machine): expert data on a mixture of the
# suites' families (0.8 min), then two training runs side by side, one per core, each with its own seeds:
# BC + 4 DAgger rounds with the slot encoder (`--features slots`, 25 min), PPO from those weights, 8 M
# steps with collisions weighted 150 (33 min), then 4 start-state rounds of 2 M PPO steps with collisions
# weighted 300 and one more circle-24 entry (10 min each: every round first collects the previous model's
# states shortly before its contacts and where an obstacle is about to hit a robot, on the crowd and
# dynamic entries, and half of those worlds start from them); last, of both runs' last rounds, the
# checkpoint that does best on validation seeds (1 min), released with a safety shield on its actions
# (docs/experiments.md, the safety shield). The recipe is seed-sensitive (one seed pair of two kept circle-24 at 0.86),
# so both runs are part of it; docs/experiments.md, stage N.
# Usage: [ROOT=runs/generalist] [RUNS="0:0 1:10"] bash policies/generalist.sh
# Run again, it skips every stage whose result is there; a stage that died leaves its directory without model.zip,
# which vcs-env refuses to train into: remove that directory first.
# RUNS: one BC_SEED:S0 pair per run, run side by side (BC seed BC_SEED, the 8 M PPO steps seed S0, round r
# seed S0 + r), into $ROOT/run-BC_SEED-S0. Steps with a model.zip are skipped; the selection always runs.
set -euo pipefail
ROOT=${ROOT:-runs/generalist}
RUNS=${RUNS:-"0:0 1:10"}
for pair in $RUNS; do
  [[ $pair =~ ^[0-9]+:[0-9]+$ ]] || { echo "RUNS holds BC_SEED:S0 pairs such as \"0:0 1:10\", got '$pair'" >&2; exit 2; }
done
export OMP_NUM_THREADS=1
mkdir -p "$ROOT"
# The mixture: every entry is one or more scenarios (agents.config.mixture_scenarios), named by its
# suite so it keeps the suite's conventions.
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
# One training run: BC_SEED S0 DIR.
train_run() {
  local BC_SEED=$1 S0=$2 DIR=$3
  mkdir -p "$DIR"
  [ -f "$DIR/bc/model.zip" ] || vcs-env bc --data "$ROOT/expert.npz" --out "$DIR/bc" --net-arch 256 256 --features slots --seed "$BC_SEED" \
    --epochs 20 --dagger-iters 4 --dagger-episodes 300 --eval-episodes 50
  # Worlds shared by robots: every scenario steps about as many robots.
  [ -f "$DIR/ppo/model.zip" ] || vcs-env train --mixture "${MIX[@]}" --mixture-balance robots --on-collision terminate \
    --rewards collision=150 --net-arch 256 256 --features slots --init "$DIR/bc/model.zip" --seed "$S0" --timesteps 8000000 \
    --n-worlds 300 --lr-schedule linear --eval-freq 2000000 --eval-episodes 96 --no-progress-bar --out "$DIR/ppo"
  # Start-state rounds: collect the previous model's pre-contact and danger states on the crowd and dynamic
  # entries (vcs-env collect-states), then 2 M PPO steps with half of those worlds starting from them.
  local prev="$DIR/ppo/model.zip" lr=1.5e-4 r
  for r in 1 2 3 4; do
    if [ ! -f "$DIR/round$r/model.zip" ]; then
      [ -f "$DIR/states$r.npz" ] || vcs-env collect-states --policy "$prev" --on-collision terminate \
        --mixture "${OBST[@]}" --episodes 400 \
        --seed $((80000 + 100000 * r)) --out "$DIR/states$r.npz"
      vcs-env train --mixture "${MIX[@]}" "circle-24-v0:jitter=0.1-0.2/0.1" --mixture-balance robots \
        --on-collision terminate --rewards collision=300 --net-arch 256 256 --features slots --init "$prev" \
        --timesteps 2000000 --seed $((S0 + r)) --n-worlds 300 --learning-rate $lr --lr-schedule linear --eval-freq 0 \
        --checkpoint-freq 500000 --no-progress-bar --start-states "$DIR/states$r.npz" --start-prob 0.5 \
        --out "$DIR/round$r"
    fi
    prev="$DIR/round$r/model.zip"; lr=1e-4
  done
}
OBST=("${MIX[@]:5:7}")
# The runs side by side (logs in $ROOT/run-*.log); no selection if any of them failed.
runs=(); pids=()
for pair in $RUNS; do
  bc=${pair%%:*} s0=${pair##*:}; runs+=("$ROOT/run-$bc-$s0")
  train_run "$bc" "$s0" "${runs[-1]}" > "${runs[-1]}.log" 2>&1 &
  pids+=($!)
done
failed=0
for i in "${!pids[@]}"; do
  wait "${pids[$i]}" || { echo "training run ${runs[$i]} failed: see ${runs[$i]}.log" >&2; failed=1; }
done
[ "$failed" = 0 ] || exit 1
# Keep the checkpoint of the runs' last rounds (from 1 M steps on, and their final models) that solves most
# episodes on validation seeds no suite or probe uses (7000 on): circle-24 swings by tens of points between
# checkpoints and between seeds.
vcs-env select "${runs[@]/%//round4}" --from-step 1000000 --no-progress --out "$ROOT/release" \
  --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200
# The released policy runs with a safety shield (agents/shield.py) kept in its run record: horizon 1.5 s, margin
# 0.1 m, robots counted at most 0.05 m/s fast, chosen on the same validation seeds (docs/experiments.md, the safety shield);
# the same margin to still bodies and no driving guard, the rule it was released with (its record predates both).
vcs-env shield "$ROOT/release/model.zip" --horizon 1.5 --margin 0.1 --robot-speed 0.05 --still-margin 0.1 --no-driving-guard
