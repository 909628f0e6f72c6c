"""BenchMARL on vcs-env: the task family builds TorchRL envs that pass ``check_env_specs`` with only the
observation as the model's input; ``vcs-env train --backend benchmarl`` trains each algorithm a few iterations
and saves an actor that acts as BenchMARL's own deterministic policy does and that the evaluation harness,
``compare`` and the ONNX export load; bad input gets one-line errors. BenchMARL is part of the README's full install
(``.[all]`` then ``pip install --no-deps benchmarl==1.5.2``): these tests run, never skip."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch
from tensordict import TensorDict
from torchrl.envs.utils import ExplorationType, check_env_specs, set_exploration_type

from agents.checkpoint import BenchMARLCheckpoint, load_model, open_checkpoint
from agents.evaluate import evaluate
from agents.runs import BenchMARLConfig
from agents.train.benchmarl import make_experiment, save_actor, train
from vcs_cli import main
from vcs_env.benchmarl import DEFAULTS, VcsNavTask
from vcs_env.observations import observation_dim
from vcs_env.scenario import make_scenario
from vcs_env.suites import Suite, get_suite

torch.set_num_threads(1)
TINY = dict(n_worlds=4, n_steps=32, batch_size=128, n_epochs=1, net_arch=(32, 32), eval_episodes=2)
"""A run of a few seconds: 4 worlds x 32 steps per batch."""


@pytest.mark.parametrize("task", list(VcsNavTask), ids=lambda t: t.name.lower())
def test_every_task_builds_an_env_that_passes_check_env_specs(task):
    tc = task.get_task()
    env = tc.get_env_fun(num_envs=3, continuous_actions=True, seed=0, device="cpu")()
    check_env_specs(env)
    scenario = get_suite(DEFAULTS[task.name.lower()]).scenario
    assert env.scenario.kind == scenario.kind and env.n_robots == scenario.n_robots
    assert tc.max_steps(env) == scenario.max_steps
    assert tc.group_map(env) == {"agents": [f"robot_{i}" for i in range(scenario.n_robots)]}
    assert list(tc.observation_spec(env)["agents"].keys()) == ["observation"]  # no mask, info or expert as input
    assert list(tc.info_spec(env)["agents"].keys()) == ["info"]
    assert tc.action_spec(env)["agents", "action"].shape == (scenario.n_robots, 2)
    with pytest.raises(ValueError, match="continuous actions only"):
        tc.get_env_fun(num_envs=1, continuous_actions=False, seed=0, device="cpu")


def test_a_task_config_overrides_the_scenario():
    tc = VcsNavTask.CIRCLE.get_task({"scenario": "circle", "n_robots": 5, "max_steps": 40})
    env = tc.get_env_fun(num_envs=2, continuous_actions=True, seed=1, device="cpu")()
    assert env.n_robots == 5 and tc.max_steps(env) == 40
    with pytest.raises(ValueError, match="unknown scenario"):
        VcsNavTask.CIRCLE.get_task({"scenario": "no-such-suite"}).get_env_fun(1, True, 0, "cpu")


def test_the_potential_shaping_discounts_with_the_runs_gamma(tmp_path):
    """vcs_potential shaping is policy-invariant only with the learner's discount; the task's env kept 0.99 whatever
    --gamma said."""
    assert VcsNavTask.CIRCLE.get_task({"gamma": 0.9}).get_env_fun(1, True, 0, "cpu")().engine.gamma == 0.9
    assert VcsNavTask.CIRCLE.get_task().get_env_fun(1, True, 0, "cpu")().engine.gamma == 0.99
    cfg = BenchMARLConfig(**TINY, timesteps=4 * 32 * 4, gamma=0.9)
    exp = make_experiment(cfg, make_scenario("circle", n_robots=4), tmp_path / "bm")
    assert exp.test_env.base_env.engine.gamma == 0.9


def fresh_observations(scenario, n: int = 1000, seed: int = 0) -> np.ndarray:
    """``(n, D)`` observations of driving robots in fresh episodes (random actions)."""
    from vcs_env.engine import NavEngine

    rng = np.random.default_rng(seed)
    eng = NavEngine(scenario, 8)
    obs = eng.reset(list(range(seed, seed + 8)))
    rows = []
    while sum(len(r) for r in rows) < n:
        rows.append(obs[eng.world.active])
        obs = eng.step(rng.uniform(-1, 1, (8, scenario.n_robots, 2))).obs
    return np.concatenate(rows)[:n].astype(np.float32)


@pytest.mark.parametrize("algorithm", ["mappo", "ippo", "masac"])
def test_the_saved_actor_acts_as_benchmarls_deterministic_policy_and_exports_to_onnx(tmp_path, algorithm):
    scenario = make_scenario("circle", n_robots=4)
    cfg = BenchMARLConfig(**TINY, algorithm=algorithm, timesteps=4 * 32 * 4, out=str(tmp_path / "run"))
    if algorithm == "masac":
        cfg = dataclasses.replace(cfg, n_epochs=BenchMARLConfig.n_epochs)  # no epochs in SAC
    exp = make_experiment(cfg, scenario, tmp_path / "bm")
    exp.run()  # one update: weights off their initial values
    obs = fresh_observations(scenario)
    path = save_actor(exp.policy, scenario, tmp_path / "run" / "actor.pt", {"observation_dim": obs.shape[1]})
    per_world = torch.as_tensor(obs).reshape(250, 4, -1)  # BenchMARL's policy takes every robot of a world
    td = TensorDict({"agents": TensorDict({"observation": per_world}, [250, 4])}, [250])
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        want = exp.policy(td)["agents", "action"].reshape(1000, 2).numpy()
    ckpt = open_checkpoint(tmp_path / "run")
    assert isinstance(ckpt, BenchMARLCheckpoint) and ckpt.path == path.path
    got, _ = load_model(tmp_path / "run").predict(obs, deterministic=True)
    assert np.abs(got - want).max() <= 1e-6 and np.abs(want).max() > 0.01
    one = load_model(tmp_path / "run").predict(obs[0], deterministic=True)[0]  # one observation, one action
    assert one.shape == (2,) and np.abs(one - got[0]).max() <= 1e-6  # (a batch of one rounds alike)
    sampled, _ = load_model(tmp_path / "run").predict(obs, deterministic=False)
    assert np.all(np.abs(sampled) <= 1.0) and np.abs(sampled - got).mean() > 0.05  # BenchMARL's scale ~ 1
    onnx_path, json_path = ckpt.export_onnx(tmp_path / "policy.onnx")
    session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    assert np.abs(session.run(["action"], {"observation": obs})[0] - got).max() <= 1e-5
    assert json.loads(json_path.read_text())["checkpoint"]["format"] == "benchmarl"


@pytest.mark.parametrize("algorithm", ["mappo", "ippo", "masac"])
def test_vcs_env_train_backend_benchmarl_trains_and_evaluates(tmp_path, algorithm, capsys):
    out = tmp_path / algorithm
    code = main(
        ["train", "--backend", "benchmarl", "--algorithm", algorithm, "--scenario", "circle", "--n-robots", "4",
         "--n-worlds", "4", "--n-steps", "32", "--batch-size", "128", "--net-arch", "32", "32",
         "--timesteps", "1024", "--eval-freq", "512", "--checkpoint-freq", "512", "--eval-episodes", "2",
         "--out", str(out)] + (["--n-epochs", "1"] if algorithm != "masac" else [])
    )  # fmt: skip
    assert code == 0
    lines = [json.loads(x) for x in (out / "eval.jsonl").read_text().splitlines()]
    assert [x["timesteps"] for x in lines] == [512, 1024]  # every 512 robot steps = 32 world steps of 4 worlds
    record = json.loads((out / "actor.json").read_text())
    assert record["kind"] == f"benchmarl_{algorithm}" and record["num_timesteps"] == 1024
    assert record["evaluation"] == lines[-1]  # the last evaluation, as SB3 and RLlib records keep it
    periodic = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert periodic == ["actor_1024.json", "actor_1024.pt", "actor_512.json", "actor_512.pt"]
    assert load_model(out / "checkpoints" / "actor_512.pt").observation_space.shape == (record["observation_dim"],)
    saved = [p.stat().st_size for p in (out / "benchmarl").rglob("*.pt")]
    assert saved and max(saved) < 5e6  # BenchMARL's own checkpoint, without MASAC's replay memory
    assert record["command"].startswith("vcs-env train --backend benchmarl")
    assert record["observation_dim"] == observation_dim(make_scenario("circle", n_robots=4))
    assert record["config"]["algorithm"] == algorithm
    assert "reproduce: vcs-env train --backend benchmarl" in capsys.readouterr().out
    suite = Suite("circle4-test", make_scenario("circle", n_robots=4), (0, 1))
    summary = evaluate(load_model(out), suite, progress=False).summary
    assert 0.0 <= summary["success"]["mean"] <= 1.0


def test_compare_loads_a_benchmarl_run(tmp_path):
    cfg = BenchMARLConfig(**TINY, scenario="circle-8-v0", timesteps=1024, eval_freq=0, out=str(tmp_path / "run"))
    train(cfg)
    lines = (tmp_path / "run" / "eval.jsonl").read_text().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["timesteps"] == 1024  # no periodic ones, one at the end
    code = main(["compare", "--suite", "circle-8-v0-smoke", "--policies", f"vcs,bm={tmp_path / 'run'}",
                 "--no-plots", "--out", str(tmp_path / "cmp")])  # fmt: skip
    assert code == 0
    assert (tmp_path / "cmp" / "results.md").exists()
    assert "bm" in (tmp_path / "cmp" / "results.md").read_text()


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--backend", "benchmarl", "--algorithm", "qmix"], "--algorithm must be one of mappo, ippo, masac"),
        (["--backend", "benchmarl", "--residual", "vcs"], "--residual not available with --backend benchmarl"),
        (["--backend", "benchmarl", "--residual-gate"], "--residual-gate not available with --backend benchmarl"),
        (["--backend", "benchmarl", "--vf-coef", "1.0"], "--vf-coef not available with --backend benchmarl"),
        (["--backend", "benchmarl", "--features", "contact"], "--features contact not available"),
        (["--backend", "benchmarl", "--algorithm", "masac", "--clip-range", "0.1"], "--clip-range not available with"),
        (["--backend", "benchmarl", "--n-steps", "0"], "n_steps"),
        (["--backend", "benchmarl", "--eval-suite", "no-such-suite"], "unknown suite 'no-such-suite'"),
        (["--algorithm", "mappo"], "--algorithm applies only to --backend benchmarl"),
        (["--backend", "benchmarl", "--num-env-runners", "2"], "--num-env-runners applies only to --backend rllib"),
        (["--backend", "benchmarl", "--resume", "runs/x"], "--resume is not available with --backend benchmarl"),
        (["--backend", "benchmarl", "--guide-anneal", "1000"], "--guide-anneal not available with --backend benchmarl"),
        (
            ["--backend", "benchmarl", "--no-progress-bar"],
            "--no-progress-bar is not available with --backend benchmarl",
        ),
        (["--backend", "benchmarl", "--tensorboard"], "--tensorboard is not available with --backend benchmarl"),
        (["--backend", "rllib", "--tensorboard"], "--tensorboard is not available with --backend rllib"),
        (
            ["--backend", "rllib", "--progress-bar"],
            "--progress-bar is not available with --backend rllib (RLlib prints",
        ),
    ],
)
def test_bad_input_gets_one_line_errors(tmp_path, argv, message, capsys):
    code = main(["train", "--scenario", "circle", "--timesteps", "1000", "--out", str(tmp_path / "r"), *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and len(err) == 1 and message in err[0], err


def test_a_file_that_is_not_an_actor_is_refused(tmp_path):
    bad = tmp_path / "actor.pt"
    torch.save({"layers": [[47, 4]]}, bad)
    with pytest.raises(Exception, match="not a vcs-env BenchMARL actor"):
        load_model(tmp_path)
    Path(bad).write_bytes(b"\x80\x04not a torch file")
    with pytest.raises(Exception, match="corrupt or unreadable") as err:
        load_model(bad)
    assert "\n" not in str(err.value)  # one line, whatever torch says
    internal = tmp_path / "run" / "benchmarl" / "exp" / "checkpoints" / "checkpoint_1024.pt"
    internal.parent.mkdir(parents=True)
    torch.save({"state": 1}, internal)  # BenchMARL's own: export and evaluate said it was not an SB3 checkpoint
    with pytest.raises(Exception, match="BenchMARL's own checkpoint.*'" + str(tmp_path / "run" / "actor.pt")):
        load_model(internal)


def test_a_linear_schedule_brings_the_learning_rate_to_zero_at_the_end_of_the_budget(tmp_path):
    from agents.train.benchmarl_callback import LinearLR

    scenario = make_scenario("circle", n_robots=4)
    cfg = BenchMARLConfig(**TINY, timesteps=4 * 4 * 32 * 4, lr_schedule="linear", learning_rate=1e-3)
    schedule = LinearLR(cfg.learning_rate)
    exp = make_experiment(cfg, scenario, tmp_path / "bm", [schedule])
    seen = []
    original = schedule.on_batch_collected
    schedule.on_batch_collected = lambda batch: (original(batch), seen.append(_lrs(exp)))  # after pickling
    exp.run()
    want = [[7.5e-4] * 2, [5e-4] * 2, [2.5e-4] * 2, [0.0] * 2]  # 4 batches; the actor's and the critic's optimizer
    assert np.allclose(seen, want, rtol=1e-9, atol=0.0)


def _lrs(exp) -> list[float]:
    return [g["lr"] for opt in exp.optimizers["agents"].values() for g in opt.param_groups]
