"""The issues' targets of ``python -m benchmarks`` (:mod:`benchmarks.run`): each one's text, the ratios measured
for it and whether it is met."""

from __future__ import annotations

import math

from .report import _rate
from .timing import fit_exponent, ratio


def targets(data: dict) -> list[dict]:
    """The issue's targets with the measured ratios."""
    out = []
    env = data.get("env")
    if env:
        ratios = {e["n"]: ratio(_rate(e, "pettingzoo"), _rate(e, "mpe")) for e in env["single"]}
        out.append(
            _target(
                "PettingZoo env (B = 1) >= 2x MPE simple_spread robot-steps/s, equal agent count",
                ratios,
                lambda x: x >= 2.0,
                "n={}",
            )
        )
        for ours in ("engine", "vecenv"):
            ratios = {(e["n"], e["B"]): ratio(_rate(e, ours), _rate(e, "vmas")) for e in env["batched"]}
            out.append(
                _target(
                    f"batched env ({ours}) >= VMAS-CPU robot-steps/s, equal batch size and agent count",
                    ratios,
                    lambda x: x >= 1.0,
                    "n={0[0]},B={0[1]}",
                )
            )
        out += _issue14_env_targets(env)
    for e in data.get("gym_vector", []):
        out.append(
            _target(
                f"gym.make_vec vector_entry_point >= 10x sync at {e['B']} envs, others={e['others']} (issue 14)",
                {e["n"]: ratio(_rate(e, "gym_vector"), _rate(e, "gym_sync"))},
                lambda x: x >= 10.0,
                "n={}",
            )
        )
    pl = data.get("planner")
    if pl:
        at16 = [e for e in pl["circle"] if e["n"] == 16] or [
            e for e in pl["circle"] if e["n"] == max(x["n"] for x in pl["circle"])
        ]
        for ref in ("orca", "pyrvo_raw"):
            # time per decision of VCS over that of ORCA = rate(ORCA) / rate(VCS)
            ratios = {(e["n"], e["B"]): ratio(_rate(e, ref), _rate(e, "vcs")) for e in at16}
            label = "our orca planner" if ref == "orca" else "raw RVO2 do_step (lower bound)"
            out.append(
                _target(
                    f"VCS time/decision <= 10x ORCA's at 16 robots, vs {label} (ratio = VCS/ORCA time)",
                    ratios,
                    lambda x: x <= 10.0,
                    "n={0[0]},B={0[1]}",
                )
            )
        dens = pl["density"]
        ns = [e["n"] for e in dens]
        step_cost = [e["decisions_per_call"] / _rate(e, "vcs") for e in dens]
        p = fit_exponent(ns, step_cost)
        out.append(
            _target(
                "VCS near-linear in robots at a fixed neighbourhood (exponent of time per world-step "
                "vs n at constant density <= 1.2)",
                {"exponent": p},
                lambda x: x <= 1.2,
                "{}",
            )
        )
    tr = data.get("training")
    if tr:
        base = tr["none"]["median_rate"]
        ratios = {v: ratio(tr[v]["median_rate"], base) for v in tr if v != "none"}
        out.append(
            _target("expert-shaped PPO >= 2/3 of unshaped PPO's agent-steps/s", ratios, lambda x: x >= 2.0 / 3.0, "{}")
        )
    return out


def _issue14_env_targets(env: dict) -> list[dict]:
    """Issue 14: a single-world step an order of magnitude cheaper, the batched engine >= 5x VMAS
    (the ``gym.make_vec`` target is in :func:`targets`)."""
    single = {e["n"]: ratio(_rate(e, "pettingzoo"), _rate(e, "mpe")) for e in env["single"]}
    out = [
        _target(
            f"PettingZoo env (B = 1) >= {need:g}x MPE simple_spread robot-steps/s at n={n} (issue 14)",
            {n: single[n]},
            lambda x, need=need: x >= need,
            "n={}",
        )
        for n, need in ((4, 2.0), (10, 10.0))
        if n in single
    ]
    at64 = {e["n"]: ratio(_rate(e, "engine"), _rate(e, "vmas")) for e in env["batched"] if e["B"] == 64}
    if at64:
        out.append(_target("batched engine >= 5x VMAS-CPU at B=64 (issue 14)", at64, lambda x: x >= 5.0, "n={},B=64"))
    return out


def _target(text: str, ratios: dict, ok, key_fmt: str) -> dict:
    vals = {key_fmt.format(k): v for k, v in ratios.items()}
    finite = [v for v in vals.values() if math.isfinite(v)]
    if not finite:
        met = "not measured"
    elif len(finite) < len(vals):
        met = "partly measured: " + ("yes" if all(ok(v) for v in finite) else "no")
    else:
        met = "yes" if all(ok(v) for v in finite) else ("no" if not any(ok(v) for v in finite) else "partly")
    return {"target": text, "ratios": vals, "met": met}
