"""3D voxel map: counts, volume, rebuild, key packing."""

import numpy as np
import pytest

from explore_rl.geometry import se2_to_matrix
from explore_rl.mapping.config import VoxelConfig
from explore_rl.mapping.voxels import VoxelCounts, VoxelMap, pack_keys, unpack_keys


def plane_cloud(step: float = 0.01) -> np.ndarray:
    """Points on the 1 m x 1 m square [0, 1]^2 at z = 0.05, away from voxel faces."""
    u = np.arange(step / 2, 1.0, step)
    x, y = np.meshgrid(u, u)
    return np.stack([x.ravel(), y.ravel(), np.full(x.size, 0.05)], axis=-1)


def test_plane_fills_one_layer_of_voxels():
    voxels = VoxelMap(VoxelConfig(voxel_size=0.1))
    voxels.insert(plane_cloud())
    assert voxels.occupied_count == 100
    assert voxels.occupied_volume() == pytest.approx(100 * 0.1**3)


def test_insert_is_a_set_union():
    voxels = VoxelMap()
    cloud = plane_cloud()
    voxels.insert(cloud)
    voxels.insert(cloud)  # same voxels again: nothing new
    assert voxels.occupied_count == 100
    voxels.insert(cloud + [0.5, 0.0, 0.0])  # half overlaps
    assert voxels.occupied_count == 150
    voxels.insert(np.array([[np.nan, 0.0, 0.0], [0.0, np.inf, 0.0]]))  # skipped
    assert voxels.occupied_count == 150


def test_matches_a_python_set_reference_including_negative_coordinates():
    rng = np.random.default_rng(3)
    cloud = rng.uniform(-2.0, 2.0, size=(2000, 3))
    voxels = VoxelMap(VoxelConfig(voxel_size=0.25))
    voxels.insert(cloud[:1000])
    voxels.insert(cloud[1000:])
    reference = {tuple(int(np.floor(c / 0.25)) for c in p) for p in cloud}
    assert voxels.occupied_count == len(reference)
    centres = voxels.points()
    got = {tuple(int(v) for v in np.floor(c / 0.25)) for c in centres}
    assert got == reference
    np.testing.assert_allclose(np.mod(centres, 0.25), 0.125)


def test_rebuild_uses_the_new_transforms():
    cloud_sensor = plane_cloud() - [0.0, 0.0, 0.5]  # the sensor sits 0.5 m above the plane
    voxels = VoxelMap()
    voxels.rebuild([cloud_sensor], [se2_to_matrix(np.array([0.0, 0.0, 0.0]), z=0.5)])
    np.testing.assert_allclose(voxels.points()[:, 2], 0.05)
    first = voxels.points()

    moved = se2_to_matrix(np.array([2.0, 0.0, 0.0]), z=0.5)
    voxels.rebuild([cloud_sensor, cloud_sensor], [moved, moved])
    assert voxels.occupied_count == 100
    np.testing.assert_allclose(np.sort(voxels.points()[:, 0]), np.sort(first[:, 0] + 2.0))


def test_key_packing_round_trips():
    rng = np.random.default_rng(0)
    keys = rng.integers(-(2**20), 2**20, size=(500, 3))
    np.testing.assert_array_equal(unpack_keys(pack_keys(keys)), keys)
    with pytest.raises(ValueError):
        pack_keys(np.array([[2**21, 0, 0]]))


def test_incremental_inserts_keep_keys_sorted_unique_and_equal_to_union1d():
    rng = np.random.default_rng(7)
    voxels, reference = VoxelMap(VoxelConfig(voxel_size=0.1)), np.zeros(0, dtype=np.int64)
    for _ in range(30):  # overlapping clouds: some keys new, some present, some beyond the ends
        cloud = rng.normal(rng.uniform(-3.0, 3.0, 3), 0.5, size=(300, 3))
        voxels.insert(cloud)
        reference = np.union1d(reference, pack_keys(np.floor(cloud / 0.1).astype(np.int64)))
        np.testing.assert_array_equal(voxels.keys, reference)


# --- VoxelCounts (mapping.updates=incremental) against the sorted-key reference ------------


def test_counts_match_the_reference_and_removal_is_exact():
    rng = np.random.default_rng(11)
    clouds = [rng.normal(rng.uniform(-3.0, 3.0, 3), 0.6, size=(400, 3)) for _ in range(12)]
    counts, reference = VoxelCounts(VoxelConfig(voxel_size=0.1)), VoxelMap(VoxelConfig(voxel_size=0.1))
    for cloud in clouds:  # the box grows in every direction, negative keys included
        counts.insert(cloud)
        reference.insert(cloud)
        np.testing.assert_array_equal(counts.keys, reference.keys)
        assert counts.occupied_count == reference.occupied_count
    # take three clouds out again: the map of the other nine
    for i in (2, 5, 11):
        counts.remove(clouds[i])
    rest = VoxelMap(VoxelConfig(voxel_size=0.1))
    rest.insert(np.concatenate([c for i, c in enumerate(clouds) if i not in (2, 5, 11)]))
    assert rest.occupied_count < reference.occupied_count
    np.testing.assert_array_equal(counts.keys, rest.keys)
    assert counts.occupied_volume() == pytest.approx(rest.occupied_volume(), rel=1e-12)
    np.testing.assert_allclose(counts.points(), rest.points(), rtol=0, atol=1e-9)


def test_counts_skip_non_finite_points_and_refuse_removing_what_was_never_inserted():
    counts = VoxelCounts()
    counts.insert(np.array([[0.05, 0.05, 0.05], [np.nan, 0.0, 0.0], [0.0, np.inf, 0.0]]))
    assert counts.occupied_count == 1
    with pytest.raises(ValueError, match="never inserted"):
        counts.remove(np.array([[0.25, 0.05, 0.05]]))
    with pytest.raises(ValueError, match="outside"):
        counts.remove(np.array([[50.0, 0.05, 0.05]]))
    counts.remove(np.array([[0.05, 0.05, 0.05]]))
    assert counts.occupied_count == 0


def test_counts_rebuild_equals_the_reference_rebuild():
    rng = np.random.default_rng(5)
    clouds = [rng.uniform(-1.0, 1.0, size=(300, 3)) for _ in range(4)]
    transforms = [se2_to_matrix(rng.uniform(-5, 5, 3), z=0.4) for _ in clouds]
    counts, reference = VoxelCounts(), VoxelMap()
    counts.insert(rng.uniform(10, 11, size=(50, 3)))  # stale content: cleared by the rebuild
    counts.rebuild(clouds, transforms)
    reference.rebuild(clouds, transforms)
    np.testing.assert_array_equal(counts.keys, reference.keys)
