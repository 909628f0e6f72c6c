"""Social metrics (vcs_env.social_metrics) on hand-made episodes, and their scalar twins."""

import dataclasses
import math

import numpy as np
import pytest
from test_evaluate import make_episode

from vcs_env import metrics, social_metrics
from vcs_env.social_metrics import TTC_CAP, time_to_contact


def with_people(ep, people, radius=0.3):
    """``ep`` with static obstacles at ``people`` ``(m, 2)`` [m]."""
    people = np.asarray(people, dtype=np.float64).reshape(-1, 2)
    T1 = len(ep.pos)
    return dataclasses.replace(ep, obs_pos=np.broadcast_to(people, (T1, *people.shape)).copy(),
                               obs_radius=np.full(len(people), radius))  # fmt: skip


def straight_run(people, to=10):
    """Robot of radius 0.25 m along +x from 0 to ``to`` m at 1 m/s (dt 1 s) past static people."""
    return with_people(make_episode([(x, 0.0) for x in range(to + 1)]), people)


def test_intrusions_and_gap_by_hand():
    # Person at (5, 0.9): gap 0.9 - 0.55 = 0.35 m at x = 5 (intimate), sqrt(1 + 0.81) - 0.55 = 0.795 m at
    # x = 4 and 6 (personal), 1.643 m at x = 3 and 7 (neither); 11 driving states.
    m = metrics.episode_metrics(straight_run([(5.0, 0.9)]))
    assert m["intimate_intrusion"] == pytest.approx(1 / 11)
    assert m["personal_intrusion"] == pytest.approx(3 / 11)
    assert m["min_human_distance"] == pytest.approx(0.35)
    assert m["min_ttc"] == TTC_CAP  # never on a collision course (0.9 m aside > 0.55 m)


def test_time_to_collision_by_hand():
    # Person at (8, 0.3), robot stops at x = 5: from x = 4 it would touch after 8 - 4 - sqrt(0.55^2 - 0.3^2) s.
    ep = straight_run([(8.0, 0.3)], to=5)
    assert metrics.episode_metrics(ep)["min_ttc"] == pytest.approx(4.0 - math.sqrt(0.55**2 - 0.09))


def test_without_people_social_metrics_are_undefined():
    m = metrics.episode_metrics(make_episode([(x, 0.0) for x in range(5)]))
    for key in ("intimate_intrusion", "personal_intrusion", "min_human_distance", "min_ttc"):
        assert math.isnan(m[key]), key
    assert m["spl"] == pytest.approx(1.0) and m["path_irregularity"] == pytest.approx(0.0)


def test_spl_and_path_irregularity_by_hand():
    # 3 m east then 4 m north to (3, 4): 7 m driven for 5 m; it turned pi/2, facing the goal needed atan2(4, 3).
    ep = make_episode([(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (3, 3), (3, 4)])
    m = metrics.episode_metrics(ep)
    assert m["spl"] == pytest.approx(5 / 7)
    assert m["path_irregularity"] == pytest.approx((math.pi / 2 - math.atan2(4, 3)) / 7)
    failed = make_episode([(0, 0), (1, 0)], reached_step=-1, goal=(5, 0))
    assert metrics.episode_metrics(failed)["spl"] == 0.0


def scalar_time_to_contact(dp, dv, reach):
    """The first t >= 0 with |dp + dv t| <= reach, by the quadratic formula, one pair at a time."""
    if dp @ dp <= reach * reach:
        return 0.0
    a, b, c = dv @ dv, 2 * (dp @ dv), dp @ dp - reach * reach
    if a == 0 or b * b - 4 * a * c < 0:
        return math.inf
    t = (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)
    return t if t >= 0 else math.inf


def test_time_to_contact_equals_scalar_twin():
    rng = np.random.default_rng(0)
    dp, dv, reach = rng.uniform(-3, 3, (500, 2)), rng.uniform(-2, 2, (500, 2)), rng.uniform(0.2, 1.0, 500)
    ours = time_to_contact(dp, dv, reach)
    twin = [scalar_time_to_contact(dp[i], dv[i], reach[i]) for i in range(500)]
    np.testing.assert_allclose(ours, twin, rtol=1e-9)
    assert np.isfinite(ours).sum() > 50 and (ours == 0).sum() > 5


def test_intrusion_share_equals_scalar_twin():
    rng = np.random.default_rng(1)
    ep = with_people(make_episode(np.cumsum(rng.uniform(-0.5, 1.0, (30, 2)), axis=0)), rng.uniform(0, 10, (4, 2)))
    ep = dataclasses.replace(ep, obs_pos=ep.obs_pos + rng.uniform(-0.3, 0.3, ep.obs_pos.shape))
    for zone in (0.45, 1.2, 3.0):
        hits = total = 0
        for t in range(len(ep.pos)):
            if (t < ep.steps and ep.acted[t, 0]) or (t > 0 and ep.acted[t - 1, 0]):
                total += 1
                gaps = [np.linalg.norm(ep.pos[t, 0] - ep.obs_pos[t, k]) - 0.25 - 0.3 for k in range(4)]
                hits += min(gaps) < zone
        assert social_metrics.intrusion_share(ep, zone)[0] == pytest.approx(hits / total)


def test_an_intrusion_zone_must_be_a_positive_number():
    """NaN or a negative zone read 0 intrusions everywhere."""
    from vcs_env.social_metrics import intrusion_share

    ep = make_episode([(x, 0.0) for x in range(5)])
    for zone in (float("nan"), -1.0, 0.0, "0.5"):
        with pytest.raises(ValueError, match="zone must be a number > 0"):
            intrusion_share(ep, zone)


def test_a_hand_made_episode_whose_arrays_disagree_is_named():
    """A person added to obs_pos but not to obs_radius read 0 intrusions and then failed in numpy's min."""
    ep = make_episode([(x, 0.0) for x in range(5)])
    person = dataclasses.replace(ep, obs_pos=np.tile([[[2.0, 0.9]]], (len(ep.pos), 1, 1)))
    with pytest.raises(ValueError, match=r"Episode.obs_pos has shape \(5, 1, 2\), expected \(5, 0, 2\)"):
        metrics.episode_metrics(person)
    metrics.episode_metrics(dataclasses.replace(person, obs_radius=np.array([0.3])))  # with its radius: fine
