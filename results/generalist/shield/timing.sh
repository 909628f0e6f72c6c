#!/bin/bash
# timing.sh: compute per decision of the shielded release, the network alone and the VCS expert on the 1000 fresh
# dynamic-v0 episodes (seeds 9000-9999), one after another on one core. Run from the repository root.
set -euo pipefail
export OMP_NUM_THREADS=1
P=policies/generalist/model.zip
for run in "shielded:--policy $P" "network:--policy $P --no-shield" "vcs:--policy vcs"; do
  echo "${run%%:*}: $(vcs-env evaluate --scenario dynamic-v0 --seeds 9000:10000 ${run#*:} --no-progress 2>/dev/null | head -1)"
done
