#!/bin/bash
# run.sh B STATES OUT LOGSTD [SEED]: the fifth round's variant v1 of ../round5.sh (same command, seed SEED, default
# 15) started from run B's round-4 model with the policy's log standard deviation reset to LOGSTD (the model had
# -1.2 / -1.3 for acceleration / turn: training noise 0.3 / 0.27 in action units, where the scores use the mean
# action), then vcs-env select and ../../stage-m/evaluate.sh. B: run B's directory (its round4/model.zip), STATES:
# round5.sh's states5.npz. A diagnostic, not a recipe.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
B=$(cd "$1" && pwd); STATES=$(realpath "$2"); OUT=$3; logstd=$4; seed=${5:-15}; name=n${logstd}-s$seed
mkdir -p "$OUT"; cd "$OUT"
export OMP_NUM_THREADS=1
python - "$B/round4/model.zip" "$logstd" "init-$name.zip" <<'PY'
import io, sys, zipfile
import torch
src, logstd, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
with zipfile.ZipFile(src) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
    for item in zin.infolist():
        data = zin.read(item.filename)
        if item.filename == "policy.pth":
            weights = torch.load(io.BytesIO(data), map_location="cpu")
            weights["log_std"].fill_(logstd)
            buf = io.BytesIO(); torch.save(weights, buf); data = buf.getvalue()
        zout.writestr(item, data)
PY
cp "$B/round4/model.json" "init-$name.json"
source "$HERE/../mixture.sh"
vcs-env train --mixture "${MIX[@]}" --mixture-balance robots --on-collision terminate --rewards collision=300 \
  --net-arch 256 256 --features slots --init "init-$name.zip" --timesteps 2000000 --seed "$seed" --n-worlds 300 \
  --learning-rate 1e-4 --lr-schedule linear --eval-freq 0 --checkpoint-freq 500000 --no-progress-bar \
  --start-states "$STATES" --start-prob 0.5 --out "$name"
vcs-env select "$name" --from-step 1000000 --no-progress --out "sel-$name" \
  --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200
OUT="$PWD/eval" bash "$HERE/../../stage-m/evaluate.sh" "sel-$name/model.zip" "$name"
