"""``vcs-env rollout``: run a scripted planner on a scenario and print per-episode metrics."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from agents.config import (
    ScenarioConfig,
    add_config_args,
    build_scenario,
    config_from_args,
    require_modules,
)
from agents.outputs import check_out_file
from agents.runs import jsonable
from vcs_env.files import write_text
from vcs_env.planning import PLANNERS

PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg")
"""File types ``--plot`` writes (by its suffix)."""
ROLLOUT_SKIP = ("rewards", "shaping", "shaping_weight")
"""Scenario flags a planner rollout has no use for (rewards do not change what a planner does)."""
ROLLOUT_JSON = (
    "an earlier rollout's --json (a list of episodes)",
    lambda data: isinstance(data, list) and all(isinstance(row, dict) and "seed" in row for row in data),
)
"""What ``--json`` may replace (:func:`~agents.config.check_out_file`)."""


def _fmt(x: float, spec: str = ".2f") -> str:
    return "-" if x != x else format(x, spec)


def cmd_rollout(args: argparse.Namespace) -> int:
    from vcs_env.metrics import episode_metrics
    from vcs_env.planning import make_planner
    from vcs_env.rollout import planner_controller, run_episodes, warm_up

    cfg = config_from_args(ScenarioConfig, args)
    scenario = build_scenario(cfg)
    planner = make_planner(args.planner)
    # Before the episodes, not after them.
    outputs = [(args.gif, "--gif"), (args.video, "--video"), (args.plot, "--plot"), (args.json, "--json")]
    named = [(out, flag) for out, flag in outputs if out]
    for k, (out, flag) in enumerate(named):  # the later would replace the earlier
        for out2, flag2 in named[k + 1 :]:
            if Path(out).resolve() == Path(out2).resolve():
                raise ValueError(f"{flag} and {flag2} name the same file {out!r}; give each its own")
    for (out, flag), suffixes in zip(outputs, ((".gif",), (".mp4",), PLOT_SUFFIXES, ())):
        check_out_file(out, flag, suffixes, writable=True, replaces=ROLLOUT_JSON if flag == "--json" else None)
    for out, flag, modules in ((args.gif, "--gif", ("pygame", "imageio")), (args.plot, "--plot", ("matplotlib",)),
                               (args.video, "--video", ("pygame", "imageio", "imageio_ffmpeg"))):  # fmt: skip
        if out:
            require_modules(modules, flag)
    seeds = list(range(args.seed, args.seed + args.episodes))
    render = range(len(seeds)) if (args.gif or args.video) else ()
    controller = planner_controller(planner)
    warm_up(scenario, controller, seeds[0])
    episodes = run_episodes(scenario, controller, seeds, render_worlds=render)
    rows = []
    print(f"scenario={cfg.scenario} robots={scenario.n_robots} obstacles={scenario.n_obstacles} planner={args.planner}")
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
    if render:
        from vcs_env.render import write_video

        count = sum(len(ep.frames) for ep in episodes)
        for path in (args.gif, args.video):
            if path:
                write_video((f for ep in episodes for f in ep.frames), path, fps=int(round(1.0 / scenario.dt)))
                print(f"wrote {path} ({count} frames)")
    if args.plot:
        from matplotlib.figure import Figure

        from vcs_env.render import plot_trajectories

        ep = episodes[0]
        ax = plot_trajectories(
            ep.pos,
            ep.goal,
            ep.radius,
            ep.obs_pos,
            ep.obs_radius,
            ax=Figure(figsize=(6, 6)).subplots(),
            title=f"{args.planner} seed {ep.seed}",
            segments=ep.segments,
        )
        ax.figure.savefig(args.plot, dpi=120, bbox_inches="tight")
        print(f"wrote {args.plot}")
    if args.json:
        write_text(args.json, json.dumps(jsonable(rows), indent=2, allow_nan=False))  # no value (NaN) is null in JSON
        print(f"wrote {args.json}")
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("rollout", help="run a scripted planner and print per-episode metrics")
    add_config_args(p, ScenarioConfig, skip=ROLLOUT_SKIP)
    p.add_argument("--planner", default="vcs", help=f"planner name, one of: {', '.join(PLANNERS)} (default: vcs)")
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode (then seed+1, ...)")
    p.add_argument("--gif", default=None, help="write the episodes to this GIF")
    p.add_argument("--video", default=None, help="write the episodes to this MP4")
    p.add_argument("--plot", default=None, help="write a trajectory plot of the first episode (PNG)")
    p.add_argument("--json", default=None, help="write per-episode metrics to this JSON file")
    p.set_defaults(func=cmd_rollout)
