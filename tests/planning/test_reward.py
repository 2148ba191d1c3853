"""Reward of paper Algorithm 1."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.planning.reward import normalize_rewards, normalized_reward, raw_reward


def test_raw_reward():
    assert raw_reward(-100.0, -130.0, 10.0, 2.0) == pytest.approx(10.0)
    np.testing.assert_allclose(
        raw_reward(-100.0, np.array([-130.0, -110.0]), np.array([10.0, 1.0]), 2.0), [10.0, 8.0]
    )


def test_best_is_nearest_gives_r_minus_one():
    raw = np.array([5.0, 1.0, 3.0])
    nearest = 0
    assert normalized_reward(raw, chosen=0, nearest=nearest) == pytest.approx(0.0)
    assert normalized_reward(raw, chosen=1, nearest=nearest) == pytest.approx(-1.0)
    assert normalized_reward(raw, chosen=2, nearest=nearest) == pytest.approx(0.5 - 1.0)


def test_best_is_not_nearest_gives_two_r_minus_one():
    raw = np.array([5.0, 1.0, 3.0])
    nearest = 2
    assert normalized_reward(raw, chosen=0, nearest=nearest) == pytest.approx(1.0)
    assert normalized_reward(raw, chosen=1, nearest=nearest) == pytest.approx(-1.0)
    assert normalized_reward(raw, chosen=2, nearest=nearest) == pytest.approx(0.0)


def test_all_equal_every_r_is_one():
    raw = np.array([2.5, 2.5, 2.5])
    np.testing.assert_allclose(normalize_rewards(raw, nearest=1), 0.0)  # r = 1, nearest best
    assert normalized_reward(np.array([7.0]), chosen=0, nearest=0) == 0.0
    # equal up to float noise counts as equal
    np.testing.assert_allclose(normalize_rewards(raw + [0.0, 1e-13, -1e-13], nearest=0), 0.0)


def test_ranges_over_random_candidates():
    rng = np.random.default_rng(5)
    for _ in range(200):
        raw = rng.normal(0, 10, rng.integers(2, 8))
        nearest = int(rng.integers(len(raw)))
        rewards = normalize_rewards(raw, nearest)
        if np.argmax(raw) == nearest:
            assert rewards.min() == pytest.approx(-1.0) and rewards.max() == pytest.approx(0.0)
        else:
            assert rewards.min() == pytest.approx(-1.0) and rewards.max() == pytest.approx(1.0)
        # order is preserved
        assert np.array_equal(np.argsort(rewards, kind="stable"), np.argsort(raw, kind="stable"))


def test_empty_candidates_raise():
    with pytest.raises(ValueError):
        normalize_rewards(np.array([]), nearest=0)
