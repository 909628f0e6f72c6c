"""``vcs-env select``: keep the checkpoint of a run that solves most validation episodes.

The checkpoints of one PPO run can differ by tens of points on a hard family (circle-24 in
stage I in ``docs/experiments.md``), so a release keeps the best of its last checkpoints on validation
episodes no suite or probe uses, instead of whatever the last step left::

    vcs-env select runs/generalist/round2 --from-step 1000000 \\
        --validation circle-24-v0:7000:7200 dynamic-v0:7000:7300 crowd-20-v0:7000:7200 \\
        --out runs/generalist/release

Each validation set is ``SCENARIO:START:STOP``: the scenario (a preset or suite name, on the
conventions of its family's suite, as ``vcs-env evaluate --scenario``) played on seeds START..STOP-1.
The chosen checkpoint has the highest success averaged over the sets (each set counts the same),
then the lowest collision rate, then comes last in the candidates' order (later training wins a
tie). It is copied with its JSON to ``out/model.zip`` and ``out/model.json``; ``out/selection.json``
holds every candidate's scores.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import warnings
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from vcs_env.checks import check_int
from vcs_env.files import write_text
from vcs_env.suites import Suite

from ..checkpoint import SB3Checkpoint, open_checkpoint
from ..config import ScenarioConfig, parse_seeds, probe_scenario
from ..policies import resolve_policy
from ..runs import check_fresh_out
from . import DEFAULT_BATCH, evaluate

_STEP = SB3Checkpoint.periodic


def validation_suite(spec: str) -> Suite:
    """``"dynamic-v0:7000:7300"`` -> the ad-hoc suite of that scenario on seeds 7000..7299."""
    name, sep, seeds = str(spec).partition(":")
    if not name or not sep:
        raise ValueError(f"a validation set is SCENARIO:START:STOP (e.g. dynamic-v0:7000:7300), got {spec!r}")
    scenario = probe_scenario(ScenarioConfig(scenario=name))
    try:
        seeds = parse_seeds(seeds)
    except ValueError as err:
        raise ValueError(f"validation set {spec!r}: {str(err).replace('--seeds ', '')}") from None
    return Suite(f"validation:{name}@{seeds[0]}:{seeds[-1] + 1}", scenario, seeds, f"validation episodes of {name}")


def candidates_of(paths: Sequence[str | Path], from_step: int = 0) -> list[Path]:
    """The checkpoints to choose from, in order: a ``.zip`` as given; a run directory expands to its
    ``checkpoints/model_<steps>.zip`` by step (other files there are not candidates), then its final
    ``model.zip``. Periodic checkpoints (``model_<steps>.zip``) before ``from_step`` are left out (the count in
    their names: environment steps, or labelled robot-steps for a ``vcs-env distil`` run). A file named twice
    is one candidate, at its first place; two files with the same content (:func:`_identity`) and the same run
    record (but for its ``wall_time``), such as a distil run's last round and its ``model.zip``, are one candidate,
    at the later place (later training wins a tie anyway)."""
    check_int("--from-step", from_step, 0, 2**62)
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = [c.path for c in SB3Checkpoint.in_run(p)]
            if not found:
                raise ValueError(
                    f"run directory {str(p)!r} holds no model.zip and no checkpoints/model_<steps>.zip (select keeps "
                    "an SB3 policy as <out>/model.zip; RLlib and BenchMARL runs are compared with vcs-env compare)"
                )
        else:
            ckpt = open_checkpoint(p)
            if not isinstance(ckpt, SB3Checkpoint):  # it was copied to <out>/model.zip, which nothing could load
                raise ValueError(
                    f"{str(p)!r} is a {ckpt.format} checkpoint: select keeps an SB3 policy as <out>/model.zip "
                    "(compare the others with vcs-env compare)"
                )
            found = [ckpt.path]
        out += [c for c in found if not (m := _STEP.fullmatch(c.name)) or int(m[1]) >= from_step]
    if not out:
        raise ValueError(f"no candidate checkpoint from step {from_step} on in {', '.join(map(str, paths))}")
    seen: set[Path] = set()  # a file named twice is scored once, at its first place
    out = [c for c in out if not (c.resolve() in seen or seen.add(c.resolve()))]
    same = [_identity(c) for c in out]
    return [c for i, c in enumerate(out) if same[i] not in same[i + 1 :]]


def _identity(path: Path) -> tuple[str, str]:
    """What a candidate scores as: its content (a zip's entries by name, CRC and size: SB3 stamps each entry with the
    time of the save) and its run record but for the record's ``wall_time`` (a directory, an RLlib checkpoint, by
    its path)."""
    if not path.is_file():
        return str(path.resolve()), ""
    record = {k: v for k, v in open_checkpoint(path).record.items() if k != "wall_time"}
    if zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as z:
            content = repr(sorted((i.filename, i.CRC, i.file_size) for i in z.infolist()))
    else:
        content = hashlib.sha256(path.read_bytes()).hexdigest()
    return content, json.dumps(record, sort_keys=True)


def select_checkpoint(
    candidates: Sequence[Path],
    validation: Sequence[Suite],
    out: str | Path,
    batch_size: int = DEFAULT_BATCH,
    progress: bool | None = False,
    shield: bool = True,
    command: str | None = None,
) -> dict[str, Any]:
    """Score every candidate on every validation suite, copy the best (module docstring) to ``out``, a directory that
    holds no run (nor an earlier selection). ``shield=False`` scores the networks without the shields their records
    name (the copy keeps its record as it is). ``command``: the command line that asked, kept in the result.

    Returns:
        ``{"chosen": path, "candidates": [{"checkpoint", "shield", "success", "collision", "sets": {suite name:
        {"success", "collision"}}}, ...], "command"}`` (``shield``: what it was scored with, or None; ``command``
        only when given), also written to ``out/selection.json``.
    """
    if not validation:
        raise ValueError("give at least one validation set")
    out = Path(out)
    inside = [c for c in candidates if Path(c).resolve().is_relative_to(out.resolve())]
    if inside:
        raise ValueError(f"--out {str(out)!r} holds candidate {str(inside[0])!r}: writing there would overwrite it")
    check_fresh_out(out)
    if (out / "selection.json").exists():
        raise ValueError(f"--out {str(out)!r} holds an earlier selection; give another --out, or remove it first")
    with warnings.catch_warnings():  # errors only: evaluate warns once per candidate below
        warnings.simplefilter("ignore")
        for c in candidates:  # every candidate fits every set before the first is scored
            for suite in validation:
                resolve_policy(str(c), suite.scenario, shield=shield)  # as evaluate loads it (its own sensing)
    scores = []
    for c in candidates:
        sets, guard = {}, None
        for suite in validation:
            res = evaluate(str(c), suite, batch_size=batch_size, progress=progress, shield=shield)
            s, guard = res.summary, res.shield
            sets[suite.name] = {"success": s["success"]["mean"], "collision": s["collision"]["mean"]}
        row = {
            "checkpoint": str(c),
            "shield": guard,
            "success": sum(x["success"] for x in sets.values()) / len(sets),
            "collision": sum(x["collision"] for x in sets.values()) / len(sets),
            "sets": sets,
        }
        scores.append(row)
        each = " ".join(f"{x['success']:.3f}" for x in sets.values())
        print(f"{c}: success {each} (mean {row['success']:.3f}), collision {row['collision']:.3f}", flush=True)
    best = max(range(len(scores)), key=lambda i: (scores[i]["success"], -scores[i]["collision"], i))
    chosen = Path(candidates[best])
    out.mkdir(parents=True, exist_ok=True)
    record = open_checkpoint(chosen).record_path
    shutil.copy(chosen, out / "model.zip")
    if record.exists():
        shutil.copy(record, out / "model.json")
    result = {"chosen": str(chosen), "candidates": scores} | ({"command": command} if command else {})
    write_text(out / "selection.json", json.dumps(result, indent=1))
    print(f"kept {chosen} as {out / 'model.zip'}")
    return result
