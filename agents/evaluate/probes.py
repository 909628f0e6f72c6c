"""The probe table: policies scored off their training distribution, beside the VCS expert.

A probe is one change along one axis (robot count, start jitter, obstacle count, obstacle speed, and on
maps corridor width, door width, wall count)
from the suite of a family (:func:`agents.config.probe_scenario`: the suite's jitter, collision
handling and limits, so only the named field changes), played on seeds no suite uses
(:data:`PROBE_SEED_BASE` on). ``vcs-env probe`` scores every policy on the same episodes of every
probe (:func:`agents.evaluate.compare`) and writes one table: success and collision rate per
policy, and for each policy that is not a planner its gap to the expert where the expert succeeds
in at least :data:`EXPERT_BAR` of the episodes (issue 13's generalisation bar: within
:data:`MAX_GAP`).

A probe only tests generalisation for a policy that never trained on it: :func:`training_boxes`
reads a checkpoint's training scenarios (its mixture, or its one scenario) as boxes over the probe
axes, and :func:`inside_training` names the box a probe lies in. The table marks those cells
(``in training``) and the gap check leaves them out, so its verdict is over held-out probes only.
"""

from __future__ import annotations

import datetime
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vcs_env.applies import MAP_FIELDS
from vcs_env.files import write_text
from vcs_env.suites import Suite

from ..checkpoint import open_checkpoint
from ..config import ScenarioConfig, build_scenario, config_from_dict, parse_names, probe_scenario
from ..mixture import mixture_scenarios
from ..policies import is_checkpoint_spec, policy_label
from . import compare
from .report import shield_lines

PROBE_SEED_BASE = 5000
"""First seed of every probe; the suites use seeds 1000..1099."""
EXPERT_BAR = 0.95
"""Probes where the expert's success is at least this count for the gap check."""
MAX_GAP = 0.10
"""Largest success gap to the expert a generalising policy may show on those probes."""


@dataclass(frozen=True)
class Probe:
    """One off-distribution change from a family's suite."""

    scenario: str
    """Preset (family) name, e.g. ``circle``."""
    axis: str
    """What changes: ``robots``, ``jitter``, ``obstacles`` or ``obstacle speed``."""
    changes: dict[str, Any] = field(default_factory=dict)
    """:class:`~agents.config.ScenarioConfig` fields set, e.g. ``{"n_robots": 12}``."""

    @property
    def name(self) -> str:
        parts = [f"{k}={'-'.join(map(str, v)) if isinstance(v, tuple) else v}" for k, v in self.changes.items()]
        return f"{self.scenario}[{','.join(parts)}]"

    def suite(self, n_episodes: int) -> Suite:
        """The probe's episodes: ``n_episodes`` seeds from :data:`PROBE_SEED_BASE`."""
        if isinstance(n_episodes, bool) or not isinstance(n_episodes, int) or n_episodes < 1:
            raise ValueError(f"episodes per probe must be a positive integer, got {n_episodes!r}")
        scenario = probe_scenario(ScenarioConfig(scenario=self.scenario, **self.changes))
        seeds = range(PROBE_SEED_BASE, PROBE_SEED_BASE + n_episodes)
        return Suite(f"probe:{self.name}", scenario, tuple(seeds), f"{self.axis} probe of the {self.scenario} suite")


PROBES: tuple[Probe, ...] = (
    Probe("circle", "jitter", {"jitter": 0.2}),
    Probe("circle", "jitter", {"jitter": 0.3}),
    Probe("circle", "jitter", {"jitter": 0.5}),
    Probe("circle", "robots", {"n_robots": 4}),
    Probe("circle", "robots", {"n_robots": 10}),
    Probe("circle", "robots", {"n_robots": 12}),
    Probe("swap", "robots", {"n_robots": 10}),
    Probe("crossing", "robots", {"n_robots": 12}),
    Probe("crowd", "obstacles", {"n_obstacles": 3}),
    Probe("crowd", "obstacles", {"n_obstacles": 8}),
    Probe("crowd", "obstacle speed", {"obstacle_speed": (0.2, 0.5)}),
    Probe("dynamic", "robots", {"n_robots": 6}),
    Probe("dynamic", "obstacle speed", {"obstacle_speed": (1.0, 1.3)}),
    Probe("circle", "robots", {"n_robots": 32}),
    Probe("circle", "jitter", {"jitter": 0.7}),
    Probe("swap", "robots", {"n_robots": 14}),
    Probe("crossing", "robots", {"n_robots": 16}),
    Probe("crowd", "obstacles", {"n_obstacles": 26, "layout_radius": 7.5}),
    Probe("crowd", "obstacle speed", {"obstacle_speed": (1.6, 2.0)}),
    Probe("dynamic", "robots", {"n_robots": 8}),
    Probe("dynamic", "obstacles", {"n_obstacles": 10}),
    Probe("dynamic", "obstacle speed", {"obstacle_speed": (1.3, 1.6)}),
    Probe("random", "robots", {"n_robots": 8}),
    Probe("random", "robots", {"n_robots": 16}),
    Probe("corridor", "corridor width", {"corridor_width": 2.0}),
    Probe("corridor", "corridor width", {"corridor_width": 3.5}),
    Probe("doorway", "door width", {"door_width": 1.0}),
    Probe("doorway", "door width", {"door_width": 2.0}),
    Probe("room", "robots", {"n_robots": 5}),
    Probe("room", "door width", {"door_width": 1.6}),
    Probe("intersection", "corridor width", {"corridor_width": 3.2}),
    Probe("intersection", "robots", {"n_robots": 6}),
    Probe("walls", "walls", {"n_walls": 4}),
    Probe("walls", "walls", {"n_walls": 18}),
)
"""The probe table (issue 13): robot count, jitter, obstacle count and speed, per family, and the map
axes (corridor and door widths, wall count) and random layouts with robots parking in the traffic. None lies in a
range the v2 generalist trained on (``tests/test_probes.py``); of the first thirteen, most lie in the v1
generalist's. The two obstacle-speed probes of the first thirteen read 1.0-1.5 m/s (crowd) and 0.8-1.2 m/s (dynamic)
until 2026-12-07: they shared part of their speeds with the v2 mixture's entries, and slow crowds (0.2-0.5 m/s) and
obstacles between the dynamic entries' speeds and the fast probe (1.0-1.3 m/s) replaced them."""

AXES = ("n_robots", "n_obstacles", "jitter", "obstacle_speed", *MAP_FIELDS)
"""The scenario fields a probe or a training box spans."""


def _axes(scenario) -> dict[str, tuple[float, float]]:
    """``{axis: (low, high)}`` of one scenario (a number reads as ``(x, x)``; obstacle axes only with
    obstacles, map axes only on the kinds that read them)."""
    out = {a: (float(getattr(scenario, a)),) * 2 for a in ("n_robots", "n_obstacles", "jitter")}
    if scenario.n_obstacles:
        out["obstacle_speed"] = tuple(float(v) for v in scenario.obstacle_speed)
    for a, kinds in MAP_FIELDS.items():
        if scenario.kind in kinds:
            out[a] = (float(getattr(scenario, a)),) * 2
    return out


def training_boxes(record: dict[str, Any]) -> list[tuple[str, str, dict[str, tuple[float, float]]]]:
    """The training scenarios of a checkpoint's run record as boxes: per mixture entry (or the one
    scenario) ``(entry, kind, {axis: (low, high)})``, the lowest and highest value each axis takes
    over the entry's grid (a ``bc`` run's: its dataset's; [] for a record without a config)."""
    config = record.get("config") if isinstance(record, dict) else None
    if isinstance(config, dict) and "scenario" not in config and isinstance(record.get("dataset_meta"), dict):
        config = record["dataset_meta"].get("config")  # bc: the scenarios of its dataset (its DAgger rounds' too)
    if not config:
        return []
    cfg = config_from_dict(ScenarioConfig, config)
    entries = tuple(config.get("mixture") or ()) or (None,)
    boxes = []
    for entry in entries:
        scenarios = mixture_scenarios(cfg, (entry,)) if entry else [build_scenario(cfg)]  # what the run trained on
        box: dict[str, tuple[float, float]] = {}
        for axes in map(_axes, scenarios):
            for a, (lo, hi) in axes.items():
                old = box.get(a, (lo, hi))
                box[a] = (min(old[0], lo), max(old[1], hi))
        boxes.append((entry or config.get("scenario", "?"), scenarios[0].kind, box))
    return boxes


def inside_training(probe: Probe, boxes) -> str | None:
    """The training entry whose box ``probe``'s scenario meets (same kind, every axis meeting the box's range:
    :func:`meets`), or None when the probe is held out: no episode of it lies in a range the run trained on."""
    scenario = probe.suite(1).scenario
    point = _axes(scenario)
    for entry, kind, box in boxes:
        if kind == scenario.kind and all(a in box and meets((lo, hi), box[a]) for a, (lo, hi) in point.items()):
            return entry
    return None


def meets(probe: tuple[float, float], box: tuple[float, float]) -> bool:
    """Does a probe's axis ``(low, high)`` share values with a training range ``(low, high)``: a value within the
    range, or an interval (obstacle speeds, drawn uniformly) overlapping it over some length, or holding the range's
    single value. Intervals that only touch share no episodes. (Until 2026-12-07 a probe's interval had to lie
    within the range: a probe of 1.0-1.5 m/s beside a mixture entry of 1.1-1.4 m/s counted as held out.)"""
    (lo, hi), (blo, bhi) = probe, box
    if lo == hi:
        return blo <= lo <= bhi
    if blo == bhi:
        return lo <= blo <= hi
    return lo < bhi and blo < hi


def select_probes(families: str | None) -> tuple[Probe, ...]:
    """The probes of the comma-separated families (all with None), with a clear error for a typo."""
    if families is None:
        return PROBES
    wanted = parse_names(families, "--families")
    known = sorted({p.scenario for p in PROBES})
    unknown = [f for f in wanted if f not in known]
    if unknown:
        raise ValueError(f"unknown probe families {unknown or families!r}; probes exist for {known}")
    return tuple(p for p in PROBES if p.scenario in wanted)


def policy_labels(specs: list[str], expert: str | None = "vcs") -> dict[str, str]:
    """``{label: spec}`` with the ``expert`` first (None: in the given order): ``LABEL=SPEC`` by
    its label, planners by name, a checkpoint by its run directory (``policies/circle8/model.zip``
    -> ``circle8``) or its file stem (:func:`agents.policies.policy_label`); two policies with one
    label are an error."""
    out = {} if expert is None else {expert: expert}
    for spec in specs:
        if spec == expert:
            continue
        named, sep, rest = spec.partition("=")
        if sep and named.strip() and not rest.strip() and not os.path.exists(spec):
            raise ValueError(f"policy {spec!r} has a label and nothing after '=': give LABEL=PATH (or a planner)")
        if sep and named and rest and "/" not in named and os.sep not in named and not os.path.exists(spec):
            label, spec = named.strip(), rest.strip()
        else:
            label = policy_label(spec)
        if "|" in label or "\n" in label:  # the results.md table's column separator
            raise ValueError(f"policy label {label!r} holds '|' or a line break, which would break the results table")
        if label in out:
            raise ValueError(
                f"two policies would be labelled {label!r} in the table: {out[label]}, {spec} (name them: LABEL=PATH)"
            )
        out[label] = spec
    return out


def run_probes(policies: dict[str, str], probes: tuple[Probe, ...], n_episodes: int, **kwargs) -> dict:
    """Score ``policies`` (``{label: spec}``, the expert first) on the same episodes of every probe.

    Returns:
        ``{"expert": label, "probes": [{"probe", "axis", "episodes", "policies": {label:
        {"success", "collision"}}, "inside": {label: training entry}}], "shields": {label: parameters}}``
        (rates in [0, 1]; ``inside``: the checkpoints whose training ranges hold the probe,
        :func:`inside_training`; the safety shields checkpoints ran with, :mod:`agents.shield`).
    """
    rows, shields = [], {}
    boxes = {
        name: training_boxes(open_checkpoint(spec).record)
        for name, spec in policies.items()
        if is_checkpoint_spec(spec)
    }
    for probe in probes:
        comp = compare(policies, probe.suite(n_episodes), **kwargs)
        rates = {name: {m: comp.summaries[name][m]["mean"] for m in ("success", "collision")} for name in comp.results}
        inside = {name: entry for name, b in boxes.items() if (entry := inside_training(probe, b))}
        rows.append(
            {"probe": probe.name, "axis": probe.axis, "episodes": n_episodes, "policies": rates, "inside": inside}
        )
        shields.update({name: res.shield for name, res in comp.results.items() if res.shield})
    return {"expert": next(iter(policies)), "probes": rows, "shields": shields}


def gaps(table: dict, planners: set[str]) -> dict[str, list[tuple[str, float]]]:
    """Per learned policy (not in ``planners``): the held-out probes (not inside its training ranges)
    where the expert reaches :data:`EXPERT_BAR` and the policy's success is more than :data:`MAX_GAP`
    below it."""
    out: dict[str, list[tuple[str, float]]] = {}
    expert = table["expert"]
    for row in table["probes"]:
        ref = row["policies"][expert]["success"]
        for name, r in row["policies"].items():
            if name in planners:
                continue
            out.setdefault(name, [])
            if name in row.get("inside", {}):
                continue
            # Rates are counts over episodes: compare in their units (0.9875 - 0.8875 is 0.10000000000000009).
            if ref >= EXPERT_BAR - 1e-9 and ref - r["success"] > MAX_GAP + 1e-9:
                out[name].append((row["probe"], ref - r["success"]))
    return out


def table_lines(table: dict, planners: set[str]) -> list[str]:
    """The probe table as Markdown: success / collision per policy, one row per probe."""
    names = list(table["probes"][0]["policies"])
    lines = [
        "| probe | axis | " + " | ".join(names) + " |",
        "|---|---|" + "---|" * len(names),
    ]
    for row in table["probes"]:
        inside = row.get("inside", {})
        cells = [
            f"{row['policies'][n]['success']:.2f} / {row['policies'][n]['collision']:.2f}"
            + (" (t)" if n in inside else "")
            for n in names
        ]
        lines.append(f"| {row['probe']} | {row['axis']} | " + " | ".join(cells) + " |")
    n_ep, points = table["probes"][0]["episodes"], f"{100 * MAX_GAP:.0f} points"
    lines += [
        "",
        f"Success / collision over {n_ep} episodes per probe (seeds from {PROBE_SEED_BASE}); (t): the probe lies "
        "inside the policy's training ranges (not held out, left out of the check below). "
        f"Learned policies against {table['expert']} on the held-out probes where it reaches {EXPERT_BAR:.2f}:",
    ]
    for name, bad in gaps(table, planners).items():
        worst = ", ".join(f"{p} (-{g:.2f})" for p, g in bad)
        lines.append(
            f"- {name}: " + (f"within {points} everywhere" if not bad else f"more than {points} below on {worst}")
        )
    return lines


def write_probes(table: dict, out: str | Path, planners: set[str], command: str, machine: dict) -> list[Path]:
    """Write ``probes.md`` (with the command, ``machine`` and date) and ``probes.json`` under ``out``.

    ``machine``: ``cpu``, ``usable_cores`` and ``load_average`` of the machine that ran the probes
    (:func:`benchmarks.timing.machine_info`)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    load = ", ".join(f"{x:.1f}" for x in machine["load_average"] or ())
    stamp = (
        f"{datetime.date.today().isoformat()}, {machine['cpu']}, {machine['usable_cores']} cores, load average {load}"
    )
    notes = shield_lines(table.get("shields", {}))
    md = ["# Probe table", "", f"`{command}` ({stamp})", "", *table_lines(table, planners), *notes, ""]
    write_text(out / "probes.md", "\n".join(md))
    write_text(out / "probes.json", json.dumps({**table, "command": command, "date": stamp}, indent=1))
    return [out / "probes.md", out / "probes.json"]
