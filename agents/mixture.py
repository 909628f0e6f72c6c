"""Training and evaluation mixtures: one ``--mixture`` entry is a preset or suite and grids of a few of its
fields (``circle:n_robots=4-16/4,jitter=0-0.4``); :func:`mixture_scenarios` expands them into scenarios
that share one observation config."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from typing import Any

from vcs_env.observations import observation_config

from .config import ScenarioConfig, build_scenario, scenario_base

MIXTURE_FIELDS = {
    "n_robots": int,
    "n_obstacles": int,
    "jitter": float,
    "layout_radius": float,
    "arena_half_size": float,
    "obstacle_speed": float,
    "corridor_width": float,
    "door_width": float,
    "n_walls": int,
}
"""Scenario fields a mixture entry may set, with their type. ``obstacle_speed=LO-HI`` sets the
scenario's speed interval (drawn per obstacle and episode); the others give a value or a grid."""


def _split_range(body: str) -> tuple[str, str, str]:
    """``"LO-HI"`` -> ``("LO", "-", "HI")`` (``(body, "", "")`` without a range); the dash of an exponent
    (``1e-2``) or a leading sign is a number's, not the range's."""
    body = body.strip()
    for i, ch in enumerate(body):
        if ch == "-" and i > 0 and body[i - 1] not in "eE":
            return body[:i], "-", body[i + 1 :]
    return body, "", ""


def parse_mixture_entry(text: str) -> tuple[str, dict[str, tuple]]:
    """``"circle:n_robots=4-16/4,jitter=0-0.4"`` -> ``("circle", {"n_robots": (4, 8, 12, 16),
    "jitter": (0.0, 0.2, 0.4)})``.

    ``FIELD=V`` is one value; ``FIELD=LO-HI/STEP`` the grid LO, LO+STEP, ..., HI (STEP must divide
    HI - LO); without ``/STEP`` integers step by 1 and floats give 3 levels (LO, middle, HI).
    ``obstacle_speed=LO-HI`` is one interval ``((LO, HI),)`` (no STEP). A field may appear once.
    The name before the colon is a preset or a suite (``crowd-20-v0:obstacle_speed=0.5-1.5``
    starts from that suite's conventions, :func:`scenario_base`).
    """
    preset, _, rest = text.partition(":")
    preset = preset.strip()
    try:
        scenario_base(preset)
    except ValueError as err:
        raise ValueError(f"mixture entry {text!r}: {err}") from None
    fields: dict[str, tuple] = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in MIXTURE_FIELDS:
            raise ValueError(
                f"mixture entry {text!r}: {item!r} must be FIELD=VALUE or FIELD=LO-HI[/STEP] with FIELD in "
                f"{list(MIXTURE_FIELDS)}"
            )
        if name in fields:
            raise ValueError(f"mixture entry {text!r}: {name} is set twice")
        conv = MIXTURE_FIELDS[name]
        body, _, step_text = value.partition("/")
        lo_text, dash, hi_text = _split_range(body)
        try:
            lo = conv(lo_text)
            hi = conv(hi_text) if dash else lo
            step = conv(step_text) if step_text else None
        except ValueError:
            raise ValueError(f"mixture entry {text!r}: {name} needs {conv.__name__} values, got {value!r}") from None
        if not all(math.isfinite(v) for v in (lo, hi, 1.0 if step is None else step)):
            raise ValueError(f"mixture entry {text!r}: {name} needs finite values, got {value!r}")
        if hi < lo or (step is not None and step <= 0):
            raise ValueError(f"mixture entry {text!r}: {name} needs LO <= HI and STEP > 0, got {value!r}")
        if name == "obstacle_speed":
            if step is not None:
                raise ValueError(
                    f"mixture entry {text!r}: obstacle_speed=LO-HI is one interval (each obstacle draws its speed "
                    f"from it), it takes no /STEP; got {value!r}"
                )
            fields[name] = ((lo, hi),)
            continue
        step = step if step is not None else (1 if conv is int else (hi - lo) / 2)
        count = round((hi - lo) / step) + 1 if hi > lo else 1
        if hi > lo and abs(lo + (count - 1) * step - hi) > 1e-9 * max(1.0, abs(hi)):
            raise ValueError(
                f"mixture entry {text!r}: {name}={value} does not end at {hi}: the step must divide HI - LO"
            )
        fields[name] = tuple(conv(round(lo + k * step, 12)) for k in range(count))
    return preset, fields


def mixture_split(scenarios: Sequence, seeds: Sequence[int]) -> list[tuple[Any, list[int]]]:
    """Episode ``j`` of a mixture plays ``scenarios[j % S]`` with ``seeds[j]``: the pairs
    ``(scenario, its seeds)`` in scenario order, scenarios without an episode left out. The one
    rule behind mixture data (:func:`agents.imitation.data.play_mixture`) and scoring
    (:func:`agents.evaluate.score_scenarios`)."""
    seeds = [int(s) for s in seeds]
    return [(sc, seeds[g :: len(scenarios)]) for g, sc in enumerate(scenarios) if seeds[g :: len(scenarios)]]


def scenarios_of(cfg: ScenarioConfig, mixture: tuple[str, ...] = ()) -> list:
    """The scenario of a config, or every scenario of its mixture (:func:`mixture_scenarios`)."""
    return mixture_scenarios(cfg, tuple(mixture)) if mixture else [build_scenario(cfg)]


def mixture_scenarios(cfg: ScenarioConfig, mixture: tuple[str, ...]) -> list:
    """Every scenario of a mixture: for each entry (:func:`parse_mixture_entry`) the product of its
    grids, applied to the preset together with the config's common flags (``max_steps``,
    ``on_collision``, ``obstacle_motion``, ``rewards``, shaping, the sensing ``n_wall_points``,
    ``wall_segments``, ``lidar_beams`` and ``stall_clock``). The per-scenario flags of ``cfg`` (``scenario`` and
    :data:`MIXTURE_FIELDS`) must be unset: entries set those. All scenarios must share one observation config."""

    per_entry = tuple(MIXTURE_FIELDS)
    clash = [f for f in per_entry if getattr(cfg, f) is not None]
    if cfg.scenario != type(cfg)().scenario:
        clash.insert(0, "scenario")
    if clash:
        flags = ", ".join("--" + f.replace("_", "-") for f in clash)
        raise ValueError(
            f"with --mixture, set {flags} inside the mixture entries (the scenario before the colon, fields "
            "after it: circle:n_robots=8)"
        )
    out = []
    for entry in mixture:
        preset, fields = parse_mixture_entry(entry)
        names = list(fields)
        for values in itertools.product(*(fields[n] for n in names)):
            sub = dataclasses.replace(cfg, scenario=preset, **dict(zip(names, values)))
            try:
                out.append(build_scenario(sub, check=tuple(names)))
            except ValueError as err:
                raise ValueError(f"mixture entry {entry!r}: {err}") from None
    if not out:
        raise ValueError("--mixture needs at least one entry, e.g. circle:n_robots=4-12/4 crowd")
    configs = [observation_config(s) for s in out]
    if any(c != configs[0] for c in configs):
        raise ValueError(f"mixture scenarios must share one observation config, got {configs[0]} and others")
    return out
