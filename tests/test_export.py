"""``vcs-env export --onnx``: the ONNX file of each checkpoint format gives the checkpoint's own
deterministic actions (``predict(..., deterministic=True)``) to 1e-5 on 1000 observations of fresh
episodes, its layout JSON says what goes in and out, bad input gets one-line errors, and the example
of ``docs/export.md`` drives the PettingZoo env from the file in a Python without torch."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("onnxruntime", reason="the export extra (pip install -e '.[export]')")
pytest.importorskip("stable_baselines3", reason="the train extra")

import onnxruntime as ort  # noqa: E402
import torch  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402

from agents.checkpoint import CheckpointError, load_model, open_checkpoint, save_model  # noqa: E402
from agents.export import OPSET, opset_range  # noqa: E402
from agents.features import extractor_kwargs  # noqa: E402
from agents.runs import RLlibConfig, TrainConfig, run_record  # noqa: E402
from agents.shield import Shield, shield_from_record  # noqa: E402
from agents.vec_env import NavVecEnv  # noqa: E402
from vcs_cli import main  # noqa: E402
from vcs_env.observations import observation_config, observation_layout, with_sensors  # noqa: E402
from vcs_env.parallel import parallel_env  # noqa: E402
from vcs_env.scenario import make_scenario  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
GENERALIST = ROOT / "policies" / "generalist" / "model.zip"
SCALE = 6.0
"""Largest weight of the untrained RLlib policy's last layer."""
torch.set_num_threads(1)


def fresh_observations(scenario, n: int = 1000, seed: int = 0) -> np.ndarray:
    """``(n, D)`` observations of the PettingZoo env: episodes from fresh resets, random actions."""
    rng = np.random.default_rng(seed)
    env = parallel_env(scenario=scenario)
    rows, episode = [], 0
    while sum(len(r) for r in rows) < n:
        obs, _ = env.reset(seed=seed + episode)
        episode += 1
        for _ in range(20):
            if not env.agents:
                break
            rows.append(np.stack([obs[a] for a in env.agents]))
            obs, *_ = env.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents})
    return np.concatenate(rows)[:n].astype(np.float32)


def onnx_actions(path: Path, obs: np.ndarray) -> np.ndarray:
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return session.run(["action"], {"observation": obs})[0]


def sb3_checkpoint(tmp_path: Path, scenario, features: str = "flat") -> Path:
    """An untrained SB3 PPO checkpoint whose mean actions often leave [-1, 1] (so clipping is tested)."""
    kwargs = dict(net_arch=[16], **extractor_kwargs(features, observation_layout(scenario)))
    model = PPO("MlpPolicy", NavVecEnv(scenario, 1), device="cpu", policy_kwargs=kwargs, seed=0)
    with torch.no_grad():
        model.policy.action_net.weight.mul_(300.0)
    return save_model(model, tmp_path / features / "model", "ppo", TrainConfig(features=features), scenario)


@pytest.mark.parametrize(
    "features,kind,extra",
    [
        ("flat", "crowd", {}),
        ("contact", "crowd", {}),
        ("slots", "crowd", {}),
        ("slots", "corridor", {"n_wall_points": 4}),
        ("slots-fine", "corridor", {"n_wall_points": 4}),
    ],
    ids=["flat", "contact", "slots", "slots-wall-points", "slots-fine"],
)
def test_sb3_onnx_gives_the_deterministic_actions(tmp_path, features, kind, extra):
    scenario = make_scenario(kind, **extra)
    path = sb3_checkpoint(tmp_path, scenario, features)
    onnx_path, json_path = open_checkpoint(path).export_onnx(tmp_path / "policy.onnx")
    obs = fresh_observations(scenario)
    want, _ = load_model(path).predict(obs, deterministic=True)
    got = onnx_actions(onnx_path, obs)
    assert got.shape == want.shape == (1000, 2) and got.dtype == np.float32
    assert np.abs(got - want).max() <= 1e-5
    assert np.any(np.abs(want) == 1.0) and np.any(np.abs(want) < 1.0)  # clipped and unclipped actions both tested
    layout = json.loads(json_path.read_text())
    assert layout["opset"] == OPSET and layout["observation_dim"] == obs.shape[1]
    assert layout["observation"] == json.loads(json.dumps(observation_config(scenario)))  # version 2, its blocks
    assert layout["record"]["config"]["features"] == features and layout["record"]["scenario"]["kind"] == kind
    assert layout["checkpoint"]["format"] == "sb3" and layout["shield"] is None and layout["shield_note"] is None


def test_the_released_generalist_exports_with_a_note_on_its_shield(tmp_path, capsys):
    meta = json.loads(GENERALIST.with_suffix(".json").read_text())
    assert meta.get("shield")  # the released policy carries a shield in its record
    assert main(["export", str(GENERALIST.parent), "--onnx", str(tmp_path / "g.onnx")]) == 0
    out = capsys.readouterr()
    assert "wrote" in out.out and "note: the run record names a safety shield" in out.err
    scenario = with_sensors(make_scenario(meta["scenario"]["kind"], **meta["scenario"]), meta["observation"])  # v1
    obs = fresh_observations(scenario, seed=100)
    want, _ = load_model(GENERALIST).predict(obs, deterministic=True)
    assert np.abs(onnx_actions(tmp_path / "g.onnx", obs) - want).max() <= 1e-5
    layout = json.loads((tmp_path / "g.json").read_text())
    assert "network only" in layout["shield_note"]
    # every parameter spelled out: the release's record predates still_margin, driving_guard, keep_turn,
    # brake_backup, driving_stop and robots_stand: its rule
    assert layout["shield"] == meta["shield"] | {
        "still_margin": None,
        "driving_guard": False,
        "keep_turn": False,
        "brake_backup": False,
        "driving_stop": False,
        "robots_stand": False,
    }
    assert Shield(**layout["shield"]) == shield_from_record(meta)


def rllib_checkpoint(tmp_path: Path, scenario) -> Path:
    """An untrained RLlib checkpoint as ``vcs-env train --backend rllib`` lays it out: the shared
    module of PPO's default torch RLModule (the run's model config) and the run record."""
    pytest.importorskip("ray.rllib", reason="the rllib extra")
    from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    from agents.checkpoint import RLlibCheckpoint
    from vcs_env.spaces import action_space, observation_space

    model = {"fcnet_hiddens": [16, 16], "fcnet_activation": "tanh", "vf_share_layers": False, "free_log_std": True}
    spec = RLModuleSpec(
        module_class=DefaultPPOTorchRLModule,
        observation_space=observation_space(scenario),
        action_space=action_space(),
        model_config=model,
    )
    torch.manual_seed(0)
    module = spec.build()
    last = [m for m in module.pi.modules() if isinstance(m, torch.nn.Linear)][-1]
    with torch.no_grad():
        last.weight.mul_(SCALE / last.weight.abs().max())  # means of a few units: some leave [-1, 1]
    ckpt = tmp_path / "rl" / "checkpoint"
    module.save_to_path((ckpt / "learner_group" / "learner" / "rl_module" / RLlibCheckpoint.MODULE_ID).as_posix())
    record = run_record("rllib_ppo", RLlibConfig(net_arch=(16, 16)), scenario, None, 0)
    (ckpt / RLlibCheckpoint.record_name).write_text(json.dumps(record))
    return ckpt.parent


def test_rllib_onnx_gives_the_deterministic_actions(tmp_path):
    scenario = make_scenario("circle", n_robots=6)
    run = rllib_checkpoint(tmp_path, scenario)
    onnx_path, json_path = open_checkpoint(run).export_onnx(tmp_path / "rl.onnx")
    obs = fresh_observations(scenario)
    want, _ = load_model(run).predict(obs, deterministic=True)
    got = onnx_actions(onnx_path, obs)
    assert np.abs(got - want).max() <= 1e-5
    assert np.any(np.abs(want) == 1.0) and np.any(np.abs(want) < 1.0)
    assert json.loads(json_path.read_text())["checkpoint"]["format"] == "rllib"


def one_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_bad_input_gets_one_line_errors(tmp_path, capfd):
    scenario = make_scenario("crowd")
    path = sb3_checkpoint(tmp_path, scenario)
    # Not an .onnx output path: refused before loading anything.
    assert main(["export", str(path), "--onnx", str(tmp_path / "policy.pt")]) == 2
    assert "must end in .onnx" in one_error(capfd)
    # An unknown format: a file that is no checkpoint, and a directory holding none.
    (tmp_path / "weights.pt").write_bytes(b"\x80\x04not a checkpoint")
    assert main(["export", str(tmp_path / "weights.pt"), "--onnx", str(tmp_path / "w.onnx")]) == 2
    assert "is not a checkpoint of a known format (benchmarl, sb3, rllib)" in one_error(capfd)
    (tmp_path / "empty").mkdir()
    assert main(["export", str(tmp_path / "empty"), "--onnx", str(tmp_path / "w.onnx")]) == 2
    assert "checkpoint not found" in one_error(capfd)
    # A JSON file that exists (an export's layout) is no checkpoint; it was "not found".
    (tmp_path / "layout.json").write_text("{}")
    assert main(["export", str(tmp_path / "layout.json"), "--onnx", str(tmp_path / "w.onnx")]) == 2
    assert "layout.json' is a JSON file, not a checkpoint" in one_error(capfd)
    # An SB3 PPO of another env: its actions are not the env's (the ONNX file and its layout disagreed).
    from stable_baselines3 import PPO

    PPO("MlpPolicy", "Pendulum-v1", n_steps=16, batch_size=16).save(tmp_path / "pendulum.zip")
    assert main(["export", str(tmp_path / "pendulum.zip"), "--onnx", str(tmp_path / "w.onnx")]) == 2
    assert "not in vcs-env's Box(-1, 1, (2,)): a policy of another env" in one_error(capfd)
    assert not (tmp_path / "w.onnx").exists()
    # An opset torch cannot write: one line (captured at the file descriptor: torch's exporter prints its graph there).
    low, high = opset_range()  # torch 2.13 (pinned by the install) says
    for opset in (low - 1, high + 1):
        assert main(["export", str(path), "--onnx", str(tmp_path / "w.onnx"), "--opset", str(opset)]) == 2
        assert f"exports ONNX opsets {low} to {high}, got {opset}" in one_error(capfd)
    # An opset torch has but cannot write this network in (slots: slices with dynamic inputs need opset 10 and up):
    # one line, and nothing on stdout (torch's exporter writes its whole traced graph there before it refuses).
    slots = sb3_checkpoint(tmp_path, scenario, "slots")
    assert main(["export", str(slots), "--onnx", str(tmp_path / "w.onnx"), "--opset", "9"]) == 2
    out, err = capfd.readouterr()
    assert not out and len(err.strip().splitlines()) == 1 and "could not be exported at opset 9" in err
    # The layout would overwrite the run record beside the checkpoint: refused, the record kept.
    record_text = path.with_suffix(".json").read_text()
    assert main(["export", str(path), "--onnx", str(path.with_suffix(".onnx"))]) == 2
    assert "which holds another file (a run record?)" in one_error(capfd)
    assert path.with_suffix(".json").read_text() == record_text and not path.with_suffix(".onnx").exists()
    # An export again over an earlier one replaces it; a failed one leaves the earlier file as it was.
    assert main(["export", str(path), "--onnx", str(tmp_path / "v.onnx")]) == 0
    assert main(["export", str(path), "--onnx", str(tmp_path / "v.onnx")]) == 0
    capfd.readouterr()
    before = (tmp_path / "v.onnx").read_bytes()
    assert main(["export", str(path), "--onnx", str(tmp_path / "v.onnx"), "--opset", "1"]) == 2
    assert "got 1" in one_error(capfd)
    assert (tmp_path / "v.onnx").read_bytes() == before and not list(tmp_path.glob("*.part"))
    # A record for another observation size than the network's.
    record = json.loads(path.with_suffix(".json").read_text())
    record["observation_dim"] = 99
    path.with_suffix(".json").write_text(json.dumps(record))
    assert main(["export", str(path), "--onnx", str(tmp_path / "w.onnx")]) == 2
    line = one_error(capfd)
    assert "takes observations of size 83, but its run record" in line and "says 99" in line
    assert not (tmp_path / "w.onnx").exists()
    with pytest.raises(CheckpointError, match="must end in .onnx"):
        open_checkpoint(path).export_onnx(tmp_path / "w")
    # No run record: exported, with a note that the layout lacks the observation config.
    path.with_suffix(".json").unlink()
    assert main(["export", str(path), "--onnx", str(tmp_path / "w.onnx")]) == 0
    assert "has no run record" in one_error(capfd)
    assert json.loads((tmp_path / "w.json").read_text())["observation"] is None


def test_the_docs_example_drives_the_env_without_torch(tmp_path):
    """The example runs an exported checkpoint without a shield, and the released generalist with its shield."""
    scenario = make_scenario("circle", n_robots=4, max_steps=60)
    open_checkpoint(sb3_checkpoint(tmp_path, scenario)).export_onnx(tmp_path / "policy.onnx")
    open_checkpoint(GENERALIST).export_onnx(tmp_path / "generalist.onnx")
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "export.md").read_text(), re.S)
    (tmp_path / "example.py").write_text(blocks[0])
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "sitecustomize.py").write_text("import sys\nsys.modules['torch'] = None\n")
    env = {"PYTHONPATH": f"{tmp_path / 'site'}:{ROOT}", "OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, *args], cwd=tmp_path, capture_output=True, text=True, env=env)

    blocked = run("-c", "import torch")
    assert blocked.returncode != 0 and "ModuleNotFoundError" in blocked.stderr  # torch really is blocked
    for name, said in (("policy.onnx", "no shield"), ("generalist.onnx", "with its safety shield")):
        res = run("example.py", name)
        assert res.returncode == 0, res.stderr[-2000:]
        assert f"{name}: opset {OPSET}, {said}" in res.stdout, res.stdout
        assert re.search(r"\d+ steps, \d of 4 robots reached their goals", res.stdout), res.stdout
    assert "4 of 4 robots reached their goals" in res.stdout  # the generalist solves its own circle


@pytest.mark.slow
def test_a_trained_rllib_run_exports(tmp_path):
    """The real thing: a few RLlib PPO steps (``--num-env-runners 0``), then ``vcs-env export`` of its run."""
    pytest.importorskip("ray.rllib", reason="the rllib extra")
    vcs_env = str(Path(sys.executable).with_name("vcs-env"))
    small = ["--scenario", "circle", "--n-robots", "4", "--n-worlds", "2", "--n-steps", "16", "--batch-size", "64"]
    small += ["--n-epochs", "1", "--eval-freq", "0", "--eval-episodes", "2", "--net-arch", "16", "16"]
    env = {**__import__("os").environ, "RAY_USAGE_STATS_ENABLED": "0", "OMP_NUM_THREADS": "1"}
    args = ["train", "--backend", "rllib", "--num-env-runners", "0", *small, "--timesteps", "64"]
    res = subprocess.run([vcs_env, *args, "--out", str(tmp_path / "rl")], capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    onnx_path, _ = open_checkpoint(tmp_path / "rl").export_onnx(tmp_path / "rl.onnx")
    scenario = make_scenario("circle", n_robots=4)
    obs = fresh_observations(scenario)
    want, _ = load_model(tmp_path / "rl").predict(obs, deterministic=True)
    assert np.abs(onnx_actions(onnx_path, obs) - want).max() <= 1e-5


def test_an_exported_layout_names_the_block_a_scenario_gives_otherwise():
    """onnxruntime checks the observation size only: a scenario whose blocks differ at the same size ran silently."""
    from agents.fits import check_layout_fits
    from agents.runs import jsonable
    from vcs_env import make_scenario
    from vcs_env.lidar import LidarSpec
    from vcs_env.observations import observation_config, observation_dim

    senses = make_scenario("doorway", stall_clock=True, n_wall_points=6)
    layout = {"observation": jsonable(observation_config(senses)), "observation_dim": observation_dim(senses)}
    check_layout_fits(layout, senses)
    other = make_scenario("doorway", lidar=LidarSpec(n_beams=5), n_wall_points=6)  # the same size
    assert observation_dim(other) == layout["observation_dim"]
    with pytest.raises(CheckpointError, match="block 'clock': 1 x 5 floats .* \\(scenario: absent\\)"):
        check_layout_fits(layout, other)
