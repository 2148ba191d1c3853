"""Every keyframe's marginal covariance from one sparse factorisation of the pose graph.

iSAM2 answers one ``marginalCovariance`` query at a time (~50-150 µs each on office
graphs); a planner that needs all of them, for many hypothetical graphs, pays that per
pose per graph. Here the live graph's linearised system (its information matrix ``H``,
``6N x 6N`` in gtsam's Pose3 tangent order, at iSAM2's linearisation point, so the
marginals equal ``isam.marginalCovariance`` up to round-off) is factorised once with
``scipy.sparse.linalg.splu`` and then gives

* every 6x6 diagonal block of ``H^-1`` at once (:meth:`SparseMarginals.diagonal_blocks`):
  Takahashi's selected inversion on the 6x6-block sparsity pattern of the Cholesky-like
  factor, vectorised over the levels of the block elimination tree -- never the dense
  joint of all poses (DESIGN.md);
* a few covariance columns ``H^-1 E_r`` by sparse solves (:meth:`SparseMarginals.columns`),
  what a low-rank update for a few extra factors needs.

The block ordering is a minimum-degree ordering of the pose adjacency (SuperLU's
``MMD_AT_PLUS_A`` on the block pattern); with the matrix permuted blockwise, SuperLU
factorises it in that order without pivoting (``diag_pivot_thresh=0``, symmetric mode),
so ``L`` is unit lower triangular, ``U = D L^T`` and the 6 scalars of a pose stay together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

BLOCK = 6  # Pose3 tangent dimension
# Block updates of one elimination-tree level from which the solve scatters by a sparse
# matrix product (~0.15 ms to build, then ~10x faster than ``np.subtract.at`` on big levels).
SPARSE_SCATTER = 64


def _splu(matrix: sp.csc_matrix, ordering: str, relax: int | None = None) -> spla.SuperLU:
    """LU without pivoting (symmetric positive definite input) in ``ordering``; ``relax``:
    SuperLU's supernode relaxation (the block size for a block system: its columns come in
    blocks; ~40 % faster than the default on office graphs)."""
    return spla.splu(matrix, permc_spec=ordering, diag_pivot_thresh=0.0, relax=relax,
                     options={"SymmetricMode": True})


def block_ordering(information: sp.csr_matrix, num_blocks: int) -> np.ndarray:
    """``order[k]`` = the pose eliminated k-th: minimum degree on the pose adjacency."""
    block = information.shape[0] // num_blocks
    blocks = sp.csr_matrix(information).tobsr(blocksize=(block, block))
    pattern = sp.csr_matrix((np.ones(len(blocks.indices)), blocks.indices, blocks.indptr),
                            shape=(num_blocks, num_blocks))
    pattern = (pattern + sp.identity(num_blocks, format="csr") * num_blocks).tocsc()
    lu = _splu(pattern, "MMD_AT_PLUS_A")
    return np.argsort(lu.perm_c)


def scalar_indices(blocks: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """Scalar rows of the ``block``-blocks ``blocks`` (in the given order)."""
    return (block * np.asarray(blocks)[:, None] + np.arange(block)).ravel()


@dataclass
class _Level:
    """The block columns of one level of the elimination tree, padded to one width."""

    columns: np.ndarray  # (C,) block columns (factor order)
    rows: np.ndarray  # (C, S) block rows below the diagonal, padded with -1
    l_ids: np.ndarray  # (C, S) ids of the blocks L[row, col] in ``factor_blocks`` (pad: the zero block)
    pair_ids: np.ndarray  # (C, S, S) ids of Z[row_a, row_b] (lower block stored; pad: zero block)
    pair_transposed: np.ndarray  # (C, S, S) the stored block is Z[row_b, row_a]: transpose it
    diag_ids: np.ndarray  # (C,) ids of the diagonal blocks
    scatter: sp.csr_matrix | None = None  # (U, V) sums the V valid slots into their U rows (built on use)
    scatter_rows: np.ndarray | None = None  # (U,) those rows, ascending


    def scatter_matrix(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """The ``(U, V)`` 0/1 matrix summing this level's ``V`` valid block updates into
        their ``U`` distinct rows, and those rows (built once)."""
        if self.scatter is None:
            flat = self.rows[self.rows >= 0]
            order = np.argsort(flat, kind="stable")
            self.scatter_rows, starts = np.unique(flat[order], return_index=True)
            self.scatter = sp.csr_matrix((np.ones(len(flat)), order, np.r_[starts, len(flat)]),
                                         shape=(len(self.scatter_rows), len(flat)))
        return self.scatter, self.scatter_rows


@dataclass
class _Factor:
    """``H = L D L^T`` in 6x6 blocks (factor order) and its elimination-tree levels."""

    blocks: np.ndarray  # (nnz blocks + 1, 6, 6) L[row, col] per stored block; the last is zero
    lcc_inv: np.ndarray  # (N, 6, 6) inverses of the (unit lower) diagonal blocks
    d_inv: np.ndarray  # (N, 6) 1 / D
    diag_ids: np.ndarray  # (N,) stored id of each diagonal block
    levels: list[_Level]  # root first; one entry per (depth, padded width)


class SparseMarginals:
    """Marginal covariances of a linear Gaussian system ``H x = b`` over ``block``-vectors
    (6: Pose3 tangents; 3: their planar part when nothing couples it to the rest).

    ``information`` is ``H`` (``bN x bN``, symmetric positive definite, variables in
    pose order). Factorised once at construction.
    """

    block = BLOCK  # scalars per variable (set per instance at construction)

    def __init__(self, information: sp.spmatrix, block: int = BLOCK) -> None:
        information = sp.csr_matrix(information)
        size = information.shape[0]
        self.block = block
        if information.shape != (size, size) or size % block:
            raise ValueError(f"information matrix must be square {block}N x {block}N, got {information.shape}")
        self.num_blocks = size // block
        self.order = block_ordering(information, self.num_blocks)  # factor position -> pose
        self.position = np.argsort(self.order)  # pose -> factor position
        scalar = scalar_indices(self.order, block)
        permuted = information[scalar][:, scalar].tobsr(blocksize=(block, block)).tocsc()
        self.lu = _splu(permuted, "NATURAL", relax=block)
        identity = np.arange(size)
        if not (np.array_equal(self.lu.perm_c, identity) and np.array_equal(self.lu.perm_r, identity)):
            raise RuntimeError("SuperLU reordered the block-permuted system; cannot read block marginals")
        self._columns: dict[tuple, np.ndarray] = {}  # (pose, components) -> (6N, c)
        self._diagonal: np.ndarray | None = None
        self._factor: _Factor | None = None

    # ------------------------------------------------------------- columns

    def columns(self, poses, components=None) -> np.ndarray:
        """``(bN, c k)``: the covariance columns of the ``components`` (``c`` of the ``b``
        per block; default all) of each of ``poses`` (pose order rows), cached."""
        block = self.block
        components = tuple(range(block)) if components is None else tuple(int(c) for c in components)
        width = len(components)
        poses = [int(p) for p in np.atleast_1d(poses)]
        missing = [p for p in dict.fromkeys(poses) if (p, components) not in self._columns]
        if missing:
            rhs = np.zeros((self.num_blocks, block, width * len(missing)))
            for k, pose in enumerate(missing):
                rhs[self.position[pose], list(components), width * k + np.arange(width)] = 1.0
            solved = self.solve(rhs)[self.position].reshape(block * self.num_blocks, -1)
            for k, pose in enumerate(missing):
                self._columns[(pose, components)] = solved[:, width * k: width * (k + 1)]
        if not poses:
            return np.zeros((block * self.num_blocks, 0))
        return np.hstack([self._columns[(p, components)] for p in poses])

    def cross_blocks(self, poses) -> np.ndarray:
        """``(N, k, 6, 6)``: block ``[i, j]`` is ``Cov(x_i, x_{poses[j]})``."""
        cols = self.columns(poses)
        return cols.reshape(self.num_blocks, self.block, -1, self.block).transpose(0, 2, 1, 3)

    # ------------------------------------------------------------- diagonal

    def diagonal_blocks(self) -> np.ndarray:
        """``(N, 6, 6)`` marginal covariance of every pose (selected inversion), cached."""
        if self._diagonal is None:
            self._diagonal = self._selected_inverse()
        return self._diagonal.copy()

    def _selected_inverse(self) -> np.ndarray:
        """Takahashi's recurrences on the block pattern of ``L`` (factor order), a level of
        the block elimination tree at a time, root first:

        ``Z[S, c] = -Z[S, S] L[S, c] L[c, c]^-1`` and
        ``Z[c, c] = (L[c, c]^-T D_c^-1 - Z[S, c]^T L[S, c]) L[c, c]^-1``,
        with ``S`` the block rows below the diagonal of column ``c`` (a clique of the
        filled graph, so every ``Z[S, S]`` it needs is on the pattern and already known).
        """
        f = self._structure()
        z = np.zeros_like(f.blocks)
        for lv in f.levels:
            self._solve_columns(lv, f.blocks, f.lcc_inv, f.d_inv, z)
        return z[f.diag_ids[self.position]]

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``H^-1 rhs`` for ``rhs (N, 6, k)`` in factor order (block ``c`` = pose
        ``order[c]``): forward substitution a level at a time from the deepest (a level's
        columns are final once their descendants have updated them), the diagonal, then
        back substitution from the root. Vectorised like the selected inversion (SuperLU's
        own solve costs ~2 ms per right-hand side here)."""
        f = self._structure()
        n = self.num_blocks
        work = np.concatenate([np.asarray(rhs, float), np.zeros((1,) + rhs.shape[1:])])  # row n: padding
        for lv in reversed(f.levels):  # L y = b
            y = f.lcc_inv[lv.columns] @ work[lv.columns]
            work[lv.columns] = y
            valid = lv.rows >= 0
            update = f.blocks[lv.l_ids[valid]] @ np.repeat(y, valid.sum(axis=1), axis=0)
            if len(update) >= SPARSE_SCATTER:  # rows shared by several columns: a sparse sum beats ufunc.at
                scatter, rows = lv.scatter_matrix()
                work[rows] -= (scatter @ update.reshape(len(update), -1)).reshape(len(rows), *work.shape[1:])
            else:
                np.subtract.at(work, lv.rows[valid], update)
        work[:n] *= f.d_inv[:, :, None]  # D z = y
        for lv in f.levels:  # L^T x = z
            l_sc = np.swapaxes(f.blocks[lv.l_ids], -1, -2)  # (C, S, 6, 6): L[a, c]^T
            gathered = (l_sc @ work[lv.rows]).sum(axis=1)  # padding rows are zero
            work[lv.columns] = np.swapaxes(f.lcc_inv[lv.columns], 1, 2) @ (work[lv.columns] - gathered)
        return work[:n]

    def _structure(self) -> _Factor:
        """The block factor ``L D L^T`` and its elimination-tree levels (built once)."""
        if self._factor is None:
            self._factor = self._block_factor()
        return self._factor

    def _block_factor(self) -> _Factor:
        n = self.num_blocks
        block = self.block
        by_column = self.lu.L.T.tocsr().tobsr(blocksize=(block, block))  # row c of L^T = column c of L
        by_column.sort_indices()
        indptr, indices = by_column.indptr, by_column.indices
        # stored block k = L[indices[k], column of k]^T (row block of L^T); Z shares the ids
        blocks = np.concatenate([np.swapaxes(by_column.data, 1, 2), np.zeros((1, block, block))])
        zero_id = len(indices)
        column_of = np.repeat(np.arange(n), np.diff(indptr))
        keys = column_of.astype(np.int64) * n + indices  # sorted: column-major, rows ascending
        d_inv = 1.0 / self.lu.U.diagonal().reshape(n, block)
        diag_ids = indptr[:-1]  # first stored block of each column is its diagonal
        if not np.array_equal(indices[diag_ids], np.arange(n)):
            raise RuntimeError("factor without a full block diagonal")
        parent = np.full(n, -1)
        has_below = np.diff(indptr) > 1
        parent[has_below] = indices[diag_ids[has_below] + 1]
        depth = np.zeros(n, dtype=int)
        for c in range(n - 1, -1, -1):  # parents come after their children
            if parent[c] >= 0:
                depth[c] = depth[parent[c]] + 1
        below = np.diff(indptr) - 1
        width_class = np.ceil(np.log2(np.maximum(below, 1))).astype(int)  # pad within a power of two
        group = depth * (int(width_class.max()) + 1) + width_class  # root first, then by width
        order = np.argsort(group, kind="stable")
        bounds = np.flatnonzero(np.diff(group[order])) + 1
        levels = [self._level(columns, indptr, indices, keys, zero_id, n) for columns in np.split(order, bounds)]
        return _Factor(blocks, np.linalg.inv(blocks[diag_ids]), d_inv, diag_ids, levels)

    @staticmethod
    def _solve_columns(lv: _Level, factor_blocks: np.ndarray, lcc_inv: np.ndarray, d_inv: np.ndarray,
                       z: np.ndarray) -> None:
        """Takahashi's two recurrences for the block columns of ``lv`` (in place in ``z``)."""
        c = lv.columns
        count, width = lv.rows.shape
        block = factor_blocks.shape[-1]
        l_sc = factor_blocks[lv.l_ids].reshape(count, width * block, block)  # (C, bS, b)
        z_ss = z[lv.pair_ids]  # (C, S, S, 6, 6)
        z_ss[lv.pair_transposed] = np.swapaxes(z_ss[lv.pair_transposed], -1, -2)
        z_ss = z_ss.transpose(0, 1, 3, 2, 4).reshape(count, width * block, width * block)
        z_sc = -(z_ss @ l_sc) @ lcc_inv[c]  # (C, 6S, 6)
        first = np.swapaxes(lcc_inv[c], 1, 2) * d_inv[c][:, None, :]
        z_cc = (first - np.swapaxes(z_sc, 1, 2) @ l_sc) @ lcc_inv[c]
        z[lv.diag_ids] = 0.5 * (z_cc + np.swapaxes(z_cc, 1, 2))
        valid = lv.rows >= 0
        z[lv.l_ids[valid]] = z_sc.reshape(count, width, block, block)[valid]

    @staticmethod
    def _level(columns, indptr, indices, keys, zero_id, n) -> _Level:
        """Padded index arrays for the block columns ``columns`` of one level."""
        counts = np.diff(indptr)[columns] - 1  # below-diagonal blocks
        width = max(int(counts.max()), 1) if len(columns) else 1
        slot = np.arange(width)
        valid = slot[None, :] < counts[:, None]
        ids = np.where(valid, indptr[columns][:, None] + 1 + slot[None, :], zero_id)
        rows = np.where(valid, indices[np.minimum(ids, len(indices) - 1)], -1)
        a, b = rows[:, :, None], rows[:, None, :]
        pair_valid = valid[:, :, None] & valid[:, None, :]
        high, low = np.maximum(a, b), np.minimum(a, b)
        pair_keys = np.where(pair_valid, low.astype(np.int64) * n + high, -1)
        found = np.searchsorted(keys, pair_keys)
        found = np.minimum(found, len(keys) - 1)
        ok = pair_valid & (keys[found] == pair_keys)
        if not np.array_equal(ok, pair_valid):
            raise RuntimeError("block pattern of the factor is not closed (selected inversion)")
        pair_ids = np.where(ok, found, zero_id)
        return _Level(columns, rows, ids, pair_ids, a < b, indptr[columns])
