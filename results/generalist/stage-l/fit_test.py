"""Can the policy network learn the expert's action in danger states? Fit the released policy's mean
to the VCS expert's actions on the danger rows of a round file of ``anchored_dagger.py`` (rows where
an obstacle would touch the robot within H s), holding out the last 20 % of the rows (other episodes,
rows are in play order), and print the squared action error on both parts every 10 epochs.

    PYTHONPATH=. python results/generalist/stage-l/fit_test.py ROUND.npz 3.0 policies/generalist/model.zip
"""

import sys

import numpy as np
import torch as th

from agents.checkpoint import load_model

th.set_num_threads(1)
d = np.load(sys.argv[1])
danger = d["thr"] < float(sys.argv[2])
obs, exp, anchor = d["obs"][danger], d["exp"][danger], d["anchor"][danger]
saturated = (np.abs(exp) > 0.95).mean(0)
print(f"danger rows {danger.sum()}; expert |a| > 0.95 (accel, turn) {saturated.round(3)}")
print(f"squared error expert vs policy {((exp - anchor) ** 2).sum(-1).mean():.3f}")
n = len(obs)
cut = int(0.8 * n)
policy = load_model(sys.argv[3]).policy
X, Y = th.as_tensor(obs), th.as_tensor(exp)
opt = th.optim.Adam(policy.parameters(), lr=3e-4)
g = th.Generator().manual_seed(0)


def error(a: int, b: int) -> float:
    with th.no_grad():
        mean = policy.get_distribution(X[a:b]).distribution.mean.clamp(-1, 1)
        return ((mean - Y[a:b]) ** 2).sum(-1).mean().item()


print(f"epoch 0: train {error(0, cut):.3f} held out {error(cut, n):.3f}")
for epoch in range(1, 61):
    perm = th.randperm(cut, generator=g)
    for s in range(0, cut, 256):
        i = perm[s : s + 256]
        loss = ((policy.get_distribution(X[i]).distribution.mean - Y[i]) ** 2).sum(-1).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    if epoch % 10 == 0:
        print(f"epoch {epoch}: train {error(0, cut):.3f} held out {error(cut, n):.3f}", flush=True)
