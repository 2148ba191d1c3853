"""Scalar sampling helpers of the fitted noise models agree with their numpy references."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.slam.calibration import Mixture, interpolate


def test_interpolate_equals_numpy_interp_including_the_clamped_ends():
    rng = np.random.default_rng(0)
    xs = tuple(np.sort(rng.uniform(0.0, 1.0, 9)))
    ys = tuple(rng.normal(size=9))
    for x in np.concatenate([rng.uniform(-0.2, 1.2, 500), xs]):
        assert interpolate(float(x), xs, ys) == pytest.approx(np.interp(x, xs, ys), rel=1e-12, abs=1e-15)
    assert isinstance(interpolate(0.5, xs, ys), float)


def test_sample_pair_draws_what_sample_of_two_draws():
    mixture = Mixture(core_sigma=0.01, tail_sigma=0.2, tail_fraction=0.3)
    for seed in range(20):
        pair = mixture.sample_pair(np.random.default_rng(seed))
        np.testing.assert_array_equal(pair, mixture.sample(np.random.default_rng(seed), 2))
