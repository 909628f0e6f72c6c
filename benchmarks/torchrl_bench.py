"""TorchRL env throughput: :class:`vcs_env.torchrl.VcsNavEnv` against VMAS through TorchRL's ``VmasEnv``.

Both contestants are TorchRL envs stepped the way collectors step them (``step_and_maybe_reset``: a step,
then a reset of the worlds that are done), ``B`` worlds of ``n`` agents, random actions drawn before
timing, torch on one thread. The rate is in env-steps (world-steps) per CPU second: one world advanced by
one step (``B`` per call), whatever its agent count.

* ``torchrl_vcs``: our worlds of :func:`benchmarks.env_bench.our_scenario` (the ``dynamic`` preset with
  ``n`` robots and 10 moving obstacles, ``on_collision="continue"``, 200-step episodes).
* ``torchrl_vmas``: VMAS ``navigation`` with ``n_agents = n``, CPU, 200-step episodes, spawning square
  scaled as in :func:`benchmarks.env_bench.vmas_spawn_half_size`.

Run: ``python -m benchmarks.torchrl_bench`` (``--n 8 --B 1024``), with ``OMP_NUM_THREADS=1`` as
``python -m benchmarks`` sets it (numpy and the numba kernels on one thread, like torch here).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from .env_bench import EPISODE_STEPS, POOL, our_scenario, vmas_spawn_half_size
from .peers import require, torch_single_thread
from .timing import Budget, Result, Step, side_by_side


def _stepper(env, pool) -> Step:
    """``step_and_maybe_reset`` with the actions of ``pool`` in turn; returns ``B`` world-steps per call."""
    td = env.reset()
    key = env.action_key
    k = [0]
    state = [td]

    def step() -> int:
        k[0] = (k[0] + 1) % len(pool)
        td = state[0]
        td.set(key, pool[k[0]])
        _, state[0] = env.step_and_maybe_reset(td)
        return env.batch_size[0]

    return step


def torchrl_vcs_env(n: int, B: int, seed: int = 0) -> Step:
    torch = require("torch")
    from vcs_env.torchrl import VcsNavEnv

    env = VcsNavEnv(our_scenario(n), B)
    env.set_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    pool = [torch.rand(B, n, 2, generator=gen) * 2.0 - 1.0 for _ in range(POOL)]
    return _stepper(env, pool)


def torchrl_vmas_env(n: int, B: int, seed: int = 0) -> Step:
    torch = require("torch")
    require("vmas")
    from torchrl.envs.libs.vmas import VmasEnv

    s = vmas_spawn_half_size(n)
    env = VmasEnv(
        "navigation",
        num_envs=B,
        device="cpu",
        continuous_actions=True,
        max_steps=EPISODE_STEPS,
        seed=seed,
        n_agents=n,
        world_spawning_x=s,
        world_spawning_y=s,
    )
    spec = env.full_action_spec[env.action_key]
    gen = torch.Generator().manual_seed(seed)
    low, high = spec.space.low, spec.space.high
    pool = [low + (high - low) * torch.rand(spec.shape, generator=gen) for _ in range(POOL)]
    return _stepper(env, pool)


def builders(n: int, B: int) -> dict[str, Callable[[], Step]]:
    return {"torchrl_vcs": lambda: torchrl_vcs_env(n, B), "torchrl_vmas": lambda: torchrl_vmas_env(n, B)}


def main(argv: list[str] | None = None) -> dict[str, Result]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=8, help="agents per world")
    parser.add_argument("--B", type=int, default=1024, help="worlds stepped together")
    parser.add_argument("--repeats", type=int, default=3, help="measurements per contestant (median reported)")
    args = parser.parse_args(argv)
    threads = torch_single_thread()
    results = side_by_side(builders(args.n, args.B), Budget(warmup=2, min_time=1.0, repeats=args.repeats))
    print(f"n={args.n} B={args.B} ({threads}); env-steps per CPU second, median of {args.repeats}:")
    for name, res in results.items():
        print(f"  {name:14s} {f'{res.rate:,.0f}' if res.ok else res.status}")
    return results


if __name__ == "__main__":
    main()
