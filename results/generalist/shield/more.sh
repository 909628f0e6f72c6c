#!/bin/bash
# more.sh: the shielded release off the suites, beside the numbers of the network alone in ../stage-n: the failed
# fresh dynamic episodes by first contact (contacts.txt), the 6-dynamic-robot probe on 3400 more episodes
# (edge-probe.txt), and the probe table at 400 episodes (probes-400). Run from the repository root.
set -euo pipefail
export OMP_NUM_THREADS=1
H=results/generalist/shield
P=policies/generalist/model.zip
python results/generalist/stage-n/contacts.py $P vcs --seeds 9000:10000 > $H/contacts.txt
for seeds in 5000:5400 20000:20400 30000:31000 40000:42000; do
  echo "seeds $seeds: $(vcs-env evaluate --scenario dynamic --n-robots 6 --seeds $seeds --policy $P --no-progress | sed -n 3p)"
done > $H/edge-probe.txt
vcs-env probe --policies vcs,$P --out $H/probes-400 --episodes 400 --no-progress > /dev/null
