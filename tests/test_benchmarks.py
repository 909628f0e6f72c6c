"""Smoke test of the benchmarks: every section runs with tiny sizes (``--quick``) so the code
cannot rot. No timing is asserted; peers that are not installed are reported as missing and do
not fail the test, but our own contestants must run and a peer that is installed must work."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import peers
from benchmarks.run import SECTIONS
from benchmarks.targets import _target
from benchmarks.timing import Budget, Missing, fit_exponent, side_by_side

ROOT = Path(__file__).resolve().parents[1]
OURS = {"pettingzoo", "engine", "vcs", "vo", "hrvo", "gym_vector", "gym_sync"}
PEERS = {"mpe": "mpe2", "vmas": "vmas", "orca": "pyrvo", "pyrvo_raw": "pyrvo", "vecenv": None}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "RESULTS.md"
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    proc = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--quick", "--out", str(out)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out, json.loads(out.with_suffix(".json").read_text())


def _contestants(data):
    for e in data["env"]["single"] + data["env"]["batched"] + data["gym_vector"]:
        yield from e["results"].items()
    for key in ("circle", "neighbours", "density"):
        for e in data["planner"][key]:
            yield from e["results"].items()
    for r in data["scaling"]["rows"]:
        yield from r["results"].items()


@pytest.mark.slow
def test_quick_run_writes_report_and_json(quick):
    out, data = quick
    text = out.read_text()
    for heading in (
        "## Machine",
        "## Peers",
        "## Targets",
        "## 1. Env",
        "## 2. Planner",
        "## 3. Training",
        "## 4. Scaling",
        "## 5. Where the time goes",
    ):
        assert heading in text
    assert "| ours (vcs_nav_v2) |" in text  # the env it steps (the label said v1)
    assert set(SECTIONS) <= set(data) | {"profiles"}
    assert data["meta"]["quick"] and data["meta"]["machine"]["cpu"]
    assert data["targets"] and all(t["met"] for t in data["targets"])


@pytest.mark.slow
def test_ours_measured_peers_measured_or_missing(quick):
    _, data = quick
    status = data["peers"]
    for name, r in _contestants(data):
        base = name.split("_B")[0]
        if base in OURS:
            assert r["status"] == "ok" and r["median_rate"] > 0, (name, r["status"])
        else:
            assert r["status"] == "ok" or r["status"].startswith("missing"), (name, r["status"])
            module = PEERS.get(base)
            if module and status[module].startswith("ok"):
                assert r["status"] == "ok", (name, r["status"])
    for v, r in data["training"].items():
        assert r["status"] == "ok" or r["status"].startswith("missing"), (v, r["status"])
    for name, p in data["profiles"].items():
        assert "rows" in p or "orca" in name or "MPE" in name, (name, p)


@pytest.mark.slow
def test_gym_vector_rows_and_issue14_targets(quick):
    out, data = quick
    assert [e["others"] for e in data["gym_vector"]] == ["vcs", "straight"]
    assert "### Gymnasium vector API" in out.read_text()
    assert any("issue 14" in t["target"] and "MPE" in t["target"] for t in data["targets"])
    assert sum("make_vec" in t["target"] for t in data["targets"]) == 2


@pytest.mark.slow
def test_merge_keeps_the_sections_not_run(quick, tmp_path, capsys):
    out, data = quick
    merged = tmp_path / "RESULTS.md"
    merged.with_suffix(".json").write_text(out.with_suffix(".json").read_text())
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    cmd = [sys.executable, "-m", "benchmarks", "--quick", "--sections", "profiles", "--merge", "--out", str(merged)]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    new = json.loads(merged.with_suffix(".json").read_text())
    assert new["planner"] == data["planner"] and new["env"] == data["env"]  # kept as they were
    run_of = {"date": data["meta"]["date"], "commit": data["meta"]["commit"]}
    assert new["kept"] == {k: run_of for k in ("env", "gym_vector", "planner", "training", "scaling")}
    assert "Kept from earlier runs" in merged.read_text() and "## 2. Planner" in merged.read_text()
    # A second merge keeps each section's own provenance.
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert json.loads(merged.with_suffix(".json").read_text())["kept"] == new["kept"]
    # A full run does not merge with a quick one, a file without meta is named, and no section is no run.
    from benchmarks.run import main

    def refused(argv, said):
        assert main(argv) == 2 and said in capsys.readouterr().err

    capsys.readouterr()
    refused(["--sections", "profiles", "--merge", "--out", str(merged)], "holds a quick run; a full run does not merge")
    merged.with_suffix(".json").write_text("{}")
    refused(["--quick", "--sections", "profiles", "--merge", "--out", str(merged)], "is no results file of python -m")
    merged.with_suffix(".json").write_text('{"meta": {"da')  # cut short: named, not a bare JSON error
    refused(["--quick", "--sections", "profiles", "--merge", "--out", str(merged)], "RESULTS.json is not JSON")
    refused(["--quick", "--sections", ",", "--out", str(merged)], "choose from")


def test_missing_peer_is_reported_not_skipped():
    def broken():
        raise Missing("no such package")

    res = side_by_side(
        {"ours": lambda: lambda: 3, "peer": broken}, Budget(warmup=0, min_time=0, min_calls=1, repeats=2)
    )
    assert res["ours"].ok and len(res["ours"].rates) == 2
    assert res["peer"].status == "missing: no such package" and math.isnan(res["peer"].rate)
    with pytest.raises(Missing, match="bench"):
        peers.require("surely_not_a_module_xyz")


def test_fit_exponent_and_target():
    n = [4, 8, 16, 32]
    assert fit_exponent(n, [x**1.5 for x in n]) == pytest.approx(1.5)
    assert math.isnan(fit_exponent([4], [1.0]))
    t = _target("t", {1: 3.0, 2: float("nan")}, lambda x: x >= 2, "{}")
    assert t["met"].startswith("partly measured")


def test_cli_has_bench_command():
    from vcs_cli import build_parser

    args = build_parser().parse_args(["bench", "--quick", "--out", "x.md"])
    assert args.quick and args.out == "x.md"


def test_quick_run_without_out_writes_no_committed_file(monkeypatch):
    """A smoke run never overwrites the committed report: without ``--out`` it goes under ``runs/``
    (gitignored), even from the repository root; a full run still writes ``benchmarks/RESULTS.md``."""
    from benchmarks.run import DEFAULT_OUT, default_out
    from vcs_cli import build_parser

    monkeypatch.chdir(ROOT)
    args = build_parser().parse_args(["bench", "--quick"])
    assert args.out is None
    out = default_out(args.quick).resolve()
    committed = {p.resolve() for p in (ROOT / "benchmarks").iterdir()}
    assert out not in committed and out.with_suffix(".json") not in committed
    assert out.relative_to(ROOT).parts[0] == "runs" and "runs/" in (ROOT / ".gitignore").read_text().split()
    assert default_out(False) == DEFAULT_OUT == ROOT / "benchmarks" / "RESULTS.md"


def test_rllib_section_is_rendered_from_its_json_and_replaced_in_place(tmp_path):
    """``python -m benchmarks`` rewrites RESULTS.md; section 6 (RLlib, measured separately) comes
    back from benchmarks/rllib_bench.json, once, before any later section."""
    import json
    from pathlib import Path

    from benchmarks import rllib_bench

    data = json.loads((Path(rllib_bench.__file__).parent / rllib_bench.DEFAULT_JSON).read_text())
    text = rllib_bench.render_section(data)
    assert text.startswith(rllib_bench.SECTION) and "| rllib-pettingzoo-1 |" in text
    report = tmp_path / "RESULTS.md"
    report.write_text("# R\n\n## 1. Env\nrows\n")
    rllib_bench.write_section(str(report), text)
    rllib_bench.write_section(str(report), text)
    assert report.read_text().count(rllib_bench.SECTION) == 1 and report.read_text().startswith("# R\n\n## 1. Env")


def test_threads_bench_quick_writes_its_table(tmp_path):
    """``python -m benchmarks.threads_bench --quick`` (issue 45) runs in a subprocess (numba's pool
    size is fixed at import) and writes the table with the machine and the load."""
    out = tmp_path / "THREADS.md"
    cmd = [sys.executable, "-m", "benchmarks.threads_bench", "--quick", "--out", str(out)]
    subprocess.run(cmd, check=True, capture_output=True, cwd=Path(__file__).resolve().parents[1])
    text = out.read_text()
    assert "| B | lidar beams | 1 thread [M/s]" in text and "Load average" in text and "Machine:" in text
    res = json.loads(out.with_suffix(".json").read_text())
    assert res["threads"][0] == 1 and res["rows"] and res["crossover"] and res["expert"]
    assert "| `circle-16-v0` | 16 |" in text
    assert "| VMAS, 1 thread [M/s] | ours / VMAS (1 thread) |" in text
    vmas = importlib.util.find_spec("vmas") is not None  # a peer of the bench extra; missing, its cells read nan
    assert all(row["open"] > 0 and (row["vmas"] > 0 if vmas else math.isnan(row["vmas"])) for row in res["rows"])
    header = next(line for line in text.splitlines() if line.startswith("| B | lidar beams |"))
    rows = [line for line in text.splitlines() if line.startswith("| 64 | ")]  # --quick: B = 64
    assert len(rows) == 2 and all(row.count("|") == header.count("|") for row in rows)  # cells line up
    # The report says how it was made (the command as typed, the date) and that it is a quick run, whose expert
    # rows ran 2 steps once (it said 30 steps, best of 3)
    assert res["command"] == f"python -m benchmarks.threads_bench --quick --out {out}" and res["date"]
    assert f"Generated by `{res['command']}`" in text and "A quick run (--quick" in text
    assert "(2 steps from the reset, planning and stepping, best of 1 runs" in text
    bad = subprocess.run([*cmd[:3], "--steps", "0", "--out", str(out)], capture_output=True, text=True)
    assert bad.returncode == 2 and "--steps and --repeats must be >= 1" in bad.stderr  # it divided by 0 at the end


def test_jaxmarl_bench_quick_writes_its_tables_with_or_without_jaxmarl(tmp_path):
    """``python -m benchmarks.jaxmarl_bench --quick`` (issue 45): both tables, our engine measured, and
    JaxMARL either measured or named as missing with how to install it (it is not in any extra)."""
    out = tmp_path / "JAXMARL.md"
    cmd = [sys.executable, "-m", "benchmarks.jaxmarl_bench", "--quick", "--out", str(out)]
    subprocess.run(cmd, check=True, capture_output=True, cwd=Path(__file__).resolve().parents[1])
    text = out.read_text()
    assert text.count("| B | ours [M/s] | ours, open [M/s] | JaxMARL step [M/s]") == 2 and "Machine:" in text
    res = json.loads(out.with_suffix(".json").read_text())
    rows = [row for phase in res["phases"] for row in phase["rows"]]
    assert len(rows) == 2 and all(row[k]["median_wall_rate"] > 0 for row in rows for k in ("ours", "ours_open"))
    for row in rows:
        for name in ("jaxmarl_step", "jaxmarl_scan"):
            assert row[name]["status"] == "ok" or "pip install jaxmarl" in row[name]["status"]
    installed = importlib.util.find_spec("jaxmarl") is not None  # the report said it was installed either way
    assert ("JaxMARL installed beside torch" in text) == installed
    bad = subprocess.run([*cmd[:3], "--batches", "0", "--out", str(out)], capture_output=True, text=True)
    assert bad.returncode == 2 and "--batches and --repeats must be >= 1" in bad.stderr  # it wrote a table of nan


def test_an_output_the_report_would_overwrite_is_refused_before_the_runs(tmp_path):
    """``--out R.json`` wrote the Markdown report over its own raw numbers; a directory failed after the runs."""
    from benchmarks.run import run

    for out in (tmp_path / "R.json", tmp_path):
        with pytest.raises(ValueError, match="give the Markdown report's file name"):
            run(quick=True, out=out, sections=("env",))
    (tmp_path / "afile").write_text("")  # a report under a file failed only after every section had run
    with pytest.raises(ValueError, match="lies under .*afile.*, a file"):
        run(quick=True, out=tmp_path / "afile" / "R.md", sections=("env",))


def test_the_benchmarks_run_our_kernels_on_one_thread_whatever_the_process_has(tmp_path, monkeypatch):
    """``vcs-env bench`` runs in a process with numba's default thread count (all usable cores), unlike ``python -m
    benchmarks``, which sets NUMBA_NUM_THREADS=1: the run itself sets one thread (every peer gets one), says so in
    its report, and gives the process its count back."""
    import benchmarks.run as bench_run
    import vcs_env

    seen = []
    measure = bench_run._run
    monkeypatch.setattr(bench_run, "_run", lambda *a: (seen.append(vcs_env.get_threads()), measure(*a))[1])
    before = vcs_env.get_threads()
    data = bench_run.run(quick=True, out=tmp_path / "R.md", sections=("scaling",))
    assert seen == [1] and data["meta"]["numba_threads"] == 1 and vcs_env.get_threads() == before
    assert "our numba kernels: 1 thread" in (tmp_path / "R.md").read_text()


def test_install_bench_reports_every_step(tmp_path):
    """The install benchmark's report names each README command with its time, and sizes count files once."""
    from benchmarks import install_bench as ib

    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "f").write_bytes(b"x" * 1000)
    (tmp_path / "g").write_bytes(b"y" * 234)
    (tmp_path / "link").symlink_to(tmp_path / "g")
    assert ib.tree_size(tmp_path) == 1234

    def step(cmd, seconds, last=""):
        return {"command": " ".join(cmd), "seconds": seconds, "last_line": last}

    res = {
        "argv": "python -m benchmarks.install_bench --tests",
        "date": "2026-12-07T00:00:00+00:00",
        "info": {
            "cpu": "cpu",
            "logical_cores": 2,
            "usable_cores": 2,
            "platform": "p",
            "python": "3.11",
            "load_average": [1, 1, 1],
        },
        "load_average_end": [2, 2, 2],
        "pip_sources": ["PyPI"],
        "light": {"steps": [step(ib.LIGHT[0], 14.2)], "bytes": 629_000_000},
        "run": {"first": step(ib.RUN, 71.0, "wrote circle.gif"), "second": step(ib.RUN, 5.0, "wrote circle.gif")},
        "full": {"steps": [step(c, 30.0) for c in ib.FULL], "bytes": 2_500_000_000},
        "tests": [step(ib.TESTS[0], 93.0, "400 passed"), step(ib.TESTS[1], 355.0, "1353 passed")],
    }
    text = ib.render(res)
    for cmd in (*ib.LIGHT, *ib.FULL, *ib.TESTS):
        assert f"`{' '.join(cmd)}`" in text
    assert "| 14 s |" in text and "| 1 min 11 s |" in text and "| 5 min 55 s | 1353 passed |" in text
    assert "629 MB" in text and "2,500 MB" in text
    assert "python -m benchmarks.install_bench --tests" in text


def test_a_missing_peer_names_the_extra_that_installs_it(monkeypatch):
    """Every peer's hint named [bench]; stable-baselines3 comes with [train]."""
    import re

    from benchmarks.timing import Missing

    def absent(name):
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)

    monkeypatch.setattr(peers.importlib, "import_module", absent)
    for module, extra in (("stable_baselines3", "train"), ("vmas", "bench"), ("pyrvo", "bench")):
        with pytest.raises(Missing, match=re.escape(f"pip install -e '.[{extra}]'")):
            peers.require(module)
