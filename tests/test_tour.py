"""The scripted tour keeps its own path settings when the exploration's change."""

from __future__ import annotations

from explore_rl.config import load_config
from explore_rl.tour import tour_paths


def test_tour_paths_take_the_tours_margin_and_costs_not_the_explorations():
    config = load_config(["mapping.paths.clearance_weight=7", "mapping.paths.clearance_scale=0.05",
                          "mapping.paths.start_snap_radius=0.4"])
    paths = tour_paths(config)
    assert paths.inflation_margin == config.tour.inflation_margin != config.mapping.paths.inflation_margin
    assert (paths.clearance_weight, paths.clearance_scale) == (config.tour.clearance_weight,
                                                               config.tour.clearance_scale) == (1.0, 0.3)
    assert paths.start_snap_radius == 0.4  # everything else is the exploration's
