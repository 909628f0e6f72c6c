#!/bin/bash
# score.sh: the released generalist (network + shield) on every suite beside vcs and hrvo (results/generalist/SUITE),
# on the probe table (results/probes/generalist), and on 1000 fresh dynamic-v0 episodes with and without its shield
# (../stage-m/evaluate.sh, files under $EVAL, default runs/shield-eval). Run from the repository root.
set -euo pipefail
export OMP_NUM_THREADS=1
EVAL=${EVAL:-runs/shield-eval}
P=policies/generalist/model.zip
for s in circle-8-v0 circle-16-v0 circle-24-v0 swap-v0 crossing-v0 crowd-5-v0 crowd-10-v0 crowd-20-v0 dynamic-v0 random-dense-v0; do
  vcs-env compare --suite $s --policies vcs,hrvo,$P --out results/generalist/$s --episode 0 --no-progress > /dev/null
  echo "$s done"
done
vcs-env probe --policies vcs,hrvo,$P --out results/probes/generalist --episodes 50 --no-progress > /dev/null
echo "probes done"
OUT=$EVAL bash results/generalist/stage-m/evaluate.sh $P shielded
mkdir -p $EVAL/network
vcs-env evaluate --scenario dynamic-v0 --seeds 9000:10000 --policy $P --no-shield --no-progress --json $EVAL/network/fresh.json \
  | sed -n 3,4p
