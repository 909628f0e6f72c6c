"""The ``vcs-env`` command line. Each subcommand imports what it needs lazily."""

from __future__ import annotations

import argparse
import json
import sys

SCENARIO_HELP = "preset name: circle, swap, crossing, random, crowd, dynamic, custom"


def add_scenario_args(p: argparse.ArgumentParser) -> None:
    """Scenario selection flags shared by the subcommands."""
    p.add_argument("--scenario", default="circle", help=SCENARIO_HELP)
    p.add_argument("--n-robots", type=int, default=None, help="number of robots (overrides the preset)")
    p.add_argument("--n-obstacles", type=int, default=None, help="number of obstacles (overrides the preset)")
    p.add_argument("--max-steps", type=int, default=None, help="episode step limit (overrides the preset)")
    p.add_argument(
        "--on-collision", choices=["terminate", "continue"], default=None, help="what a collision does to a robot"
    )


def scenario_from_args(args: argparse.Namespace):
    from vcs_env.scenario import make_scenario

    over = {}
    for flag, field in (
        ("n_robots", "n_robots"),
        ("n_obstacles", "n_obstacles"),
        ("max_steps", "max_steps"),
        ("on_collision", "on_collision"),
    ):
        value = getattr(args, flag, None)
        if value is not None:
            over[field] = value
    return make_scenario(args.scenario, **over)


def _fmt(x: float, spec: str = ".2f") -> str:
    return "-" if x != x else format(x, spec)


def cmd_rollout(args: argparse.Namespace) -> int:
    from vcs_env.metrics import episode_metrics
    from vcs_env.planning import make_planner
    from vcs_env.rollout import planner_controller, run_episodes

    scenario = scenario_from_args(args)
    planner = make_planner(args.planner)
    seeds = list(range(args.seed, args.seed + args.episodes))
    render = list(range(len(seeds))) if (args.gif or args.video) else []
    episodes = run_episodes(scenario, planner_controller(planner), seeds, render_worlds=render)
    rows = []
    print(
        f"scenario={args.scenario} robots={scenario.n_robots} obstacles={scenario.n_obstacles} planner={args.planner}"
    )
    header = ("seed", "success", "collided", "arrived", "time[s]", "path[m]", "min_sep[m]", "ms/dec")
    widths = (5, 7, 8, 7, 8, 8, 10, 7)
    print(" ".join(f"{h:>{w}}" for h, w in zip(header, widths)))
    for ep in episodes:
        m = episode_metrics(ep)
        collided_robots = int((ep.robot_contact | ep.obstacle_contact).any(axis=0).sum())
        rows.append({"seed": ep.seed, **m, "collided_robots": collided_robots})
        print(
            f"{ep.seed:>5} {int(m['success']):>7} {collided_robots:>8} {m['arrived_fraction']:>7.2f} "
            f"{_fmt(m['time_to_goal']):>8} {_fmt(m['path_length']):>8} {_fmt(m['min_separation'], '+.3f'):>10} "
            f"{1e3 * m['compute_per_decision']:>7.3f}"
        )
    if args.gif or args.video:
        from vcs_env.render import write_video

        frames = [f for ep in episodes for f in ep.frames]
        for path in (args.gif, args.video):
            if path:
                write_video(frames, path, fps=int(round(1.0 / scenario.dt)))
                print(f"wrote {path} ({len(frames)} frames)")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from vcs_env.render import plot_trajectories

        ep = episodes[0]
        ax = plot_trajectories(
            ep.pos, ep.goal, ep.radius, ep.obs_pos, ep.obs_radius, title=f"{args.planner} seed {ep.seed}"
        )
        ax.figure.savefig(args.plot, dpi=120, bbox_inches="tight")
        plt.close(ax.figure)
        print(f"wrote {args.plot}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
        print(f"wrote {args.json}")
    return 0


COMMAND_MODULES = ("vcs_env.cli", "agents.evaluate", "agents.train", "agents.imitation", "benchmarks.run")
"""Modules that add subcommands: each has ``add_commands(subparsers)``, which adds its parsers
and sets ``func``. They must not import torch or stable-baselines3 at module level (the CLI
imports them all to build ``--help``); heavy imports go inside the command functions."""


def add_commands(sub) -> None:
    p = sub.add_parser("rollout", help="run a scripted planner and print per-episode metrics")
    add_scenario_args(p)
    p.add_argument("--planner", default="vcs", help="planner name (see baselines.PLANNERS)")
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode (then seed+1, ...)")
    p.add_argument("--gif", default=None, help="write the episodes to this GIF")
    p.add_argument("--video", default=None, help="write the episodes to this MP4")
    p.add_argument("--plot", default=None, help="write a trajectory plot of the first episode (PNG)")
    p.add_argument("--json", default=None, help="write per-episode metrics to this JSON file")
    p.set_defaults(func=cmd_rollout)


def build_parser() -> argparse.ArgumentParser:
    import importlib

    parser = argparse.ArgumentParser(prog="vcs-env", description="Multi-robot navigation with a VCS expert planner.")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "episodes", 1) is not None and getattr(args, "episodes", 1) < 1:
        parser.error("--episodes must be >= 1")
    try:
        return int(args.func(args) or 0)
    except (ValueError, ImportError) as e:  # bad parameters, unknown names, a missing extra: a message
        print(f"vcs-env {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
