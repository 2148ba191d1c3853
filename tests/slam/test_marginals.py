"""Sparse marginals: one factorisation of the pose graph against iSAM2's own queries."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from explore_rl.geometry import se2_between
from explore_rl.slam.config import PoseGraphConfig
from explore_rl.planning.em_fast import PLANAR
from explore_rl.slam.marginals import (
    DepthMarginals,
    SparseMarginals,
    information_from_jacobian,
    planar_blocks,
    unit_lower_inverse,
)
from explore_rl.slam.pose_graph import PoseGraph, key

LOOP_COV = np.diag([1e-4] * 3 + [0.05**2] * 3)


def looped_graph(seed: int = 0, laps: int = 3, per_lap: int = 40) -> PoseGraph:
    """Noisy laps of a square with loops back to the first lap (and a few spans > 1)."""
    rng = np.random.default_rng(seed)
    angles = np.linspace(0, 2 * np.pi, per_lap, endpoint=False)
    truth = np.array([[5 + 4 * np.cos(a), 5 + 4 * np.sin(a), a + np.pi / 2] for a in angles] * laps)
    graph = PoseGraph(PoseGraphConfig(), truth[0])
    for k in range(1, len(truth)):
        delta = se2_between(truth[k - 1], truth[k]) + rng.normal(0, [0.01, 0.01, 0.002])
        graph.add_keyframe(delta, 3)
        if k >= per_lap and k % 7 == 0:  # loop to the same place one lap earlier (noisy)
            relative = se2_between(truth[k - per_lap], truth[k]) + rng.normal(0, [0.02, 0.02, 0.005])
            graph.add_loop_closure(k - per_lap, k, relative, LOOP_COV, "pose_matching")
        if k % 11 == 0:  # a factor skipping a keyframe
            graph.add_loop_closure(k - 2, k, se2_between(truth[k - 2], truth[k]), LOOP_COV, "segment_matching")
    return graph


@pytest.fixture(scope="module")
def graph() -> PoseGraph:
    return looped_graph()


def isam_marginals(graph: PoseGraph) -> np.ndarray:
    return np.stack([graph.isam.marginalCovariance(key(i)) for i in range(graph.num_poses)])


def test_information_matrix_is_symmetric_positive_definite(graph):
    information = graph.information_matrix()
    assert information.shape == (6 * graph.num_poses,) * 2
    assert abs(information - information.T).max() < 1e-9 * abs(information).max()
    # sparse: a few blocks per pose, nothing like the dense joint
    assert information.nnz < 20 * 36 * graph.num_poses
    smallest = sp.linalg.eigsh(information.tocsc(), k=1, sigma=0, which="LM", return_eigenvectors=False)
    assert smallest[0] > 0


def test_diagonal_blocks_equal_isam_marginals(graph):
    expected = isam_marginals(graph)
    blocks = SparseMarginals(graph.information_matrix()).diagonal_blocks()
    scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(blocks / scale, expected / scale, rtol=0, atol=1e-8)


def test_columns_equal_isam_joint_marginals(graph):
    marginals = SparseMarginals(graph.information_matrix())
    poses = [0, 37, graph.num_poses - 1]
    cross = marginals.cross_blocks(poses)
    assert cross.shape == (graph.num_poses, 3, 6, 6)
    for other in (5, 60, graph.num_poses - 2):
        for j, pose in enumerate(poses):
            joint = graph.isam.jointMarginalCovariance([key(other), key(pose)])
            expected = joint.at(key(other), key(pose)) if other != pose else joint.at(key(pose), key(pose))
            scale = np.abs(expected).max()
            np.testing.assert_allclose(cross[other, j] / scale, expected / scale, rtol=0, atol=1e-8)


def test_selected_inverse_of_a_random_sparse_system():
    """Against the dense inverse of a small random SPD block system (tree + cycles)."""
    rng = np.random.default_rng(4)
    n = 30
    blocks = {}
    edges = [(i, i + 1) for i in range(n - 1)] + [(0, 17), (3, 25), (10, 29), (12, 20)]
    dense = np.zeros((6 * n, 6 * n))
    for i, j in edges:
        a = rng.normal(size=(12, 12))
        info = a @ a.T
        idx = np.r_[6 * i: 6 * i + 6, 6 * j: 6 * j + 6]
        dense[np.ix_(idx, idx)] += info
        blocks[(i, j)] = info
    dense += np.eye(6 * n)
    marginals = SparseMarginals(sp.csr_matrix(dense))
    inverse = np.linalg.inv(dense)
    expected = np.stack([inverse[6 * i: 6 * i + 6, 6 * i: 6 * i + 6] for i in range(n)])
    np.testing.assert_allclose(marginals.diagonal_blocks(), expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(marginals.columns([17, 3]), inverse[:, np.r_[102:108, 18:24]], rtol=1e-9, atol=1e-12)
    some = marginals.columns([17, 3], components=(2, 3, 4))  # a few tangent components of each
    np.testing.assert_allclose(some, inverse[:, [104, 105, 106, 20, 21, 22]], rtol=1e-9, atol=1e-12)


def test_bad_shape_fails_in_one_line():
    with pytest.raises(ValueError, match="6N x 6N"):
        SparseMarginals(sp.identity(7, format="csr"))


def corridor_graph(stretch: int = 70, seed: int = 1) -> PoseGraph:
    """A loop-free stretch of ``stretch`` keyframes (a corridor driven once), then a
    square lap twice with loops: minimum degree leaves the stretch as a deep chain of the
    elimination tree."""
    rng = np.random.default_rng(seed)
    corridor = [[0.3 * k, 0.0, 0.0] for k in range(stretch)]
    x0 = corridor[-1][0]
    angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    lap = [[x0 + 3 * np.sin(a), 3 - 3 * np.cos(a), a] for a in angles]
    truth = np.array(corridor + lap + lap)
    graph = PoseGraph(PoseGraphConfig(), truth[0])
    for k in range(1, len(truth)):
        graph.add_keyframe(se2_between(truth[k - 1], truth[k]) + rng.normal(0, [0.01, 0.01, 0.002]), 3)
        if k >= stretch + 24 and k % 3 == 0:
            relative = se2_between(truth[k - 24], truth[k]) + rng.normal(0, [0.02, 0.02, 0.005])
            graph.add_loop_closure(k - 24, k, relative, LOOP_COV, "pose_matching")
    return graph


def scaled(blocks: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    scale = np.abs(reference).max(axis=(1, 2), keepdims=True)
    return blocks / scale, reference / scale


@pytest.mark.parametrize("make", [looped_graph, corridor_graph])
def test_depth_marginals_equal_the_sparse_marginals_and_isam(make):
    """The learned policy's route (the information matrix from the Jacobian in blocks, the
    chains halved, the levels by depth) against :class:`SparseMarginals` and iSAM2's own
    queries: the same matrix exactly, the same diagonal blocks up to round-off of another
    elimination order, the same covariance columns."""
    graph = make()
    information = graph.information_matrix()
    linear = graph.isam.getFactorsUnsafe().linearize(graph.isam.getLinearizationPoint())
    blocks = information_from_jacobian(*linear.sparseJacobian_(), graph.num_poses)
    assert blocks.format == "bsr" and blocks.blocksize == (6, 6)
    assert abs(blocks - information).max() == 0.0
    depth, sparse = DepthMarginals(blocks), SparseMarginals(information)
    np.testing.assert_allclose(*scaled(depth.diagonal_blocks(), sparse.diagonal_blocks()), rtol=0, atol=1e-9)
    np.testing.assert_allclose(*scaled(depth.diagonal_blocks(), isam_marginals(graph)), rtol=0, atol=1e-8)
    poses = [0, graph.num_poses // 2, graph.num_poses - 1]
    columns, expected = depth.columns(poses), sparse.columns(poses)
    np.testing.assert_allclose(columns / np.abs(expected).max(), expected / np.abs(expected).max(), rtol=0,
                               atol=1e-9)


def test_a_loop_free_stretch_is_halved_into_a_shallow_tree():
    """Minimum degree eliminates the corridor keyframe after keyframe (a chain as deep as
    the corridor is long); halving it leaves a tree a few levels deep there, and the
    marginals of the stretch equal the column-at-a-time ones."""
    graph = corridor_graph(stretch=120)
    information = graph.information_matrix()
    sparse, depth = SparseMarginals(information), DepthMarginals(information)
    sparse_levels, depth_levels = len(sparse._structure().levels), len(depth._structure().levels)
    assert sparse_levels > 100 and depth_levels < sparse_levels / 3
    np.testing.assert_allclose(*scaled(depth.diagonal_blocks(), sparse.diagonal_blocks()), rtol=0, atol=1e-9)


def test_depth_marginals_of_a_random_sparse_system():
    """Against the dense inverse of a small random SPD block system with a long chain."""
    rng = np.random.default_rng(5)
    n = 40
    edges = [(i, i + 1) for i in range(n - 1)] + [(30, 39), (32, 37), (31, 35)]
    dense = np.zeros((6 * n, 6 * n))
    for i, j in edges:
        a = rng.normal(size=(12, 12))
        idx = np.r_[6 * i: 6 * i + 6, 6 * j: 6 * j + 6]
        dense[np.ix_(idx, idx)] += a @ a.T
    dense += np.eye(6 * n)
    inverse = np.linalg.inv(dense)
    expected = np.stack([inverse[6 * i: 6 * i + 6, 6 * i: 6 * i + 6] for i in range(n)])
    np.testing.assert_allclose(DepthMarginals(sp.csr_matrix(dense)).diagonal_blocks(), expected, rtol=1e-9,
                               atol=1e-12)
    with pytest.raises(ValueError, match="6N x 6N"):
        DepthMarginals(sp.identity(7, format="csr"))


@pytest.mark.parametrize("size", [1, 2, 3, 6])
def test_unit_lower_inverse_inverts_every_block(size):
    """The diagonal blocks' inverses (Horner on the nilpotent part) against ``np.linalg.inv``."""
    rng = np.random.default_rng(size)
    blocks = np.tril(rng.normal(size=(50, size, size)), -1) + np.eye(size)
    inverse = unit_lower_inverse(blocks)
    np.testing.assert_allclose(inverse, np.linalg.inv(blocks), rtol=0, atol=1e-11)
    np.testing.assert_allclose(blocks @ inverse, np.broadcast_to(np.eye(size), blocks.shape), rtol=0, atol=1e-12)


@pytest.mark.parametrize("make", [looped_graph, corridor_graph])
def test_planar_depth_marginals_equal_the_planar_part_of_the_whole_system(make):
    """A planar pose graph joins no planar component (yaw, x, y) to roll, pitch or z, so
    :func:`planar_blocks` gives its planar system, whose marginals (3x3 blocks) are the
    planar part of the 6-dof marginals and of iSAM2's own queries."""
    graph = make()
    linear = graph.isam.getFactorsUnsafe().linearize(graph.isam.getLinearizationPoint())
    blocks = information_from_jacobian(*linear.sparseJacobian_(), graph.num_poses)
    planar = planar_blocks(blocks, PLANAR)
    assert planar is not None and planar.blocksize == (3, 3) and planar.shape == (3 * graph.num_poses,) * 2
    whole = DepthMarginals(blocks).diagonal_blocks()[:, 2:5, 2:5]
    np.testing.assert_allclose(*scaled(DepthMarginals(planar, block=3).diagonal_blocks(), whole), rtol=0, atol=1e-9)
    np.testing.assert_allclose(*scaled(DepthMarginals(planar, block=3).diagonal_blocks(),
                                       isam_marginals(graph)[:, 2:5, 2:5]), rtol=0, atol=1e-8)


def test_planar_blocks_refuses_a_coupled_system_and_3_blocks_match_a_dense_inverse():
    """A block that joins x to z makes the planar part not closed (None); a random SPD
    system of 3x3 blocks gives the dense inverse's diagonal blocks."""
    rng = np.random.default_rng(7)
    n = 12
    dense = np.eye(6 * n)
    for i in range(n - 1):
        a = rng.normal(size=(12, 12))
        idx = np.r_[6 * i: 6 * i + 6, 6 * i + 6: 6 * i + 12]
        dense[np.ix_(idx, idx)] += a @ a.T  # joins every component of neighbours
    assert planar_blocks(sp.csr_matrix(dense).tobsr(blocksize=(6, 6)), PLANAR) is None
    keep = np.ravel([[6 * i + c for c in PLANAR] for i in range(n)])
    small = dense[np.ix_(keep, keep)]
    inverse = np.linalg.inv(small)
    expected = np.stack([inverse[3 * i: 3 * i + 3, 3 * i: 3 * i + 3] for i in range(n)])
    np.testing.assert_allclose(DepthMarginals(sp.csr_matrix(small), block=3).diagonal_blocks(), expected,
                               rtol=1e-9, atol=1e-12)
    with pytest.raises(ValueError, match="3N x 3N"):
        DepthMarginals(sp.identity(7, format="csr"), block=3)
