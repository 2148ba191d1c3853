"""Planar transforms: the scalar single-pose paths against the vectorised ones."""

import math

import numpy as np

from explore_rl.geometry import se2_between, se2_between_tuple, se2_compose, se2_compose_tuple, wrap_angle


def _poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-20, 20, n), rng.uniform(-20, 20, n), rng.uniform(-9, 9, n)])


def test_single_pose_compose_and_between_match_the_stacked_code():
    a, b = _poses(500, 0), _poses(500, 1)
    stacked_compose, stacked_between = se2_compose(a, b), se2_between(a, b)
    for i in range(len(a)):
        np.testing.assert_allclose(se2_compose(a[i], b[i]), stacked_compose[i], rtol=0, atol=1e-12)
        np.testing.assert_allclose(se2_between(a[i], b[i]), stacked_between[i], rtol=0, atol=1e-12)


def test_single_pose_results_are_wrapped_and_invert_each_other():
    a, b = _poses(200, 2), _poses(200, 3)
    for i in range(len(a)):
        motion = se2_between(a[i], b[i])
        assert -math.pi <= motion[2] < math.pi
        back = se2_compose(a[i], motion)
        np.testing.assert_allclose(back[:2], b[i, :2], atol=1e-9)
        assert abs(float(wrap_angle(back[2] - b[i, 2]))) < 1e-9


def test_single_pose_paths_return_new_float_arrays():
    a, b = np.array([1, 2, 0]), np.array([0.5, 0.0, math.pi / 2])  # an integer pose too
    out = se2_compose(a, b)
    assert out.dtype == np.float64 and out.shape == (3,)
    np.testing.assert_allclose(out, [1.5, 2.0, math.pi / 2], atol=1e-12)
    out[0] = 99.0
    assert a[0] == 1 and b[0] == 0.5
    np.testing.assert_allclose(se2_compose((1.0, 2.0, 0.0), (0.5, 0.0, 0.0)), [1.5, 2.0, 0.0])


def test_tuple_helpers_are_the_single_pose_paths():
    a, b = _poses(50, 4), _poses(50, 5)
    for i in range(len(a)):
        assert se2_compose_tuple(tuple(a[i]), tuple(b[i])) == tuple(se2_compose(a[i], b[i]))
        assert se2_between_tuple(tuple(a[i]), tuple(b[i])) == tuple(se2_between(a[i], b[i]))
