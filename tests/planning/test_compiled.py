"""The compiled loops of EM's decision (fusion, round layout, in-range pairs) against the numpy code they stand
for, exactly."""

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.planning.em import Observations
from explore_rl.planning.em_fast import FuseRounds, fuse_batched, fuse_batched_reference
from explore_rl.runner import Explorer
from tests.planning.test_em_fast import lever_observations, random_covariances


def assert_same_fusion(rounds: FuseRounds, pose_covs: np.ndarray, initial: np.ndarray) -> None:
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = fuse_batched_reference(rounds, pose_covs, initial)
    fused = fuse_batched(rounds, pose_covs, initial)
    assert fused.shape == expected.shape
    np.testing.assert_array_equal(fused, expected)


@pytest.mark.parametrize("sets", [1, 4])
def test_compiled_fusion_equals_the_rounds_on_random_observations(sets):
    rng = np.random.default_rng(5)
    count, poses, landmarks = 3000, 40, 60
    gain, noise = lever_observations(rng, count)
    observations = Observations(np.sort(rng.integers(0, poses, count)), rng.integers(0, landmarks, count),
                                gain, noise)
    rounds = FuseRounds.of(observations)
    assert len(rounds.offsets) > 30  # many rounds, uneven columns
    prior = np.repeat(0.04 * np.eye(2)[None], landmarks, axis=0)
    assert_same_fusion(rounds, random_covariances(rng, sets, poses), prior[rounds.landmarks])


def test_compiled_fusion_of_no_observations_is_empty():
    empty = Observations(np.zeros(0, int), np.zeros(0, int), np.zeros((0, 2, 3)), np.zeros((0, 2, 2)))
    rounds = FuseRounds.of(empty)
    fused = fuse_batched(rounds, np.zeros((3, 5, 3, 3)), np.zeros((0, 2, 2)))
    assert fused.shape == (3, 0, 2, 2)


def test_a_singular_observation_gives_what_numpy_gives():
    """A zero pose covariance and zero noise: determinants 0, inf and nan as in numpy, no error."""
    gain = np.zeros((3, 2, 3))
    gain[:, 0, 0] = gain[:, 1, 1] = -1.0
    observations = Observations(np.array([0, 1, 2]), np.array([0, 0, 1]), gain, np.zeros((3, 2, 2)))
    rounds = FuseRounds.of(observations)
    fused = fuse_batched(rounds, np.zeros((1, 3, 3, 3)), np.repeat(0.04 * np.eye(2)[None], 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        expected = fuse_batched_reference(rounds, np.zeros((1, 3, 3, 3)), np.repeat(0.04 * np.eye(2)[None], 2, axis=0))
    assert not np.isfinite(expected).all()
    np.testing.assert_array_equal(fused, expected)  # nan == nan here


def test_compiled_fusion_equals_the_rounds_in_em_decisions(monkeypatch):
    """Every fusion of EM's decisions in a real office episode (U0 and the loop candidates'
    sets), compiled and in numpy rounds, and every round layout, counted and sorted: the
    same floats."""
    calls = []

    def recording(rounds, pose_covs, initial):
        calls.append((rounds, pose_covs.copy(), initial.copy()))
        return fuse_batched(rounds, pose_covs, initial)

    monkeypatch.setattr("explore_rl.planning.em.fuse_batched", recording)
    layouts = []
    counted = FuseRounds.of.__func__

    def recording_layout(cls, observations):
        layouts.append(observations)
        return counted(cls, observations)

    monkeypatch.setattr(FuseRounds, "of", classmethod(recording_layout))
    config = load_config(["scene=office", "slam=model", "seed=0", "policy=em", "explore.progress_bar=false",
                          "explore.max_decisions=4"])
    Explorer(config).run()
    batched = [call for call in calls if len(call[1]) > 1]
    assert len(calls) >= 4 and batched  # U0 of each decision, and candidates' sets together
    for rounds, pose_covs, initial in calls:
        assert_same_fusion(rounds, pose_covs, initial)
    monkeypatch.undo()  # FuseRounds.of itself again, unrecorded
    assert len(layouts) >= 4
    for observations in layouts:
        assert_same_rounds(observations)


def assert_same_rounds(observations: Observations) -> None:
    rounds, expected = FuseRounds.of(observations), FuseRounds.of_reference(observations)
    for name in ("offsets", "landmarks", "pose_idx", "terms"):
        got, want = getattr(rounds, name), getattr(expected, name)
        assert got.shape == want.shape, name
        np.testing.assert_array_equal(got, want, err_msg=name)


def test_counted_rounds_equal_the_sorted_rounds():
    """Random observations (ties in the counts, unseen landmark ids between seen ones) and none."""
    rng = np.random.default_rng(6)
    for count in (0, 1, 7, 3000):
        gain, noise = lever_observations(rng, count)
        assert_same_rounds(Observations(np.sort(rng.integers(0, 40, count)), rng.integers(0, 90, count),
                                        gain, noise))


def test_window_pairs_equal_the_numpy_window():
    """Poses inside, on cell edges, near and beyond the grid's borders: the same pairs, in order."""
    from explore_rl.grid import GridSpec
    from explore_rl.planning.config import VirtualMapConfig
    from explore_rl.planning.virtual_map import VirtualMap

    grid = GridSpec(origin=(-1.0, -2.0), resolution=0.05, shape=(160, 200))
    vmap = VirtualMap(grid, VirtualMapConfig())
    rng = np.random.default_rng(7)
    poses = np.column_stack([rng.uniform(-4.0, 12.0, 400), rng.uniform(-5.0, 9.0, 400), rng.uniform(-3, 3, 400)])
    poses[:20, :2] = np.round(poses[:20, :2] / 0.5) * 0.5  # on landmark cell edges
    got, want = vmap.in_range_pairs(poses), vmap.in_range_pairs_reference(poses)
    assert 1000 < len(want[0]) and len(np.unique(want[0])) < len(poses)  # pairs found; some poses see none
    for a, b in zip(got, want):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    empty = vmap.in_range_pairs(np.zeros((0, 3)))
    assert empty[0].shape == empty[1].shape == (0,)
