"""``vcs-env train --backend rllib``: the env adapters, the policy wrapper, clear errors, and a
few PPO iterations on a two-node Ray cluster (two raylets on loopback) scored by the harness."""

from __future__ import annotations

import json
import os
import re
import secrets
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from vcs_env.observations import EGO_DIM, NEIGHBOR_DIM

pytest.importorskip("ray.rllib", reason="the rllib extra (pip install -e '.[rllib]')")

from agents.checkpoint import RLlibPolicy  # noqa: E402
from agents.runs import RLlibConfig, run_command  # noqa: E402
from agents.train.rllib_cluster import LOCAL_NODE_IP  # noqa: E402
from agents.train.rllib_env import NavMultiAgentEnv, PettingZooNavEnv, world_seeds  # noqa: E402
from vcs_env.parallel import parallel_env  # noqa: E402
from vcs_env.scenario import make_scenario  # noqa: E402

pytestmark = pytest.mark.slow  # notebooks / Ray clusters / training: minutes, not seconds

RAY = str(Path(sys.executable).with_name("ray"))
RAY_LOG_LINE = re.compile(r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d+\s+(ERROR|WARNING|INFO) \S+\.py:\d+ -- ")
VCS_ENV = str(Path(sys.executable).with_name("vcs-env"))
# Drivers outside the cluster fixture: a token of their own, never a ~/.ray/auth_token of the machine.
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "RAY_USAGE_STATS_ENABLED": "0", "PYTHONUNBUFFERED": "1"}
ENV.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32))
LOOPBACK = LOCAL_NODE_IP  # Ray would swap 127.0.0.1 for the machine's network address


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --------------------------------------------------------------------------- env adapters
def test_batched_adapter_is_independent_worlds_of_the_parallel_env():
    """World b of the batched adapter is the PettingZoo env reset with world_seeds(...)[b],
    stepped with the same actions; robots leave the agent dict when they finish, and __all__
    ends the episode when the last robot of the last world is done."""
    scenario = make_scenario("circle", n_robots=3, jitter=0.1, max_steps=40)
    B = 2
    env = NavMultiAgentEnv(scenario, B, worker_index=1)
    seeds = world_seeds(7, 1, B)
    assert len(set(seeds)) == B and seeds != world_seeds(7, 2, B) and seeds != world_seeds(8, 1, B)
    refs = [parallel_env(scenario=scenario) for _ in range(B)]

    def slot(b: int, agent: str) -> int:  # robot_i of world b
        return b * scenario.n_robots + int(agent.rpartition("_")[2])

    obs, _ = env.reset(seed=7)
    ref_obs = [r.reset(seed=s)[0] for r, s in zip(refs, seeds)]
    rng = np.random.default_rng(0)
    steps = 0
    while True:
        for b in range(B):
            for a, o in ref_obs[b].items():
                np.testing.assert_array_equal(obs[slot(b, a)], o)
        assert set(obs) == {slot(b, a) for b in range(B) for a in refs[b].agents}
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in obs}
        obs, rew, term, trunc, _ = env.step(actions)
        steps += 1
        ref_obs = []
        for b, r in enumerate(refs):
            if not r.agents:
                ref_obs.append({})
                continue
            o, rw, te, tr, _ = r.step({a: actions[slot(b, a)] for a in r.agents})
            for a in rw:
                assert rew[slot(b, a)] == pytest.approx(rw[a])
                assert term[slot(b, a)] == te[a] and trunc[slot(b, a)] == (tr[a] and not te[a])
            ref_obs.append({a: o[a] for a in r.agents})
        over = not any(r.agents for r in refs)
        assert term["__all__"] or trunc["__all__"] if over else not (term["__all__"] or trunc["__all__"])
        if over:
            break
    assert steps <= 40 and env.agents == []


def test_pettingzoo_adapter_ends_when_no_robot_is_left():
    """A time-out where one robot arrives on the last step and another is cut off still ends the
    episode (RLlib's wrapper alone would keep it running with no agents)."""
    scenario = make_scenario("circle", n_robots=2, max_steps=5)
    env = PettingZooNavEnv(scenario)
    obs, _ = env.reset(seed=0)
    assert sorted(obs) == env.agents == [0, 1]
    assert set(env.observation_space.spaces) == set(env.action_space.spaces) == {0, 1}  # int ids, as the agents
    np.testing.assert_array_equal(
        obs[1], parallel_env(scenario=scenario).reset(seed=world_seeds(0, 0, 1)[0])[0]["robot_1"]
    )
    for t in range(5):
        obs, _, term, trunc, _ = env.step({a: np.zeros(2, np.float32) for a in obs})
        assert bool(term["__all__"] or trunc["__all__"]) == (t == 4)
    assert trunc["__all__"] and not term["__all__"] and not env.par_env.agents and env.agents == []


# --------------------------------------------------------------------------- policy and config
class _Module:
    """A stand-in RLModule with a linear policy (mean = obs[:, :2], log std = -1)."""

    def __init__(self, scenario):
        from gymnasium import spaces

        from vcs_env.spaces import observation_space

        self.observation_space = observation_space(scenario)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)

    def forward_inference(self, batch):
        import torch

        obs = batch["obs"]
        return {"action_dist_inputs": torch.cat([3 * obs[:, :2], torch.full_like(obs[:, :2], -1.0)], dim=1)}


@pytest.mark.parametrize("adapter", ["pettingzoo", "batched"])
def test_adapters_pass_rllibs_own_env_check(adapter):
    # RLlib's pre-check of multi-agent envs (the one ParallelPettingZooEnv failed in some versions, ray #39453),
    # on a map with obstacles so that every observation block is present.
    from ray.rllib.utils.pre_checks.env import check_multiagent_environments

    scenario = make_scenario("corridor", n_robots=4, n_obstacles=2, obstacle_motion="constant")
    env = PettingZooNavEnv(scenario, 0.99, 0) if adapter == "pettingzoo" else NavMultiAgentEnv(scenario, 2, 0.99, 0)
    check_multiagent_environments(env)  # raises on any mismatch of spaces, ids, dones or infos


def test_policy_predicts_the_clipped_mean_or_samples():
    scenario = make_scenario("circle", n_robots=2)
    pol = RLlibPolicy(_Module(scenario), rng=np.random.default_rng(0))
    obs = np.random.default_rng(1).uniform(-1, 1, (5, pol.observation_space.shape[0])).astype(np.float32)
    act, state = pol.predict(obs, deterministic=True)
    assert state is None and act.shape == (5, 2) and act.dtype == np.float32
    np.testing.assert_allclose(act, np.clip(3 * obs[:, :2], -1, 1), atol=1e-6)
    one = pol.predict(obs[0], deterministic=True)[0]  # one observation, one action: what env.step takes
    assert one.shape == (2,) and np.array_equal(one, act[0])
    noisy = pol.predict(obs, deterministic=False)[0]
    assert np.all(np.abs(noisy) <= 1) and not np.allclose(noisy, act)


def test_run_command_and_flags():
    from vcs_cli import build_parser

    cfg = RLlibConfig(n_robots=4, num_env_runners=2, address="127.0.0.1:6379")
    cmd = run_command("rllib_ppo", cfg)
    assert cmd.startswith("vcs-env train --backend rllib ") and "--num-env-runners 2" in cmd
    args = build_parser().parse_args(shlex.split(cmd)[1:])
    assert args.backend == "rllib" and args.num_env_runners == 2 and args.address == "127.0.0.1:6379"


def _run(*argv: str, timeout: float = 120, code: str | None = None, env=None) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-c", code, *argv] if code else [VCS_ENV, *argv]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env or ENV)


def test_bad_input_gets_one_line_errors(tmp_path, capsys):
    from vcs_cli import main

    with pytest.raises(SystemExit):  # argparse: unknown backend
        main(["train", "--backend", "tf"])
    assert main(["train", "--num-env-runners", "2", "--out", str(tmp_path / "x")]) == 2  # sb3 + rllib flag
    # SB3-only training flags are refused, not dropped (a --mixture run trained on circle alone).
    for flags, name in (
        (["--mixture", "crowd:n_obstacles=3"], "--mixture"),
        (["--target-kl", "0.02"], "--target-kl"),
    ):
        assert main(["train", "--backend", "rllib", *flags, "--out", str(tmp_path / "m")]) == 2
        assert name in capsys.readouterr().err
    # PPO settings as the other backends check them, before Ray starts (they trained to the end, or failed inside
    # RLlib: net_arch 0 an IndexError, n_epochs 0 an UnboundLocalError, gamma 1.5 after Ray had started).
    for flags, said in (
        (["--learning-rate", "-1"], "learning_rate must be"),
        (["--n-steps", "0"], "n_steps must be"),
        (["--n-epochs", "0"], "n_epochs must be"),
        (["--net-arch", "0"], "net_arch must be"),
        (["--gae-lambda", "2"], "gae_lambda must be"),
        (["--gamma", "1.5"], "gamma must be"),
        (["--eval-freq", "-1"], "eval_freq must be"),
    ):
        assert main(["train", "--backend", "rllib", *flags, "--out", str(tmp_path / "p")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and said in err[0], err
    assert not (tmp_path / "p").exists()
    # Nothing listens on this port: an error before Ray is started, naming the address.
    port = free_port()
    res = _run("train", "--backend", "rllib", "--address", f"127.0.0.1:{port}", "--out", str(tmp_path / "y"))
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and f"127.0.0.1:{port}" in lines[0], res.stderr
    assert "no Ray head answers" in lines[0]
    # Without the package: the install command, on one line.
    hide_ray = "import sys; sys.modules['ray'] = None; from vcs_cli import main; sys.exit(main(sys.argv[1:]))"
    res = _run("train", "--backend", "rllib", "--timesteps", "10", "--out", str(tmp_path / "z"), code=hide_ray)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and "pip install -e '.[rllib]'" in lines[0], res.stderr


# --------------------------------------------------------------------------- cluster
def _kill_leftovers(marker: str) -> None:
    """SIGKILL every process whose command line holds ``marker`` (this test's Ray temp dir), and
    their descendants (Ray's agents and workers)."""
    parent, marked = {}, set()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            parent[int(pid)] = int(Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        if marker in cmdline and int(pid) != os.getpid():
            marked.add(int(pid))
    grown = True
    while grown:
        more = {p for p, pp in parent.items() if pp in marked} - marked
        marked |= more
        grown = bool(more)
    for pid in marked:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


class Cluster:
    """Raylets of one Ray cluster on a loopback address, each a ``ray start --block`` process."""

    def __init__(self, env: dict[str, str] = ENV):
        self.env = env
        """The environment of its raylets and of every driver that joins it (one auth mode)."""
        self.temp = tempfile.mkdtemp(prefix="vr", dir="/tmp")  # short: Ray's socket paths have a length limit
        self.port = free_port()
        self.address = f"{LOOPBACK}:{self.port}"
        self.procs: list[subprocess.Popen] = []
        self.log = open(Path(self.temp) / "ray_start.log", "w")

    def start(self, head: bool, env: dict[str, str] | None = None) -> None:
        cmd = [RAY, "start", f"--node-ip-address={LOOPBACK}", "--num-cpus=1", "--block", "--disable-usage-stats"]
        cmd += [f"--temp-dir={self.temp}", f"--dashboard-agent-listen-port={free_port()}"]
        cmd += [f"--metrics-export-port={free_port()}", f"--runtime-env-agent-port={free_port()}"]
        if head:
            cmd += ["--head", f"--port={self.port}", "--include-dashboard=false"]
            cmd += [f"--ray-client-server-port={free_port()}"]
        else:
            cmd += [f"--address={self.address}"]
        self.procs.append(
            subprocess.Popen(cmd, stdout=self.log, stderr=self.log, start_new_session=True, env=env or self.env)
        )

    def wait_for_nodes(self, n: int) -> None:
        wait = (
            "import sys, time, ray; t = time.time()\n"
            "ray.init(address=sys.argv[1], _node_ip_address=sys.argv[1].split(':')[0], log_to_driver=False)\n"
            f"while sum(n['Alive'] for n in ray.nodes()) < {n} and time.time() - t < 60: time.sleep(0.5)\n"
            f"sys.exit(0 if sum(n['Alive'] for n in ray.nodes()) == {n} else 1)"
        )
        res = _run(self.address, code=wait, timeout=120, env=self.env)
        assert res.returncode == 0, f"the cluster did not reach {n} nodes: " + res.stderr[-2000:] + self.log_text()

    def log_text(self) -> str:
        self.log.flush()
        return (Path(self.temp) / "ray_start.log").read_text()[-3000:]

    def stop(self) -> None:
        """Stop the raylets (Ray stops what it started), kill their process groups, then any
        process still naming the temp dir, and remove it: nothing is left behind and no other
        Ray instance on the machine is touched."""
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in reversed(self.procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                pass
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        _kill_leftovers(self.temp)
        self.log.close()
        subprocess.run(["rm", "-rf", self.temp], check=False)

    def up(self) -> Cluster:
        """Start a head and a second raylet (1 CPU each) and wait until both are alive."""
        self.start(head=True)
        deadline = time.time() + 60
        while True:
            try:
                socket.create_connection((LOOPBACK, self.port), timeout=1).close()
                break
            except OSError:
                if time.time() > deadline or self.procs[0].poll() is not None:
                    raise RuntimeError("no Ray head: " + (Path(self.temp) / "ray_start.log").read_text()) from None
                time.sleep(0.5)
        self.start(head=False)
        self.wait_for_nodes(2)
        return self


def laptop_env(home: Path) -> dict[str, str]:
    """A user's environment: no RAY_AUTH_* set, and ``home`` as HOME (where Ray 2.60 wrote its token)."""
    return {k: v for k, v in ENV.items() if not k.startswith("RAY_AUTH")} | {"HOME": str(home)}


@pytest.fixture(scope="module")
def ray_cluster(tmp_path_factory):
    """Two raylets (1 CPU each) on a loopback address with their own temp dir, started as README's
    cluster path does on a user's machine (:func:`laptop_env`, a HOME of its own)."""
    cluster = Cluster(laptop_env(tmp_path_factory.mktemp("home")))
    try:
        yield cluster.up()
    finally:
        cluster.stop()


def test_a_laptop_run_leaves_no_token_and_a_two_node_cluster_resumes_it(ray_cluster, tmp_path):
    """Ray 2.60 wrote ~/.ray/auth_token on the first local run; every `ray start --head` then
    required it, and the second raylet and the driver (no RAY_AUTH_* set) failed to authenticate.
    Now the local run leaves no token, and README's cluster path works after it: ``--address``
    continues the local run, killed mid-way, from its newest checkpoint on two raylets with two env
    runners, evaluates periodically, and the harness loads the checkpoint."""
    from agents.checkpoint import CheckpointError, load_model
    from agents.evaluate import evaluate

    env, home = ray_cluster.env, Path(ray_cluster.env["HOME"])
    out = tmp_path / "run"
    small = ["--scenario", "circle", "--n-robots", "4", "--n-worlds", "2", "--n-steps", "16", "--batch-size", "64"]
    small += ["--n-epochs", "2", "--eval-freq", "0", "--eval-episodes", "2", "--checkpoint-freq", "128"]
    res = _run("train", "--backend", "rllib", "--num-env-runners", "0", *small, "--timesteps", "256", "--out", str(out),
               env=env, timeout=300)  # fmt: skip
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert not (home / ".ray" / "auth_token").exists()
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == ["checkpoint_128"]
    subprocess.run(["rm", "-rf", str(out / "checkpoint")], check=True)  # killed before its end

    more = ["--address", ray_cluster.address, "--num-env-runners", "2", "--timesteps", "600", "--eval-freq", "200"]
    more += ["--eval-suite", "circle-8-v0-smoke"]
    res = _run("train", "--resume", str(out), *more, env=env, timeout=300)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    newest = out / "checkpoints" / "checkpoint_128"
    assert f"its newest checkpoint is {newest} (128 timesteps)" in res.stdout, res.stdout
    assert "ray cluster: 2 nodes, 2 CPUs" in res.stdout, res.stdout
    ckpt = out / "checkpoint"
    meta = json.loads((ckpt / "vcs_env.json").read_text())
    assert meta["kind"] == "rllib_ppo" and meta["num_timesteps"] >= 600
    assert meta["resumed_from"] == {"checkpoint": str(newest), "timesteps": 128}  # the weights' origin, as SB3's
    assert f"reproduce: the run of {newest} (128 timesteps), then vcs-env train --backend rllib" in res.stdout
    assert meta["command"].startswith("vcs-env train --backend rllib")
    assert f"--address {ray_cluster.address}" in meta["command"]
    assert json.loads((out / "config.json").read_text())["num_env_runners"] == 2
    evals = [json.loads(line) for line in (out / "eval.jsonl").read_text().splitlines()]
    assert len(evals) >= 2 and evals[-1]["timesteps"] == meta["num_timesteps"]
    assert all(e["timesteps"] > 128 for e in evals)  # the abandoned branch's evaluation at 256 is gone
    assert all(0 <= e["suite"]["success"] <= 1 and 0 <= e["episode_collision"] <= 1 for e in evals)

    # The harness loads it like an SB3 checkpoint, on another robot count (same observation layout).
    result = evaluate(str(ckpt), "circle-8-v0-smoke", progress=False)
    assert result.summary["success"]["n"] > 0 and 0 <= result.summary["collision"]["mean"] <= 1
    assert result.summary["success"]["mean"] == pytest.approx(evals[-1]["suite"]["success"])
    # Another observation layout: a one-line error naming the sizes.
    size = EGO_DIM + NEIGHBOR_DIM * make_scenario("circle").n_neighbors
    with pytest.raises(CheckpointError, match=f"observations of size {size}") as err:
        load_model(ckpt, make_scenario("circle", n_robots=4, n_neighbors=2))
    assert "\n" not in str(err.value)


def test_a_node_without_the_package_is_named(ray_cluster, tmp_path):
    """A third raylet whose Python cannot import vcs_env: the run stops before training, with
    a one-line error naming the node and the package."""
    blocker = tmp_path / "site"
    blocker.mkdir()
    (blocker / "sitecustomize.py").write_text("import sys\nsys.modules['vcs_env'] = None\n")
    ray_cluster.start(head=False, env={**ray_cluster.env, "PYTHONPATH": str(blocker)})
    ray_cluster.wait_for_nodes(3)
    res = _run("train", "--backend", "rllib", "--address", ray_cluster.address, "--out", str(tmp_path / "run"),
               env=ray_cluster.env)  # fmt: skip
    # Ray's own logger may add timestamped lines (a worker torn down at exit); ours is the one other.
    ours = [line for line in res.stderr.splitlines() if not RAY_LOG_LINE.match(line)]
    errors = [line for line in ours if "error" in line.lower()]
    assert res.returncode == 2 and len(errors) == 1 and errors[0].startswith("vcs-env train: error:"), res.stderr
    assert "lacks vcs-env" in errors[0] and ray_cluster.address.split(":")[0] in errors[0], errors[0]
    assert not (tmp_path / "run").exists()


def test_ray_auth_mode_of_a_run(tmp_path, monkeypatch):
    from agents.train.rllib_cluster import auth_mode

    monkeypatch.setenv("HOME", str(tmp_path))
    for name in ("RAY_AUTH_MODE", "RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH"):
        monkeypatch.delenv(name, raising=False)
    assert auth_mode(joining=False) == "disabled" and auth_mode(joining=True) == "disabled"
    (tmp_path / ".ray").mkdir()
    (tmp_path / ".ray" / "auth_token").write_text("x" * 64)
    assert auth_mode(joining=False) == "disabled" and auth_mode(joining=True) == "token"
    monkeypatch.setenv("RAY_AUTH_MODE", "token")
    assert auth_mode(joining=False) == "token"
