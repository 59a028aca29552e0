"""Stacks of sparse matrices of one pattern (ufmt.mstmm.sparse) against the same matrices
held densely (oracle: numpy's dense products and determinants, overall.equilibrate)."""

import numpy as np

from ufmt.mstmm.overall import equilibrate
from ufmt.mstmm.sparse import SparseRows


def _stack(seed: int = 0, n: int = 3):
    """A random pattern of a 9 x 9 matrix made of diagonal blocks of orders 4, 3 and 2 with
    rows and columns permuted, its values for n matrices, and the dense matrices."""
    rng = np.random.default_rng(seed)
    orders = (4, 3, 2)
    mask = np.zeros((9, 9), dtype=bool)
    start = 0
    for m in orders:
        mask[start : start + m, start : start + m] = rng.random((m, m)) < 0.7
        mask[np.arange(start, start + m), np.arange(start, start + m)] = True  # nonsingular
        start += m
    mask = mask[rng.permutation(9)][:, rng.permutation(9)]
    rows, columns = np.nonzero(mask)
    shuffle = rng.permutation(rows.size)
    pattern, order = SparseRows.of((9, 9), rows[shuffle], columns[shuffle])
    values = rng.standard_normal((n, rows.size))[:, order]
    return pattern, values, pattern.dense(values), orders


def test_dense_products_and_scalings_match_the_dense_matrices():
    pattern, values, dense, _ = _stack()
    assert np.count_nonzero(dense) == dense.shape[0] * pattern.size
    x = np.random.default_rng(1).standard_normal((3, 9, 2))
    np.testing.assert_allclose(pattern.times(values, x), dense @ x, rtol=1e-14, atol=1e-14)
    r, c = pattern.equilibrate(values)
    r_dense, c_dense = equilibrate(dense)
    np.testing.assert_array_equal(r, r_dense[:, :, 0])  # the same arithmetic: bitwise
    np.testing.assert_array_equal(c, c_dense[:, 0, :])


def test_diagonal_blocks_recover_the_permuted_blocks_and_split_the_determinant():
    """A block diagonal matrix with rows and columns shuffled: its blocks come back with
    their orders, every entry in exactly one, and det = ± the product of theirs."""
    pattern, values, dense, orders = _stack(seed=2)
    blocks = pattern.diagonal_blocks
    assert sorted(b.rows.size for b in blocks) == sorted(orders)
    assert all(b.rows.size == b.columns.size for b in blocks)
    assert np.array_equal(
        np.sort(np.concatenate([b.entries for b in blocks])), np.arange(pattern.size)
    )
    product = np.prod([np.linalg.det(b.local.dense(values[:, b.entries])) for b in blocks], axis=0)
    np.testing.assert_allclose(np.abs(product), np.abs(np.linalg.det(dense)), rtol=1e-12)
    for b in blocks:  # each block is the dense matrix cut to its rows and columns
        np.testing.assert_array_equal(
            b.local.dense(values[:, b.entries]), dense[:, b.rows][:, :, b.columns]
        )


def test_a_pattern_that_does_not_split_into_square_blocks_is_one_block():
    """Components of unequal rows and columns (a structurally singular pattern) give no
    factorisation of det: the whole matrix is one block."""
    rows, columns = (
        np.array([0, 0, 1, 2]),
        np.array([0, 1, 0, 2]),
    )  # rows {0,1} x columns {0,1}, row 2 x column 2
    pattern, _ = SparseRows.of((3, 3), rows, columns)
    assert len(pattern.diagonal_blocks) == 2
    rows, columns = np.array([0, 1, 2]), np.array([0, 0, 2])  # rows {0,1} x column {0}
    pattern, _ = SparseRows.of((3, 3), rows, columns)
    (block,) = pattern.diagonal_blocks
    assert block.rows.size == block.columns.size == 3
