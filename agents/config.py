"""Typed run configs shared by the ``vcs-env`` commands, and their command-line flags.

:class:`ScenarioConfig` with :func:`build_scenario` is the one way from flags to a scenario
(``rollout``, ``train``, ``collect``); :func:`probe_scenario` builds the same flags on the
conventions of the evaluation suites (``evaluate`` / ``compare`` without ``--suite``), and
:func:`suite_differences` lists how a training scenario differs from the suite of its family.
:mod:`agents.mixture` expands a training mixture (``--mixture``) into one scenario per world.

Every config is a dataclass whose fields carry a docstring (cleanrl style); :func:`add_config_args`
turns the fields into ``--flags`` whose help is that docstring, so the config, its JSON copy
beside a checkpoint and ``--help`` never disagree. No torch import here.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import importlib.util
import inspect
import shlex
import textwrap
import types
import typing
from dataclasses import dataclass
from typing import Any

from vcs_env.applies import check_applies
from vcs_env.checks import EXTRA_OF, install_hint
from vcs_env.lidar import LidarSpec
from vcs_env.scenario import RewardWeights, fit_time_limit, make_scenario, short_time_limit
from vcs_env.suites import SUITES

SHAPING = ("none", "vcs_imitation", "vcs_potential")
DEFAULT_SHAPING_WEIGHT = {"vcs_imitation": 0.1, "vcs_potential": 1.0}
"""Default weight of each shaping term. ``vcs_imitation`` is in [-1, 0] per step (a random action
scores about -0.4), so 0.1 makes it comparable to ``progress`` (~0.08 per step at full speed).
``vcs_potential`` = gamma phi(s') - phi(s) with phi = -(expert's cost) in [-2.7, 0] (about -0.2
in free space, the floor where no velocity change is admissible): at weight 1 its jumps stay
well below the arrival and collision rewards (10). At weight 10 they outweighed them (about -20
on the approach to a crash) and PPO never arrived in 4 of 5 runs on circle-8 and crowd-5
(measured; policies/README.md)."""


@dataclass
class ScenarioConfig:
    """Which scenario a run uses: a preset and a few overrides, plus optional VCS shaping."""

    scenario: str = "circle"
    """Scenario preset name (circle, swap, crossing, random, crowd, dynamic, or a map: corridor,
    doorway, room, intersection, walls), or a suite name (e.g. crowd-20-v0: that suite's scenario
    with its conventions; the other flags then change it). A custom layout is built in Python
    (Scenario(kind="custom", ...))."""
    n_robots: int | None = None
    """Number of robots n (None: the preset's)."""
    n_obstacles: int | None = None
    """Number of obstacles m (None: the preset's)."""
    max_steps: int | None = None
    """Episode step limit (None: the preset's)."""
    jitter: float | None = None
    """Uniform noise on start positions [m] for circle/swap/crossing (None: in training the preset's, 0 for
    circle, i.e. one fixed layout; in evaluation, probes and ad-hoc seeds, the family suite's, 0.1)."""
    on_collision: str | None = None
    """terminate or continue (None: in training the preset's, terminate; in evaluation the family suite's,
    continue)."""
    layout_radius: float | None = None
    """Circle radius for circle/crowd, half lane length for swap/crossing [m] (None: the preset's)."""
    arena_half_size: float | None = None
    """Half size of the square arena [m]: where random, dynamic and walls layouts place robots, walls and obstacles,
    the doorway's wall, and the edges obstacles bounce off (None: the preset's)."""
    obstacle_speed: tuple[float, ...] | None = None
    """Obstacle speed range LOW HIGH [m/s], drawn per obstacle and episode (None: the preset's)."""
    obstacle_motion: str | None = None
    """How obstacles move: static, constant, patrol, arbitrary, stop_and_go or pedestrians (None: the
    preset's; vcs_env.obstacles)."""
    corridor_width: float | None = None
    """Corridor width of corridor and intersection maps [m] (None: the preset's)."""
    door_width: float | None = None
    """Door width of doorway and room maps [m] (None: the preset's)."""
    n_walls: int | None = None
    """Random wall segments of walls maps (None: the preset's)."""
    n_wall_points: int | None = None
    """Nearest points on walls in every robot's observation (Scenario.n_wall_points; None: the preset's, 0)."""
    wall_segments: bool | None = None
    """Each nearest point on a wall also gives the wall segment it lies on, its direction and extent
    (Scenario.wall_segments; None: the preset's, off)."""
    lidar_beams: int | None = None
    """Lidar beams in every robot's observation, over 360 degrees and 4 m (vcs_env.lidar; None: no lidar)."""
    stall_clock: bool | None = None
    """Each robot's stall clock in its observation (Scenario.stall_clock, vcs_env.stall: how long it has been
    stuck and the detour the expert's stall rule gives it; None: the preset's, off)."""
    rewards: str | None = None
    """Overrides of the scenario's reward weights as name=weight pairs, comma separated, e.g.
    time=2,collision=20 (names: progress, arrival, collision, time, vcs_imitation, vcs_potential, danger,
    arrival_speed, stuck)."""
    shaping: str = "none"
    """Reward shaping from the VCS expert: none, vcs_imitation or vcs_potential."""
    shaping_weight: float | None = None
    """Weight of the shaping term (None: DEFAULT_SHAPING_WEIGHT of the chosen shaping)."""


def build_scenario(cfg: ScenarioConfig, check: tuple[str, ...] | None = None):
    """The :class:`~vcs_env.scenario.Scenario` of a config (preset or suite + overrides + shaping weight).

    A field the config sets that cannot change the scenario's episodes (``jitter`` on a kind
    that does not read it, an obstacle setting without obstacles) is a ``ValueError``; ``check``
    limits that test to the fields named (mixtures: an entry's own fields, not the common flags).
    Without ``max_steps``, the time limit grows with a layout grown past its preset's; notes say so."""
    if cfg.shaping not in SHAPING:
        raise ValueError(f"shaping must be one of {list(SHAPING)}, got {cfg.shaping!r}")
    over: dict[str, Any] = _overrides(cfg)
    weights = parse_weights(cfg.rewards)
    if cfg.shaping == "none" and cfg.shaping_weight is not None:
        raise ValueError("--shaping-weight weighs the --shaping term: give --shaping too (or the weight in --rewards)")
    if cfg.shaping != "none":
        if cfg.shaping in weights:
            raise ValueError(
                f"--rewards sets {cfg.shaping}={weights[cfg.shaping]:g} and --shaping {cfg.shaping} sets its weight "
                "too: give it once (--shaping with --shaping-weight, or the weight in --rewards alone)"
            )
        weight = DEFAULT_SHAPING_WEIGHT[cfg.shaping] if cfg.shaping_weight is None else cfg.shaping_weight
        weights[cfg.shaping] = float(weight)
    if weights:
        over["rewards"] = weights
    given = over if check is None else {k: v for k, v in over.items() if k in check}
    base = scenario_base(cfg.scenario)
    scenario = make_scenario(base, **over)
    check_applies(scenario, given)
    return _time_limit(scenario, base, cfg)


def _time_limit(scenario, base, cfg: ScenarioConfig):
    """``scenario`` with its time limit grown for a layout grown past ``base``'s, unless ``cfg`` sets
    ``max_steps``; a note says so, or that a limit given is too short to arrive."""
    if cfg.max_steps is None:  # a grown layout, a grown limit
        scenario, note = fit_time_limit(scenario, base)
    else:
        note = short_time_limit(scenario)
    if note:
        print(f"note: {note} (--max-steps sets it)", flush=True)
    return scenario


def scenario_base(name: str):
    """The scenario a ``--scenario NAME`` (or a mixture entry) starts from: a preset
    (:data:`vcs_env.SCENARIOS`, :data:`vcs_env.MAPS`) or, for a suite name such as
    ``crowd-20-v0``, that suite's scenario with all its conventions (jitter,
    ``on_collision="continue"``, spacing, time limit); flags and entry fields then change it."""
    if name == "custom":
        raise ValueError("--scenario custom has no layout here: build a Scenario(kind='custom', ...) in Python")
    return make_scenario(name)


_SCENARIO_FLAGS = (
    "n_robots", "n_obstacles", "max_steps", "jitter", "on_collision", "layout_radius", "arena_half_size",
    "obstacle_speed", "obstacle_motion", "corridor_width", "door_width", "n_walls", "n_wall_points", "wall_segments",
    "stall_clock",
)  # fmt: skip
SCENARIO_FLAGS = (*_SCENARIO_FLAGS, "lidar_beams")
"""Every flag that changes a scenario (``lidar_beams`` becomes its ``lidar``, :func:`_overrides`)."""
FEATURES = ("flat", "contact", "slots", "slots-fine")
"""Names accepted by ``--features`` (what the policy's MLPs read, :mod:`agents.features`)."""


def _overrides(cfg: ScenarioConfig) -> dict[str, Any]:
    """The Scenario fields a config sets (flags given), by name."""
    over = {name: getattr(cfg, name) for name in _SCENARIO_FLAGS if getattr(cfg, name) is not None}
    if cfg.lidar_beams is not None:
        over["lidar"] = LidarSpec(n_beams=cfg.lidar_beams)
    if over.get("obstacle_motion", "pedestrians") != "pedestrians":
        over["pedestrians"] = None  # another motion than a suite's pedestrians: their spec goes (no flag sets it)
    if "obstacle_speed" in over:
        over["obstacle_speed"] = tuple(float(v) for v in over["obstacle_speed"])
        if len(over["obstacle_speed"]) != 2:
            raise ValueError(f"obstacle_speed must be two numbers LOW HIGH [m/s], got {over['obstacle_speed']}")
    return over


def family_suite(kind: str):
    """The full evaluation suite of a layout kind (``circle`` -> ``circle-8-v0``, ``crowd`` ->
    ``crowd-5-v0``: the first one defined), or None if no suite uses that kind."""
    return next((s for s in SUITES.values() if not s.is_smoke and s.scenario.kind == kind), None)


def probe_scenario(cfg: ScenarioConfig):
    """A scenario for ad-hoc evaluation: the scenario of the suite of the preset's family
    (:func:`family_suite`: its jitter, ``on_collision="continue"``, spacing, limits ...) with the
    flags given in ``cfg`` applied; presets without a suite (random, custom) start from the preset.
    Reward flags are ignored (they do not change the metrics). Without ``max_steps`` the time limit grows with a
    layout grown past the suite's, as in :func:`build_scenario`; notes say so."""
    base = scenario_base(cfg.scenario)
    suite = SUITES[cfg.scenario] if cfg.scenario in SUITES else family_suite(base.kind)
    base = base if suite is None else suite.scenario
    over = _overrides(cfg)
    if suite is not None and "n_robots" in over and base.kind == "circle" and "layout_radius" not in over:
        # The suites' circle radius is for their n; keep the preset's rule (max(5, 0.3 n) [m]).
        over["layout_radius"] = None
    scenario = make_scenario(base, **over)
    check_applies(scenario, _overrides(cfg))
    return _time_limit(scenario, base, cfg)


_DIFF_FIELDS = (
    "jitter", "on_collision", "min_separation", "circle_radius", "max_steps", "dt", "r_goal", "r_ca", "n_neighbors",
    "robot", "obstacle_motion", "obstacle_radius", "obstacle_speed", "park_finished",
)  # fmt: skip


def suite_differences(scenario) -> tuple[str | None, list[str]]:
    """How ``scenario`` differs from the nearest suite of its family (the suite of its kind with
    the fewest differing fields; ties go to the first defined) on the fields that set the
    difficulty (jitter, collision handling, spacing, radius, limits, sensing, obstacles); robot
    and obstacle counts and rewards are not compared.

    Returns:
        The suite name (None if the kind has no suite) and one ``"field: ours (suite: theirs)"``
        line per differing field.
    """
    show = lambda v: round(v, 6) if isinstance(v, float) else v  # noqa: E731 (7.199999999999999 -> 7.2)
    best: tuple[str | None, list[str]] = (None, [])
    for suite in SUITES.values():
        if suite.is_smoke or suite.scenario.kind != scenario.kind:
            continue
        out = [
            f"{name}: {show(getattr(scenario, name))} (suite: {show(getattr(suite.scenario, name))})"
            for name in _DIFF_FIELDS
            if getattr(scenario, name) != getattr(suite.scenario, name)
        ]
        if best[0] is None or len(out) < len(best[1]):
            best = (suite.name, out)
    return best


def print_suite_differences(scenarios, doing: str = "training on") -> list[str]:
    """Print (and return) :func:`suite_differences` of a scenario, or of the last scenario of each
    family in a list (a mixture: one note per family and nearest suite), so a run that differs from
    the suites says so."""
    if not isinstance(scenarios, (list, tuple)):
        scenarios = [scenarios]
    out = []
    last = {}  # nearest suite -> (last scenario of the list nearest to it, its differences)
    for s in scenarios:
        suite, diffs = suite_differences(s)
        last[suite] = (s, diffs)
    for suite, (scenario, diffs) in last.items():
        if diffs:
            print(
                f"note: {doing} {scenario.kind} with settings unlike its suite {suite}: " + "; ".join(diffs), flush=True
            )
        out += diffs
    return out


def require_modules(modules: tuple[str, ...], what: str) -> None:
    """Before the work that needs them: an ``ImportError`` naming the first of ``modules`` (import names) that is not
    installed, what needs it, and its extra (:data:`vcs_env.checks.EXTRA_OF`)."""
    for name in modules:
        if importlib.util.find_spec(name) is None:
            hint = install_hint(EXTRA_OF.get(name, "all"))
            raise ImportError(f"{what}: {name} is not installed; install it with: {hint}")


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"5000:5100"`` -> seeds 5000..5099 (start included, stop excluded, like ``range``);
    ``"7"`` -> (7,). Raises ``ValueError`` naming the expected form."""
    start, sep, stop = str(text).partition(":")
    try:
        lo = int(start)
        hi = int(stop) if sep else lo + 1
    except ValueError:
        raise ValueError(f"--seeds must be START:STOP (integers, e.g. 5000:5100) or one seed, got {text!r}") from None
    if lo < 0 or hi <= lo:
        raise ValueError(f"--seeds START:STOP needs 0 <= START < STOP, got {text!r}")
    if hi - lo > 100_000:
        raise ValueError(f"--seeds {text!r} asks for {hi - lo} episodes; at most 100000")
    return tuple(range(lo, hi))


def parse_names(text: str, flag: str) -> list[str]:
    """``"vcs, orca"`` -> ``["vcs", "orca"]``: the comma-separated list of ``flag``; an empty entry is a ``ValueError``
    (``"vcs,,orca"`` is a typo, not two policies)."""
    names = [name.strip() for name in str(text).split(",")]
    if not all(names):
        raise ValueError(f"{flag} {text!r} has an empty entry; give names separated by single commas")
    return names


def parse_weights(text: str | None) -> dict[str, float]:
    """``"time=2,collision=20"`` -> ``{"time": 2.0, "collision": 20.0}`` (names checked)."""
    if not text:
        return {}
    names = [f.name for f in dataclasses.fields(RewardWeights)]
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in names:
            raise ValueError(f"rewards must be name=weight pairs with names in {names}, got {item!r}")
        if name in out:
            raise ValueError(f"rewards: {name!r} is given twice ({text!r}); give each weight once")
        try:
            out[name] = float(value)
        except ValueError:
            raise ValueError(f"rewards: weight of {name!r} must be a number, got {value!r}") from None
    return out


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """``{field: docstring}`` from the string literal under each field of a dataclass (and its bases)."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if not dataclasses.is_dataclass(klass):
            continue
        tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        body = tree.body[0].body
        for node, nxt in zip(body, body[1:]):
            if (
                isinstance(node, ast.AnnAssign)
                and isinstance(node.target, ast.Name)
                and isinstance(nxt, ast.Expr)
                and isinstance(nxt.value, ast.Constant)
                and isinstance(nxt.value.value, str)
            ):
                docs[node.target.id] = " ".join(nxt.value.value.split())
    return docs


def _base_type(tp) -> tuple[Any, bool]:
    """(scalar type, optional) of an annotation like ``int | None`` or ``tuple[int, ...]``."""
    optional = False
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        optional = len(args) < len(typing.get_args(tp))
        tp = args[0]
    return tp, optional


def _parse_none(conv):
    def parse(text: str):
        return None if text.lower() == "none" else conv(text)

    parse.__name__ = getattr(conv, "__name__", "value")
    return parse


def add_config_args(parser: argparse.ArgumentParser, cls: type, skip: tuple[str, ...] = ()) -> None:
    """Add one ``--field-name`` flag per field of dataclass ``cls``; defaults are ``None`` (=
    "not given") so :func:`config_from_args` can tell given flags from defaults. A tuple field's flag takes one or
    more values, and given again adds to them."""
    hints = typing.get_type_hints(cls)
    docs = field_docs(cls)
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        flag = "--" + f.name.replace("_", "-")
        tp, optional = _base_type(hints[f.name])
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()  # type: ignore[misc]
        help_text = f"{docs.get(f.name, '')} (default: {default})".replace("%", "%%")
        if tp is bool:
            parser.add_argument(flag, dest=f.name, action=argparse.BooleanOptionalAction, default=None, help=help_text)
        elif typing.get_origin(tp) is tuple:
            (item, *_rest) = typing.get_args(tp)
            # extend: a flag given twice adds to the first (``--mixture a --mixture b``), not replaces it
            parser.add_argument(flag, dest=f.name, type=item, nargs="+", action="extend", default=None, help=help_text)
        else:
            conv = _parse_none(tp) if optional else tp
            parser.add_argument(flag, dest=f.name, type=conv, default=None, help=help_text)


def config_from_args(cls: type, args: argparse.Namespace, base: Any = None):
    """A ``cls`` instance: flags given on the command line replace ``base`` (or the defaults)."""
    cfg = base if base is not None else cls()
    changes = {}
    for f in dataclasses.fields(cls):
        value = getattr(args, f.name, None)
        if value is not None:
            changes[f.name] = tuple(value) if isinstance(value, list) else value
    return dataclasses.replace(cfg, **changes)


def config_command(command: str, cfg: Any, skip: tuple[str, ...] = ("progress_bar", "tensorboard")) -> str:
    """The ``vcs-env <command>`` line that rebuilds ``cfg`` (the inverse of
    :func:`config_from_args`): one flag per field that differs from its default.

    Example: ``config_command("train", TrainConfig(n_robots=8))`` -> ``"vcs-env train --n-robots 8"``.
    """
    parts = ["vcs-env", command]
    defaults = type(cfg)()
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        if f.name in skip or value == getattr(defaults, f.name):
            continue
        flag = "--" + f.name.replace("_", "-")
        if isinstance(value, bool):
            parts.append(flag if value else "--no-" + flag[2:])
        elif isinstance(value, (tuple, list)):
            parts += [flag, *(str(v) for v in value)]
        else:
            parts += [flag, "none" if value is None else str(value)]
    return " ".join(shlex.quote(p) for p in parts)


def config_from_dict(cls: type, data: dict[str, Any]):
    """A ``cls`` instance from its JSON form (unknown keys are ignored, lists become tuples)."""
    names = {f.name for f in dataclasses.fields(cls)}
    kw = {k: (tuple(v) if isinstance(v, list) else v) for k, v in data.items() if k in names}
    return cls(**kw)
