"""``vcs-env evaluate``, ``compare``, ``probe``, ``select`` and ``shield``: the evaluation layer of
``agents`` (the harness :mod:`agents.evaluate`, its report :mod:`agents.evaluate.report`, the probe
table :mod:`agents.evaluate.probes`, checkpoint selection :mod:`agents.evaluate.selection` and the
safety shield :mod:`agents.shield`) on the command line.

Episodes come from a named suite (``--suite circle-8-v0``) or, to probe a policy off its training
distribution, from scenario flags and a seed range::

    vcs-env evaluate --policy vcs --scenario circle --n-robots 12 --jitter 0.3 --seeds 5000:5100

The flags start from the scenario of the suite of the same family (:func:`agents.config.probe_scenario`:
the suites' jitter, ``on_collision="continue"``, spacing and limits), so only what is named changes.
"""

from __future__ import annotations

import json
import shlex
from dataclasses import asdict

from agents import shield
from agents.checkpoint import attach_shield, open_checkpoint
from agents.config import (
    SCENARIO_FLAGS,
    ScenarioConfig,
    add_config_args,
    config_from_args,
    parse_names,
    parse_seeds,
    probe_scenario,
    require_modules,
)
from agents.evaluate import DEFAULT_BATCH, EvalResult, compare, evaluate, selection
from agents.evaluate import probes as probe_table
from agents.evaluate.report import describe_shield, fmt, provenance, table_lines, table_metrics, write_report
from agents.outputs import check_out_file, check_report_dir
from agents.policies import is_checkpoint_spec
from agents.residual import refuse_residual
from benchmarks.timing import machine_info
from vcs_env.files import write_text
from vcs_env.suites import Suite, get_suite, suite_names


def _print_summary(res: EvalResult) -> None:
    s = res.suite
    print(
        f"{res.policy} on {s.name} ({s.n_episodes} episodes, fingerprint {s.fingerprint}): "
        f"{res.wall_time:.1f} s, {1e3 * res.seconds_per_decision:.3f} ms/decision"
    )
    if res.shield:
        print(f"with its safety shield: {describe_shield(res.shield)}")
    print(f"{'metric':<20} {'mean':>9} {'95% interval':>21} {'n':>5}")
    for metric in table_metrics():
        st = res.summary.get(metric.name)
        if st is None:
            continue
        none = st["n"] == 0 or (st["n"] == 1 and not metric.rate)  # a mean has no interval from one episode
        ci = "-" if none else f"[{fmt(st['low'], '.3f')}, {fmt(st['high'], '.3f')}]"
        print(f"{metric.label:<20} {fmt(st['mean'], '.3f'):>9} {ci:>21} {st['n']:>5}")


SENSING_FLAGS = ("n_wall_points", "wall_segments", "stall_clock", "lidar_beams")
"""Scenario flags that set only what robots sense (the observation), not the episodes."""


def episodes_of(args) -> Suite:
    """The named suite, or an ad-hoc one from the scenario flags and ``--seeds``."""
    given = [f for f in ("scenario", *SCENARIO_FLAGS) if getattr(args, f, None) is not None]
    if args.suite is not None:
        if given or args.seeds is not None:
            flags = ", ".join("--" + f.replace("_", "-") for f in given + (["seeds"] if args.seeds else []))
            raise ValueError(f"give either --suite or scenario flags with --seeds, not both (got --suite and {flags})")
        return get_suite(args.suite)
    if args.seeds is None:
        raise ValueError("give --suite NAME, or scenario flags (--scenario circle --n-robots 12 ...) with --seeds A:B")
    sensing = [f"--{f.replace('_', '-')}" for f in SENSING_FLAGS if f in given]
    if sensing:  # the same episodes under another suite name and fingerprint
        raise ValueError(
            f"{', '.join(sensing)} set what robots sense, which never changes an episode: each checkpoint runs with "
            "the sensing its run record names, planners read none; leave it out"
        )
    cfg = config_from_args(ScenarioConfig, args)
    scenario = probe_scenario(cfg)
    seeds = parse_seeds(args.seeds)
    changes = ",".join(f"{f}={getattr(cfg, f)}" for f in SCENARIO_FLAGS if getattr(cfg, f) is not None)
    name = f"{cfg.scenario}" + (f"[{changes}]" if changes else "") + f"@{seeds[0]}:{seeds[-1] + 1}"
    desc = f"ad-hoc: the {cfg.scenario} suite conventions" + (f" with {changes}" if changes else "")
    return Suite(name.replace(" ", ""), scenario, seeds, desc)


EVALUATE_JSON = (
    "an earlier evaluate's --json",
    lambda data: isinstance(data, dict) and {"policy", "suite", "summary", "episodes"} <= data.keys(),
)
"""What ``--json`` may replace (:func:`~agents.outputs.check_out_file`)."""
COMPARE_REPORT = (
    "an earlier compare's report",
    lambda data: isinstance(data, dict) and {"suite", "fingerprint", "seeds", "policies"} <= data.keys(),
)
"""What ``compare --out`` may replace (:func:`~agents.outputs.check_report_dir`)."""
PROBE_TABLE = (
    "an earlier probe table",
    lambda data: isinstance(data, dict) and {"expert", "probes", "command"} <= data.keys(),
)
"""What ``probe --out`` may replace."""


def cmd_evaluate(args) -> int:
    check_out_file(args.json, "--json", writable=True, replaces=EVALUATE_JSON)
    _check_no_shield(args, [args.policy])
    res = evaluate(
        args.policy,
        episodes_of(args),
        action_mode=args.action_mode,
        batch_size=args.batch_size,
        progress=False if args.no_progress else None,
        shield=not args.no_shield,
    )
    if args.json:  # before the table: output piped into a reader that closes early (head) stops the printing
        write_text(args.json, json.dumps(res.to_dict(), indent=1, allow_nan=False))
    _print_summary(res)
    if args.json:
        print(f"wrote {args.json}")
    return 0


def cmd_compare(args) -> int:
    policies = probe_table.policy_labels(parse_names(args.policies, "--policies"), expert=None)
    _check_no_shield(args, policies.values())
    suite = episodes_of(args)
    if args.episode is not None and args.no_plots:
        raise ValueError("--episode chooses the episode whose trajectories are plotted: leave it out with --no-plots")
    args.episode = 0 if args.episode is None else args.episode
    if not 0 <= args.episode < suite.n_episodes:
        raise ValueError(f"--episode must be in 0..{suite.n_episodes - 1} for {suite.name}, got {args.episode}")
    check_report_dir(args.out, ("results.md", "results.json"), COMPARE_REPORT)
    if not args.no_plots:
        require_modules(("matplotlib",), "the report's plots (--no-plots leaves them out)")
    comp = compare(
        policies,
        suite,
        action_mode=args.action_mode,
        batch_size=args.batch_size,
        keep_episodes=(args.episode,),
        progress=False if args.no_progress else None,
        shield=not args.no_shield,
    )
    made = provenance(shlex.join(["vcs-env", *args.argv]), machine_info())
    files = write_report(comp, args.out, episode=args.episode, plots=not args.no_plots, provenance=made)
    print("\n".join(table_lines(comp)))
    print(f"wrote {len(files)} files to {args.out} (results.md, results.json{', plots' if not args.no_plots else ''})")
    return 0


def cmd_probe(args) -> int:
    check_report_dir(args.out, ("probes.md", "probes.json"), PROBE_TABLE)
    specs = parse_names(args.policies, "--policies")
    policies = probe_table.policy_labels(specs)
    _check_no_shield(args, policies.values())
    probes = probe_table.select_probes(args.families)
    table = probe_table.run_probes(
        policies,
        probes,
        args.episodes,
        action_mode=args.action_mode,
        batch_size=args.batch_size,
        progress=False if args.no_progress else None,
        shield=not args.no_shield,
    )
    planners = {label for label, spec in policies.items() if not is_checkpoint_spec(spec)}
    command = f"vcs-env probe --policies {shlex.quote(args.policies)} --out {shlex.quote(str(args.out))}"
    command += f" --episodes {args.episodes}" + (f" --families {shlex.quote(args.families)}" if args.families else "")
    if args.action_mode != "delta":
        command += f" --action-mode {args.action_mode}"
    if args.batch_size != DEFAULT_BATCH:  # changes nothing but speed; said so the run can be repeated as made
        command += f" --batch-size {args.batch_size}"
    if args.no_shield:
        command += " --no-shield"
    print("\n".join(probe_table.table_lines(table, planners)))
    files = probe_table.write_probes(table, args.out, planners, command, machine_info())
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def _common_args(p) -> None:
    p.add_argument(
        "--suite",
        default=None,
        help="suite name: " + ", ".join(suite_names(smoke=False)) + " (each also as NAME-smoke); or, "
        "instead, scenario flags with --seeds",
    )
    p.add_argument(
        "--seeds",
        default=None,
        help="seed range START:STOP (stop excluded, e.g. 5000:5100) of ad-hoc episodes built from the "
        "scenario flags on the conventions of the family's suite",
    )
    add_config_args(p, ScenarioConfig, skip=("rewards", "shaping", "shaping_weight"))
    p.add_argument(
        "--action-mode",
        choices=["delta", "absolute"],
        default="delta",
        help="action units of learned policies (planners adapt)",
    )
    p.add_argument("--batch-size", type=int, default=DEFAULT_BATCH, help="worlds stepped together")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _shield_arg(p)


def _check_no_shield(args, specs) -> None:
    """``--no-shield`` among planners only changes nothing: refused, as other flags that cannot apply are."""
    if args.no_shield and not any(is_checkpoint_spec(s) for s in specs):
        raise ValueError("--no-shield applies to checkpoints (the shield their run record names); no policy is one")


def _shield_arg(p) -> None:
    p.add_argument(
        "--no-shield",
        action="store_true",
        help="run checkpoints without the safety shield their run record names (agents.shield)",
    )


def cmd_select(args) -> int:
    validation = [selection.validation_suite(v) for v in args.validation]
    selection.select_checkpoint(
        selection.candidates_of(args.candidates, args.from_step),
        validation,
        args.out,
        batch_size=args.batch_size,
        progress=False if args.no_progress else None,
        shield=not args.no_shield,
        command=shlex.join(["vcs-env", *args.argv]),
    )
    return 0


def _add_select(sub) -> None:
    p = sub.add_parser(
        "select",
        help="keep the checkpoint of a run that solves most validation episodes",
        description=selection.__doc__.split("\n\n")[0],
    )
    p.add_argument("candidates", nargs="+", help="checkpoint .zip files and/or run directories (their checkpoints)")
    p.add_argument(
        "--validation",
        nargs="+",
        action="extend",  # given twice, the sets add up
        required=True,
        help="validation sets SCENARIO:START:STOP, e.g. dynamic-v0:7000:7300 (seeds no suite or probe uses)",
    )
    p.add_argument(
        "--from-step",
        type=int,
        default=0,
        help="leave out periodic checkpoints named before this count (environment steps; a distil run "
        "names them by labelled robot-steps)",
    )
    p.add_argument("--out", required=True, help="directory for model.zip, model.json and selection.json")
    p.add_argument(
        "--no-shield",
        action="store_true",
        help="score checkpoints without the safety shield their run record names (agents.shield)",
    )
    p.add_argument("--batch-size", type=int, default=DEFAULT_BATCH, help="worlds stepped together")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_select)


SHIELD_FLAGS = {
    "horizon": shield.Shield.horizon, "margin": shield.Shield.margin, "robot_speed": shield.Shield.robot_speed,
    "still_margin": shield.Shield.still_margin, "no_driving_guard": False, "no_keep_turn": False,
    "no_brake_backup": False, "driving_stop": False, "no_robots_stand": False,
}  # fmt: skip
"""The shield's settings on the command line, and their defaults."""


def cmd_shield(args) -> int:
    given = ["--" + k.replace("_", "-") for k, default in SHIELD_FLAGS.items() if getattr(args, k) != default]
    if args.remove and given:
        raise ValueError(f"--remove takes the shield out; it takes no shield settings ({', '.join(given)})")
    guard = (
        None
        if args.remove
        else shield.Shield(
            args.horizon,
            args.margin,
            args.robot_speed,
            args.still_margin,
            driving_guard=not args.no_driving_guard,
            keep_turn=not args.no_keep_turn,
            brake_backup=not args.no_brake_backup,
            driving_stop=args.driving_stop,
            robots_stand=not args.no_robots_stand,
        )
    )
    if guard is not None:  # a shield filters a network's actions, a residual's network corrects a planner's
        why = "and a shield filters a network's own actions (evaluate would refuse the record): none written"
        refuse_residual(open_checkpoint(args.checkpoint).record, args.checkpoint, "a shield on", why)
    before = attach_shield(args.checkpoint, guard)
    if guard is None:
        said = "removed the shield from" if before is not None else "no shield to remove in"
    else:
        said = f"wrote {asdict(guard)}" + (f" (it replaces {before})" if before not in (None, asdict(guard)) else "")
        said += " into"
    print(f"{said} the run record of {args.checkpoint}")
    return 0


def _add_shield(sub) -> None:
    p = sub.add_parser(
        "shield",
        help="give a checkpoint a safety shield (kept in its run record, applied wherever it is evaluated)",
        description=shield.__doc__.split("\n\n")[0],
    )
    p.add_argument("checkpoint", help="checkpoint .zip (with its run record .json beside it) or run directory")
    p.add_argument("--horizon", type=float, default=shield.Shield.horizon, help="prediction horizon [s]")
    p.add_argument("--margin", type=float, default=shield.Shield.margin, help="smallest predicted gap to keep [m]")
    p.add_argument(
        "--robot-speed", type=float, default=shield.Shield.robot_speed, help="robots at most this fast count [m/s]"
    )
    p.add_argument(
        "--still-margin",
        type=float,
        default=shield.Shield.still_margin,
        help="smallest predicted gap to keep to still bodies: walls, parked and slow robots [m]",
    )
    p.add_argument(
        "--no-driving-guard",
        action="store_true",
        help="let a replacement steer closer to driving robots than the policy's action (the rule before 2026-12-04)",
    )
    p.add_argument(
        "--no-keep-turn",
        action="store_true",
        help="no candidates with the policy's own turn at other accelerations (the rule before 2026-12-05)",
    )
    p.add_argument(
        "--no-brake-backup",
        action="store_true",
        help="judge still bodies along the held candidate only, not also along one step and braking (the rule "
        "before 2026-12-05, with --still-margin 0.02)",
    )
    p.add_argument(
        "--no-robots-stand",
        action="store_true",
        help="predict the parked and slow robots at their observed velocity, not standing (the rule before 2026-12-06)",
    )
    p.add_argument(
        "--driving-stop",
        action="store_true",
        help="cap the policy's speed so that the robot can stop short of where every driving robot is now (any may "
        "park dead on arrival); the policy's turn is kept",
    )
    p.add_argument("--remove", action="store_true", help="take the shield out of the run record")
    p.set_defaults(func=cmd_shield)


def add_commands(sub) -> None:
    """Add ``evaluate``, ``compare``, ``probe``, ``select`` and ``shield`` to the ``vcs-env`` subcommands."""
    p = sub.add_parser("evaluate", help="score one planner or policy on a named suite")
    _common_args(p)
    p.add_argument("--policy", required=True, help="planner name (baselines.PLANNERS) or checkpoint (.zip, run dir)")
    p.add_argument("--json", default=None, help="write the summary and per-episode metrics to this JSON file")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("compare", help="score several policies on the same episodes; write a report")
    _common_args(p)
    p.add_argument(
        "--policies",
        required=True,
        help="comma-separated planner names and/or checkpoint paths, each optionally LABEL=... (its name in tables)",
    )
    p.add_argument("--out", required=True, help="output directory for results.md, results.json and plots")
    p.add_argument("--episode", type=int, default=None, help="index of the episode whose trajectories to plot (0)")
    p.add_argument("--no-plots", action="store_true", help="skip the matplotlib plots")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser(
        "probe", help="score policies beside the VCS expert off their training distribution (the probe table)"
    )
    p.add_argument(
        "--policies",
        required=True,
        help="comma-separated planner names and/or checkpoint paths, each optionally LABEL=... (its name in tables)",
    )
    p.add_argument("--out", required=True, help="output directory for probes.md and probes.json")
    p.add_argument("--families", default=None, help="comma-separated families to probe (default: all)")
    p.add_argument("--episodes", type=int, default=100, help="episodes per probe (seeds from 5000)")
    p.add_argument("--action-mode", choices=["delta", "absolute"], default="delta", help="as for compare")
    p.add_argument("--batch-size", type=int, default=DEFAULT_BATCH, help="worlds stepped together")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _shield_arg(p)
    p.set_defaults(func=cmd_probe)

    _add_select(sub)
    _add_shield(sub)
