"""Stage L prototype: anchored DAgger on obstacle-danger states.

Rounds: play the mixture with the current policy (deterministic), label every robot-step with
  - the VCS expert's action where an obstacle would touch the robot within H s at current velocities,
  - the initial (anchor) policy's deterministic action elsewhere,
aggregate, fit the policy mean (MSE) with danger rows and safe rows weighted equally in the loss.
Usage (from the repository root, PYTHONPATH=.):
    python results/generalist/stage-l/anchored_dagger.py INIT OUT H ROUNDS EPISODES EPOCHS LR [DANGER_WEIGHT=1]
(round<k>.npz: observations, expert and anchor actions, obstacle contact times of round k, for fit_test.py)
"""

import copy
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import torch as th

th.set_num_threads(1)
from agents.checkpoint import load_model  # noqa: E402
from agents.config import ScenarioConfig, mixture_scenarios, mixture_split  # noqa: E402
from agents.expert_data import ExpertLabels  # noqa: E402
from agents.policies import predictor_controller  # noqa: E402
from vcs_env.rollout import play as play_episodes  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
import start_states  # noqa: E402

MIX = list(start_states.MIX[:-1])  # policies/generalist.sh's mixture


class Labels(ExpertLabels):
    def __init__(self):
        super().__init__()
        self.parts["thr"] = []

    def begin(self, engine, seeds, first):
        super().begin(engine, seeds, first)
        self.threat = start_states.obstacle_contact_time(self.engine.world)

    def step(self, s):
        b, i = np.nonzero(s.acting)
        self.parts["thr"].append(self.threat[b, i])
        super().step(s)
        self.threat = start_states.obstacle_contact_time(self.engine.world)


def main():
    init, out, H, rounds, episodes, epochs, lr = sys.argv[1:8]
    wd = float(sys.argv[8]) if len(sys.argv) > 8 else 1.0
    H, rounds, episodes, epochs, lr = float(H), int(rounds), int(episodes), int(epochs), float(lr)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    scenarios = mixture_scenarios(ScenarioConfig(on_collision="terminate"), tuple(MIX))
    model = load_model(init, scenarios[0])
    policy = model.policy
    anchor = copy.deepcopy(policy)
    anchor.set_training_mode(False)

    def mean_action(p, obs):
        with th.no_grad():
            return p.get_distribution(th.as_tensor(obs)).distribution.mean.clamp(-1, 1).numpy()

    control = predictor_controller(policy)  # the policy as it is trained, deterministic
    X, Y, D = [], [], []
    opt = th.optim.Adam(policy.parameters(), lr=lr)
    g = th.Generator().manual_seed(0)
    for k in range(rounds):
        seeds = list(range(60_000 + k * episodes, 60_000 + (k + 1) * episodes))
        lab = Labels()

        collided = reached = trajs = 0
        for sc, part in mixture_split(scenarios, seeds):
            for c0 in range(0, len(part), 32):
                play_episodes(sc, control, part[c0 : c0 + 32], [lab], expert="vcs", first=c0)
                collided += sum(t["collided"] for t in lab.traj.values())
                reached += sum(t["reached"] for t in lab.traj.values())
                trajs += len(lab.traj)
                lab.traj.clear()
        obs = np.concatenate(lab.parts["obs"]).astype(np.float32)
        exp = np.concatenate(lab.parts["act"]).astype(np.float32)
        thr = np.concatenate(lab.parts["thr"])
        danger = thr < H
        own = mean_action(anchor, obs)
        y = np.where(danger[:, None], exp, own)
        np.savez_compressed(out / f"round{k + 1}.npz", obs=obs, exp=exp, thr=thr, anchor=own)
        X.append(obs)
        Y.append(y)
        D.append(danger)
        print(
            f"[round {k + 1}] {len(obs)} rows, danger {danger.mean():.3f}; robots collided {collided / trajs:.4f} "
            f"reached {reached / trajs:.4f}; policy-expert gap on danger rows "
            f"{np.linalg.norm(mean_action(policy, obs[danger]) - exp[danger], axis=-1).mean():.3f} "
            f"({time.time() - t0:.0f} s)",
            flush=True,
        )
        Xt = th.as_tensor(np.concatenate(X))
        Yt = th.as_tensor(np.concatenate(Y))
        Dt = th.as_tensor(np.concatenate(D))
        nd, ns = int(Dt.sum()), int((~Dt).sum())
        w = th.where(Dt, wd * 0.5 / max(nd, 1), 0.5 / max(ns, 1)) * len(Dt)
        policy.set_training_mode(True)
        for _ in range(epochs):
            perm = th.randperm(len(Xt), generator=g)
            tot = 0.0
            for s in range(0, len(perm), 1024):
                idx = perm[s : s + 1024]
                m = policy.get_distribution(Xt[idx]).distribution.mean
                loss = (w[idx] * ((m - Yt[idx]) ** 2).sum(-1)).mean()
                opt.zero_grad()
                loss.backward()
                opt.step()
                tot += loss.item() * len(idx)
            print(f"  epoch loss {tot / len(perm):.4f}", flush=True)
        policy.set_training_mode(False)
        model.save(str(out / f"model_r{k + 1}.zip"))
        meta = json.loads(Path(init).with_suffix(".json").read_text())
        (out / f"model_r{k + 1}.json").write_text(json.dumps(meta))
    shutil.copy(out / f"model_r{rounds}.zip", out / "model.zip")
    shutil.copy(out / f"model_r{rounds}.json", out / "model.json")
    print(f"done in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
