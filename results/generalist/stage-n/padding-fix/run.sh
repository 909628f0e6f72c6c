#!/bin/bash
# run.sh REPRO FIX: policies/generalist.sh's start-state rounds 1-4 and its selection, on the code after the
# NavVecEnv padding fix (robots that had finished in a saved start state are padding slots, not live ones),
# from the same expert data, BC + DAgger and 8 M PPO steps as the release (REPRO: the ROOT of a run of the
# script before the fix; those stages do not use start states, so the fix does not change them), into FIX;
# then every round's final model and the kept checkpoint on 1000 fresh dynamic-v0 episodes (seeds 9000-9999)
# beside the same files of REPRO, and ../../stage-m/evaluate.sh on the kept checkpoint.
set -euo pipefail
REPRO=$(cd "$1" && pwd); FIX=$2; HERE=$(cd "$(dirname "$0")" && pwd); ROOT_DIR=$(cd "$HERE/../../../.." && pwd)
mkdir -p "$FIX"; FIX=$(cd "$FIX" && pwd)
ln -sf "$REPRO/expert.npz" "$FIX/expert.npz"
for r in run-0-0 run-1-10; do
  mkdir -p "$FIX/$r"; ln -sfn "$REPRO/$r/bc" "$FIX/$r/bc"; ln -sfn "$REPRO/$r/ppo" "$FIX/$r/ppo"
done
(cd "$ROOT_DIR" && ROOT="$FIX" bash policies/generalist.sh)
export OMP_NUM_THREADS=1
for r in run-0-0 run-1-10; do
  for k in 1 2 3 4; do
    for base in "$REPRO" "$FIX"; do
      s=$(vcs-env evaluate --scenario dynamic-v0 --seeds 9000:10000 --policy "$base/$r/round$k/model.zip" --no-progress \
          | awk '$1 == "success" {print $2}')
      echo "$r round$k $(basename "$base") fresh dynamic success $s"
    done
  done
done
OUT="$FIX/eval" bash "$HERE/../../stage-m/evaluate.sh" "$FIX/release/model.zip" fixed-kept
