#!/bin/bash
# held-out.sh: 2000 dynamic-v0 episodes on seeds no choice of this study looked at (100000-101999): the shielded
# release, the network alone and the VCS expert. Run from the repository root; prints one line each.
set -euo pipefail
export OMP_NUM_THREADS=1
P=policies/generalist/model.zip
for run in "shielded:--policy $P" "network:--policy $P --no-shield" "vcs:--policy vcs"; do
  echo "${run%%:*}: $(vcs-env evaluate --scenario dynamic-v0 --seeds 100000:102000 ${run#*:} --no-progress 2>/dev/null | sed -n 3,4p | tr -s ' ' | tr '\n' ' ')"
done
