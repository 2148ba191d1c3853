"""3D voxel map: counts, volume, rebuild, key packing."""

import numpy as np
import pytest

from explore_rl.geometry import se2_to_matrix
from explore_rl.mapping.config import VoxelConfig
from explore_rl.mapping.voxels import VoxelMap, pack_keys, unpack_keys


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
