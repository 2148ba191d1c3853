"""Radix-pass stable sorts against numpy's own stable sort and ``np.unique``."""

import numpy as np
import pytest

from explore_rl.sorting import RADIX_FROM, stable_argsort, unique_first_inverse


TOPS = [7, 40_000, 1 << 16, (1 << 31) - 1]
CASES = [(dtype, top) for dtype in (np.int64, np.int32, np.uint32, np.uint16) for top in TOPS
         if top <= np.iinfo(dtype).max]


@pytest.mark.parametrize(("dtype", "top"), CASES)
def test_stable_argsort_is_numpys_stable_permutation(dtype, top):
    """Keys with many ties (the order among equal keys is what a stable sort fixes), below
    one 16-bit digit, at its edge and above it (two passes), of several integer types."""
    rng = np.random.default_rng(top % 97)
    keys = rng.integers(0, top + 1, size=5 * RADIX_FROM).astype(dtype)
    keys[: RADIX_FROM] = keys[RADIX_FROM: 2 * RADIX_FROM]  # many ties
    np.testing.assert_array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))


@pytest.mark.parametrize("keys", [
    np.array([3, -1, 2, -1, 0] * RADIX_FROM),  # negative: numpy's sort
    np.array([1 << 33, 5, 1 << 33, 0] * RADIX_FROM, dtype=np.int64),  # beyond two digits: numpy's sort
    np.array([0.5, 0.25, 0.5] * RADIX_FROM),  # not integers: numpy's sort
    np.array([4, 1, 4, 0]),  # few keys: numpy's sort
    np.zeros(0, dtype=np.int64),
])
def test_stable_argsort_falls_back_to_numpy_where_radix_does_not_apply(keys):
    np.testing.assert_array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))


@pytest.mark.parametrize("size", [0, 1, 10, 3 * RADIX_FROM])
def test_unique_first_inverse_is_np_unique(size):
    keys = np.random.default_rng(size).integers(0, 100_000, size=size) // 7 * 7  # ties
    got = unique_first_inverse(keys)
    expected = np.unique(keys, return_index=True, return_inverse=True)
    for mine, numpys in zip(got, expected):
        np.testing.assert_array_equal(mine, numpys.reshape(-1))
    assert got[1].dtype == expected[1].dtype and got[2].dtype == expected[2].dtype
