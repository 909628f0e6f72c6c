"""Where an RLlib run executes: checking a cluster address and that every node can import vcs-env,
and starting or joining Ray (:func:`init_ray`) with the authentication the cluster uses.

Ray 2.60 turns on token authentication for a new local instance and writes a token to
``~/.ray/auth_token`` when there is none; from then on every ``ray start --head`` on that machine
picks the file up and requires the token, which a second ``ray start --address`` and a driver
joining with ``--address`` do not send (they fail with an authentication error). So a local run
here starts its loopback-only instance without authentication and leaves no token behind, and a
run joining a cluster sends the token of ``~/.ray/auth_token`` (or ``RAY_AUTH_TOKEN_PATH``) when
there is one, which a cluster without authentication ignores. ``RAY_AUTH_MODE`` set by the user
wins in both cases.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path
from typing import Any

from ..checkpoint import import_ray
from ..runs import RLlibConfig

LOCAL_NODE_IP = "127.0.0.2"
"""Node address of a local Ray instance: loopback. Ray replaces 127.0.0.1 and localhost by the
machine's network address (to be reachable from other nodes), but not other 127.x addresses."""


def auth_mode(joining: bool) -> str:
    """``RAY_AUTH_MODE`` for this driver: the user's if set; else ``token`` when joining a cluster
    with a token at hand (``RAY_AUTH_TOKEN``, ``RAY_AUTH_TOKEN_PATH`` or ``~/.ray/auth_token``),
    ``disabled`` otherwise (a local instance on loopback: no token is written)."""
    if os.environ.get("RAY_AUTH_MODE"):
        return os.environ["RAY_AUTH_MODE"]
    token_file = Path(os.environ.get("RAY_AUTH_TOKEN_PATH") or Path.home() / ".ray" / "auth_token")
    has_token = bool(os.environ.get("RAY_AUTH_TOKEN")) or token_file.is_file()
    return "token" if joining and has_token else "disabled"


def check_address(address: str, timeout: float = 3.0) -> None:
    """Raise a one-line ``ValueError`` unless a Ray head answers at ``host:port`` (``auto`` passes)."""
    if address == "auto":
        return
    host, sep, port = address.rpartition(":")
    if address.startswith("ray://"):
        raise ValueError(f"--address {address!r}: Ray Client addresses are not supported; give the head's host:port")
    if not sep or not host or not port.isdigit():
        raise ValueError(f"--address must be host:port of a Ray head (ray start --head), got {address!r}")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout):
            pass
    except OSError as e:
        raise ValueError(
            f"--address {address!r}: no Ray head answers there ({e.strerror or e}); start one with "
            f"`ray start --head --port={port}` or fix the address"
        ) from None


def _package_probe():
    """What a cluster node can import. Run as a Ray task on every node, so it refers to nothing
    of this module (a nested copy is shipped by value: a node without vcs-env can still run it)."""

    def probe() -> dict[str, Any]:
        import importlib
        import importlib.metadata as md
        import socket

        out: dict[str, Any] = {"node": socket.gethostname(), "missing": []}
        for dist, module in (("vcs-env", "agents.train.rllib_env"), ("torch", "torch"), ("ray", "ray.rllib")):
            try:
                out[dist] = md.version(dist)
                importlib.import_module(module)
            except Exception as e:  # not installed, or not importable there
                out["missing"].append(f"{dist} ({type(e).__name__}: {e})")
        return out

    return probe


def check_cluster(ray) -> list[dict[str, Any]]:
    """Probe every alive node; a node that cannot import vcs-env, torch or Ray RLlib, or runs
    another Ray version than this driver, raises a one-line ``RuntimeError``."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    probe = ray.remote(num_cpus=0, max_retries=0)(_package_probe())
    nodes = [n for n in ray.nodes() if n.get("Alive")]
    refs = [
        probe.options(scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False)).remote()
        for n in nodes
    ]
    # Fetch every probe before judging any: a result left unfetched when the run stops makes Ray
    # log an "Unhandled error" from the killed worker after our one-line message.
    results = []
    for ref in refs:
        try:
            results.append(ray.get(ref, timeout=120))
        except Exception as e:
            results.append(e)
    found = []
    for node, got in zip(nodes, results):
        where = f"the Ray cluster's node {node.get('NodeManagerAddress')}"
        if isinstance(got, Exception):
            raise RuntimeError(f"{where} cannot run a probe task: {str(got).splitlines()[0]}")
        if got["missing"]:
            raise RuntimeError(
                f"{where} ({got['node']}) lacks {'; '.join(got['missing'])}: install the same environment "
                f"on every node (vcs-env with the rllib extra)"
            )
        if got["ray"] != ray.__version__:
            raise RuntimeError(f"{where} ({got['node']}) runs ray {got['ray']}, this driver {ray.__version__}")
        found.append(got)
    return found


def init_ray(cfg: RLlibConfig):
    """Join ``cfg.address`` or start a local Ray instance; check every node can run the envs. A Ray this process
    already runs (a notebook's, a script's own ``ray.init``) is used as it is, and ``cfg.address`` must be unset:
    its workers then have the environment it was started with (this function starts them with
    ``OMP_NUM_THREADS=1`` and ``PYTHONHASHSEED=0``, which the run's reproducibility across runners needs)."""
    ray = import_ray()
    if ray.is_initialized():
        if cfg.address not in (None, "", "auto"):
            raise ValueError(
                f"this process already runs Ray; --address {cfg.address} would join another cluster: leave it out to "
                "use the running one, or call ray.shutdown() first"
            )
        nodes = check_cluster(ray)
        print(f"ray cluster: the one this process runs ({len(nodes)} node{'s' * (len(nodes) != 1)})", flush=True)
        return ray
    if cfg.address:
        check_address(cfg.address)
    os.environ["RAY_AUTH_MODE"] = auth_mode(joining=bool(cfg.address))  # read by ray.init and the processes it starts
    # PYTHONHASHSEED: RLlib iterates over sets of agent ids, whose order (and so which robot gets
    # which exploration noise) otherwise changes with every runner process (measured).
    env = {"OMP_NUM_THREADS": "1", "RAY_DEDUP_LOGS": "0", "PYTHONHASHSEED": "0"}
    kw: dict[str, Any] = dict(
        include_dashboard=False, log_to_driver=False, logging_level="WARNING", runtime_env={"env_vars": env}
    )
    if cfg.address:
        host = cfg.address.rpartition(":")[0]
        if host.startswith("127."):  # a cluster on this machine: the driver joins it on loopback too
            kw["_node_ip_address"] = host
        try:
            ray.init(address=cfg.address, **kw)
        except ConnectionError as e:
            raise RuntimeError(
                f"could not join the Ray cluster at {cfg.address} ({str(e).splitlines()[0]}); a cluster with token "
                f"authentication needs its token here too (~/.ray/auth_token, or RAY_AUTH_TOKEN)"
            ) from None
    else:
        ray.init(num_cpus=max(1, cfg.num_env_runners), _node_ip_address=LOCAL_NODE_IP, **kw)
    nodes = check_cluster(ray)
    cpus = int(ray.cluster_resources().get("CPU", 0))
    print(f"ray cluster: {len(nodes)} node{'s' * (len(nodes) != 1)}, {cpus} CPUs", flush=True)
    return ray
