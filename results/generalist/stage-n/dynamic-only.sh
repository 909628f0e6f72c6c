#!/bin/bash
# dynamic-only.sh B OUT: a diagnostic, not a recipe step. From run B's round-4 model (B = $ROOT/run-1-10 of
# policies/generalist.sh), PPO on the mixture's three dynamic entries alone, 2 M (d1) and 4 M (d2) steps,
# the rounds' settings otherwise; every checkpoint scored on 1000 fresh dynamic-v0 episodes (seeds 9000-9999).
set -euo pipefail
B=$(cd "$1" && pwd); mkdir -p "$2"; cd "$2"
export OMP_NUM_THREADS=1
D=("dynamic-v0:n_robots=2-6/2" "dynamic-v0:n_obstacles=4-8/2" "dynamic-v0:obstacle_speed=0.6-1.2")
[ -f states.npz ] || vcs-env collect-states --policy "$B/round4/model.zip" --on-collision terminate --mixture "${D[@]}" \
  --episodes 400 --seed 680000 --out states.npz
run() {  # NAME STEPS SEED CHECKPOINT_FREQ
  vcs-env train --mixture "${D[@]}" --mixture-balance robots --on-collision terminate --rewards collision=300 \
    --net-arch 256 256 --features slots --init "$B/round4/model.zip" --timesteps "$2" --seed "$3" --n-worlds 300 \
    --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 --checkpoint-freq "$4" --no-progress-bar \
    --start-states states.npz --start-prob 0.5 --out "$1"
}
run d1 2000000 15 500000 & p1=$!; run d2 4000000 16 1000000 & p2=$!
wait "$p1"; wait "$p2"
for c in d1/checkpoints/model_*.zip d1/model.zip d2/checkpoints/model_*.zip d2/model.zip; do
  echo "$c $(vcs-env evaluate --scenario dynamic-v0 --seeds 9000:10000 --policy "$c" --no-progress |
    awk '/^success/{s=$2}/^collision /{c=$2}END{print s"/"c}')"
done
