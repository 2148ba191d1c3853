"""3D voxel map: the set of occupied voxels, for the coverage-volume metric.

Voxel keys ``floor(p / voxel_size)`` are packed into one int64 each and kept as a sorted
unique array. Inserting a cloud sorts only the cloud's keys and inserts the new ones at
their ``np.searchsorted`` positions (no Python loop, and no re-sort of the whole map: on
a 144k-voxel map a 5,000-point cloud takes ~3 ms this way and ~150 ms with ``np.union1d``;
in model-mode office tours the maps stage went from 9-12 to 3-7 ms per keyframe).
Range capping and ground removal are the caller's job.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from explore_rl.geometry import transform_points
from explore_rl.mapping.config import VoxelConfig

_KEY_BITS = 21  # bits per axis in a packed key: +-2^20 voxels (~100 km at 0.1 m)
_KEY_OFFSET = 1 << (_KEY_BITS - 1)
_KEY_MASK = (1 << _KEY_BITS) - 1


def pack_keys(keys: np.ndarray) -> np.ndarray:
    """Pack integer voxel keys ``(N, 3)`` into int64 ``(N,)``."""
    shifted = np.asarray(keys, dtype=np.int64) + _KEY_OFFSET
    if shifted.size and (shifted.min() < 0 or shifted.max() > _KEY_MASK):
        raise ValueError("voxel keys out of the packable range; are the points in metres?")
    return (shifted[:, 0] << (2 * _KEY_BITS)) | (shifted[:, 1] << _KEY_BITS) | shifted[:, 2]


def unpack_keys(packed: np.ndarray) -> np.ndarray:
    """Inverse of :func:`pack_keys`."""
    packed = np.asarray(packed, dtype=np.int64)
    keys = np.stack(
        [packed >> (2 * _KEY_BITS), (packed >> _KEY_BITS) & _KEY_MASK, packed & _KEY_MASK], axis=-1
    )
    return keys - _KEY_OFFSET


class VoxelMap:
    """Occupied voxels of a world-frame point map."""

    def __init__(self, config: VoxelConfig | None = None) -> None:
        self.config = config or VoxelConfig()
        if self.config.voxel_size <= 0:
            raise ValueError(f"voxel_size must be positive, got {self.config.voxel_size}")
        self.keys = np.zeros(0, dtype=np.int64)  # sorted, unique, packed

    @property
    def voxel_size(self) -> float:
        return self.config.voxel_size

    @property
    def occupied_count(self) -> int:
        return int(self.keys.size)

    def occupied_volume(self) -> float:
        """Occupied voxel count times the voxel volume (m^3)."""
        return self.occupied_count * self.voxel_size**3

    def clear(self) -> None:
        self.keys = np.zeros(0, dtype=np.int64)

    def insert(self, points_world: np.ndarray) -> None:
        """Mark the voxels holding world points ``(N, 3)`` occupied (non-finite points skipped)."""
        points = np.asarray(points_world, dtype=float).reshape(-1, 3)
        points = points[np.isfinite(points).all(axis=1)]
        keys = np.unique(pack_keys(np.floor(points / self.voxel_size).astype(np.int64)))
        positions = np.searchsorted(self.keys, keys)
        present = np.zeros(len(keys), dtype=bool)
        inside = positions < len(self.keys)
        present[inside] = self.keys[positions[inside]] == keys[inside]
        self.keys = np.insert(self.keys, positions[~present], keys[~present])

    def rebuild(
        self, clouds_sensor: Sequence[np.ndarray], world_from_sensor: Sequence[np.ndarray]
    ) -> None:
        """Clear and re-insert every cloud at its (possibly corrected) 4x4 pose."""
        if len(clouds_sensor) != len(world_from_sensor):
            raise ValueError(f"{len(clouds_sensor)} clouds but {len(world_from_sensor)} transforms")
        self.clear()
        world = [
            transform_points(
                np.asarray(T, dtype=float), np.asarray(cloud, dtype=float).reshape(-1, 3)
            )
            for cloud, T in zip(clouds_sensor, world_from_sensor)
        ]
        if world:
            self.insert(np.concatenate(world))

    def points(self) -> np.ndarray:
        """Centres of the occupied voxels, ``(N, 3)``."""
        return (unpack_keys(self.keys) + 0.5) * self.voxel_size
