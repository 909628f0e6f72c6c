"""Which scenario fields a layout kind reads: the one check, shared by the command line (flags, mixture entries) and
the envs' keywords, that a field given cannot go unused."""

from __future__ import annotations

from . import layouts
from .custom_layout import SCRIPTED
from .placement import arena_moves

MAP_FIELDS = {"corridor_width": ("corridor", "intersection"), "door_width": ("doorway", "room"), "n_walls": ("walls",)}
"""Map fields and the kinds that read them (flags, mixture entries, env keywords and probe axes)."""


def check_applies(scenario, given, own_motion: bool = False) -> None:
    """A ``ValueError`` if a field named in ``given`` (set by a flag, a mixture entry or an env's keyword) cannot
    change ``scenario``'s episodes: a layout field its kind does not read (:attr:`ScenarioKind.reads`; the arena's
    size also where obstacles are placed in it, :attr:`ScenarioKind.obstacles_in_arena`, or move in it,
    :func:`vcs_env.placement.arena_moves`), a map field of another kind, an
    obstacle setting without obstacles, or one of a custom layout, whose obstacles follow their scripts, or a motion
    setting the named obstacle motion does not read (:func:`vcs_env.obstacles.check_motion_fields`; not with
    ``own_motion``, an ``ObstacleMotion`` object of one's own, which may read any field)."""
    kind = layouts.kind_of(scenario)  # looked up now: kinds of one's own may be registered late
    reads = kind.reads
    moves = arena_moves(scenario) or (scenario.n_obstacles > 0 and kind.obstacles_in_arena)
    for name in ("jitter", "layout_radius", "arena_half_size"):
        if name in given and name not in reads and not (name == "arena_half_size" and moves):
            uses = f"it reads {', '.join(sorted(reads))} only" if reads else "its layout reads none of them"
            if name == "arena_half_size" and kind.obstacles_in_arena:
                uses += "; with obstacles (n_obstacles > 0) the arena is where they are placed"
            raise ValueError(
                f"{name} does not apply to {scenario.kind} scenarios (of jitter, layout_radius and arena_half_size, "
                f"{uses}); leave it out"
            )
    for name, kinds in MAP_FIELDS.items():
        if name in given and scenario.kind not in kinds:
            raise ValueError(f"{name} does not apply to {scenario.kind} scenarios (only to {', '.join(kinds)})")
    if scenario.kind == "custom":  # a custom layout's obstacles follow their scripts (custom_layout.check_scripted)
        for name in SCRIPTED:
            if name in given:
                raise ValueError(
                    f"{name} does not apply to custom scenarios: their obstacles follow their scripts "
                    "(CustomLayout.obstacles, ObstacleTrajectory times, positions and radius)"
                )
    for name in ("obstacle_speed", "obstacle_motion"):
        if name in given and scenario.n_obstacles == 0:
            raise ValueError(
                f"{name} needs obstacles, and this {scenario.kind} scenario has n_obstacles=0 (set n_obstacles too)"
            )
    if not own_motion and scenario.n_obstacles and scenario.kind != "custom":
        from .obstacles import check_motion_fields  # late: obstacles imports the scenario module

        check_motion_fields(scenario, given)
