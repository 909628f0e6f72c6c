"""Behaviour cloning and DAgger from Python: datasets from collect(), their checks, the labelling planner."""

import json

import numpy as np
import pytest
import torch

torch.set_num_threads(1)


def test_bc_takes_paths_and_dagger_labels_with_the_datasets_planner(tmp_path, monkeypatch):
    # The Path collect() returns goes into BCConfig as it is (model.json is written), and DAgger asks
    # the planner that collected the data, not the VCS expert, for its labels.
    import agents.imitation as imitation

    data = imitation.collect(
        imitation.CollectConfig(scenario="swap", n_robots=2, episodes=3, planner="hrvo", out=str(tmp_path / "d.npz"))
    )
    assert isinstance(data, type(tmp_path))
    experts = []
    play = imitation.play_mixture
    monkeypatch.setattr(imitation, "play_mixture", lambda *a, **kw: experts.append(kw.get("expert")) or play(*a, **kw))
    cfg = imitation.BCConfig(
        data=data, out=tmp_path / "bc", epochs=1, dagger_iters=1, dagger_episodes=2, eval_episodes=1, net_arch=(16,)
    )
    imitation.behaviour_clone(cfg)
    assert experts == ["hrvo"]
    assert json.loads((tmp_path / "bc" / "model.json").read_text())["config"]["data"] == str(data)


def test_bad_datasets_are_named_and_a_held_out_share_leaves_episodes_to_train_on(tmp_path, capsys):
    import agents.imitation as imitation
    from agents.imitation.data import load_dataset

    path = imitation.collect(
        imitation.CollectConfig(scenario="swap", n_robots=2, episodes=2, out=str(tmp_path / "d.npz"))
    )
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    for key, change, message in (
        ("rewards", None, r"lacks \['rewards'\]"),
        ("actions", lambda a: a[:, :1], r"actions has shape \(\d+, 1\)"),
        ("observations", lambda a: a[:0], "holds no robot-steps"),
        ("traj_start", lambda a: a[:-1], "traj_start must rise from 0 to N"),
        ("episode_starts", lambda a: a[:5], r"episode_starts has shape \(5,\)"),  # these were not checked
        ("traj_robot", lambda a: a[:0], r"traj_robot has shape \(0,\), expected \(4,\)"),
        ("traj_truncated", lambda a: a[:1], r"traj_truncated has shape \(1,\)"),
    ):
        bad = {k: v for k, v in arrays.items() if k != key}
        if change is not None:
            bad[key] = change(arrays[key])
        np.savez(tmp_path / "bad.npz", **bad)
        with pytest.raises(ValueError, match=message):
            load_dataset(tmp_path / "bad.npz")
    # Holding out 90 % of 2 episodes still trains on one (it held out both: a ZeroDivisionError).
    cfg = imitation.BCConfig(data=str(path), out=str(tmp_path / "bc"), epochs=1, val_fraction=0.9, eval_episodes=1)
    assert imitation.behaviour_clone(cfg)["rows"] > 0
    # The default share (10 %) of 2 episodes holds out none: said, not left to a missing number in the report.
    capsys.readouterr()
    cfg = imitation.BCConfig(data=str(path), out=str(tmp_path / "bc2"), epochs=1, eval_episodes=1)
    report = imitation.behaviour_clone(cfg)
    assert report["held_out_rows"] == 0 and "held_out_error" not in report
    assert "val_fraction 0.1 of the dataset's 2 episode(s) holds out none" in capsys.readouterr().out


def test_collect_names_the_file_it_writes(tmp_path, capsys):
    # numpy adds .npz to a name without it; the command printed the name without, and `bc --data`
    # with that name found nothing. A directory as --out is refused by name.
    import vcs_cli as cli

    base = ["collect", "--scenario", "circle", "--n-robots", "2", "--episodes", "2"]
    assert cli.main([*base, "--out", str(tmp_path / "noext")]) == 0
    assert f"-> {tmp_path / 'noext.npz'}" in capsys.readouterr().out
    assert (tmp_path / "noext.npz").is_file()
    from agents.imitation.data import load_dataset  # the name given to collect loads, as the name written does

    assert load_dataset(tmp_path / "noext")[1] == load_dataset(tmp_path / "noext.npz")[1]
    assert cli.main([*base, "--out", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
