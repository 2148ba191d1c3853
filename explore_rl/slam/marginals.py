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


def _splu(matrix: sp.csc_matrix, ordering: str, relax: int | None = None,
          panel_size: int | None = None) -> spla.SuperLU:
    """LU without pivoting (symmetric positive definite input) in ``ordering``; ``relax``:
    SuperLU's supernode relaxation (the block size for a block system: its columns come in
    blocks; ~40 % faster than the default on office graphs); ``panel_size``: its panel
    width (the block size too: ~10 % faster again on the icp graphs of bench_decision_real)."""
    return spla.splu(matrix, permc_spec=ordering, diag_pivot_thresh=0.0, relax=relax, panel_size=panel_size,
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


def _num_blocks(information: sp.spmatrix, block: int) -> int:
    """``N`` of a square ``bN x bN`` system (else a one-line error)."""
    size = information.shape[0]
    if information.shape != (size, size) or size % block:
        raise ValueError(f"information matrix must be square {block}N x {block}N, got {information.shape}")
    return size // block


def _unpivoted(lu: spla.SuperLU) -> spla.SuperLU:
    """``lu``, checked to keep the given order (the block marginals are read in it)."""
    identity = np.arange(lu.shape[0])
    if not (np.array_equal(lu.perm_c, identity) and np.array_equal(lu.perm_r, identity)):
        raise RuntimeError("SuperLU reordered the block-permuted system; cannot read block marginals")
    return lu


def _factor_by_column(lu: spla.SuperLU, n: int, block: int) -> tuple[np.ndarray, ...]:
    """The block factor column by column: ``indptr``, ``indices`` (rows ascending, the
    diagonal first), the stored blocks (block ``k`` = ``L[indices[k], column of k]^T``, a
    zero block appended for padding; Z shares the ids), the diagonal ids and ``D^-1``."""
    by_column = lu.L.T.tocsr().tobsr(blocksize=(block, block))  # row c of L^T = column c of L
    by_column.sort_indices()
    indptr, indices = by_column.indptr, by_column.indices
    blocks = np.concatenate([np.swapaxes(by_column.data, 1, 2), np.zeros((1, block, block))])
    diag_ids = indptr[:-1]  # first stored block of each column is its diagonal
    if not np.array_equal(indices[diag_ids], np.arange(n)):
        raise RuntimeError("factor without a full block diagonal")
    return indptr, indices, blocks, diag_ids, 1.0 / lu.U.diagonal().reshape(n, block)


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

    def __init__(self, information: sp.spmatrix, block: int = BLOCK) -> None:
        information = sp.csr_matrix(information)
        self.block, self.num_blocks = block, _num_blocks(information, block)
        self.order = block_ordering(information, self.num_blocks)  # factor position -> pose
        self.position = np.argsort(self.order)  # pose -> factor position
        scalar = scalar_indices(self.order, block)
        permuted = information[scalar][:, scalar].tobsr(blocksize=(block, block)).tocsc()
        self.lu = _unpivoted(_splu(permuted, "NATURAL", relax=block))
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
        indptr, indices, blocks, diag_ids, d_inv = _factor_by_column(self.lu, n, self.block)
        zero_id = len(indices)
        column_of = np.repeat(np.arange(n), np.diff(indptr))
        keys = column_of.astype(np.int64) * n + indices  # sorted: column-major, rows ascending
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



# ---------------------------------------------------------------------- levels by depth


CHAIN_HALVING_MIN = 4  # elimination-tree chains at least this long are eliminated by halving


class DepthMarginals(SparseMarginals):
    """:class:`SparseMarginals` with the elimination-tree levels built in one vectorised
    pass and grouped by depth alone (the base class pads within powers of two of the
    width, so a pose graph's ~80-deep tree gives ~160 levels, each built by its own
    ~20 numpy calls). A pose graph's columns have at most a few blocks below the
    diagonal, so padding a depth to its widest column costs less than the extra levels.
    The same recurrences on the same factor (equal up to round-off; tests/slam/test_marginals.py),
    for a decision that needs every keyframe's marginal once (the learned policy). The
    matrix is permuted block by block (one BSR conversion, no scalar fancy indexing):
    the same ordering and the same permuted matrix for SuperLU."""

    def __init__(self, information: sp.spmatrix, block: int = BLOCK) -> None:
        """``information``: any sparse ``H`` of ``block``-scalar variables; in
        ``block x block`` BSR (:func:`information_from_jacobian`, :func:`planar_blocks`)
        it is used as it is."""
        self.block, self.num_blocks = block, _num_blocks(information, block)
        if information.format == "bsr" and information.blocksize == (block, block):
            blocks = information.copy()
        else:
            blocks = sp.csr_matrix(information).tobsr(blocksize=(block, block))
        blocks.sort_indices()
        self.order = _chains_halved(_splu(_block_pattern(blocks), "MMD_AT_PLUS_A"))
        self.position = np.argsort(self.order)
        self.lu = _unpivoted(_splu(_permuted_blocks(blocks, self.position), "NATURAL", relax=block, panel_size=block))
        self._columns, self._diagonal, self._factor = {}, None, None

    def _block_factor(self) -> _Factor:
        n = self.num_blocks
        indptr, indices, blocks, diag_ids, d_inv = _factor_by_column(self.lu, n, self.block)
        columns = _depth_columns(indptr, indices, n)
        levels = [_Level(c, *columns.of(c)) for c in columns.levels()]
        return _Factor(blocks, unit_lower_inverse(blocks[diag_ids]), d_inv, diag_ids, levels)


def unit_lower_inverse(blocks: np.ndarray) -> np.ndarray:
    """Inverses of unit lower triangular matrices ``(N, b, b)`` (the diagonal blocks of
    ``L``): with ``S = I - T`` strictly lower, hence nilpotent (``S^b = 0``), ``T^-1 =
    I + S + ... + S^(b-1)``, by Horner's rule in ``b - 1`` batched products -- about a third
    of ``np.linalg.inv``'s batched LU on 6x6 blocks (equal up to round-off)."""
    identity = np.eye(blocks.shape[-1])
    strict = identity - blocks
    inverse = identity + strict
    for _ in range(blocks.shape[-1] - 2):
        inverse = identity + strict @ inverse
    return inverse


@dataclass
class _Columns:
    """Every block column's rows below the diagonal and the ids the recurrences read,
    padded to the widest column, and its depth in the elimination tree."""

    rows: np.ndarray  # (N, W) block rows below the diagonal, padded with -1
    l_ids: np.ndarray  # (N, W) ids of L[row, col] (pad: the zero block)
    pair_ids: np.ndarray  # (N, W, W) ids of the stored Z[row_a, row_b] (pad: the zero block)
    pair_transposed: np.ndarray  # (N, W, W) the stored block is Z[row_b, row_a]
    diag_ids: np.ndarray  # (N,)
    width: np.ndarray  # (N,) blocks below the diagonal
    depth: np.ndarray  # (N,) root 0

    def levels(self) -> list[np.ndarray]:
        """The columns of each depth, root first."""
        order = np.argsort(self.depth, kind="stable")
        return np.split(order, np.flatnonzero(np.diff(self.depth[order])) + 1)

    def of(self, columns: np.ndarray) -> tuple[np.ndarray, ...]:
        """``_Level`` fields (after ``columns``) of ``columns``, trimmed to their widest."""
        s = max(int(self.width[columns].max()), 1)
        return (self.rows[columns, :s], self.l_ids[columns, :s], self.pair_ids[columns, :s, :s],
                self.pair_transposed[columns, :s, :s], self.diag_ids[columns])


def _depth_columns(indptr: np.ndarray, indices: np.ndarray, n: int) -> _Columns:
    """:class:`_Columns` of the block factor stored column by column (``indptr``,
    ``indices``: rows ascending, the diagonal first); the pairs of rows looked up once,
    only the ones a column has."""
    zero_id = len(indices)
    width = np.diff(indptr) - 1
    w = max(int(width.max()), 1)
    slot = np.arange(w)
    valid = slot[None, :] < width[:, None]
    l_ids = np.where(valid, indptr[:-1, None] + 1 + slot[None, :], zero_id)
    rows = np.where(valid, indices[np.minimum(l_ids, zero_id - 1)], -1)
    # the (a, b) row pairs of every column, flat: column c has width[c]^2 of them
    squares = width.astype(np.int64) ** 2
    column = np.repeat(np.arange(n), squares)
    within = np.arange(int(squares.sum())) - np.repeat(np.cumsum(squares) - squares, squares)
    i, j = within // width[column], within % width[column]
    a, b = rows[column, i], rows[column, j]
    keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * n + indices  # sorted
    wanted = np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)
    found = np.minimum(np.searchsorted(keys, wanted), zero_id - 1)
    if not np.array_equal(keys[found], wanted):
        raise RuntimeError("block pattern of the factor is not closed (selected inversion)")
    pair_ids = np.full((n, w, w), zero_id)
    pair_ids[column, i, j] = found
    pair_transposed = rows[:, :, None] < rows[:, None, :]
    parent = np.where(width > 0, rows[:, 0], -1)
    depth = np.zeros(n, dtype=np.int64)
    for c in range(n - 1, -1, -1):  # parents come after their children
        if parent[c] >= 0:
            depth[c] = depth[parent[c]] + 1
    return _Columns(rows, l_ids, pair_ids, pair_transposed, indptr[:-1], width, depth)


def _block_pattern(blocks: sp.bsr_matrix) -> sp.csc_matrix:
    """The pose-level matrix :func:`block_ordering` orders: a one per stored block, ``N``
    on the diagonal."""
    n = blocks.shape[0] // blocks.blocksize[0]
    pattern = sp.csr_matrix((np.ones(len(blocks.indices)), blocks.indices, blocks.indptr), shape=(n, n))
    return (pattern + sp.identity(n, format="csr") * n).tocsc()


def _permuted_blocks(blocks: sp.bsr_matrix, position: np.ndarray) -> sp.csc_matrix:
    """The scalar matrix with block ``(i, j)`` of ``blocks`` moved to ``(position[i], position[j])``."""
    n = len(position)
    rows = position[np.repeat(np.arange(n), np.diff(blocks.indptr))]
    cols = position[blocks.indices]
    order = np.lexsort((cols, rows))
    indptr = np.searchsorted(rows[order], np.arange(n + 1))
    return sp.bsr_matrix((blocks.data[order], cols[order], indptr), shape=blocks.shape).tocsc()


def information_from_jacobian(rows: np.ndarray, cols: np.ndarray, values: np.ndarray,
                              num_blocks: int) -> sp.bsr_matrix:
    """``H = A^T A`` (``6N x 6N``, 6x6 BSR) of a whitened Jacobian given as gtsam's
    ``sparseJacobian_`` triplets (1-based; the last column is ``b``, dropped) -- the
    entries of ``PoseGraph.information_matrix`` (same products, same sums), formed block
    by block: the BSR product and its blocks for :class:`DepthMarginals` cost about half
    the scalar product and its conversion."""
    size = BLOCK * num_blocks
    rows, cols = rows.astype(np.int64) - 1, cols.astype(np.int64) - 1
    keep = cols < size
    height = BLOCK * -(-(int(rows.max()) + 1) // BLOCK) if len(rows) else BLOCK  # whole 6-row blocks
    jacobian = sp.csr_matrix((values[keep], (rows[keep], cols[keep])), shape=(height, size))
    jacobian = jacobian.tobsr(blocksize=(BLOCK, BLOCK))
    return (jacobian.T @ jacobian).tobsr(blocksize=(BLOCK, BLOCK))


def planar_blocks(information: sp.bsr_matrix, planar: tuple[int, ...]) -> sp.bsr_matrix | None:
    """The ``planar`` components of every 6x6 block of ``information`` (6x6 BSR) as a
    ``len(planar)``-block BSR matrix, or None when some block joins a planar component to
    another one (then the planar marginals need the whole system). When nothing joins
    them, the planar part's inverse is the planar part of the inverse: the same marginals
    from a system of half the size."""
    others = [c for c in range(BLOCK) if c not in planar]
    rows = information.data[:, list(planar)]
    if np.any(rows[:, :, others]) or np.any(information.data[:, others][:, :, list(planar)]):
        return None
    data = np.ascontiguousarray(rows[:, :, list(planar)])
    size = len(planar) * (information.shape[0] // BLOCK)
    return sp.bsr_matrix((data, information.indices, information.indptr), shape=(size, size))


def _chains_halved(pattern_lu: spla.SuperLU) -> np.ndarray:
    """``order[k]`` = the pose eliminated k-th: :func:`block_ordering`'s minimum degree,
    except along chains of its elimination tree. Minimum degree eliminates a stretch of
    keyframes without loops (a corridor driven once) from its end, one after the other:
    each keyframe's only neighbour left is the next, so the tree has a chain as deep as
    the stretch is long, and the recurrences need one numpy step per keyframe. Such a
    chain (each node's only block below the diagonal is its parent, each parent's only
    child the node) is eliminated instead by halving (every other keyframe first, then
    every other of the rest, ...): the same positions in the order, the tree as deep as
    the chain's log2. A chain's nodes touch nothing outside it but the subtrees below it
    and the node above it, so the rest of the order and its fill are unchanged."""
    order = np.argsort(pattern_lu.perm_c)  # as block_ordering
    factor = pattern_lu.L.tocsc()
    factor.sort_indices()
    indptr, indices = factor.indptr, factor.indices
    n = len(order)
    width = np.diff(indptr) - 1
    parent = np.where(width > 0, indices[np.minimum(indptr[:-1] + 1, len(indices) - 1)], -1)
    children = np.bincount(parent[parent >= 0], minlength=n)
    linked = width == 1
    follows = np.zeros(n, dtype=bool)  # the node's parent continues its chain
    follows[linked] = linked[parent[linked]] & (children[parent[linked]] == 1)
    has_below = np.zeros(n, dtype=bool)
    has_below[parent[follows]] = True
    new_order = order.copy()
    for bottom in np.flatnonzero(linked & follows & ~has_below):
        chain = [int(bottom)]
        while follows[chain[-1]]:
            chain.append(int(parent[chain[-1]]))
        if len(chain) >= CHAIN_HALVING_MIN:
            rank = np.arange(1, len(chain) + 1)
            halving = np.lexsort((rank, np.log2(rank & -rank)))  # ruler order: odd ranks first
            new_order[np.sort(chain)] = order[np.asarray(chain)[halving]]
    return new_order
