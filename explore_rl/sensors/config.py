"""Config of the lidar group (``conf/lidar/``): a plain dataclass, no runtime imports."""

from __future__ import annotations

import math
from dataclasses import dataclass

from explore_rl import checks


@dataclass
class LidarConfig:
    """VLP-16 defaults with the range capped at 3 m (paper, Sec. IV-A)."""

    channels: int = 16
    min_elevation_deg: float = -15.0
    max_elevation_deg: float = 15.0
    azimuth_resolution_deg: float = 0.4
    max_range: float = 3.0
    min_range: float = 0.1
    range_noise: float = 0.01
    mount_height: float = 0.4
    # Side (m) of the square tiles of StaticTiles; 0 casts on the full scene model. Same
    # hits either way; 3 m tiles made mj_multiRay ~20-30 % faster (benchmarks/bench_lidar.py).
    tile_size: float = 3.0

    def validate(self) -> None:
        """A scan pattern that can be cast: one line naming the key and the allowed range."""
        checks.at_least("lidar.channels", self.channels, 1)
        for key in ("min_elevation_deg", "max_elevation_deg"):
            checks.in_range(f"lidar.{key}", getattr(self, key), -90.0, 90.0)
        if not self.min_elevation_deg <= self.max_elevation_deg:
            raise ValueError(f"lidar.min_elevation_deg={self.min_elevation_deg} must not exceed "
                             f"lidar.max_elevation_deg={self.max_elevation_deg}")
        checks.in_range("lidar.azimuth_resolution_deg", self.azimuth_resolution_deg, 0.0, 360.0, low_open=True)
        checks.positive("lidar.max_range", self.max_range)
        checks.in_range("lidar.min_range", self.min_range, 0.0, self.max_range, high_open=True)
        checks.non_negative("lidar.range_noise", self.range_noise)
        checks.positive("lidar.mount_height", self.mount_height)
        if not (self.tile_size >= 0 and math.isfinite(self.tile_size)):
            raise ValueError(f"lidar.tile_size must be >= 0 (0 = cast on the full scene model), got {self.tile_size}")
