"""The episode runner (vcs_env.rollout): hooks see every step; rendering stays out of the timed
controller calls."""

import time

import numpy as np
import pytest

from vcs_env.planning import make_planner
from vcs_env.rollout import Hook, planner_controller, run_episodes
from vcs_env.scenario import make_scenario


class Counter(Hook):
    def __init__(self):
        self.batches, self.steps, self.acting = [], 0, 0

    def begin(self, engine, seeds, first):
        self.batches.append((first, list(seeds)))

    def step(self, s):
        assert s.running.any() and not (s.finished & ~s.running).any()
        self.steps += 1
        self.acting += int(s.acting.sum())


def test_hooks_see_every_batch_and_step():
    scenario = make_scenario("crowd", max_steps=30)
    counter = Counter()
    episodes = run_episodes(scenario, planner_controller(make_planner("vcs")), [4, 5, 6], batch_size=2, hooks=[counter])
    assert counter.batches == [(0, [4, 5]), (2, [6])]
    assert counter.steps == max(e.steps for e in episodes[:2]) + episodes[2].steps
    assert counter.acting == sum(e.decisions for e in episodes) == sum(int(e.acted.sum()) for e in episodes)


def test_rendering_happens_outside_the_timed_controller_calls(monkeypatch):
    pytest.importorskip("pygame")
    from vcs_env import render

    calls, draws = [], []
    draw = render.Renderer.draw

    def timed_draw(self, world):
        draws.append(time.perf_counter())
        return draw(self, world)

    monkeypatch.setattr(render.Renderer, "draw", timed_draw)
    planner = make_planner("vcs")

    def control(world, obs):
        calls.append(time.perf_counter())
        return planner.act(world)

    (ep,) = run_episodes(make_scenario("crowd", max_steps=12), control, [3], render_worlds=[0])
    frames = list(ep.frames)  # drawn when read (a run held every frame: about 1 GB for 10 episodes of rollout --gif)
    assert len(ep.frames) == ep.steps + 1 == len(draws) == len(frames)
    assert min(draws) > max(calls)  # every frame is drawn after the last controller call
    assert np.asarray(ep.frames[0]).ndim == 3
    # The frames are those one renderer draws state after state (trails included), read in any order or sliced.
    r = render.Renderer(make_scenario("crowd", max_steps=12).view_extent, size=400)
    eager = [r.draw(w) for w in ep.frames.snapshots]
    assert all(np.array_equal(a, b) for a, b in zip(frames, eager))
    assert np.array_equal(ep.frames[7], eager[7]) and np.array_equal(ep.frames[-1], eager[-1])
    assert [np.array_equal(a, b) for a, b in zip(ep.frames[::3], eager[::3])] == [True] * len(eager[::3])


def test_cli_output_paths_are_checked_before_the_episodes(tmp_path, capsys, monkeypatch):
    # A wrong video suffix or a directory as an output file failed only after every episode.
    import vcs_cli as cli
    import vcs_env.rollout as ro

    def no_episodes(*args, **kwargs):
        raise AssertionError("episodes ran before the output paths were checked")

    monkeypatch.setattr(ro, "run_episodes", no_episodes)
    for args, message in (
        (["rollout", "--video", str(tmp_path / "v.avi")], "--video must end in .mp4"),
        (["rollout", "--gif", str(tmp_path / "g.png")], "--gif must end in .gif"),
        (["rollout", "--json", str(tmp_path)], "is a directory"),
        (["evaluate", "--suite", "circle-8-v0-smoke", "--policy", "vcs", "--json", str(tmp_path)], "is a directory"),
    ):
        assert cli.main(args) == 2
        assert message in capsys.readouterr().err
    # An existing file where a report or run directory goes: a message, not a FileExistsError
    # traceback (compare: before its episodes; train: when it makes the directory).
    afile = tmp_path / "afile"
    afile.write_text("")
    assert cli.main(["compare", "--suite", "circle-8-v0-smoke", "--policies", "vcs", "--out", str(afile)]) == 2
    assert "is a file: give a directory" in capsys.readouterr().err
    monkeypatch.undo()
    assert cli.main(["train", "--n-robots", "2", "--timesteps", "10", "--out", str(afile)]) == 2
    assert "is a file: give a directory for the run" in capsys.readouterr().err


@pytest.mark.parametrize(
    "kw, message",
    [
        ({"seeds": [1.7]}, r"each seed must be an integer in \[0, \d+\], got 1.7"),  # it ran seed 1
        ({"seeds": "12"}, "seeds must be a sequence of integers"),  # it ran seeds 1 and 2
        ({"seeds": 3}, "seeds must be a sequence of integers"),
        ({"seeds": [1, 2], "batch_size": 0}, r"batch_size must be an integer in \[1, "),  # it ran batches of 1
        ({"seeds": [1, 2], "batch_size": 1.9}, r"batch_size must be an integer in \[1, "),
        ({"seeds": [1, 2], "render_worlds": [5]}, r"render_worlds \(an index into seeds\) must be an integer"),
        ({"seeds": [1, 2], "render_worlds": [-1]}, r"must be an integer in \[0, 1\], got -1"),  # it rendered nothing
        ({"seeds": [1], "render_worlds": [0], "render_size": -10}, r"render_size \[px\] must be an integer"),
    ],
)
def test_run_episodes_refuses_what_it_would_convert_or_clip(kw, message):
    with pytest.raises(ValueError, match=message):
        run_episodes(make_scenario("circle", n_robots=2), planner_controller("straight"), **kw)


def test_planner_controller_takes_a_name_and_refuses_what_is_no_planner():
    episode = run_episodes(make_scenario("circle", n_robots=2, max_steps=5), planner_controller("straight"), [0])[0]
    assert episode.steps == 5
    with pytest.raises(TypeError, match="planner must be a Planner or a planner's name, got int"):
        planner_controller(3)
